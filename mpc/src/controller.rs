//! [`LocomotionController`]: gait schedule → footholds and swing curves → convex MPC →
//! whole-body QP (or the cheap path) → joint command, allocation-free after construction.

use std::time::Instant;

use centaur_dynamics::nalgebra::{
    DVector, Matrix3, Matrix3xX, Matrix6xX, Rotation3, UnitQuaternion, Vector3,
};
use centaur_dynamics::{
    Data, Model, ReferenceFrame, RobotState, crba, forward_kinematics, forward_kinematics_acceleration,
    frame_acceleration, frame_classical_acceleration, frame_jacobian, frame_velocity,
    jacobian_center_of_mass, nonlinear_effects, update_frame_placements,
};

use crate::background::{BackgroundMpc, MpcExecution, MpcPlan, Poll};
use crate::config::{Command, ConfigError, ControlMode, ControllerConfig};
use crate::convex_mpc::{ConvexMpc, NX};
use crate::gait::{Gait, GaitScheduler, MAX_LEGS, ramp};
use crate::qp::{QpStatus, cholesky_in_place, cholesky_solve};
use crate::robot::LeggedRobot;
use crate::swing::{PointTarget, raibert_foothold, swing_curve};
use crate::wbc::WholeBodyQp;

/// Height (m) below which an unmeasured contact point counts as touching the ground plane
/// z = 0 when the controller decides whether a robot that started in the air has landed.
pub const LANDING_HEIGHT: f64 = 0.03;

/// The command for the actuated joints, in [`LocomotionController::joint_names`] order
/// (model order). The torque to apply is `tau + kp (q_des − q) + kd (qd_des − q̇)`.
#[derive(Clone, Debug, PartialEq)]
pub struct JointCommand {
    /// Feed-forward torque (N·m or N).
    pub tau: Vec<f64>,
    /// Desired position.
    pub q_des: Vec<f64>,
    /// Desired velocity.
    pub qd_des: Vec<f64>,
    /// Position gain.
    pub kp: Vec<f64>,
    /// Velocity gain.
    pub kd: Vec<f64>,
}

impl JointCommand {
    fn new(n: usize) -> Self {
        Self {
            tau: vec![0.0; n],
            q_des: vec![0.0; n],
            qd_des: vec![0.0; n],
            kp: vec![0.0; n],
            kd: vec![0.0; n],
        }
    }

    /// The torque this command applies at joint positions `q` and velocities `qd` (both in
    /// command order), written into `out`.
    #[track_caller]
    pub fn torque(&self, q: &[f64], qd: &[f64], out: &mut [f64]) {
        assert!(q.len() == self.tau.len() && qd.len() == self.tau.len() && out.len() == self.tau.len());
        for i in 0..self.tau.len() {
            out[i] =
                self.tau[i] + self.kp[i] * (self.q_des[i] - q[i]) + self.kd[i] * (self.qd_des[i] - qd[i]);
        }
    }

    /// For position-controlled actuators with stiffness `kp_motor`: the position target that
    /// makes a PD servo produce this command's torque near the current state,
    /// `q_des + τ / k_p,motor` (written into `out`). This is the mapping to PD-target action
    /// spaces (e.g. the Minitaur's motor angles, see `centaur_envs::minitaur`).
    #[track_caller]
    pub fn position_targets(&self, kp_motor: f64, out: &mut [f64]) {
        assert!(out.len() == self.tau.len());
        for i in 0..self.tau.len() {
            out[i] = self.q_des[i] + self.tau[i] / kp_motor;
        }
    }
}

/// Which fallback produced the last command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Fallback {
    /// None: MPC and WBC (or cheap path) succeeded.
    #[default]
    None,
    /// The MPC failed: the last feasible MPC forces, decayed by
    /// `fallback_decay^failures`, or the weight split equally over the stance feet if no
    /// plan exists.
    MpcForces,
    /// The whole-body QP failed: the cheap path (`τ = −Jᵀf`, swing PD) was used.
    CheapPath,
    /// The state was not finite: posture PD towards the nominal pose with zero feed-forward.
    PosturePd,
}

/// What happened in the last tick, for logging.
#[derive(Clone, Debug)]
pub struct ControllerStatus {
    /// Time of the tick (s).
    pub t: f64,
    /// Number of ticks.
    pub ticks: u64,
    /// Gait in force.
    pub gait: Gait,
    /// Gait phase.
    pub phase: f64,
    /// Stance flag of each contact now.
    pub contact: Vec<bool>,
    /// Predicted stance flags per leg over the MPC horizon.
    pub contact_schedule: Vec<[bool; MAX_LEGS]>,
    /// Whether the MPC ran this tick ([`MpcExecution::Background`]: whether this tick
    /// adopted a plan the worker finished).
    pub mpc_ran: bool,
    /// Whether this tick solved the MPC itself ([`MpcExecution::Inline`]) or waited for
    /// the worker's solve ([`MpcExecution::Background`], only while no plan exists yet).
    pub mpc_blocked: bool,
    /// Status of the last MPC solve.
    pub mpc_status: QpStatus,
    /// Wall time of the last MPC solve (µs; on the worker thread with
    /// [`MpcExecution::Background`]).
    pub mpc_solve_us: f64,
    /// Iterations of the last MPC solve.
    pub mpc_iterations: u32,
    /// Status of this tick's whole-body QP (`NotRun` in cheap mode).
    pub wbc_status: QpStatus,
    /// Wall time of this tick's whole-body QP (µs).
    pub wbc_solve_us: f64,
    /// Iterations of this tick's whole-body QP.
    pub wbc_iterations: u32,
    /// Fallback used this tick.
    pub fallback: Fallback,
    /// MPC solves that failed since construction.
    pub mpc_failures: u64,
    /// Whole-body QPs that failed since construction.
    pub wbc_failures: u64,
    /// Whole-body QPs that were infeasible with their joint-limit bounds and were solved
    /// again without them, since construction.
    pub wbc_limit_relaxations: u64,
    /// Ticks with a non-finite state since construction.
    pub invalid_states: u64,
    /// Planned CoM positions over the horizon (world).
    pub planned_com: Vec<[f64; 3]>,
    /// Contact forces the MPC plan (or its fallback) gives for this tick (world, N).
    pub mpc_forces: Vec<[f64; 3]>,
    /// Contact forces applied this tick (world, N): the whole-body QP's, or the MPC's on the
    /// cheap path.
    pub forces: Vec<[f64; 3]>,
    /// Measured position of each contact point (world).
    pub foot_positions: Vec<[f64; 3]>,
    /// Target of each contact point: the swing curve point, or the current position in stance.
    pub foot_targets: Vec<[f64; 3]>,
    /// Planned touch-down point of each contact.
    pub footholds: Vec<[f64; 3]>,
    /// Horizontal position reference of the CoM (world; z = 0).
    pub position_reference: [f64; 3],
    /// Body task of the whole-body QP: desired CoM and body angular acceleration (world).
    pub body_acceleration_target: [f64; 6],
    /// The same accelerations in the QP's solution (the difference is the task residual).
    pub body_acceleration_planned: [f64; 6],
    /// Measured CoM (world).
    pub com: [f64; 3],
    /// Measured CoM velocity (world).
    pub com_velocity: [f64; 3],
    /// Roll, pitch, yaw of the body.
    pub rpy: [f64; 3],
}

/// The convex MPC, solved in `tick` or on a worker thread.
#[allow(clippy::large_enum_variant)] // one per controller, never moved in a hot path
enum MpcRunner {
    Inline { mpc: ConvexMpc, plan: MpcPlan },
    Background(BackgroundMpc),
}

