//! Whole-body QP (weighted tasks, torques eliminated).
//!
//! Decision variables `x = [q̈, f, λ]`: generalized accelerations, the ground reaction force
//! of every stance contact (world axes) and the loop-closure forces. With
//! `M q̈ + h = Sᵀ τ + J_cᵀ f + J_lᵀ λ` (`h = C q̇ + g` from [`centaur_dynamics::nonlinear_effects`]):
//!
//! ```text
//! minimise  Σ_tasks w ‖A x − b‖² + ε ‖x‖²
//!   tasks:  body        J_com q̈ + J̇_com q̇ = c̈_des            (CoM, 3 rows, linear weight)
//!                       J_ω q̈ + J̇_ω q̇ = ω̇_des                (body frame, 3 rows, angular weight)
//!           stance feet J_c q̈ + J̇_c q̇ = 0                    (soft, high weight)
//!           swing feet  J_c q̈ + J̇_c q̇ = a_c,des
//!           posture     q̈_j = k_p (q_nom − q) − k_d q̇          (non-base joints)
//!           forces      f = f_MPC                              (stance contacts)
//! subject to
//!   unactuated rows (base, passive joints):  (M q̈ + h − J_cᵀ f − J_lᵀ λ)_u = 0
//!   loop closures:  J_l q̈ = −J̇_l q̇ − k_p e − k_d ė
//!   torque limits:  |(M q̈ + h − J_cᵀ f − J_lᵀ λ)_a| ≤ τ_max
//!   friction:       pyramid rows (or SOC with the Clarabel backend), f_z ≤ f_max
//!   joint limits:   q̈_lo ≤ q̈_j ≤ q̈_hi                       (joints with position limits)
//! ```
//!
//! The joint-limit bounds stop a joint at its position limit within the horizon `h`
//! ([`WbcConfig::joint_limit_horizon`]): `q̈_hi = 2 (q_max − q − q̇ h) / h²` and likewise
//! `q̈_lo` from `q_min`. The deceleration they may demand is capped at
//! [`WbcConfig::joint_limit_max_deceleration`] and, for an actuated joint, at half its
//! effort limit over its diagonal inertia `M_jj` (armature included), so that a joint that
//! starts outside its range (the Ant's ankles start at 0, outside [30°, 70°]) or moves fast
//! towards a limit does not ask for more than its motor gives. Should the problem still be
//! infeasible, it is solved again without the joint-limit bounds
//! ([`WholeBodyQp::limits_relaxed`]). Without them a robot that stands on a limit
//! (Walker2d's straight knees and hips rest on their upper limits of 0) gets a plan that
//! drives the joint through the limit; the simulator's limit stops it, and the body
//! accelerates otherwise than planned.
//!
//! Stance contacts are a weighted task rather than an equality: with `f = 0, τ = 0`,
//! `q̈ = M⁻¹(J_lᵀλ − h)` satisfies every constraint but the joint-limit bounds (free fall),
//! so the QP without them is feasible for every state by construction — which is why an
//! infeasible problem is retried without the bounds; a robot whose feet must slip shows up
//! as a residual, not as an infeasible problem. Torques follow as `τ = (M q̈ + h − J_cᵀ f − J_lᵀ λ)_a`.
//!
//! Two backends solve the same problem: [`QpBackend::Dense`] (Goldfarb–Idnani on dense
//! Cholesky, [`crate::DenseQp`]) and [`QpBackend::Clarabel`] (one interior-point solver
//! per stance pattern, built at construction with the structural sparsity of the model and
//! updated in place).

use centaur_dynamics::Model;
use centaur_dynamics::nalgebra::{DMatrix, DVector, Matrix3xX, Matrix6xX, Vector3, Vector6};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SupportedConeT};

use crate::error::ConfigError;
use crate::friction::FrictionModel;
use crate::qp::{DenseQp, DenseQpData, QpStatus};
use crate::robot::LeggedRobot;

/// Which solver the whole-body QP uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum QpBackend {
    /// Goldfarb–Idnani dual active set on dense matrices (linear friction only).
    #[default]
    Dense,
    /// Clarabel interior point (exact cones allowed).
    Clarabel,
}

