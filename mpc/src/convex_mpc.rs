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
//! **Sparse formulation** (both states and forces are decision variables,
//! `z = [x₁ … x_N, u₀ … u_{N−1}]`):
//!
//! ```text
//! minimise   Σₖ (xₖ − x_ref,ₖ)ᵀ Q (xₖ − x_ref,ₖ) + uₖᵀ R uₖ
//! subject to x₁ = A₀ x₀ + B₀ u₀,   x_{k+1} = A_k x_k + B_k u_k     (Clarabel ZeroCone)
//!            f_z,ik ≤ f_max                                           (NonnegativeCone)
//!            ‖(f_x, f_y)‖ ≤ μ f_z   (SecondOrderConeT(3); or a pyramid, NonnegativeCone)
//!            optional hard bounds: z_k ≥ z₀ − Δz_max, |ṗ_xy,N − ṗ_ref,N| ≤ band
//! ```
//!
//! A foot predicted in swing at step `k` keeps its variables and cone (fixed sparsity), but
//! its columns of `B_k` are zero, so it cannot act on the body and the `R` term drives its
//! force to zero; reported forces of swing feet are exactly zero.
//!
//! The problem is built once ([`ConvexMpc::new`]) with every entry that may ever be
//! non-zero stored explicitly (Clarabel keeps explicit zeros from triplets), and each solve
//! rewrites the values of `A`, `q` and `b` in place (`update_A/q/b`, presolve off).
//!
//! **Planar variant** ([`MpcConfig::planar`], used for Walker2d): the same problem with the
//! feet projected to the sagittal plane through the CoM, the lateral force columns of `B`
//! removed and the inertia reduced to its diagonal, so lateral, roll and yaw motion are
//! neither produced nor required.

use centaur_dynamics::spatial::skew;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SupportedConeT};
use nalgebra::{Matrix3, Vector3};

use crate::error::ConfigError;
use crate::friction::FrictionModel;
use crate::qp::QpStatus;
use crate::robot::MAX_CONTACTS;

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
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct HardConstraints {
    /// The predicted CoM height must stay above `z₀ − max_height_drop` at every step
    /// (default: none).
    pub max_height_drop: Option<f64>,
    /// The predicted horizontal velocity at the end of the horizon must be within this
    /// band (m/s) of the reference (default: none).
    pub terminal_velocity_band: Option<f64>,
}

/// Convex-MPC settings. [`Default`] is the trot of the MIT Cheetah 3 paper adapted to
/// small robots.
#[derive(Clone, Debug, PartialEq)]
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
    /// Clarabel's gap and feasibility tolerances (default: 1e-8).
    pub tolerance: f64,
    /// Clarabel's iteration limit (default: 50).
    pub max_iter: u32,
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

/// Problem data of one solve, written by the caller before [`ConvexMpc::solve`].
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
}

/// The convex MPC: a Clarabel solver built once and updated in place.
pub struct ConvexMpc {
    cfg: MpcConfig,
    nc: usize,
    mass: f64,
    inertia_body: Matrix3<f64>,
    /// Inputs of the next solve.
    pub input: MpcInput,
    solver: DefaultSolver<f64>,
    // A in CSC with a fixed pattern: values in triplet order and their nzval positions.
    a_pos: Vec<usize>,
    a_nz: Vec<f64>,
    q: Vec<f64>,
    b: Vec<f64>,
    n_var: usize,
    status: QpStatus,
    forces: Vec<Vector3<f64>>,
    states: Vec<[f64; NX]>,
    iterations: u32,
    solve_time: f64,
}