/// The locomotion controller. See the crate documentation for the pipeline.
pub struct LocomotionController {
    cfg: ControllerConfig,
    robot: LeggedRobot,
    data: Data,
    gait: GaitScheduler,
    mpc: MpcRunner,
    wbc: WholeBodyQp,
    command: JointCommand,
    status: ControllerStatus,
    // State copies and kinematics.
    q: DVector<f64>,
    v: DVector<f64>,
    zeros_v: DVector<f64>,
    jac6: Matrix6xX<f64>,
    j_contact: Vec<Matrix3xX<f64>>,
    p_contact: Vec<Vector3<f64>>,
    v_contact: Vec<Vector3<f64>>,
    com: Vector3<f64>,
    com_vel: Vector3<f64>,
    rot: Matrix3<f64>,
    omega: Vector3<f64>,
    rpy: Vector3<f64>,
    // Command shaping.
    v_cmd: Vector3<f64>,
    yaw_rate_cmd: f64,
    yaw_ref: f64,
    p_ref: Vector3<f64>,
    last_t: Option<f64>,
    // Swing bookkeeping per contact.
    was_stance: Vec<bool>,
    /// Measured contact flags of this tick (valid if `measured_valid`).
    measured: Vec<bool>,
    measured_valid: bool,
    /// Contacts measured on the ground at least once, and whether all have been.
    ever_touched: Vec<bool>,
    landed: bool,
    /// A scheduled stance whose foot has touched the ground (measured).
    touched: Vec<bool>,
    /// A swing that ended early by touching the ground in its second half (measured).
    early: Vec<bool>,
    liftoff: Vec<Vector3<f64>>,
    foothold: Vec<Vector3<f64>>,
    next_foothold: Vec<Vector3<f64>>,
    targets: Vec<PointTarget>,
    // MPC plan.
    plan_forces: Vec<Vector3<f64>>,
    plan_valid: bool,
    plan_t: f64,
    last_mpc_t: Option<f64>,
    mpc_consecutive_failures: u32,
    forces_now: Vec<Vector3<f64>>,
    schedule: Vec<[bool; MAX_LEGS]>,
    // IK / cheap path buffers.
    ik_a: Vec<f64>,
    ik_b: Vec<f64>,
    tau_full: Vec<f64>,
    lam_a: Vec<f64>,
    lam_b: Vec<f64>,
    passive_joint_v: Vec<usize>,
    contact_frame_names: Vec<String>,
}

impl std::fmt::Debug for LocomotionController {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LocomotionController").field("robot", &self.robot.model.name).finish()
    }
}

impl LocomotionController {
    /// Resolves the configuration against `model` and allocates everything.
    pub fn new(model: &Model, config: ControllerConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let robot = LeggedRobot::new(model, &config.robot)?;
        let nc = robot.n_contacts();
        let nv = robot.model.nv;
        let mpc = ConvexMpc::new(&config.mpc, nc, robot.mass, robot.inertia_body)?;
        let wbc = WholeBodyQp::new(&robot, &config.wbc)?;
        let na = robot.n_actuated();
        let nj = robot.joint_v.len();
        let h = config.mpc.horizon;
        let mpc = match config.mpc_execution {
            MpcExecution::Inline => MpcRunner::Inline { mpc, plan: MpcPlan::new(h, nc) },
            MpcExecution::Background => MpcRunner::Background(BackgroundMpc::start(mpc, h, nc)?),
        };
        let passive_joint_v: Vec<usize> =
            robot.unactuated_v.iter().copied().filter(|k| !robot.base_v.contains(k)).collect();
        let nl = robot.n_closure_rows;
        let status = ControllerStatus {
            t: 0.0,
            ticks: 0,
            gait: Gait::Stand,
            phase: 0.0,
            contact: vec![true; nc],
            contact_schedule: vec![[false; MAX_LEGS]; h],
            mpc_ran: false,
            mpc_blocked: false,
            mpc_status: QpStatus::NotRun,
            mpc_solve_us: 0.0,
            mpc_iterations: 0,
            wbc_status: QpStatus::NotRun,
            wbc_solve_us: 0.0,
            wbc_iterations: 0,
            fallback: Fallback::None,
            mpc_failures: 0,
            wbc_failures: 0,
            wbc_limit_relaxations: 0,
            invalid_states: 0,
            planned_com: vec![[0.0; 3]; h],
            mpc_forces: vec![[0.0; 3]; nc],
            forces: vec![[0.0; 3]; nc],
            foot_positions: vec![[0.0; 3]; nc],
            foot_targets: vec![[0.0; 3]; nc],
            footholds: vec![[0.0; 3]; nc],
            position_reference: [0.0; 3],
            body_acceleration_target: [0.0; 6],
            body_acceleration_planned: [0.0; 6],
            com: [0.0; 3],
            com_velocity: [0.0; 3],
            rpy: [0.0; 3],
        };
        let mut command = JointCommand::new(na);
        for (i, &iq) in robot.actuated_q.iter().enumerate() {
            command.q_des[i] = robot.q_nominal[iq];
        }
        let data = Data::new(&robot.model);
        let n_rows_ik = 3 * nc + nl;
        Ok(Self {
            gait: GaitScheduler::new(robot.n_legs, config.gait_period_scale),
            mpc,
            wbc,
            command,
            status,
            q: DVector::zeros(robot.model.nq),
            v: DVector::zeros(nv),
            zeros_v: DVector::zeros(nv),
            jac6: Matrix6xX::zeros(nv),
            j_contact: vec![Matrix3xX::zeros(nv); nc],
            p_contact: vec![Vector3::zeros(); nc],
            v_contact: vec![Vector3::zeros(); nc],
            com: Vector3::zeros(),
            com_vel: Vector3::zeros(),
            rot: Matrix3::identity(),
            omega: Vector3::zeros(),
            rpy: Vector3::zeros(),
            v_cmd: Vector3::zeros(),
            yaw_rate_cmd: 0.0,
            yaw_ref: 0.0,
            p_ref: Vector3::zeros(),
            last_t: None,
            was_stance: vec![true; nc],
            measured: vec![false; nc],
            measured_valid: false,
            ever_touched: vec![false; nc],
            landed: false,
            touched: vec![true; nc],
            early: vec![false; nc],
            liftoff: vec![Vector3::zeros(); nc],
            foothold: vec![Vector3::zeros(); nc],
            next_foothold: vec![Vector3::zeros(); nc],
            targets: vec![PointTarget::default(); nc],
            plan_forces: vec![Vector3::zeros(); h * nc],
            plan_valid: false,
            plan_t: 0.0,
            last_mpc_t: None,
            mpc_consecutive_failures: 0,
            forces_now: vec![Vector3::zeros(); nc],
            schedule: vec![[false; MAX_LEGS]; h + 1],
            ik_a: vec![0.0; nj * nj.max(n_rows_ik)],
            ik_b: vec![0.0; nj.max(n_rows_ik)],
            tau_full: vec![0.0; nv],
            lam_a: vec![0.0; nl * nl],
            lam_b: vec![0.0; nl],
            passive_joint_v,
            contact_frame_names: config.robot.contacts.iter().map(|c| c.frame.clone()).collect(),
            data,
            robot,
            cfg: config,
        })
    }

    /// Names of the actuated joints: the order of every vector in [`JointCommand`].
    pub fn joint_names(&self) -> &[String] {
        &self.robot.actuated_names
    }