/// Whole-body QP settings.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct WbcConfig {
    /// Solver (default: dense).
    pub backend: QpBackend,
    /// Friction model (default: inscribed pyramid; `Cone` needs the Clarabel backend).
    pub friction: FrictionModel,
    /// Friction coefficient (default: 0.6).
    pub mu: f64,
    /// Largest normal force per contact as a multiple of the weight (default: 1.0).
    pub max_normal_force_ratio: f64,
    /// Weight of the body linear-acceleration task (default: 10).
    pub w_body_linear: f64,
    /// Weight of the body angular-acceleration task (default: 10).
    pub w_body_angular: f64,
    /// Relative weights of the rows of the body task: CoM x, y, z, body roll, pitch, yaw
    /// accelerations (default: all 1). A robot whose stance legs lock some body motions
    /// (the Ant's two-dof legs couple height, roll and pitch to forward motion) should
    /// favour the rows that matter for travel.
    pub body_axis_weights: [f64; 6],
    /// Weight of the stance no-slip task (default: 1000).
    pub w_stance: f64,
    /// Weight of the swing-foot task (default: 20).
    pub w_swing: f64,
    /// Relative weights of the x, y, z rows of the swing-foot task (default: [1, 1, 1]; legs
    /// with fewer than three dof, e.g. the Ant's, cannot follow a 3-D curve and should favour
    /// the height).
    pub swing_axis_weights: [f64; 3],
    /// Weight of the posture task (default: 0.05).
    pub w_posture: f64,
    /// Weight of tracking the MPC forces, per N² (default: 0.01).
    pub w_force: f64,
    /// Regularisation `ε` on every variable (default: 1e-6).
    pub regularization: f64,
    /// Baumgarte stiffness of loop closures (1/s²) (default: 400).
    pub closure_kp: f64,
    /// Baumgarte damping of loop closures (1/s) (default: 40).
    pub closure_kd: f64,
    /// Clarabel tolerance (default: 1e-8).
    pub tolerance: f64,
    /// Time (s) within which a joint moving towards a position limit must be able to stop
    /// there; 0 leaves joint limits out of the QP (default: 0.1).
    pub joint_limit_horizon: f64,
    /// Largest deceleration (rad/s² or m/s²) a joint-limit bound may demand (default: 200;
    /// an actuated joint is also capped by its effort, see the module docs).
    pub joint_limit_max_deceleration: f64,
}

impl Default for WbcConfig {
    fn default() -> Self {
        Self {
            backend: QpBackend::Dense,
            friction: FrictionModel::InscribedPyramid,
            mu: 0.6,
            max_normal_force_ratio: 1.0,
            w_body_linear: 10.0,
            w_body_angular: 10.0,
            w_stance: 1000.0,
            body_axis_weights: [1.0; 6],
            w_swing: 20.0,
            swing_axis_weights: [1.0; 3],
            w_posture: 0.05,
            w_force: 0.01,
            regularization: 1e-6,
            closure_kp: 400.0,
            closure_kd: 40.0,
            tolerance: 1e-8,
            joint_limit_horizon: 0.1,
            joint_limit_max_deceleration: 200.0,
        }
    }
}

impl WbcConfig {
    /// Checks ranges and the backend/friction combination.
    pub fn validate(&self) -> Result<(), ConfigError> {
        use ConfigError as E;
        let checks = [
            ("wbc.mu", self.mu, self.mu >= 0.0),
            ("wbc.max_normal_force_ratio", self.max_normal_force_ratio, self.max_normal_force_ratio > 0.0),
            ("wbc.w_body_linear", self.w_body_linear, self.w_body_linear >= 0.0),
            ("wbc.w_body_angular", self.w_body_angular, self.w_body_angular >= 0.0),
            ("wbc.w_stance", self.w_stance, self.w_stance >= 0.0),
            ("wbc.w_swing", self.w_swing, self.w_swing >= 0.0),
            (
                "wbc.body_axis_weights",
                self.body_axis_weights.iter().fold(f64::INFINITY, |a, b| a.min(*b)),
                self.body_axis_weights.iter().all(|w| *w >= 0.0 && w.is_finite()),
            ),
            ("wbc.swing_axis_weights", self.swing_axis_weights[0], self.swing_axis_weights[0] >= 0.0),
            ("wbc.swing_axis_weights", self.swing_axis_weights[1], self.swing_axis_weights[1] >= 0.0),
            ("wbc.swing_axis_weights", self.swing_axis_weights[2], self.swing_axis_weights[2] >= 0.0),
            ("wbc.w_posture", self.w_posture, self.w_posture >= 0.0),
            ("wbc.w_force", self.w_force, self.w_force >= 0.0),
            ("wbc.regularization", self.regularization, self.regularization > 0.0),
            ("wbc.closure_kp", self.closure_kp, self.closure_kp >= 0.0),
            ("wbc.closure_kd", self.closure_kd, self.closure_kd >= 0.0),
            ("wbc.tolerance", self.tolerance, self.tolerance > 0.0),
            ("wbc.joint_limit_horizon", self.joint_limit_horizon, self.joint_limit_horizon >= 0.0),
            (
                "wbc.joint_limit_max_deceleration",
                self.joint_limit_max_deceleration,
                self.joint_limit_max_deceleration > 0.0,
            ),
        ];
        for (field, value, ok) in checks {
            if !(ok && value.is_finite()) {
                return Err(E::OutOfRange { field, value, range: "finite, see the field's doc" });
            }
        }
        if self.backend == QpBackend::Dense && !self.friction.is_pyramid() {
            return Err(E::Inconsistent("the dense whole-body solver needs a pyramid friction model".into()));
        }
        Ok(())
    }
}