impl std::fmt::Debug for ConvexMpc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ConvexMpc")
            .field("cfg", &self.cfg)
            .field("nc", &self.nc)
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
        let n = cfg.horizon;
        let mut inertia = inertia_body;
        if cfg.planar {
            inertia = Matrix3::from_diagonal(&inertia.diagonal());
        }
        let input = MpcInput {
            x0: [0.0; NX],
            x_ref: vec![[0.0; NX]; n],
            contact: vec![vec![true; nc]; n],
            foot: vec![vec![Vector3::zeros(); nc]; n],
        };
        let n_var = n * NX + n * 3 * nc;
        let rows_dyn = n * NX;
        let rows_fmax = n * nc;
        let rows_hard =
            cfg.hard.max_height_drop.map_or(0, |_| n) + cfg.hard.terminal_velocity_band.map_or(0, |_| 4);
        let rows_pyr = if cfg.friction.is_pyramid() { 4 * n * nc } else { 0 };
        let rows_soc = if cfg.friction.is_pyramid() { 0 } else { 3 * n * nc };
        let m = rows_dyn + rows_fmax + rows_hard + rows_pyr + rows_soc;
        let mut mpc = ConvexMpc {
            cfg: cfg.clone(),
            nc,
            mass,
            inertia_body: inertia,
            input,
            // Placeholder, replaced below once the data exist.
            solver: tiny_solver(),
            a_pos: Vec::new(),
            a_nz: Vec::new(),
            q: vec![0.0; n_var],
            b: vec![0.0; m],
            n_var,
            status: QpStatus::NotRun,
            forces: vec![Vector3::zeros(); n * nc],
            states: vec![[0.0; NX]; n],
            iterations: 0,
            solve_time: 0.0,
        };
        // Nominal data so that the pattern is complete: every foot in contact.
        mpc.input.x0[state_index::GRAVITY] = -9.81;
        let (mut ri, mut ci, mut vi) = (Vec::new(), Vec::new(), Vec::new());
        mpc.emit_a(&mut |r, c, v| {
            ri.push(r);
            ci.push(c);
            vi.push(v);
        });
        let nnz = vi.len();
        let a = csc_from_triplets(m, n_var, &ri, &ci, &vi);
        mpc.a_pos = triplet_positions(&a, &ri, &ci);
        mpc.a_nz = a.nzval.clone();
        debug_assert_eq!(mpc.a_pos.len(), nnz);
        // P: diagonal (Q for states, R for forces).
        let mut pd = vec![0.0; n_var];
        for k in 0..n {
            for s in 0..12 {
                pd[k * NX + s] = 2.0 * cfg.state_weights[s];
            }
        }
        for v in pd.iter_mut().skip(n * NX) {
            *v = 2.0 * cfg.force_weight;
        }
        let idx: Vec<usize> = (0..n_var).collect();
        let p = csc_from_triplets(n_var, n_var, &idx, &idx, &pd);
        mpc.fill_qb();
        let mut cones = vec![SupportedConeT::ZeroConeT(rows_dyn)];
        cones.push(SupportedConeT::NonnegativeConeT(rows_fmax + rows_hard + rows_pyr));
        if rows_soc > 0 {
            for _ in 0..n * nc {
                cones.push(SupportedConeT::SecondOrderConeT(3));
            }
        }
        let settings = DefaultSettings::<f64> {
            verbose: false,
            presolve_enable: false,
            max_iter: cfg.max_iter,
            tol_gap_abs: cfg.tolerance,
            tol_gap_rel: cfg.tolerance,
            tol_feas: cfg.tolerance,
            max_threads: 1,
            ..Default::default()
        };
        mpc.solver = DefaultSolver::new(&p, &mpc.q, &a, &mpc.b, &cones, settings)
            .map_err(|source| ConfigError::Solver { problem: "convex MPC", source })?;
        Ok(mpc)
    }

    /// The configuration.
    pub fn config(&self) -> &MpcConfig {
        &self.cfg
    }

    /// Number of contacts.
    pub fn n_contacts(&self) -> usize {
        self.nc
    }

    /// Body mass used by the model.
    pub fn mass(&self) -> f64 {
        self.mass
    }

    /// Number of decision variables and constraint rows.
    pub fn size(&self) -> (usize, usize) {
        (self.n_var, self.b.len())
    }

    /// Emits every entry of the constraint matrix, in a fixed order, from `self.input`.
    fn emit_a(&self, emit: &mut impl FnMut(usize, usize, f64)) {
        let n = self.cfg.horizon;
        let nc = self.nc;
        let dt = self.cfg.dt;
        let m = self.mass;
        let ucol = |k: usize, i: usize| n * NX + (k * nc + i) * 3;
        for k in 0..n {
            let row = k * NX;
            // +x_{k+1}
            for s in 0..NX {
                emit(row + s, k * NX + s, 1.0);
            }
            let (psi, pref) = self.linearisation_point(k);
            let (c, s) = (psi.cos(), psi.sin());
            // R_zᵀ
            let rzt = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
            if k > 0 {
                // −A_d at x_k: −I − A_c Δt − A_c² Δt²/2.
                let col = (k - 1) * NX;
                for s in 0..NX {
                    emit(row + s, col + s, -1.0);
                }
                for r in 0..3 {
                    for cc in 0..3 {
                        emit(row + r, col + 6 + cc, -rzt[(r, cc)] * dt);
                    }
                }
                for r in 0..3 {
                    emit(row + 3 + r, col + 9 + r, -dt);
                }
                emit(row + 5, col + 12, -0.5 * dt * dt);
                emit(row + 11, col + 12, -dt);
            }
            // −B_d at u_k.
            let rz = rzt.transpose();
            let iw_inv = (rz * self.inertia_body * rzt).try_inverse().unwrap_or_else(Matrix3::zeros);
            for i in 0..nc {
                let on = self.input.contact[k][i];
                let mut r = self.input.foot[k][i] - pref;
                if self.cfg.planar {
                    r.y = 0.0;
                }
                let mut w = iw_inv * skew(&r); // ω̇ per unit force
                let mut lin = dt / m;
                if !on {
                    w = Matrix3::zeros();
                    lin = 0.0;
                }
                let th = rzt * w * (0.5 * dt * dt);
                let col = ucol(k, i);
                for cc in 0..3 {
                    let lat = self.cfg.planar && cc == 1;
                    let z = if lat { 0.0 } else { 1.0 };
                    for r in 0..3 {
                        emit(row + r, col + cc, -th[(r, cc)] * z);
                    }
                    emit(row + 3 + cc, col + cc, -0.5 * dt * lin * z);
                    for r in 0..3 {
                        emit(row + 6 + r, col + cc, -w[(r, cc)] * dt * z);
                    }
                    emit(row + 9 + cc, col + cc, -lin * z);
                }
            }
        }
        // f_z ≤ f_max.
        let mut row = n * NX;
        for k in 0..n {
            for i in 0..nc {
                emit(row, ucol(k, i) + 2, 1.0);
                row += 1;
            }
        }
        // Hard constraints.
        if self.cfg.hard.max_height_drop.is_some() {
            for k in 0..n {
                emit(row, k * NX + state_index::POS + 2, -1.0);
                row += 1;
            }
        }
        if self.cfg.hard.terminal_velocity_band.is_some() {
            let col = (n - 1) * NX + state_index::VEL;
            for (d, sg) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)] {
                emit(row, col + d, sg);
                row += 1;
            }
        }
        // Friction.
        let mu = self.cfg.mu;
        if self.cfg.friction.is_pyramid() {
            let rows = crate::friction::pyramid_rows(self.cfg.friction.pyramid_mu(mu));
            for k in 0..n {
                for i in 0..nc {
                    let col = ucol(k, i);
                    for a in &rows {
                        for d in 0..3 {
                            emit(row, col + d, a[d]);
                        }
                        row += 1;
                    }
                }
            }
        } else {
            // s = b − A z = (μ f_z, f_x, f_y) with b = 0.
            for k in 0..n {
                for i in 0..nc {
                    let col = ucol(k, i);
                    emit(row, col + 2, -mu);
                    emit(row + 1, col, -1.0);
                    emit(row + 2, col + 1, -1.0);
                    row += 3;
                }
            }
        }
    }

    /// Yaw and CoM position at which step `k` is linearised (current state for `k = 0`).
    fn linearisation_point(&self, k: usize) -> (f64, Vector3<f64>) {
        let x = if k == 0 { &self.input.x0 } else { &self.input.x_ref[k - 1] };
        (x[2], Vector3::new(x[3], x[4], x[5]))
    }

    /// `q = −2 Q x_ref` and `b` (initial-state row, force limits, hard bounds).
    fn fill_qb(&mut self) {
        let n = self.cfg.horizon;
        let nc = self.nc;
        for k in 0..n {
            for s in 0..12 {
                self.q[k * NX + s] = -2.0 * self.cfg.state_weights[s] * self.input.x_ref[k][s];
            }
            self.q[k * NX + 12] = 0.0;
        }
        for v in self.q.iter_mut().skip(n * NX) {
            *v = 0.0;
        }
        // b of the first dynamics block: A₀ x₀.
        self.b.fill(0.0);
        let x0 = self.input.x0;
        let dt = self.cfg.dt;
        let psi = x0[2];
        let (c, s) = (psi.cos(), psi.sin());
        let rzt = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
        let w = Vector3::new(x0[6], x0[7], x0[8]);
        let th = rzt * w * dt;
        self.b[..NX].copy_from_slice(&x0);
        for r in 0..3 {
            self.b[r] += th[r];
            self.b[3 + r] += x0[9 + r] * dt;
        }
        self.b[5] += 0.5 * dt * dt * x0[12];
        self.b[11] += dt * x0[12];
        let weight = self.mass * x0[12].abs();
        let fmax = self.cfg.max_normal_force_ratio * weight;
        let mut row = n * NX;
        for _ in 0..n * nc {
            self.b[row] = fmax;
            row += 1;
        }
        if let Some(dz) = self.cfg.hard.max_height_drop {
            for _ in 0..n {
                self.b[row] = -(x0[5] - dz);
                row += 1;
            }
        }
        if let Some(band) = self.cfg.hard.terminal_velocity_band {
            let v = &self.input.x_ref[n - 1];
            let vals = [v[9] + band, -v[9] + band, v[10] + band, -v[10] + band];
            for val in vals {
                self.b[row] = val;
                row += 1;
            }
        }
    }

    /// Updates the solver with `self.input` and solves. Returns the status; forces and
    /// predicted states are available through [`ConvexMpc::force`] and
    /// [`ConvexMpc::predicted_state`] when it is OK.
    pub fn solve(&mut self) -> QpStatus {
        let finite = self.input.x0.iter().all(|v| v.is_finite())
            && self.input.x_ref.iter().all(|x| x.iter().all(|v| v.is_finite()))
            && self.input.foot.iter().all(|f| f.iter().all(|p| p.iter().all(|v| v.is_finite())));
        if !finite {
            self.status = QpStatus::NumericalError;
            return self.status;
        }
        let mut vals = std::mem::take(&mut self.a_nz);
        let pos = std::mem::take(&mut self.a_pos);
        let mut t = 0usize;
        self.emit_a(&mut |_, _, v| {
            vals[pos[t]] = v;
            t += 1;
        });
        self.a_pos = pos;
        self.fill_qb();
        let ok = self.solver.update_A(&vals).is_ok()
            && self.solver.update_q(&self.q).is_ok()
            && self.solver.update_b(&self.b).is_ok();
        self.a_nz = vals;
        if !ok {
            self.status = QpStatus::NumericalError;
            return self.status;
        }
        self.solver.solve();
        let sol = &self.solver.solution;
        self.status = QpStatus::from_clarabel(sol.status);
        self.iterations = sol.iterations;
        self.solve_time = sol.solve_time;
        if self.status.is_ok() {
            let n = self.cfg.horizon;
            let nc = self.nc;
            for k in 0..n {
                self.states[k].copy_from_slice(&sol.x[k * NX..(k + 1) * NX]);
                for i in 0..nc {
                    let c = n * NX + (k * nc + i) * 3;
                    let mut f = Vector3::new(sol.x[c], sol.x[c + 1], sol.x[c + 2]);
                    if !self.input.contact[k][i] {
                        f = Vector3::zeros();
                    }
                    if self.cfg.planar {
                        f.y = 0.0;
                    }
                    self.forces[k * nc + i] = f;
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

    /// Clarabel's own solve time of the last solve (s).
    pub fn solve_time(&self) -> f64 {
        self.solve_time
    }

    /// Force of contact `i` at step `k` of the last successful solve (world axes, N).
    pub fn force(&self, k: usize, i: usize) -> Vector3<f64> {
        self.forces[k * self.nc + i]
    }

    /// Predicted state `x_{k+1}` of the last successful solve.
    pub fn predicted_state(&self, k: usize) -> &[f64; NX] {
        &self.states[k]
    }
}

/// A trivially small solver used as a placeholder during construction.
fn tiny_solver() -> DefaultSolver<f64> {
    let p = CscMatrix::new(1, 1, vec![0, 1], vec![0], vec![1.0]);
    let a = CscMatrix::new(1, 1, vec![0, 1], vec![0], vec![1.0]);
    let settings = DefaultSettings::<f64> { verbose: false, presolve_enable: false, ..Default::default() };
    DefaultSolver::new(&p, &[0.0], &a, &[1.0], &[SupportedConeT::NonnegativeConeT(1)], settings)
        .expect("a 1×1 QP is valid")
}

/// A CSC matrix from triplets, keeping explicit zeros and summing duplicates.
pub(crate) fn csc_from_triplets(m: usize, n: usize, r: &[usize], c: &[usize], v: &[f64]) -> CscMatrix<f64> {
    CscMatrix::new_from_triplets(m, n, r.to_vec(), c.to_vec(), v.to_vec())
}

/// For each triplet, the index of its entry in `a.nzval`.
pub(crate) fn triplet_positions(a: &CscMatrix<f64>, r: &[usize], c: &[usize]) -> Vec<usize> {
    r.iter()
        .zip(c)
        .map(|(&row, &col)| {
            let (s, e) = (a.colptr[col], a.colptr[col + 1]);
            s + a.rowval[s..e].binary_search(&row).expect("entry in pattern")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