    /// The resolved robot (model with contact frames, nominal pose, mass, inertia).
    pub fn robot(&self) -> &LeggedRobot {
        &self.robot
    }

    /// The configuration.
    pub fn config(&self) -> &ControllerConfig {
        &self.cfg
    }

    /// The status of the last tick.
    pub fn status(&self) -> &ControllerStatus {
        &self.status
    }

    /// Generalized accelerations `q̈` the whole-body QP planned in the last tick that solved
    /// it (model `v` layout).
    pub fn planned_accelerations(&self) -> &DVector<f64> {
        &self.wbc.output.qdd
    }

    /// The last command.
    pub fn command(&self) -> &JointCommand {
        &self.command
    }

    /// A state standing still at the nominal pose.
    pub fn nominal_state(&self) -> RobotState {
        let mut s = RobotState::new(&self.robot.model);
        s.q.copy_from(&self.robot.q_nominal);
        s
    }

    /// Forgets the gait phase, command ramps and MPC plan (e.g. at an episode reset).
    pub fn reset(&mut self) {
        self.gait.reset();
        self.last_t = None;
        self.plan_valid = false;
        self.last_mpc_t = None;
        self.v_cmd = Vector3::zeros();
        self.yaw_rate_cmd = 0.0;
        self.mpc_consecutive_failures = 0;
        if let MpcRunner::Background(bg) = &mut self.mpc {
            bg.reset();
        }
        self.was_stance.iter_mut().for_each(|s| *s = true);
        self.touched.iter_mut().for_each(|s| *s = true);
        self.early.iter_mut().for_each(|s| *s = false);
        self.ever_touched.iter_mut().for_each(|s| *s = false);
        self.landed = false;
    }

    /// One control step at time `t` (s). Never panics on a non-finite state (it falls back
    /// to posture PD and says so in the status).
    ///
    /// # Panics
    /// If `state` does not have the model's `nq`/`nv` (a programming error).
    #[track_caller]
    pub fn tick(&mut self, state: &RobotState, command: &Command, t: f64) -> &JointCommand {
        self.measured_valid = false;
        self.tick_inner(state, command, t)
    }

    /// [`LocomotionController::tick`] with measured contact flags, one per contact point in
    /// [`LocomotionController::contact_frames`] order (e.g. from foot switches or the
    /// simulator). A scheduled stance starts only when its foot touches the ground (until
    /// then the foot keeps descending at `touchdown_speed`), and a swing that touches the
    /// ground in its second half ends early.
    ///
    /// # Panics
    /// If `state` does not have the model's `nq`/`nv` or `contacts` does not have one flag
    /// per contact point (programming errors).
    #[track_caller]
    pub fn tick_with_contacts(
        &mut self,
        state: &RobotState,
        command: &Command,
        t: f64,
        contacts: &[bool],
    ) -> &JointCommand {
        let nc = self.robot.n_contacts();
        assert!(contacts.len() == nc, "{} contact flags for {nc} contact points", contacts.len());
        self.measured.copy_from_slice(contacts);
        self.measured_valid = true;
        self.tick_inner(state, command, t)
    }

    /// Names of the frames the contact points are attached to, in contact order.
    pub fn contact_frames(&self) -> &[String] {
        &self.contact_frame_names
    }

