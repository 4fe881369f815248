//! Convex MPC on the single-rigid-body model (Di Carlo, Wensing, Katz, Bledt & Kim 2018,
//! "Dynamic locomotion in the MIT Cheetah 3 through convex model-predictive control").
//!
//! State `x = [Θ, p, ω, ṗ, g] ∈ ℝ¹³` (roll, pitch, yaw; CoM position; world angular
//! velocity; CoM velocity; gravity as a constant state, `g = −9.81`), inputs the ground
//! reaction forces `u = [f₁ … f_nc]` (world axes). With the yaw-linearised dynamics (eq. 16
//! of the paper, roll and pitch small)
//!
//! ```text
//! Θ̇ = R_z(ψ)ᵀ ω,   ṗ = ṗ,   ω̇ = I_w⁻¹ Σᵢ rᵢ × fᵢ,   p̈ = Σᵢ fᵢ / m + g e_z,
//! I_w = R_z(ψ) I_B R_z(ψ)ᵀ,   rᵢ = p_footᵢ − p,
//! ```
//!
//! i.e. `ẋ = A_c x + B_c u`, discretised exactly for piecewise-constant forces: `A_c³ = 0`,
//! so `A_d = I + A_c Δt + A_c² Δt²/2` and `B_d = (I Δt + A_c Δt²/2) B_c`. The horizon uses
//! the reference yaw `ψ_k` and reference CoM `p_k` of each step.
//!
//! **The problem** (`N` steps; `Q`, `R` diagonal):
//!
//! ```text
//! minimise   Σₖ (xₖ − x_ref,ₖ)ᵀ Q (xₖ − x_ref,ₖ) + uₖᵀ R uₖ
//! subject to x₁ = A₀ x₀ + B₀ u₀,   x_{k+1} = A_k x_k + B_k u_k
//!            f_z,ik ≤ f_max
//!            ‖(f_x, f_y)‖ ≤ μ f_z   (the exact cone; or a four-sided pyramid)
//!            optional hard bounds: z_k ≥ z₀ − Δz_max, |ṗ_xy,N − ṗ_ref,N| ≤ band
//! ```
//!
//! A foot predicted in swing at step `k` cannot act on the body (zero columns of `B_k`);
//! reported forces of swing feet are exactly zero.
//!
//! The problem's settings, data and linearisation are in `problem.rs`. **Two solvers**
//! ([`MpcSolver`]) give the same answer:
//!
//! * [`MpcSolver::Structured`] (the default, `ipm.rs`, `riccati.rs`, `cones.rs`): our
//!   primal–dual interior point for this second-order-cone program — homogeneous
//!   embedding, Mehrotra predictor–corrector, Nesterov–Todd scaling of the exact cones —
//!   whose Newton systems are solved stage by stage by a Riccati recursion on 12 states
//!   and 3 forces per foot in stance, allocation-free.
//! * [`MpcSolver::Clarabel`] (`clarabel.rs`): the sparse formulation, states and forces
//!   of every foot as variables, handed to Clarabel's generic interior point (its KKT
//!   system factored by sparse LDL): the reference the structured solver is tested
//!   against.
//!
//! **Planar variant** ([`MpcConfig::planar`], used for Walker2d): the same problem with the
//! feet projected to the sagittal plane through the CoM, the lateral force columns of `B`
//! removed and the inertia reduced to its diagonal, so lateral, roll and yaw motion are
//! neither produced nor required.

mod clarabel;
mod cones;
mod ipm;
mod problem;
mod riccati;

use std::time::Instant;

use nalgebra::{Matrix3, Vector3};

use self::clarabel::ClarabelMpc;
pub(crate) use self::clarabel::triplet_positions;
use self::ipm::StructuredMpc;
use self::problem::SrbModel;
pub use self::problem::{HardConstraints, MpcConfig, MpcInput, MpcSolver, NX, state_index};

use crate::error::ConfigError;
use crate::qp::QpStatus;
use crate::robot::MAX_CONTACTS;

