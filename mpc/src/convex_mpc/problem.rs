//! The convex MPC's problem: its settings ([`MpcConfig`]), the data of one solve
//! ([`MpcInput`]) and the single rigid body it plans for ([`SrbModel`]) with the
//! linearisation both solvers build their matrices from.

use centaur_dynamics::spatial::skew;
use nalgebra::{Matrix3, Vector3};

use crate::error::ConfigError;
use crate::friction::FrictionModel;

/// Dimension of the MPC state.
pub const NX: usize = 13;

/// Index of each state entry.
pub mod state_index {
    /// Roll, pitch, yaw.
    pub const THETA: usize = 0;
    /// CoM position.
    pub const POS: usize = 3;
    /// World angular velocity.
    pub const OMEGA: usize = 6;
    /// CoM velocity.
    pub const VEL: usize = 9;
    /// Gravity (constant −9.81).
    pub const GRAVITY: usize = 12;
}

/// Optional hard constraints on the predicted motion (none by default). They make the
/// problem infeasible when forces cannot achieve them — used to detect, rather than hide,
/// a robot that cannot hold itself up or follow a command.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize)]
pub struct HardConstraints {
    /// The predicted CoM height must stay above `z₀ − max_height_drop` at every step
    /// (default: none).
    pub max_height_drop: Option<f64>,
    /// The predicted horizontal velocity at the end of the horizon must be within this
    /// band (m/s) of the reference (default: none).
    pub terminal_velocity_band: Option<f64>,
}

/// The solver of the convex MPC (both solve the same problem to the same tolerance).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum MpcSolver {
    /// Our interior point with a Riccati recursion as its linear solve (the default): no
    /// allocation per solve, about an order of magnitude faster than Clarabel here.
    #[default]
    Structured,
    /// Clarabel on the sparse formulation (the reference).
    Clarabel,
}

/// Convex-MPC settings. [`Default`] is the trot of the MIT Cheetah 3 paper adapted to
/// small robots.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MpcConfig {
    /// Number of steps `N` (default: 10).
    pub horizon: usize,
    /// Step `Δt` (s) (default: 0.03, one trot period over the horizon).
    pub dt: f64,
    /// Friction coefficient `μ` (default: 0.6).
    pub mu: f64,
    /// Friction model (default: exact cone).
    pub friction: FrictionModel,
    /// Largest normal force per contact as a multiple of the robot's weight `m g`
    /// (default: 1.0).
    pub max_normal_force_ratio: f64,
    /// State weights `Q` for `[Θ, p, ω, ṗ]` (default: MIT Cheetah 3's
    /// `[0.25, 0.25, 10, 2, 2, 50, 0, 0, 0.3, 0.2, 0.2, 0.1]`).
    pub state_weights: [f64; 12],
    /// Force weight `R` (default: 1e-5).
    pub force_weight: f64,
    /// Sagittal-plane variant (default: false).
    pub planar: bool,
    /// Hard constraints (default: none).
    pub hard: HardConstraints,
    /// The solver's gap and feasibility tolerances (default: 1e-8).
    pub tolerance: f64,
    /// The solver's iteration limit (default: 50).
    pub max_iter: u32,
    /// The solver (default: [`MpcSolver::Structured`]).
    pub solver: MpcSolver,
}

impl Default for MpcConfig {
    fn default() -> Self {
        Self {
            horizon: 10,
            dt: 0.03,
            mu: 0.6,
            friction: FrictionModel::Cone,
            max_normal_force_ratio: 1.0,
            state_weights: [0.25, 0.25, 10.0, 2.0, 2.0, 50.0, 0.0, 0.0, 0.3, 0.2, 0.2, 0.1],
            force_weight: 1e-5,
            planar: false,
            hard: HardConstraints::default(),
            tolerance: 1e-8,
            max_iter: 50,
            solver: MpcSolver::Structured,
        }
    }
}

impl MpcConfig {
    /// Trotting (the default: 10 × 30 ms, one 0.3 s trot cycle).
    pub fn trot() -> Self {
        Self::default()
    }

    /// Standing: stronger attitude and height weights, same horizon.
    pub fn stand() -> Self {
        Self {
            state_weights: [2.0, 2.0, 10.0, 5.0, 5.0, 50.0, 0.1, 0.1, 0.3, 1.0, 1.0, 1.0],
            ..Self::default()
        }
    }

    /// Static walk: a 0.8 s cycle, 16 × 50 ms.
    pub fn walk() -> Self {
        Self { horizon: 16, dt: 0.05, ..Self::default() }
    }

    /// Bounding and pronking: more pitch weight (the body pitches between front and hind
    /// stances).
    pub fn bound() -> Self {
        Self {
            state_weights: [0.5, 1.0, 10.0, 2.0, 2.0, 50.0, 0.0, 0.1, 0.3, 0.2, 0.2, 0.1],
            ..Self::default()
        }
    }

    /// Biped walking in the sagittal plane (Walker2d): planar, 0.8 s cycle in 16 × 50 ms.
    pub fn biped_planar() -> Self {
        Self {
            horizon: 16,
            dt: 0.05,
            planar: true,
            state_weights: [0.0, 5.0, 0.0, 2.0, 0.0, 50.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.5],
            ..Self::default()
        }
    }