    #[track_caller]
    fn tick_inner(&mut self, state: &RobotState, command: &Command, t: f64) -> &JointCommand {
        let model_nq = self.robot.model.nq;
        let model_nv = self.robot.model.nv;
        assert!(
            state.q.len() == model_nq && state.v.len() == model_nv,
            "state has nq = {}, nv = {}, but the model expects {model_nq}, {model_nv}",
            state.q.len(),
            state.v.len()
        );
        self.status.ticks += 1;
        self.status.t = t;
        self.status.mpc_ran = false;
        self.status.mpc_blocked = false;
        self.status.wbc_status = QpStatus::NotRun;
        self.status.fallback = Fallback::None;
        let cmd_ok = command.forward_velocity.is_finite()
            && command.lateral_velocity.is_finite()
            && command.yaw_rate.is_finite()
            && command.body_height.is_none_or(|h| h.is_finite() && h > 0.0);
        if !state.is_finite() || !t.is_finite() || !cmd_ok {
            self.posture_fallback();
            return &self.command;
        }
        self.q.copy_from(&state.q);
        self.v.copy_from(&state.v);
        if self.robot.model.has_floating_base() {
            let s = &mut self.q.as_mut_slice()[3..7];
            let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3]).sqrt();
            if n < 1e-9 {
                self.posture_fallback();
                return &self.command;
            }
            s.iter_mut().for_each(|x| *x /= n);
        }
        let dt = match self.last_t {
            Some(t0) if t >= t0 && t - t0 <= 0.1 => t - t0,
            _ => 0.0,
        };
        let first = self.last_t.is_none();
        self.last_t = Some(t);
        self.kinematics();
        if first {
            self.yaw_ref = self.rpy.z;
            self.p_ref = Vector3::new(self.com.x, self.com.y, 0.0);
        }
        // A robot that starts in the air stands until every contact point has touched the
        // ground once: measured contacts, or without them a contact point within
        // `LANDING_HEIGHT` of the ground plane z = 0.
        if !self.landed {
            for (c, seen) in self.ever_touched.iter_mut().enumerate() {
                *seen |=
                    if self.measured_valid { self.measured[c] } else { self.p_contact[c].z < LANDING_HEIGHT };
            }
            self.landed = self.ever_touched.iter().all(|s| *s);
        }
        let airborne = !self.landed;
        if airborne {
            // Nothing to hold the body to until it lands: references follow the state.
            self.p_ref = Vector3::new(self.com.x, self.com.y, 0.0);
            self.yaw_ref = self.rpy.z;
        }
        let command = if airborne { &Command::stand() } else { command };
        // Command shaping: rate-limited speeds, yaw reference integration.
        let cmd_gait = if airborne { command.gait } else { self.cfg.gait_for(command.gait) };
        let (c, s) = (self.yaw_ref.cos(), self.yaw_ref.sin());
        let planar = self.cfg.mpc.planar;
        let lat = if planar { 0.0 } else { command.lateral_velocity };
        let target =
            Vector3::new(c * command.forward_velocity - s * lat, s * command.forward_velocity + c * lat, 0.0);
        let step = self.cfg.max_acceleration * dt;
        self.v_cmd.x = ramp(self.v_cmd.x, target.x, step);
        self.v_cmd.y = ramp(self.v_cmd.y, target.y, step);
        let yr = if planar { 0.0 } else { command.yaw_rate };
        self.yaw_rate_cmd = ramp(self.yaw_rate_cmd, yr, self.cfg.max_yaw_acceleration * dt);
        self.yaw_ref += self.yaw_rate_cmd * dt;
        // Keep the yaw reference within reach of the measured yaw (after a push or a spin).
        let e = wrap_pi(self.yaw_ref - self.rpy.z);
        self.yaw_ref = self.rpy.z + e.clamp(-0.3, 0.3);
        let height = command.body_height.unwrap_or(self.robot.nominal_com_height);

        let changed = self.gait.update(t, cmd_gait);
        self.update_position_reference(dt, &target);
        self.update_swing(height, dt);
        // MPC.
        // (A plan whose state is later than now, from before time went back, is dropped.)
        if let MpcRunner::Background(bg) = &mut self.mpc
            && bg.poll(false) == Poll::Plan
            && bg.latest.t <= t
        {
            self.adopt_plan();
        }
        let due = self.last_mpc_t.is_none_or(|t0| t - t0 >= self.cfg.mpc_period - 1e-9 || t < t0);
        if due || changed || !self.plan_valid {
            self.run_mpc(t, height);
        }
        self.current_forces(t);
        // Torques.
        match self.cfg.mode {
            ControlMode::WholeBody => {
                if !self.run_wbc(height) {
                    self.status.fallback = Fallback::CheapPath;
                    self.cheap_path();
                }
            }
            ControlMode::Cheap => self.cheap_path(),
        }
        self.joint_targets();
        self.fill_status();
        &self.command
    }

    /// The horizontal position reference `p_ref`: the integral of the (rate-limited)
    /// commanded velocity; standing still, it moves at `recenter_speed` to the centre of
    /// the support (the mean contact position), the statically safest place for the CoM;
    /// it never strays more than `position_leash` from the measured CoM.
    fn update_position_reference(&mut self, dt: f64, target_velocity: &Vector3<f64>) {
        self.p_ref += self.v_cmd * dt;
        self.p_ref.z = 0.0;
        let nc = self.robot.n_contacts();
        let standing = self.gait.pattern().gait == Gait::Stand
            && target_velocity.norm() < 1e-9
            && self.v_cmd.norm() < 1e-9;
        if standing {
            let mut target = Vector3::zeros();
            for ci in 0..nc {
                target += self.p_contact[ci];
            }
            target /= nc as f64;
            let e = Vector3::new(target.x - self.p_ref.x, target.y - self.p_ref.y, 0.0);
            let step = self.cfg.recenter_speed * dt;
            let n = e.norm();
            self.p_ref += if n > step { e * (step / n) } else { e };
        }
        if self.cfg.mpc.planar {
            self.p_ref.y = self.com.y;
        }
        let e = Vector3::new(self.p_ref.x - self.com.x, self.p_ref.y - self.com.y, 0.0);
        let n = e.norm();
        let leash = self.cfg.position_leash;
        if n > leash {
            self.p_ref = Vector3::new(self.com.x, self.com.y, 0.0) + e * (leash / n);
        }
    }

    fn posture_fallback(&mut self) {
        self.status.invalid_states += 1;
        self.status.fallback = Fallback::PosturePd;
        let (kp, kd) = self.cfg.fallback_joint_gains;
        for (i, &iq) in self.robot.actuated_q.iter().enumerate() {
            self.command.tau[i] = 0.0;
            self.command.q_des[i] = self.robot.q_nominal[iq];
            self.command.qd_des[i] = 0.0;
            self.command.kp[i] = kp;
            self.command.kd[i] = kd;
        }
    }

    fn kinematics(&mut self) {
        // Sphere contacts: the touching point depends on the link orientations.
        forward_kinematics(&self.robot.model, &mut self.data, self.q.as_slice());
        self.robot.update_sphere_contacts(&self.data);
        let model = &self.robot.model;
        let data = &mut self.data;
        let q = self.q.as_slice();
        let v = self.v.as_slice();
        let jc = jacobian_center_of_mass(model, data, q);
        let mut cv = Vector3::zeros();
        for k in 0..model.nv {
            cv += jc.column(k) * v[k];
        }
        self.com_vel = cv;
        self.com = data.com[0];
        self.wbc.input.j_body.fixed_rows_mut::<3>(0).copy_from(&data.jacobian_com);
        crba(model, data, q);
        self.wbc.input.mass_matrix.copy_from(&data.mass_matrix);
        for k in 0..model.nv {
            self.wbc.input.mass_matrix[(k, k)] += model.armature[k];
        }
        nonlinear_effects(model, data, q, v);
        self.wbc.input.nle.copy_from(&data.nle);
        // Joint viscous damping (`<dynamics damping>`) is part of the bias forces:
        // M q̈ + C q̇ + g + D q̇ = Sᵀτ + Jᵀf.
        for k in 0..model.nv {
            self.wbc.input.nle[k] += model.damping[k] * v[k];
        }
        forward_kinematics_acceleration(model, data, q, v, self.zeros_v.as_slice());
        update_frame_placements(model, data);
        // Body.
        let bf = self.robot.body_frame;
        let o = data.o_m_f[bf];
        self.rot = o.rotation;
        let r = Rotation3::from_matrix_unchecked(self.rot);
        let (roll, pitch, yaw) = r.euler_angles();
        self.rpy = Vector3::new(roll, pitch, yaw);
        let bv = frame_velocity(model, data, bf, ReferenceFrame::LocalWorldAligned);
        self.omega = bv.angular;
        frame_jacobian(model, data, bf, ReferenceFrame::LocalWorldAligned, &mut self.jac6);
        self.wbc.input.j_body.fixed_rows_mut::<3>(3).copy_from(&self.jac6.fixed_rows::<3>(3));
        // CoM drift J̇_com q̇ = (1/m) Σᵢ mᵢ R_i (aᵢ + αᵢ × cᵢ + ωᵢ × (vᵢ + ωᵢ × cᵢ)) with the
        // body accelerations of q̈ = 0 (each body's CoM point, classical acceleration).
        let mut m_acc = Vector3::zeros();
        let mut m_tot = 0.0;
        for i in 1..model.njoints() {
            let inertia = &model.inertias[i];
            if inertia.mass <= 0.0 {
                continue;
            }
            let (vi, ai, c) = (&data.v[i], &data.a[i], &inertia.lever);
            let a_local =
                ai.linear + ai.angular.cross(c) + vi.angular.cross(&(vi.linear + vi.angular.cross(c)));
            m_acc += data.o_m_i[i].rotation * a_local * inertia.mass;
            m_tot += inertia.mass;
        }
        let lin = if m_tot > 0.0 { m_acc / m_tot } else { Vector3::zeros() };
        let ang = frame_acceleration(model, data, bf, ReferenceFrame::LocalWorldAligned).angular;
        for d in 0..3 {
            self.wbc.input.jdqd_body[d] = lin[d];
            self.wbc.input.jdqd_body[3 + d] = ang[d];
        }
        // Contacts.
        for (c, &f) in self.robot.contact_frames.iter().enumerate() {
            self.p_contact[c] = data.o_m_f[f].translation;
            self.v_contact[c] = frame_velocity(model, data, f, ReferenceFrame::LocalWorldAligned).linear;
            frame_jacobian(model, data, f, ReferenceFrame::LocalWorldAligned, &mut self.jac6);
            self.j_contact[c].copy_from(&self.jac6.fixed_rows::<3>(0));
            self.wbc.input.j_contact[c].copy_from(&self.j_contact[c]);
            self.wbc.input.jdqd_contact[c] = frame_classical_acceleration(model, data, f);
        }
        // Loop closures.
        let (kp, kd) = (self.cfg.wbc.closure_kp, self.cfg.wbc.closure_kd);
        let mut row = 0;
        for cl in &self.robot.closures {
            let pa = data.o_m_f[cl.frame_a].translation;
            let pb = data.o_m_f[cl.frame_b].translation;
            let ra = data.o_m_f[cl.frame_a].rotation;
            let va = frame_velocity(model, data, cl.frame_a, ReferenceFrame::LocalWorldAligned).linear;
            let vb = frame_velocity(model, data, cl.frame_b, ReferenceFrame::LocalWorldAligned).linear;
            let aa = frame_classical_acceleration(model, data, cl.frame_a);
            let ab = frame_classical_acceleration(model, data, cl.frame_b);
            for dl in &cl.directions {
                let d = ra * dl;
                frame_jacobian(model, data, cl.frame_a, ReferenceFrame::LocalWorldAligned, &mut self.jac6);
                for k in 0..model.nv {
                    self.wbc.input.j_closure[(row, k)] =
                        d.x * self.jac6[(0, k)] + d.y * self.jac6[(1, k)] + d.z * self.jac6[(2, k)];
                }
                frame_jacobian(model, data, cl.frame_b, ReferenceFrame::LocalWorldAligned, &mut self.jac6);
                for k in 0..model.nv {
                    self.wbc.input.j_closure[(row, k)] -=
                        d.x * self.jac6[(0, k)] + d.y * self.jac6[(1, k)] + d.z * self.jac6[(2, k)];
                }
                self.wbc.input.closure_rhs[row] =
                    -d.dot(&(aa - ab)) - kp * d.dot(&(pa - pb)) - kd * d.dot(&(va - vb));
                row += 1;
            }
        }
    }

    /// Contact states, lift-off bookkeeping, footholds and swing targets.
    ///
    /// The effective contact of a point is its scheduled stance, refined by measured
    /// contacts when [`LocomotionController::tick_with_contacts`] provides them: a stance
    /// that has not touched down (also at the first tick) is still a swing whose foot
    /// descends at `touchdown_speed` over the foothold, and a swing touching the ground in
    /// its second half ends early; without measured contacts the schedule is followed.
    /// Swing targets carry the mean reference acceleration over the coming control interval
    /// `Δt` (the last tick interval), `ā = (v_ref(t + Δt) − v_ref(t))/Δt`, so that torques
    /// held for `Δt` follow the curve.
    fn update_swing(&mut self, height: f64, dt: f64) {
        let pat = *self.gait.pattern();
        let phase = self.gait.phase();
        let g = self.robot.model.gravity.z.abs().max(1e-3);
        let yaw = self.rpy.z;
        let (c, s) = (yaw.cos(), yaw.sin());
        let mut body = self.data.o_m_f[self.robot.body_frame].translation;
        if self.cfg.foothold_from_com {
            // Where the body frame would be if it stood over the CoM as in the nominal pose.
            let nc = self.robot.nominal_com_body;
            body.x = self.com.x - (c * nc.x - s * nc.y);
            body.y = self.com.y - (s * nc.x + c * nc.y);
        }
        let v_xy = Vector3::new(self.com_vel.x, self.com_vel.y, 0.0);
        let kp = self.cfg.foothold_position_gain;
        let v_foothold = self.v_cmd
            + Vector3::new(kp * (self.p_ref.x - self.com.x), kp * (self.p_ref.y - self.com.y), 0.0);
        for ci in 0..self.robot.n_contacts() {
            let leg = self.robot.contact_leg[ci];
            let stance = pat.in_stance(phase, leg);
            let swing_progress = pat.swing_progress(phase, leg);
            if self.was_stance[ci] && !stance || self.status.ticks == 1 {
                self.liftoff[ci] = self.p_contact[ci];
            }
            if self.was_stance[ci] != stance || self.status.ticks == 1 {
                // A new phase (or the first tick): a stance has not touched down yet, a swing
                // has not ended early.
                self.touched[ci] = false;
                self.early[ci] = false;
            }
            self.was_stance[ci] = stance;
            let measured = (self.measured_valid && self.cfg.touchdown_detection).then(|| self.measured[ci]);
            let (contact, late) = match measured {
                None => (stance, false),
                Some(m) if stance => {
                    self.touched[ci] |= m;
                    (self.touched[ci], !self.touched[ci])
                }
                Some(m) => {
                    self.early[ci] |= m && swing_progress.unwrap_or(0.0) > 0.5;
                    (self.early[ci], false)
                }
            };
            self.status.contact[ci] = contact;
            // Hip reference: nominal contact under the body, rotated by yaw.
            let nb = self.robot.nominal_contacts_body[ci];
            let mut hip = body + Vector3::new(c * nb.x - s * nb.y, s * nb.x + c * nb.y, 0.0);
            if self.cfg.mpc.planar {
                hip.y = self.p_contact[ci].y;
            }
            let t_td = self.gait.time_to_touchdown(leg);
            hip += self.v_cmd * t_td;
            let mut fh = raibert_foothold(
                &hip,
                &v_xy,
                &v_foothold,
                self.yaw_rate_cmd,
                pat.stance_duration(leg),
                height,
                self.cfg.raibert_kv,
                self.liftoff[ci].z,
                g,
            );
            if self.cfg.mpc.planar {
                fh.y = self.p_contact[ci].y;
            }
            self.foothold[ci] = fh;
            // Where the MPC expects the next stance: this swing's foothold, or for a leg in
            // stance the one after its coming swing (hip carried forward to that touch-down,
            // Raibert term at the commanded velocity). The position feedback is left out of
            // this look-ahead on purpose: with it there too the Humanoid, the one preset that
            // uses it, fell after a 4 N·s push from behind that it survives without.
            self.next_foothold[ci] = if stance && !late {
                let t_next = self.gait.stance_time_left(leg) + pat.swing_duration(leg);
                let mut p = hip + self.v_cmd * (t_next + 0.5 * pat.stance_duration(leg));
                p.z = self.p_contact[ci].z;
                if self.cfg.mpc.planar {
                    p.y = self.p_contact[ci].y;
                }
                p
            } else {
                fh
            };
            self.targets[ci] = if contact {
                // A planted foot, seen from a body that follows the reference: the IK of the
                // joint PD targets then moves the body along the reference over its feet.
                stance_target(
                    &self.p_contact[ci],
                    &self.com,
                    &self.rot,
                    &Vector3::new(self.p_ref.x, self.p_ref.y, height),
                    self.yaw_ref,
                    &self.v_cmd,
                    self.yaw_rate_cmd,
                )
            } else if late {
                // Keep reaching down for the ground at `touchdown_speed` (faster than a falling
                // body), over the foothold.
                PointTarget {
                    p: Vector3::new(fh.x, fh.y, self.p_contact[ci].z),
                    v: Vector3::new(0.0, 0.0, self.com_vel.z.min(0.0) - self.cfg.touchdown_speed),
                    a: Vector3::zeros(),
                }
            } else {
                let sp = swing_progress.unwrap_or(1.0);
                let t_sw = pat.swing_duration(leg);
                let mut tg = swing_curve(&self.liftoff[ci], &fh, self.cfg.swing_height, sp, t_sw);
                if dt > 0.0 {
                    let ahead =
                        swing_curve(&self.liftoff[ci], &fh, self.cfg.swing_height, sp + dt / t_sw, t_sw);
                    tg.a = (ahead.v - tg.v) / dt;
                }
                tg
            };
        }
    }

    fn run_mpc(&mut self, t: f64, height: f64) {
        let h = self.cfg.mpc.horizon;
        let dt = self.cfg.mpc.dt;
        let nc = self.robot.n_contacts();
        let planar = self.cfg.mpc.planar;
        self.gait.contact_schedule(dt, &mut self.schedule);
        let inp = match &mut self.mpc {
            MpcRunner::Inline { mpc, .. } => &mut mpc.input,
            MpcRunner::Background(bg) => &mut bg.staging,
        };
        let mut x0 = [0.0; NX];
        let yaw = self.yaw_ref + wrap_pi(self.rpy.z - self.yaw_ref);
        x0[0] = self.rpy.x;
        x0[1] = self.rpy.y;
        x0[2] = yaw;
        x0[3..6].copy_from_slice(self.com.as_slice());
        x0[6..9].copy_from_slice(self.omega.as_slice());
        x0[9..12].copy_from_slice(self.com_vel.as_slice());
        x0[12] = self.robot.model.gravity.z;
        if planar {
            x0[0] = 0.0;
            x0[2] = 0.0;
            x0[6] = 0.0;
            x0[8] = 0.0;
            x0[10] = 0.0;
        }
        inp.x0 = x0;
        for k in 0..h {
            let tk = (k + 1) as f64 * dt;
            let r = &mut inp.x_ref[k];
            r.fill(0.0);
            r[2] = if planar { 0.0 } else { self.yaw_ref + self.yaw_rate_cmd * tk };
            r[3] = self.p_ref.x + self.v_cmd.x * tk;
            r[4] = if planar { x0[4] } else { self.p_ref.y + self.v_cmd.y * tk };
            r[5] = height;
            r[8] = self.yaw_rate_cmd;
            r[9] = self.v_cmd.x;
            r[10] = self.v_cmd.y;
            r[12] = x0[12];
        }
        for k in 0..h {
            for ci in 0..nc {
                let leg = self.robot.contact_leg[ci];
                // Now: the effective contact; later: the schedule.
                let on_at = |j: usize| if j == 0 { self.status.contact[ci] } else { self.schedule[j][leg] };
                let on = on_at(k);
                inp.contact[k][ci] = on;
                // Current position while the stance that holds now lasts; afterwards the
                // planned foothold (shifted by the commanded motion for later stances).
                let continuous = (0..=k).all(on_at);
                inp.foot[k][ci] = if continuous { self.p_contact[ci] } else { self.next_foothold[ci] };
                if planar {
                    inp.foot[k][ci].y = x0[4];
                }
            }
        }
        self.last_mpc_t = Some(t);
        match &mut self.mpc {
            MpcRunner::Inline { mpc, plan } => {
                self.status.mpc_blocked = true;
                plan.solve(mpc, t, h, nc);
            }
            MpcRunner::Background(bg) => {
                if bg.gone() {
                    self.mpc_solver_gone();
                    return;
                }
                bg.submit(t);
                if self.plan_valid {
                    return; // follow the current plan until this one is ready
                }
                // Never had a feasible plan: wait for one.
                self.status.mpc_blocked = true;
                match bg.poll(true) {
                    Poll::Plan if bg.latest.t <= t => {}
                    Poll::Plan | Poll::Nothing => return,
                    Poll::Gone => {
                        self.mpc_solver_gone();
                        return;
                    }
                }
            }
        }
        self.adopt_plan();
    }

    /// The MPC's worker thread has ended: a failed solve, every time one is due.
    fn mpc_solver_gone(&mut self) {
        self.status.mpc_status = QpStatus::SolverGone;
        self.status.mpc_failures += 1;
        self.mpc_consecutive_failures += 1;
    }

    /// Takes the plan last solved (in this thread or on the worker) into use.
    fn adopt_plan(&mut self) {
        let plan = match &self.mpc {
            MpcRunner::Inline { plan, .. } => plan,
            MpcRunner::Background(bg) => &bg.latest,
        };
        self.status.mpc_solve_us = plan.solve_us;
        self.status.mpc_status = plan.status;
        self.status.mpc_iterations = plan.iterations;
        self.status.mpc_ran = true;
        if plan.status.is_ok() {
            self.plan_forces.copy_from_slice(&plan.forces);
            self.status.planned_com.copy_from_slice(&plan.com);
            self.plan_valid = true;
            self.plan_t = plan.t;
            self.mpc_consecutive_failures = 0;
        } else {
            self.status.mpc_failures += 1;
            self.mpc_consecutive_failures += 1;
        }
    }

    /// Forces for this tick from the plan (or the fallback).
    fn current_forces(&mut self, t: f64) {
        let nc = self.robot.n_contacts();
        let h = self.cfg.mpc.horizon;
        let n_stance = self.status.contact.iter().filter(|c| **c).count();
        let weight = self.robot.mass * self.robot.model.gravity.z.abs();
        let k = (((t - self.plan_t) / self.cfg.mpc.dt).floor().max(0.0) as usize).min(h - 1);
        let use_plan = self.plan_valid && t - self.plan_t < h as f64 * self.cfg.mpc.dt;
        let scale = if self.mpc_consecutive_failures > 0 {
            self.status.fallback = Fallback::MpcForces;
            self.cfg.fallback_decay.powi(self.mpc_consecutive_failures as i32)
        } else {
            1.0
        };
        for c in 0..nc {
            let stance = self.status.contact[c];
            let mut f = Vector3::zeros();
            if stance {
                let planned = if use_plan { self.plan_forces[k * nc + c] } else { Vector3::zeros() };
                f = if planned.z > 1e-6 {
                    planned * scale
                } else {
                    // No plan, or the plan thought this foot was in the air: share the weight.
                    if !use_plan {
                        self.status.fallback = Fallback::MpcForces;
                    }
                    Vector3::new(0.0, 0.0, weight / n_stance.max(1) as f64)
                };
            }
            self.forces_now[c] = f;
            self.status.mpc_forces[c] = [f.x, f.y, f.z];
        }
    }

    /// Fills and solves the whole-body QP; writes torques on success.
    fn run_wbc(&mut self, height: f64) -> bool {
        let nc = self.robot.n_contacts();
        let cfg = &self.cfg;
        let m = self.robot.mass;
        let gvec = self.robot.model.gravity;
        let inp = &mut self.wbc.input;
        let mut f_sum = Vector3::zeros();
        let mut tau_sum = Vector3::zeros();
        for c in 0..nc {
            let stance = self.status.contact[c];
            inp.stance[c] = stance;
            inp.f_ref[c] = self.forces_now[c];
            f_sum += self.forces_now[c];
            tau_sum += (self.p_contact[c] - self.com).cross(&self.forces_now[c]);
            let tg = &self.targets[c];
            let (kp, kd) = cfg.swing_gains;
            inp.a_swing[c] = tg.a + (tg.p - self.p_contact[c]) * kp + (tg.v - self.v_contact[c]) * kd;
            inp.swing_free_direction[c] = free_direction(&self.j_contact[c], &self.robot.joint_v);
        }
        // Body task: MPC wrench feed-forward + PD.
        let body = self.data.o_m_f[self.robot.body_frame].translation;
        let _ = body;
        let pos_err = Vector3::new(
            self.p_ref.x - self.com.x,
            if cfg.mpc.planar { 0.0 } else { self.p_ref.y - self.com.y },
            height - self.com.z,
        );
        let vel_err =
            Vector3::new(self.v_cmd.x - self.com_vel.x, self.v_cmd.y - self.com_vel.y, -self.com_vel.z);
        let a_lin = f_sum / m
            + gvec
            + pos_err.component_mul(&Vector3::from(cfg.body_kp_pos))
            + vel_err.component_mul(&Vector3::from(cfg.body_kd_vel));
        let r_des = Rotation3::from_axis_angle(&Vector3::z_axis(), self.yaw_ref);
        let r_err = r_des.matrix() * self.rot.transpose();
        let ori_err = Rotation3::from_matrix_unchecked(r_err).scaled_axis();
        let w_des = Vector3::new(0.0, 0.0, self.yaw_rate_cmd);
        let iw = self.rot * self.robot.inertia_body * self.rot.transpose();
        let ff = iw.try_inverse().map_or(Vector3::zeros(), |i| i * tau_sum);
        let mut a_ang = ff
            + ori_err.component_mul(&Vector3::from(cfg.body_kp_ori))
            + (w_des - self.omega).component_mul(&Vector3::from(cfg.body_kd_ang));
        if cfg.mpc.planar {
            a_ang.x = 0.0;
            a_ang.z = 0.0;
        }
        for d in 0..3 {
            inp.a_body[d] = a_lin[d];
            inp.a_body[3 + d] = a_ang[d];
        }
        let (kp, kd) = cfg.posture_gains;
        for (k, (&iq, &iv)) in self.robot.joint_q.iter().zip(&self.robot.joint_v).enumerate() {
            inp.qdd_posture[k] = kp * (self.robot.q_nominal[iq] - self.q[iq]) - kd * self.v[iv];
        }
        inp.weight = m * gvec.z.abs();
        self.wbc.set_joint_limit_bounds(self.q.as_slice(), self.v.as_slice());
        let t0 = Instant::now();
        let st = self.wbc.solve();
        self.status.wbc_solve_us = t0.elapsed().as_secs_f64() * 1e6;
        self.status.wbc_status = st;
        self.status.wbc_iterations = self.wbc.iterations();
        if self.wbc.limits_relaxed() {
            self.status.wbc_limit_relaxations += 1;
        }
        if !st.is_ok() {
            self.status.wbc_failures += 1;
            return false;
        }
        self.command.tau.copy_from_slice(&self.wbc.output.tau);
        for c in 0..nc {
            self.forces_now[c] = self.wbc.output.forces[c];
        }
        let inp = &self.wbc.input;
        for d in 0..6 {
            let mut a = inp.jdqd_body[d];
            for k in 0..self.robot.model.nv {
                a += inp.j_body[(d, k)] * self.wbc.output.qdd[k];
            }
            self.status.body_acceleration_target[d] = inp.a_body[d];
            self.status.body_acceleration_planned[d] = a;
        }
        true
    }

    /// Stance: `τ = −J_cᵀ f`; swing: `τ = J_cᵀ(K_p e + K_d ė)`; passive joints zeroed
    /// through the closure forces (least squares).
    fn cheap_path(&mut self) {
        let nv = self.robot.model.nv;
        let nc = self.robot.n_contacts();
        self.tau_full.fill(0.0);
        let (kp, kd) = self.cfg.cheap_swing_gains;
        for c in 0..nc {
            let f = if self.status.contact[c] {
                -self.forces_now[c]
            } else {
                let tg = &self.targets[c];
                (tg.p - self.p_contact[c]) * kp + (tg.v - self.v_contact[c]) * kd
            };
            for k in 0..nv {
                let j = &self.j_contact[c];
                self.tau_full[k] += j[(0, k)] * f.x + j[(1, k)] * f.y + j[(2, k)] * f.z;
            }
        }
        for &k in &self.robot.actuated_v {
            self.tau_full[k] += self.robot.model.damping[k] * self.v[k];
        }
        // Gravity compensation of the legs is left to the stance forces; passive joints:
        // find λ with (τ + J_lᵀ λ)_passive ≈ 0.
        let nl = self.robot.n_closure_rows;
        if nl > 0 && !self.passive_joint_v.is_empty() {
            let jl = &self.wbc.input.j_closure;
            self.lam_a.fill(0.0);
            self.lam_b.fill(0.0);
            for &p in &self.passive_joint_v {
                for a in 0..nl {
                    self.lam_b[a] -= jl[(a, p)] * self.tau_full[p];
                    for b in 0..nl {
                        self.lam_a[b * nl + a] += jl[(a, p)] * jl[(b, p)];
                    }
                }
            }
            for a in 0..nl {
                self.lam_a[a * nl + a] += 1e-9;
            }
            if cholesky_in_place(&mut self.lam_a, nl) {
                cholesky_solve(&self.lam_a, nl, &mut self.lam_b);
                for k in 0..nv {
                    let mut s = 0.0;
                    for a in 0..nl {
                        s += jl[(a, k)] * self.lam_b[a];
                    }
                    self.tau_full[k] += s;
                }
            }
        }
        for (i, &iv) in self.robot.actuated_v.iter().enumerate() {
            let lim = self.robot.effort[i];
            self.command.tau[i] = self.tau_full[iv].clamp(-lim, lim);
        }
    }

    /// PD targets: damped-least-squares IK of all contact points (swing: their targets;
    /// stance: where they are) and closure rows, over the non-base joints.
    fn joint_targets(&mut self) {
        let nj = self.robot.joint_v.len();
        let nc = self.robot.n_contacts();
        let nl = self.robot.n_closure_rows;
        let lam2 = self.cfg.ik_damping * self.cfg.ik_damping;
        // A = JᵀJ + λ²I, b = Jᵀe over joint columns; then the same for velocities.
        for pass in 0..2 {
            self.ik_a[..nj * nj].fill(0.0);
            self.ik_b[..nj].fill(0.0);
            for c in 0..nc {
                let tg = &self.targets[c];
                let e = if pass == 0 { tg.p - self.p_contact[c] } else { tg.v };
                let j = &self.j_contact[c];
                for (a, &va) in self.robot.joint_v.iter().enumerate() {
                    self.ik_b[a] += j[(0, va)] * e.x + j[(1, va)] * e.y + j[(2, va)] * e.z;
                    for (b, &vb) in self.robot.joint_v.iter().enumerate() {
                        self.ik_a[b * nj + a] +=
                            j[(0, va)] * j[(0, vb)] + j[(1, va)] * j[(1, vb)] + j[(2, va)] * j[(2, vb)];
                    }
                }
            }
            let jl = &self.wbc.input.j_closure;
            for l in 0..nl {
                for (a, &va) in self.robot.joint_v.iter().enumerate() {
                    for (b, &vb) in self.robot.joint_v.iter().enumerate() {
                        self.ik_a[b * nj + a] += jl[(l, va)] * jl[(l, vb)];
                    }
                }
            }
            for a in 0..nj {
                self.ik_a[a * nj + a] += lam2;
            }
            if !cholesky_in_place(&mut self.ik_a[..nj * nj], nj) {
                return;
            }
            cholesky_solve(&self.ik_a[..nj * nj], nj, &mut self.ik_b[..nj]);
            for (i, &iv) in self.robot.actuated_v.iter().enumerate() {
                let a = self.robot.joint_v.iter().position(|&x| x == iv).unwrap_or(0);
                let iq = self.robot.actuated_q[i];
                if pass == 0 {
                    // A target beyond a position limit only presses the joint into it
                    // (max/min rather than clamp: no panic on a model built with NaN limits).
                    let (lo, hi) = (
                        self.robot.model.lower_position_limit[iq],
                        self.robot.model.upper_position_limit[iq],
                    );
                    self.command.q_des[i] = (self.q[iq] + self.ik_b[a]).max(lo).min(hi);
                } else {
                    self.command.qd_des[i] = self.ik_b[a];
                }
            }
        }
        // Gains: swing legs vs stance legs (a joint is "swing" if it moves a swing contact).
        for (i, &iv) in self.robot.actuated_v.iter().enumerate() {
            let mut swing = false;
            for c in 0..nc {
                if !self.status.contact[c] {
                    let j = &self.j_contact[c];
                    if j[(0, iv)] != 0.0 || j[(1, iv)] != 0.0 || j[(2, iv)] != 0.0 {
                        swing = true;
                    }
                }
            }
            // Standing, the whole-body QP alone holds the robot; the stance PD targets only
            // carry a walking body over its feet.
            let standing = self.gait.pattern().gait == Gait::Stand;
            let (kp, kd) = if swing {
                self.cfg.swing_joint_gains
            } else if standing {
                (0.0, 0.0)
            } else {
                self.cfg.stance_joint_gains
            };
            self.command.kp[i] = kp;
            self.command.kd[i] = kd;
        }
    }

    fn fill_status(&mut self) {
        let s = &mut self.status;
        s.gait = self.gait.pattern().gait;
        s.phase = self.gait.phase();
        for (k, row) in s.contact_schedule.iter_mut().enumerate() {
            *row = self.schedule[k];
        }
        for c in 0..self.robot.n_contacts() {
            s.forces[c] = [self.forces_now[c].x, self.forces_now[c].y, self.forces_now[c].z];
            let p = self.targets[c].p;
            s.foot_targets[c] = [p.x, p.y, p.z];
            let p = self.p_contact[c];
            s.foot_positions[c] = [p.x, p.y, p.z];
            let f = self.foothold[c];
            s.footholds[c] = [f.x, f.y, f.z];
        }
        s.com = [self.com.x, self.com.y, self.com.z];
        s.position_reference = [self.p_ref.x, self.p_ref.y, 0.0];
        s.com_velocity = [self.com_vel.x, self.com_vel.y, self.com_vel.z];
        s.rpy = [self.rpy.x, self.rpy.y, self.rpy.z];
    }
}