/// The solver behind a [`ConvexMpc`].
#[allow(clippy::large_enum_variant)] // one per controller, never moved in a hot path
enum Backend {
    Structured(StructuredMpc),
    Clarabel(ClarabelMpc),
}

/// The convex MPC: the problem built once, updated in place and solved by the
/// [`MpcSolver`] of its config.
pub struct ConvexMpc {
    model: SrbModel,
    /// Inputs of the next solve.
    pub input: MpcInput,
    backend: Backend,
    status: QpStatus,
    forces: Vec<Vector3<f64>>,
    states: Vec<[f64; NX]>,
    iterations: u32,
    solve_time: f64,
    objective: f64,
}

impl std::fmt::Debug for ConvexMpc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ConvexMpc")
            .field("cfg", &self.model.cfg)
            .field("nc", &self.model.nc)
            .field("status", &self.status)
            .finish()
    }
}

impl ConvexMpc {
    /// Builds the problem for `nc` contacts, body mass `mass` and body-frame inertia about
    /// the CoM `inertia_body`. Fails on an invalid config or if Clarabel rejects the setup.
    pub fn new(
        cfg: &MpcConfig,
        nc: usize,
        mass: f64,
        inertia_body: Matrix3<f64>,
    ) -> Result<Self, ConfigError> {
        cfg.validate()?;
        if nc == 0 || nc > MAX_CONTACTS {
            return Err(ConfigError::OutOfRange { field: "contacts", value: nc as f64, range: "1..=8" });
        }
        if !(mass.is_finite() && mass > 0.0) {
            return Err(ConfigError::OutOfRange { field: "mass", value: mass, range: "> 0" });
        }
        let n = cfg.horizon;
        let mut inertia = inertia_body;
        if cfg.planar {
            inertia = Matrix3::from_diagonal(&inertia.diagonal());
        }
        let mut input = MpcInput {
            x0: [0.0; NX],
            x_ref: vec![[0.0; NX]; n],
            contact: vec![vec![true; nc]; n],
            foot: vec![vec![Vector3::zeros(); nc]; n],
            state_weights: cfg.state_weights,
        };
        // Nominal data: every foot in contact (the sparse pattern is then complete).
        input.x0[state_index::GRAVITY] = -9.81;
        let model = SrbModel { cfg: cfg.clone(), nc, mass, inertia_body: inertia };
        let backend = match cfg.solver {
            MpcSolver::Structured => Backend::Structured(StructuredMpc::new(&model)),
            MpcSolver::Clarabel => Backend::Clarabel(ClarabelMpc::new(&model, &input)?),
        };
        Ok(ConvexMpc {
            model,
            input,
            backend,
            status: QpStatus::NotRun,
            forces: vec![Vector3::zeros(); n * nc],
            states: vec![[0.0; NX]; n],
            iterations: 0,
            solve_time: 0.0,
            objective: f64::NAN,
        })
    }

    /// The same problem (model and current input) under a changed configuration — another
    /// solver, tolerance or iteration limit — for cross-checks, e.g. solving a controller's
    /// last problem ([`crate::LocomotionController::mpc`]) with Clarabel:
    /// `mpc.twin(|c| c.solver = MpcSolver::Clarabel)`. Changes of the horizon or of the
    /// planar flag are refused (the input would not fit); changed state weights replace
    /// the input's.
    pub fn twin(&self, change: impl FnOnce(&mut MpcConfig)) -> Result<Self, ConfigError> {
        let mut cfg = self.model.cfg.clone();
        change(&mut cfg);
        if cfg.horizon != self.model.cfg.horizon || cfg.planar != self.model.cfg.planar {
            return Err(ConfigError::OutOfRange {
                field: "mpc.horizon",
                value: cfg.horizon as f64,
                range: "the twin's horizon and planar flag",
            });
        }
        let mut twin = ConvexMpc::new(&cfg, self.model.nc, self.model.mass, self.model.inertia_body)?;
        twin.input = self.input.clone();
        if cfg.state_weights != self.model.cfg.state_weights {
            twin.input.state_weights = cfg.state_weights;
        }
        Ok(twin)
    }