/// Kinematic and dynamic quantities of the current state, written by the caller.
#[derive(Clone, Debug)]
pub struct WbcInput {
    /// `M(q)`.
    pub mass_matrix: DMatrix<f64>,
    /// `h = C q̇ + g`.
    pub nle: DVector<f64>,
    /// Linear Jacobian (world axes) of each contact point.
    pub j_contact: Vec<Matrix3xX<f64>>,
    /// `J̇ q̇` of each contact point.
    pub jdqd_contact: Vec<Vector3<f64>>,
    /// Body-task Jacobian: rows 0–2 the centre-of-mass Jacobian `J_com` (world axes), rows
    /// 3–5 the angular rows of the body frame's Jacobian (LocalWorldAligned).
    pub j_body: Matrix6xX<f64>,
    /// `J̇ q̇` of the body task: CoM acceleration and body angular acceleration at `q̈ = 0`.
    pub jdqd_body: Vector6<f64>,
    /// Loop-closure rows `dᵀ(J_a − J_b)`.
    pub j_closure: DMatrix<f64>,
    /// Right-hand side of the closure rows.
    pub closure_rhs: DVector<f64>,
    /// Stance flag per contact.
    pub stance: Vec<bool>,
    /// MPC force per contact (world axes).
    pub f_ref: Vec<Vector3<f64>>,
    /// Desired body acceleration `[linear; angular]` (world axes).
    pub a_body: Vector6<f64>,
    /// Desired acceleration of each swing contact.
    pub a_swing: Vec<Vector3<f64>>,
    /// Direction each swing contact's horizontal task ignores (a unit vector, or zero for
    /// none): legs with two dof move their foot on a surface and cannot follow a 3-D curve;
    /// tracking height and the other horizontal direction exactly beats a least-squares
    /// compromise in all three.
    pub swing_free_direction: Vec<Vector3<f64>>,
    /// Desired acceleration of each non-base joint (order of `LeggedRobot::joint_v`).
    pub qdd_posture: Vec<f64>,
    /// Weight `m g` (for the normal-force limit).
    pub weight: f64,
    /// Lower bound on the acceleration of each joint with position limits (order of
    /// [`WholeBodyQp::limited_joints`]); set by [`WholeBodyQp::set_joint_limit_bounds`].
    pub qdd_lower: Vec<f64>,
    /// Upper bound, same order.
    pub qdd_upper: Vec<f64>,
}

/// A joint with finite position limits: its `v` and `q` indices, the limits and its effort
/// limit (infinite for a passive joint).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimitedJoint {
    /// Index in `v`.
    pub v: usize,
    /// Index in `q`.
    pub q: usize,
    /// Lower position limit.
    pub lower: f64,
    /// Upper position limit.
    pub upper: f64,
    /// Effort limit of its motor (infinite when passive).
    pub effort: f64,
}

/// Solution of the whole-body QP.
#[derive(Clone, Debug)]
pub struct WbcOutput {
    /// Generalized accelerations.
    pub qdd: DVector<f64>,
    /// Contact forces (zero for swing contacts).
    pub forces: Vec<Vector3<f64>>,
    /// Torques of the actuated joints.
    pub tau: Vec<f64>,
}

struct ClarabelWbc {
    solver: DefaultSolver<f64>,
    /// (row, col) of every stored entry of P (upper triangle) in nzval order.
    p_entries: Vec<(usize, usize)>,
    /// (row, col) of every stored entry of the dense rows of A in nzval order (SOC rows
    /// keep their constant values: `usize::MAX` marks them).
    a_entries: Vec<(usize, usize)>,
    p_val: Vec<f64>,
    a_val: Vec<f64>,
    b: Vec<f64>,
    q_buf: Vec<f64>,
}

/// The joint-limit bound that stands for "none" when a problem is solved again without
/// them: far beyond any acceleration the torque limits allow.
const RELAXED_BOUND: f64 = 1e6;

/// The whole-body controller QP with its buffers.
pub struct WholeBodyQp {
    cfg: WbcConfig,
    nv: usize,
    nc: usize,
    nl: usize,
    actuated_v: Vec<usize>,
    unactuated_v: Vec<usize>,
    joint_v: Vec<usize>,
    effort: Vec<f64>,
    contact_leg: Vec<usize>,
    limited: Vec<LimitedJoint>,
    limits_relaxed: bool,
    /// Inputs of the next solve.
    pub input: WbcInput,
    /// Result of the last successful solve.
    pub output: WbcOutput,
    qp: DenseQpData,
    dense: DenseQp,
    clarabel: Vec<Option<ClarabelWbc>>,
    stance_index: Vec<usize>,
    row_buf: Vec<f64>,
    status: QpStatus,
    iterations: u32,
}

impl std::fmt::Debug for WholeBodyQp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WholeBodyQp").field("cfg", &self.cfg).field("status", &self.status).finish()
    }
}

/// Dofs (v indices) that move `frame`: the support of its joint.
fn frame_support(model: &Model, frame: usize) -> Vec<bool> {
    let mut s = vec![false; model.nv];
    let j = model.frames[frame].parent_joint;
    for &a in model.support(j) {
        let jj = &model.joints[a];
        for k in 0..jj.nv() {
            s[jj.idx_v + k] = true;
        }
    }
    s
}