    /// Checks ranges.
    pub fn validate(&self) -> Result<(), ConfigError> {
        use ConfigError as E;
        if self.horizon < 1 || self.horizon > 100 {
            return Err(E::OutOfRange { field: "mpc.horizon", value: self.horizon as f64, range: "1..=100" });
        }
        let pos = |field: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(E::OutOfRange { field, value: v, range: "> 0" })
            }
        };
        pos("mpc.dt", self.dt)?;
        pos("mpc.tolerance", self.tolerance)?;
        pos("mpc.max_normal_force_ratio", self.max_normal_force_ratio)?;
        if !(self.mu.is_finite() && self.mu >= 0.0) {
            return Err(E::OutOfRange { field: "mpc.mu", value: self.mu, range: ">= 0" });
        }
        if !(self.force_weight.is_finite() && self.force_weight > 0.0) {
            return Err(E::OutOfRange { field: "mpc.force_weight", value: self.force_weight, range: "> 0" });
        }
        if let Some(w) = self.state_weights.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
            return Err(E::OutOfRange { field: "mpc.state_weights", value: *w, range: ">= 0" });
        }
        if self.max_iter == 0 {
            return Err(E::OutOfRange { field: "mpc.max_iter", value: 0.0, range: ">= 1" });
        }
        Ok(())
    }
}

/// Problem data of one solve, written by the caller before [`super::ConvexMpc::solve`].
#[derive(Clone, Debug)]
pub struct MpcInput {
    /// Current state `x₀` (`x0[12]` is gravity, −9.81 on Earth).
    pub x0: [f64; NX],
    /// Reference `x_ref,k` for `k = 1..=N` (index `k − 1`).
    pub x_ref: Vec<[f64; NX]>,
    /// Contact flags for `k = 0..N`, per contact.
    pub contact: Vec<Vec<bool>>,
    /// Foot positions (world) for `k = 0..N`, per contact.
    pub foot: Vec<Vec<Vector3<f64>>>,
    /// State weights `Q` of this solve ([`ConvexMpc::new`](super::ConvexMpc::new) sets
    /// them to [`MpcConfig::state_weights`]; a controller may change them between solves,
    /// e.g. while turning). Finite and non-negative, or the solve is refused.
    pub state_weights: [f64; 12],
}

/// The single rigid body the MPC plans for.
#[derive(Clone, Debug)]
pub(crate) struct SrbModel {
    pub cfg: MpcConfig,
    pub nc: usize,
    pub mass: f64,
    /// Body-frame inertia about the CoM (its diagonal only for the planar variant).
    pub inertia_body: Matrix3<f64>,
}

/// Where step `k` is linearised: `R_zᵀ` of its yaw, the world inverse inertia there, and
/// the CoM (the current state for `k = 0`, the reference `x_ref,k` after).
pub(crate) struct StepFrame {
    pub rzt: Matrix3<f64>,
    pub iw_inv: Matrix3<f64>,
    pub pref: Vector3<f64>,
}

impl SrbModel {
    pub(crate) fn step_frame(&self, input: &MpcInput, k: usize) -> StepFrame {
        let x = if k == 0 { &input.x0 } else { &input.x_ref[k - 1] };
        let (psi, pref) = (x[2], Vector3::new(x[3], x[4], x[5]));
        let (c, s) = (psi.cos(), psi.sin());
        let rzt = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
        let rz = rzt.transpose();
        let iw_inv = (rz * self.inertia_body * rzt).try_inverse().unwrap_or_else(Matrix3::zeros);
        StepFrame { rzt, iw_inv, pref }
    }

    /// The lever `r = p_foot − p_CoM` of foot `i` at step `k` (in the sagittal plane for the
    /// planar variant); `None` for a foot in swing.
    pub(crate) fn lever(
        &self,
        input: &MpcInput,
        frame: &StepFrame,
        k: usize,
        i: usize,
    ) -> Option<Vector3<f64>> {
        if !input.contact[k][i] {
            return None;
        }
        let mut r = input.foot[k][i] - frame.pref;
        if self.cfg.planar {
            r.y = 0.0;
        }
        Some(r)
    }

    /// The columns of `B_d` for foot `i` at step `k`, one per force axis, each over
    /// `[Θ, p, ω, ṗ]`: `R_zᵀ I_w⁻¹ [r]× Δt²/2`, `Δt²/(2m)`, `I_w⁻¹ [r]× Δt`, `Δt/m`; `None`
    /// for a foot in swing; the lateral column is zero for the planar variant.
    pub(crate) fn force_response(
        &self,
        input: &MpcInput,
        frame: &StepFrame,
        k: usize,
        i: usize,
    ) -> Option<[[f64; 12]; 3]> {
        let r = self.lever(input, frame, k, i)?;
        let dt = self.cfg.dt;
        let w = frame.iw_inv * skew(&r); // ω̇ per unit force
        let lin = dt / self.mass;
        let th = frame.rzt * w * (0.5 * dt * dt);
        let mut cols = [[0.0; 12]; 3];
        for (cc, col) in cols.iter_mut().enumerate() {
            if self.cfg.planar && cc == 1 {
                continue;
            }
            for r in 0..3 {
                col[r] = th[(r, cc)];
                col[6 + r] = w[(r, cc)] * dt;
            }
            col[3 + cc] = 0.5 * dt * lin;
            col[9 + cc] = lin;
        }
        Some(cols)
    }
}