    /// The configuration.
    pub fn config(&self) -> &MpcConfig {
        &self.model.cfg
    }

    /// Number of contacts.
    pub fn n_contacts(&self) -> usize {
        self.model.nc
    }

    /// Body mass used by the model.
    pub fn mass(&self) -> f64 {
        self.model.mass
    }

    /// Number of decision variables and constraint rows of the sparse formulation (every
    /// foot in stance; the structured solver drops the swing feet's and gravity's).
    pub fn size(&self) -> (usize, usize) {
        let cfg = &self.model.cfg;
        let (n, nc) = (cfg.horizon, self.model.nc);
        let hard =
            cfg.hard.max_height_drop.map_or(0, |_| n) + cfg.hard.terminal_velocity_band.map_or(0, |_| 4);
        let friction = if cfg.friction.is_pyramid() { 4 } else { 3 };
        (n * NX + 3 * n * nc, n * NX + n * nc * (1 + friction) + hard)
    }

    /// Solves the problem of `self.input`. Returns the status; forces and predicted states
    /// are available through [`ConvexMpc::force`] and [`ConvexMpc::predicted_state`] when
    /// it is OK. Non-finite inputs and negative state weights give
    /// [`QpStatus::NumericalError`] without a solve.
    pub fn solve(&mut self) -> QpStatus {
        let inp = &self.input;
        let finite = inp.x0.iter().all(|v| v.is_finite())
            && inp.x_ref.iter().all(|x| x.iter().all(|v| v.is_finite()))
            && inp.foot.iter().all(|f| f.iter().all(|p| p.iter().all(|v| v.is_finite())))
            && inp.state_weights.iter().all(|w| w.is_finite() && *w >= 0.0);
        self.iterations = 0;
        self.objective = f64::NAN;
        if !finite {
            self.status = QpStatus::NumericalError;
            return self.status;
        }
        match &mut self.backend {
            Backend::Structured(s) => {
                let t0 = Instant::now();
                self.status = s.solve(&self.model, inp, &mut self.forces, &mut self.states);
                self.solve_time = t0.elapsed().as_secs_f64();
                self.iterations = s.iterations();
                self.objective = s.objective();
            }
            Backend::Clarabel(c) => {
                let (status, iterations, time, objective) =
                    c.solve(&self.model, inp, &mut self.forces, &mut self.states);
                self.status = status;
                self.iterations = iterations;
                self.solve_time = time;
                if status.is_ok() {
                    self.objective = objective;
                }
            }
        }
        self.status
    }

    /// Status of the last solve.
    pub fn status(&self) -> QpStatus {
        self.status
    }

    /// Interior-point iterations of the last solve.
    pub fn iterations(&self) -> u32 {
        self.iterations
    }

    /// The solver's time in the last solve (s): Clarabel's own figure, or the structured
    /// solver's wall time.
    pub fn solve_time(&self) -> f64 {
        self.solve_time
    }

    /// Objective `Σ xᵀQx − 2 x_refᵀQx + uᵀRu` (the sparse formulation's `½zᵀPz + qᵀz`) at
    /// the last successful solve; NaN otherwise.
    pub fn objective(&self) -> f64 {
        self.objective
    }

    /// Force of contact `i` at step `k` of the last successful solve (world axes, N).
    pub fn force(&self, k: usize, i: usize) -> Vector3<f64> {
        self.forces[k * self.model.nc + i]
    }