impl WholeBodyQp {
    /// Buffers and solvers for `robot`.
    pub fn new(robot: &LeggedRobot, cfg: &WbcConfig) -> Result<Self, ConfigError> {
        cfg.validate()?;
        let model = &robot.model;
        let nv = model.nv;
        let nc = robot.n_contacts();
        let nl = robot.n_closure_rows;
        let na = robot.n_actuated();
        let n_max = nv + 3 * nc + nl;
        let p_max = robot.unactuated_v.len() + nl;
        let limited: Vec<LimitedJoint> = if cfg.joint_limit_horizon > 0.0 {
            robot
                .joint_v
                .iter()
                .zip(&robot.joint_q)
                .map(|(&v, &q)| LimitedJoint {
                    v,
                    q,
                    lower: model.lower_position_limit[q],
                    upper: model.upper_position_limit[q],
                    effort: robot
                        .actuated_v
                        .iter()
                        .position(|&a| a == v)
                        .map_or(f64::INFINITY, |a| robot.effort[a]),
                })
                .filter(|l| l.lower.is_finite() && l.upper.is_finite())
                .collect()
        } else {
            Vec::new()
        };
        let nlim = limited.len();
        let m_max = 2 * na + 6 * nc + 2 * nlim;
        let input = WbcInput {
            mass_matrix: DMatrix::zeros(nv, nv),
            nle: DVector::zeros(nv),
            j_contact: vec![Matrix3xX::zeros(nv); nc],
            jdqd_contact: vec![Vector3::zeros(); nc],
            j_body: Matrix6xX::zeros(nv),
            jdqd_body: Vector6::zeros(),
            j_closure: DMatrix::zeros(nl, nv),
            closure_rhs: DVector::zeros(nl),
            stance: vec![true; nc],
            f_ref: vec![Vector3::zeros(); nc],
            a_body: Vector6::zeros(),
            a_swing: vec![Vector3::zeros(); nc],
            swing_free_direction: vec![Vector3::zeros(); nc],
            qdd_posture: vec![0.0; robot.joint_v.len()],
            weight: robot.mass * 9.81,
            qdd_lower: vec![-cfg.joint_limit_max_deceleration; nlim],
            qdd_upper: vec![cfg.joint_limit_max_deceleration; nlim],
        };
        let output =
            WbcOutput { qdd: DVector::zeros(nv), forces: vec![Vector3::zeros(); nc], tau: vec![0.0; na] };
        let mut w = WholeBodyQp {
            cfg: cfg.clone(),
            nv,
            nc,
            nl,
            actuated_v: robot.actuated_v.clone(),
            unactuated_v: robot.unactuated_v.clone(),
            joint_v: robot.joint_v.clone(),
            effort: robot.effort.clone(),
            contact_leg: robot.contact_leg.clone(),
            limited,
            limits_relaxed: false,
            input,
            output,
            qp: DenseQpData::new(n_max, p_max, m_max),
            dense: DenseQp::new(n_max, p_max + m_max),
            clarabel: Vec::new(),
            stance_index: vec![0; nc],
            row_buf: vec![0.0; nv],
            status: QpStatus::NotRun,
            iterations: 0,
        };
        if cfg.backend == QpBackend::Clarabel {
            for mask in 0..(1usize << robot.n_legs) {
                let stance: Vec<bool> = robot.contact_leg.iter().map(|&l| mask & (1 << l) != 0).collect();
                let cw = w.build_clarabel(robot, &stance)?;
                w.clarabel.push(Some(cw));
            }
        }
        Ok(w)
    }

    /// Sets the weight of body axis `axis` (0–2 linear, 3–5 angular; see
    /// [`WbcConfig::body_axis_weights`]) for the next solves. The controller raises the yaw
    /// axis while a trot is staggered for turning; the caller passes a validated weight.
    pub(crate) fn set_body_axis_weight(&mut self, axis: usize, weight: f64) {
        debug_assert!(weight.is_finite() && weight >= 0.0);
        self.cfg.body_axis_weights[axis] = weight;
    }

    /// Sets the posture weight ([`WbcConfig::w_posture`]) for the next solves. The
    /// controller changes it while a trot is staggered for turning; the caller passes a
    /// validated weight.
    pub(crate) fn set_posture_weight(&mut self, weight: f64) {
        debug_assert!(weight.is_finite() && weight >= 0.0);
        self.cfg.w_posture = weight;
    }

    /// Sets the body-orientation weight ([`WbcConfig::w_body_angular`]) for the next solves.
    /// The controller sets the running gait's own ([`crate::GaitOffer::body_angular_weight`]);
    /// the caller passes a validated weight.
    pub(crate) fn set_body_angular_weight(&mut self, weight: f64) {
        debug_assert!(weight.is_finite() && weight >= 0.0);
        self.cfg.w_body_angular = weight;
    }

    /// Status of the last solve.
    pub fn status(&self) -> QpStatus {
        self.status
    }

    /// Iterations (dense: active-set changes; Clarabel: interior-point iterations).
    pub fn iterations(&self) -> u32 {
        self.iterations
    }

    /// Configuration.
    pub fn config(&self) -> &WbcConfig {
        &self.cfg
    }

    /// The joints whose accelerations the QP bounds to respect position limits (empty when
    /// [`WbcConfig::joint_limit_horizon`] is 0).
    pub fn limited_joints(&self) -> &[LimitedJoint] {
        &self.limited
    }

    /// Whether the last solve dropped the joint-limit bounds because the problem with them
    /// was infeasible.
    pub fn limits_relaxed(&self) -> bool {
        self.limits_relaxed
    }