/// The horizontal direction a two-dof leg cannot follow, from a contact's linear Jacobian
/// `j` and the `v` indices of the non-base joints: with `M = Σⱼ jⱼ jⱼᵀ` over those
/// columns, a rank-2 `M` (`λ_min < 10⁻⁶ λ_max`) has a null eigenvector `n`, the direction
/// the foot cannot move in; its horizontal part (normalised, if `n` is mostly horizontal)
/// is returned, otherwise zero. Ant legs give the radial direction, Minitaur and Walker2d
/// legs the lateral one.
pub fn free_direction(j: &Matrix3xX<f64>, joint_v: &[usize]) -> Vector3<f64> {
    let mut m = Matrix3::zeros();
    for &k in joint_v {
        let col = Vector3::new(j[(0, k)], j[(1, k)], j[(2, k)]);
        m += col * col.transpose();
    }
    let eig = m.symmetric_eigen();
    let (mut i_min, mut i_max) = (0, 0);
    for i in 1..3 {
        if eig.eigenvalues[i] < eig.eigenvalues[i_min] {
            i_min = i;
        }
        if eig.eigenvalues[i] > eig.eigenvalues[i_max] {
            i_max = i;
        }
    }
    // (False for NaN data, which then gives no free direction.)
    let rank_two = eig.eigenvalues[i_min] < 1e-6 * eig.eigenvalues[i_max];
    if !rank_two {
        return Vector3::zeros();
    }
    let n = eig.eigenvectors.column(i_min);
    let h = Vector3::new(n[0], n[1], 0.0);
    if h.norm() < 0.5 { Vector3::zeros() } else { h.normalize() }
}