    /// Predicted state `x_{k+1}` of the last successful solve.
    pub fn predicted_state(&self, k: usize) -> &[f64; NX] {
        &self.states[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::friction::FrictionModel;

    /// A box-shaped body with four feet at (±a, ±b, 0), CoM at height h.
    fn standing(mpc: &mut ConvexMpc, a: f64, b: f64, h: f64, com_x: f64) {
        let n = mpc.config().horizon;
        let feet = [
            Vector3::new(a, b, 0.0),
            Vector3::new(a, -b, 0.0),
            Vector3::new(-a, b, 0.0),
            Vector3::new(-a, -b, 0.0),
        ];
        let mut x0 = [0.0; NX];
        x0[3] = com_x;
        x0[5] = h;
        x0[12] = -9.81;
        mpc.input.x0 = x0;
        for k in 0..n {
            mpc.input.x_ref[k] = x0;
            for i in 0..4 {
                mpc.input.contact[k][i] = true;
                mpc.input.foot[k][i] = feet[i];
            }
        }
    }

    fn make(cfg: &MpcConfig) -> ConvexMpc {
        // 10 kg body, inertia diag(0.1, 0.3, 0.35).
        ConvexMpc::new(cfg, 4, 10.0, Matrix3::from_diagonal(&Vector3::new(0.1, 0.3, 0.35))).unwrap()
    }

    #[test]
    fn state_weights_set_per_solve_match_a_problem_built_with_them() {
        // Standing, asked to turn at 0.5 rad/s: the yaw-rate weight shapes the forces.
        let setup = |mpc: &mut ConvexMpc| {
            standing(mpc, 0.2, 0.1, 0.3, 0.0);
            for r in mpc.input.x_ref.iter_mut() {
                r[8] = 0.5;
            }
        };
        let forces = |mpc: &ConvexMpc| (0..4).map(|i| mpc.force(0, i)).collect::<Vec<_>>();
        let mut heavy = MpcConfig::default();
        heavy.state_weights[8] = 10.0;
        let mut built = make(&heavy);
        setup(&mut built);
        assert!(built.solve().is_ok());
        let want = forces(&built);
        for solver in [MpcSolver::Structured, MpcSolver::Clarabel] {
            let mut mpc = make(&MpcConfig { solver, ..MpcConfig::default() });
            setup(&mut mpc);
            assert!(mpc.solve().is_ok());
            let light = forces(&mpc);
            mpc.input.state_weights[8] = 10.0;
            assert!(mpc.solve().is_ok());
            let got = forces(&mpc);
            let tol = if solver == MpcSolver::Structured { 1e-9 } else { 1e-4 };
            for i in 0..4 {
                assert!((got[i] - want[i]).norm() < tol, "{solver:?} foot {i}: {} vs {}", got[i], want[i]);
            }
            let moved: f64 = (0..4).map(|i| (light[i] - want[i]).norm()).sum();
            assert!(moved > 1e-3, "{solver:?}: the weight changed nothing ({moved})");
            // A negative weight is refused without a solve.
            mpc.input.state_weights[3] = -1.0;
            assert_eq!(mpc.solve(), QpStatus::NumericalError);
        }
    }

    #[test]
    fn standing_forces_sum_to_weight() {
        let mut mpc = make(&MpcConfig::stand());
        standing(&mut mpc, 0.2, 0.15, 0.3, 0.0);
        assert!(mpc.solve().is_ok(), "{:?}", mpc.status());
        let total: Vector3<f64> = (0..4).map(|i| mpc.force(0, i)).sum();
        // m g = 10 · 9.81 = 98.1 N, split equally (24.525 N) by symmetry.
        assert!((total.z - 98.1).abs() < 0.5, "{total:?}");
        assert!(total.x.abs() < 1e-3 && total.y.abs() < 1e-3);
        for i in 0..4 {
            assert!((mpc.force(0, i).z - 24.525).abs() < 0.5, "{:?}", mpc.force(0, i));
        }
    }

    #[test]
    fn com_offset_loads_the_front_legs() {
        // CoM 5 cm ahead of the centre, feet at x = ±0.2: moment balance gives the front pair
        // (0.2 + 0.05)/0.4 = 62.5 % of the weight (61.3 N) and the hind pair 37.5 % (36.8 N).
        let mut mpc = make(&MpcConfig::stand());
        standing(&mut mpc, 0.2, 0.15, 0.3, 0.05);
        assert!(mpc.solve().is_ok());
        let front = mpc.force(0, 0).z + mpc.force(0, 1).z;
        let hind = mpc.force(0, 2).z + mpc.force(0, 3).z;
        assert!((front - 61.3).abs() < 1.5, "front {front}");
        assert!((hind - 36.8).abs() < 1.5, "hind {hind}");
    }

    #[test]
    fn cone_and_pyramid_both_hold_the_weight() {
        for friction in
            [FrictionModel::Cone, FrictionModel::InscribedPyramid, FrictionModel::CircumscribedPyramid]
        {
            let mut mpc = make(&MpcConfig { friction, ..MpcConfig::stand() });
            standing(&mut mpc, 0.2, 0.15, 0.3, 0.0);
            assert!(mpc.solve().is_ok(), "{friction:?}: {:?}", mpc.status());
            let total: f64 = (0..4).map(|i| mpc.force(0, i).z).sum();
            assert!((total - 98.1).abs() < 0.5);
        }
    }

    #[test]
    fn too_weak_to_stand_is_infeasible() {
        // f_max = 0.2 m g per foot: 4 feet hold 0.8 m g, so the body sinks
        // ½ · 0.2 · 9.81 · 0.3² ≈ 8.8 cm over the horizon, more than the 2 cm allowed.
        let cfg = MpcConfig {
            max_normal_force_ratio: 0.2,
            hard: HardConstraints { max_height_drop: Some(0.02), terminal_velocity_band: None },
            ..MpcConfig::stand()
        };
        let mut mpc = make(&cfg);
        standing(&mut mpc, 0.2, 0.15, 0.3, 0.0);
        assert_eq!(mpc.solve(), QpStatus::PrimalInfeasible);
        // With 0.5 m g per foot it is feasible.
        let mut mpc = make(&MpcConfig { max_normal_force_ratio: 0.5, ..cfg });
        standing(&mut mpc, 0.2, 0.15, 0.3, 0.0);
        assert!(mpc.solve().is_ok());
    }

    #[test]
    fn low_friction_cannot_accelerate() {
        // Reach 1 m/s within the 0.3 s horizon (band 0.1 m/s): needs ≈ 0.9/0.3 = 3 m/s².
        // With f_z ≤ 0.3 m g per foot (1.2 m g in total) friction gives at most
        // 1.2 μ g: 7.1 m/s² for μ = 0.6 (feasible), 1.18 m/s² for μ = 0.1 (infeasible).
        for (mu, ok) in [(0.6, true), (0.1, false)] {
            let cfg = MpcConfig {
                mu,
                max_normal_force_ratio: 0.3,
                hard: HardConstraints { max_height_drop: None, terminal_velocity_band: Some(0.1) },
                ..MpcConfig::stand()
            };
            let mut mpc = make(&cfg);
            standing(&mut mpc, 0.2, 0.15, 0.3, 0.0);
            let n = mpc.config().horizon;
            for k in 0..n {
                mpc.input.x_ref[k][9] = 1.0;
            }
            let s = mpc.solve();
            assert_eq!(s.is_ok(), ok, "μ = {mu}: {s:?}");
            if !ok {
                assert_eq!(s, QpStatus::PrimalInfeasible);
            }
        }
    }

    #[test]
    fn swing_feet_carry_nothing() {
        let mut mpc = make(&MpcConfig::trot());
        standing(&mut mpc, 0.2, 0.15, 0.3, 0.0);
        let n = mpc.config().horizon;
        for k in 0..n {
            let first = k < 5;
            mpc.input.contact[k] = vec![first, !first, !first, first];
        }
        assert!(mpc.solve().is_ok());
        assert_eq!(mpc.force(0, 1), Vector3::zeros());
        let total: f64 = (0..4).map(|i| mpc.force(0, i).z).sum();
        assert!(total > 50.0 && total < 200.0, "{total}");
    }
}