    /// Sets [`WbcInput::qdd_lower`] and [`WbcInput::qdd_upper`] from the state (call it
    /// after filling [`WbcInput::mass_matrix`]): with the horizon `h`,
    /// `q̈_hi = 2 (q_max − q − q̇ h) / h²`, no lower than `−a_max`, and
    /// `q̈_lo = 2 (q_min − q − q̇ h) / h²`, no higher than `a_max`, where `a_max` is the
    /// smaller of [`WbcConfig::joint_limit_max_deceleration`] and `τ_max / (2 M_jj)`.
    pub fn set_joint_limit_bounds(&mut self, q: &[f64], v: &[f64]) {
        let h = self.cfg.joint_limit_horizon;
        for (k, l) in self.limited.iter().enumerate() {
            let m_jj = self.input.mass_matrix[(l.v, l.v)];
            let a_max = if m_jj > 0.0 {
                self.cfg.joint_limit_max_deceleration.min(0.5 * l.effort / m_jj)
            } else {
                self.cfg.joint_limit_max_deceleration
            };
            let drift = q[l.q] + v[l.v] * h;
            let hi = 2.0 * (l.upper - drift) / (h * h);
            let lo = 2.0 * (l.lower - drift) / (h * h);
            self.input.qdd_upper[k] = hi.max(-a_max);
            self.input.qdd_lower[k] = lo.min(a_max);
        }
    }

    /// Column of the force of stance contact `c` (after `assemble`).
    fn fcol(&self, c: usize) -> usize {
        self.nv + 3 * self.stance_index[c]
    }

    /// Builds the dense problem from `self.input`, in the order of the module docs: the
    /// tasks (body, stance and swing feet, posture, forces, regularisation), then the
    /// constraints (unactuated dynamics rows, loop closures, torque limits, normal-force
    /// limits and friction, joint limits). Returns (n, n_stance).
    fn assemble(&mut self) -> (usize, usize) {
        let mut ns = 0;
        for c in 0..self.nc {
            self.stance_index[c] = ns;
            if self.input.stance[c] {
                ns += 1;
            }
        }
        let n = self.nv + 3 * ns + self.nl;
        let p = self.unactuated_v.len() + self.nl;
        let pyr = self.cfg.friction.is_pyramid();
        let m = 2 * self.actuated_v.len() + ns * if pyr { 5 } else { 1 } + 2 * self.limited.len();
        self.qp.reset(n, p, m);
        self.body_task();
        self.contact_tasks();
        self.posture_task();
        self.force_task();
        for i in 0..n {
            self.qp.h[i * n + i] += self.cfg.regularization;
        }
        let lcol = self.nv + 3 * ns;
        self.equality_rows(lcol);
        let mut ir = self.torque_limit_rows(lcol);
        ir = self.force_rows(ir);
        ir = self.joint_limit_rows(ir);
        debug_assert_eq!(ir, m);
        (n, ns)
    }

    /// Body task: `J_com q̈ + J̇_com q̇ = c̈_des` and `J_ω q̈ + J̇_ω q̇ = ω̇_des`, per axis weight.
    fn body_task(&mut self) {
        let (inp, cfg) = (&self.input, &self.cfg);
        let mut row = std::mem::take(&mut self.row_buf);
        for d in 0..6 {
            for c in 0..self.nv {
                row[c] = inp.j_body[(d, c)];
            }
            let w = if d < 3 { cfg.w_body_linear } else { cfg.w_body_angular } * cfg.body_axis_weights[d];
            add_task_row(&mut self.qp, self.nv, &row, inp.a_body[d] - inp.jdqd_body[d], w);
        }
        self.row_buf = row;
    }

    /// Stance feet: `J_c q̈ + J̇_c q̇ = 0` (soft, high weight); swing feet:
    /// `J_c q̈ + J̇_c q̇ = a_c,des` along world x, y, z, or, with a free direction `n`, along
    /// `(ẑ × n, n, ẑ)` with the `n` row dropped.
    fn contact_tasks(&mut self) {
        let (inp, cfg, nv) = (&self.input, &self.cfg, self.nv);
        let mut row = std::mem::take(&mut self.row_buf);
        for c in 0..self.nc {
            let (target, w) =
                if inp.stance[c] { (Vector3::zeros(), cfg.w_stance) } else { (inp.a_swing[c], cfg.w_swing) };
            let n = inp.swing_free_direction[c];
            let dirs = if inp.stance[c] || n == Vector3::zeros() {
                [Vector3::x(), Vector3::y(), Vector3::z()]
            } else {
                [Vector3::z().cross(&n), n, Vector3::z()]
            };
            for (d, e) in dirs.iter().enumerate() {
                for k in 0..nv {
                    let jc = &inp.j_contact[c];
                    row[k] = e.x * jc[(0, k)] + e.y * jc[(1, k)] + e.z * jc[(2, k)];
                }
                let mut wd = if inp.stance[c] { w } else { w * cfg.swing_axis_weights[d] };
                if !inp.stance[c] && n != Vector3::zeros() && d == 1 {
                    wd = 0.0;
                }
                add_task_row(&mut self.qp, nv, &row, e.dot(&(target - inp.jdqd_contact[c])), wd);
            }
        }
        self.row_buf = row;
    }

    /// Posture: `q̈_j = k_p (q_nom − q) − k_d q̇` for the non-base joints.
    fn posture_task(&mut self) {
        let n = self.qp.n;
        for (k, &iv) in self.joint_v.iter().enumerate() {
            self.qp.h[iv * n + iv] += self.cfg.w_posture;
            self.qp.g[iv] -= self.cfg.w_posture * self.input.qdd_posture[k];
        }
    }