/// The target of a planted foot at `p` for the stance joint PD: where the foot should be
/// relative to the current body if the body (CoM `c`, orientation `R`) were at its
/// reference (CoM `c*`, upright with yaw `ψ*`), `p* = c + R R*ᵀ (p − c*)`, and its
/// velocity relative to a body moving at the commanded `v*` and yaw rate `ψ̇*`,
/// `ṗ* = −v* − ψ̇* ẑ × (p − c)`.
pub fn stance_target(
    p: &Vector3<f64>,
    c: &Vector3<f64>,
    rot: &Matrix3<f64>,
    c_ref: &Vector3<f64>,
    yaw_ref: f64,
    v_cmd: &Vector3<f64>,
    yaw_rate_cmd: f64,
) -> PointTarget {
    let r_ref = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw_ref);
    let target = c + rot * (r_ref.matrix().transpose() * (p - c_ref));
    let v = -v_cmd - Vector3::new(0.0, 0.0, yaw_rate_cmd).cross(&(p - c));
    PointTarget { p: target, v, a: Vector3::zeros() }
}

/// Wraps an angle to `(−π, π]`.
#[inline]
pub fn wrap_pi(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let r = (a + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI;
    if r <= -std::f64::consts::PI { r + two_pi } else { r }
}

/// The base orientation of a yaw angle (helper for tests and tools).
pub fn yaw_quaternion(yaw: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw)
}