    /// Forces: `f = f_MPC` for the stance contacts.
    fn force_task(&mut self) {
        let (n, nv) = (self.qp.n, self.nv);
        for c in 0..self.nc {
            if self.input.stance[c] {
                let col = nv + 3 * self.stance_index[c];
                for d in 0..3 {
                    self.qp.h[(col + d) * n + col + d] += self.cfg.w_force;
                    self.qp.g[col + d] -= self.cfg.w_force * self.input.f_ref[c][d];
                }
            }
        }
    }

    /// Equalities: the unactuated dynamics rows `(M q̈ + h − J_cᵀ f − J_lᵀ λ)_u = 0`, then the
    /// loop closures `J_l q̈ = −J̇_l q̇ − k_p e − k_d ė` (`lcol`: the first λ column).
    fn equality_rows(&mut self, lcol: usize) {
        let (inp, qp) = (&self.input, &mut self.qp);
        for (i, &j) in self.unactuated_v.iter().enumerate() {
            dynamics_row(inp, self.nv, self.nl, lcol, qp.e_row(i), j, 1.0);
            qp.e[i] = -inp.nle[j];
        }
        let pu = self.unactuated_v.len();
        for l in 0..self.nl {
            let r = qp.e_row(pu + l);
            for k in 0..self.nv {
                r[k] = inp.j_closure[(l, k)];
            }
            qp.e[pu + l] = inp.closure_rhs[l];
        }
    }

    /// Torque limits `|(M q̈ + h − J_cᵀ f − J_lᵀ λ)_a| ≤ τ_max`, two rows per actuated joint
    /// from the first inequality row; returns the next row.
    fn torque_limit_rows(&mut self, lcol: usize) -> usize {
        let (inp, qp) = (&self.input, &mut self.qp);
        let mut ir = 0;
        for (a, &j) in self.actuated_v.iter().enumerate() {
            let tmax = self.effort[a];
            dynamics_row(inp, self.nv, self.nl, lcol, qp.c_row(ir), j, 1.0);
            qp.d[ir] = tmax - inp.nle[j];
            dynamics_row(inp, self.nv, self.nl, lcol, qp.c_row(ir + 1), j, -1.0);
            qp.d[ir + 1] = tmax + inp.nle[j];
            ir += 2;
        }
        ir
    }

    /// Per stance contact from row `ir`: `f_z ≤ f_max`, and the pyramid's four rows (the
    /// cone is the Clarabel backend's); returns the next row.
    fn force_rows(&mut self, mut ir: usize) -> usize {
        let (inp, cfg, qp) = (&self.input, &self.cfg, &mut self.qp);
        let fmax = cfg.max_normal_force_ratio * inp.weight;
        let mu_p = cfg.friction.pyramid_mu(cfg.mu);
        for c in 0..self.nc {
            if !inp.stance[c] {
                continue;
            }
            let col = self.nv + 3 * self.stance_index[c];
            qp.c_row(ir)[col + 2] = 1.0;
            qp.d[ir] = fmax;
            ir += 1;
            if cfg.friction.is_pyramid() {
                for a in crate::friction::pyramid_rows(mu_p) {
                    let r = qp.c_row(ir);
                    r[col..col + 3].copy_from_slice(&a);
                    ir += 1;
                }
            }
        }
        ir
    }

    /// Joint limits `q̈_lo ≤ q̈_j ≤ q̈_hi` from row `ir`; returns the next row.
    fn joint_limit_rows(&mut self, mut ir: usize) -> usize {
        for (k, l) in self.limited.iter().enumerate() {
            self.qp.c_row(ir)[l.v] = 1.0;
            self.qp.d[ir] = self.input.qdd_upper[k];
            self.qp.c_row(ir + 1)[l.v] = -1.0;
            self.qp.d[ir + 1] = -self.input.qdd_lower[k];
            ir += 2;
        }
        ir
    }

    /// Assembles and solves; on success fills [`WholeBodyQp::output`]. An infeasible problem
    /// with joint-limit bounds is solved again without them ([`WholeBodyQp::limits_relaxed`]);
    /// the bounds then stay open until the next [`WholeBodyQp::set_joint_limit_bounds`].
    pub fn solve(&mut self) -> QpStatus {
        self.limits_relaxed = false;
        let status = self.solve_once();
        if status == QpStatus::PrimalInfeasible && !self.limited.is_empty() {
            self.limits_relaxed = true;
            self.input.qdd_lower.fill(-RELAXED_BOUND);
            self.input.qdd_upper.fill(RELAXED_BOUND);
            return self.solve_once();
        }
        status
    }

    fn solve_once(&mut self) -> QpStatus {
        let (n, _ns) = self.assemble();
        let status = match self.cfg.backend {
            QpBackend::Dense => {
                let s = self.dense.solve(&mut self.qp);
                self.iterations = self.dense.iterations() as u32;
                s
            }
            QpBackend::Clarabel => self.solve_clarabel(),
        };
        self.status = status;
        if status.is_ok() {
            let x: &[f64] = match self.cfg.backend {
                QpBackend::Dense => self.dense.solution(),
                QpBackend::Clarabel => {
                    let mask = self.leg_mask();
                    &self.clarabel[mask].as_ref().expect("built").solver.solution.x
                }
            };
            let x = &x[..n];
            if x.iter().any(|v| !v.is_finite()) {
                self.status = QpStatus::NumericalError;
                return self.status;
            }
            self.output.qdd.as_mut_slice().copy_from_slice(&x[..self.nv]);
            for c in 0..self.nc {
                self.output.forces[c] = if self.input.stance[c] {
                    let col = self.fcol(c);
                    Vector3::new(x[col], x[col + 1], x[col + 2])
                } else {
                    Vector3::zeros()
                };
            }
            // τ_a = row_a · x + h_a (the torque-limit row without its bound).
            for (a, _) in self.actuated_v.iter().enumerate() {
                let r = &self.qp.c_mat[(2 * a) * n..(2 * a + 1) * n];
                let j = self.actuated_v[a];
                self.output.tau[a] = r.iter().zip(x).map(|(p, q)| p * q).sum::<f64>() + self.input.nle[j];
            }
        }
        self.status
    }

    fn leg_mask(&self) -> usize {
        let mut mask = 0;
        for c in 0..self.nc {
            if self.input.stance[c] {
                mask |= 1 << self.contact_leg[c];
            }
        }
        mask
    }

    fn build_clarabel(&mut self, robot: &LeggedRobot, stance: &[bool]) -> Result<ClarabelWbc, ConfigError> {
        let model = &robot.model;
        let nv = self.nv;
        let nc = self.nc;
        // Structural pattern: supports of every Jacobian, mass-matrix couplings.
        let sup_c: Vec<Vec<bool>> = robot.contact_frames.iter().map(|&f| frame_support(model, f)).collect();
        let sup_b = frame_support(model, robot.body_frame);
        let mut sup_l: Vec<bool> = vec![false; nv];
        for cl in &robot.closures {
            for f in [cl.frame_a, cl.frame_b] {
                for (k, s) in frame_support(model, f).into_iter().enumerate() {
                    sup_l[k] |= s;
                }
            }
        }
        let m_nz =
            |i: usize, j: usize| model.dof_support(i).contains(&j) || model.dof_support(j).contains(&i);
        // Fill the input with a pattern: ones wherever an entry may be non-zero.
        let inp = &mut self.input;
        for i in 0..nv {
            for j in 0..nv {
                inp.mass_matrix[(i, j)] = if m_nz(i, j) { 1.0 } else { 0.0 };
            }
        }
        for c in 0..nc {
            for k in 0..nv {
                for d in 0..3 {
                    inp.j_contact[c][(d, k)] = if sup_c[c][k] { 1.0 } else { 0.0 };
                }
            }
        }
        for k in 0..nv {
            for d in 0..6 {
                // The CoM rows involve every dof; the angular rows the body frame's support.
                inp.j_body[(d, k)] = if d < 3 || sup_b[k] { 1.0 } else { 0.0 };
            }
            for l in 0..self.nl {
                inp.j_closure[(l, k)] = if sup_l[k] { 1.0 } else { 0.0 };
            }
        }
        for (k, v) in inp.qdd_posture.iter_mut().enumerate() {
            *v = k as f64;
        }
        inp.stance.copy_from_slice(stance);
        let (n, ns) = self.assemble();
        let qp = &self.qp;
        let mut p_entries = Vec::new();
        for c in 0..n {
            for r in 0..=c {
                if qp.h[c * n + r] != 0.0 || r == c {
                    p_entries.push((r, c));
                }
            }
        }
        let rows = qp.p + qp.m;
        let pyr = self.cfg.friction.is_pyramid();
        let n_soc = if pyr { 0 } else { ns };
        let mut a_entries = Vec::new();
        for c in 0..n {
            for r in 0..rows {
                let v = if r < qp.p { qp.e_mat[r * n + c] } else { qp.c_mat[(r - qp.p) * n + c] };
                if v != 0.0 {
                    a_entries.push((r, c));
                }
            }
        }
        // SOC rows after the dense rows: s = (μ f_z, f_x, f_y) = −A f with b = 0.
        let mut soc = Vec::new();
        for s in 0..n_soc {
            let col = nv + 3 * s;
            soc.push((rows + 3 * s, col + 2, -self.cfg.mu));
            soc.push((rows + 3 * s + 1, col, -1.0));
            soc.push((rows + 3 * s + 2, col + 1, -1.0));
        }
        let m_total = rows + 3 * n_soc;
        let (pr, pc): (Vec<usize>, Vec<usize>) = p_entries.iter().copied().unzip();
        let p_val: Vec<f64> = p_entries.iter().map(|&(r, c)| qp.h[c * n + r]).collect();
        let p = CscMatrix::new_from_triplets(n, n, pr.clone(), pc.clone(), p_val.clone());
        let mut ar: Vec<usize> = a_entries.iter().map(|e| e.0).collect();
        let mut ac: Vec<usize> = a_entries.iter().map(|e| e.1).collect();
        let mut av: Vec<f64> = vec![1.0; a_entries.len()];
        for &(r, c, v) in &soc {
            ar.push(r);
            ac.push(c);
            av.push(v);
        }
        let a = CscMatrix::new_from_triplets(m_total, n, ar.clone(), ac.clone(), av);
        // Sort entries in nzval order.
        let pos_p = crate::convex_mpc::triplet_positions(&p, &pr, &pc);
        let mut p_sorted = vec![(0, 0); p_entries.len()];
        for (t, &k) in pos_p.iter().enumerate() {
            p_sorted[k] = p_entries[t];
        }
        let pos_a = crate::convex_mpc::triplet_positions(&a, &ar, &ac);
        let mut a_sorted = vec![(usize::MAX, 0); ar.len()];
        for (t, &k) in pos_a.iter().enumerate() {
            a_sorted[k] = if t < a_entries.len() { a_entries[t] } else { (usize::MAX, t - a_entries.len()) };
        }
        let mut cones = Vec::new();
        if qp.p > 0 {
            cones.push(SupportedConeT::ZeroConeT(qp.p));
        }
        cones.push(SupportedConeT::NonnegativeConeT(qp.m));
        for _ in 0..n_soc {
            cones.push(SupportedConeT::SecondOrderConeT(3));
        }
        let settings = DefaultSettings::<f64> {
            verbose: false,
            presolve_enable: false,
            tol_gap_abs: self.cfg.tolerance,
            tol_gap_rel: self.cfg.tolerance,
            tol_feas: self.cfg.tolerance,
            max_iter: 50,
            max_threads: 1,
            ..Default::default()
        };
        let b = vec![0.0; m_total];
        let solver = DefaultSolver::new(&p, &qp.g[..n], &a, &b, &cones, settings)
            .map_err(|source| ConfigError::Solver { problem: "whole-body QP", source })?;
        let soc_vals: Vec<f64> = soc.iter().map(|s| s.2).collect();
        let mut a_val = a.nzval.clone();
        for (k, e) in a_sorted.iter().enumerate() {
            if e.0 == usize::MAX {
                a_val[k] = soc_vals[e.1];
            }
        }
        Ok(ClarabelWbc {
            solver,
            p_entries: p_sorted,
            a_entries: a_sorted,
            p_val: p.nzval.clone(),
            a_val,
            b,
            q_buf: vec![0.0; n],
        })
    }