#[cfg(test)]
mod tests {
    use centaur_dynamics::{BaseKind, Model};

    use super::*;

    #[test]
    fn infeasible_joint_limit_bounds_are_dropped_not_failed() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/mujoco/walker2d.urdf");
        let model = Model::from_urdf_file(path, BaseKind::Fixed).unwrap();
        let mut c = LocomotionController::new(&model, ControllerConfig::walker2d()).unwrap();
        let s = c.nominal_state();
        c.tick(&s, &Command::stand(), 0.0);
        assert!(c.status().wbc_status.is_ok());
        assert_eq!(c.status().wbc_limit_relaxations, 0);
        // With the input of that tick, demand 10⁶ rad/s² of the first limited joint: no
        // 100 N·m motor gives that, so the QP is infeasible with the bound and solved without.
        let first = c.wbc.limited_joints()[0];
        c.wbc.input.qdd_lower[0] = 1e6;
        assert_eq!(c.wbc.solve(), QpStatus::Solved);
        assert!(c.wbc.limits_relaxed());
        assert!(c.wbc.output.qdd[first.v] < 1e3);
        // A reachable bound holds as a constraint: bend the joint away from its upper limit.
        let (q, v) = (c.q.clone(), c.v.clone());
        c.wbc.set_joint_limit_bounds(q.as_slice(), v.as_slice());
        c.wbc.input.qdd_upper[0] = -5.0;
        assert_eq!(c.wbc.solve(), QpStatus::Solved);
        assert!(!c.wbc.limits_relaxed());
        assert!(c.wbc.output.qdd[first.v] <= -5.0 + 1e-6, "{}", c.wbc.output.qdd[first.v]);
    }

    /// Feet in swing at some tick of `seconds` of stand commands from the nominal state
    /// raised by `lift` metres, and the gait run.
    fn stand_for(config: ControllerConfig, seconds: f64, lift: f64) -> ([bool; 2], Gait) {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/mujoco/humanoid.urdf");
        let model = Model::from_urdf_file(path, BaseKind::Floating).unwrap();
        let mut c = LocomotionController::new(&model, config).unwrap();
        let mut s = c.nominal_state();
        s.q[2] += lift;
        let mut swung = [false; 2];
        for k in 0..(seconds / 0.015) as usize {
            c.tick(&s, &Command::stand(), k as f64 * 0.015);
            for (leg, sw) in swung.iter_mut().enumerate() {
                *sw |= !c.status().contact[leg];
            }
        }
        (swung, c.status().gait)
    }

    #[test]
    fn a_humanoid_told_to_stand_steps_in_place_with_both_feet() {
        let (swung, gait) = stand_for(ControllerConfig::humanoid(), 1.2, 0.0);
        assert_eq!(gait, Gait::Walk);
        assert_eq!(swung, [true, true]);
        let still = ControllerConfig { step_in_place: false, ..ControllerConfig::humanoid() };
        let (swung, gait) = stand_for(still, 1.2, 0.0);
        assert_eq!(gait, Gait::Stand);
        assert_eq!(swung, [false, false]);
        // In the air (dropped from 10 cm, not landed yet) it waits on both feet.
        let (swung, gait) = stand_for(ControllerConfig::humanoid(), 0.3, 0.1);
        assert_eq!(gait, Gait::Stand);
        assert_eq!(swung, [false, false]);
    }
}