    fn solve_clarabel(&mut self) -> QpStatus {
        if !self.qp.is_finite() {
            return QpStatus::NumericalError;
        }
        let mask = self.leg_mask();
        let qp = &self.qp;
        let n = qp.n;
        let Some(cw) = self.clarabel[mask].as_mut() else { return QpStatus::NumericalError };
        for (k, &(r, c)) in cw.p_entries.iter().enumerate() {
            cw.p_val[k] = qp.h[c * n + r];
        }
        for (k, &(r, c)) in cw.a_entries.iter().enumerate() {
            if r == usize::MAX {
                continue;
            }
            cw.a_val[k] = if r < qp.p { qp.e_mat[r * n + c] } else { qp.c_mat[(r - qp.p) * n + c] };
        }
        cw.b[..qp.p].copy_from_slice(&qp.e[..qp.p]);
        cw.b[qp.p..qp.p + qp.m].copy_from_slice(&qp.d[..qp.m]);
        cw.q_buf.copy_from_slice(&qp.g[..n]);
        let ok = cw.solver.update_P(&cw.p_val).is_ok()
            && cw.solver.update_q(&cw.q_buf).is_ok()
            && cw.solver.update_A(&cw.a_val).is_ok()
            && cw.solver.update_b(&cw.b).is_ok();
        if !ok {
            return QpStatus::NumericalError;
        }
        cw.solver.solve();
        self.iterations = cw.solver.solution.iterations;
        QpStatus::from_clarabel(cw.solver.solution.status)
    }
}
/// Adds the task row `a·x ≈ b` with weight `w` over the `q̈` block (`nv` columns):
/// `H += w aᵀa`, `g −= w b a`.
fn add_task_row(qp: &mut DenseQpData, nv: usize, a: &[f64], b: f64, w: f64) {
    if w == 0.0 {
        return;
    }
    let n = qp.n;
    for c in 0..nv {
        let ac = a[c];
        if ac == 0.0 {
            continue;
        }
        qp.g[c] -= w * b * ac;
        for r in 0..nv {
            qp.h[c * n + r] += w * a[r] * ac;
        }
    }
}

/// Row `j` of `sign · (M q̈ − J_cᵀ f − J_lᵀ λ)` over `[q̈, f (stance contacts), λ]` into
/// `qp_row` (`lcol`: the first λ column; `h_j` goes to the right-hand side).
fn dynamics_row(inp: &WbcInput, nv: usize, nl: usize, lcol: usize, qp_row: &mut [f64], j: usize, sign: f64) {
    for k in 0..nv {
        qp_row[k] = sign * inp.mass_matrix[(j, k)];
    }
    let mut s = 0;
    for c in 0..inp.stance.len() {
        if inp.stance[c] {
            let col = nv + 3 * s;
            for d in 0..3 {
                qp_row[col + d] = -sign * inp.j_contact[c][(d, j)];
            }
            s += 1;
        }
    }
    for l in 0..nl {
        qp_row[lcol + l] = -sign * inp.j_closure[(l, j)];
    }
}
