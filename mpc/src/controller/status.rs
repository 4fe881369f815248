//! Stage 6, the report: the [`JointCommand`] the tick returns and the
//! [`ControllerStatus`] that says how it was made (solver statuses and times, fallbacks,
//! contacts, forces, plan) for logging and recording.

use centaur_dynamics::nalgebra::Vector3;

use super::estimate::Estimate;
use super::reference::Reference;
use super::targets::LocomotionTargets;
use crate::gait::{Gait, GaitScheduler, MAX_LEGS};
use crate::qp::QpStatus;

/// The command for the actuated joints, in [`crate::LocomotionController::joint_names`] order
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
    pub(crate) fn new(n: usize) -> Self {
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
    /// Whether the MPC ran this tick ([`crate::MpcExecution::Background`]: whether this tick
    /// adopted a plan the worker finished).
    pub mpc_ran: bool,
    /// Whether this tick solved the MPC itself ([`crate::MpcExecution::Inline`]) or waited for
    /// the worker's solve ([`crate::MpcExecution::Background`], only while no plan exists yet).
    pub mpc_blocked: bool,
    /// Status of the last MPC solve.
    pub mpc_status: QpStatus,
    /// Wall time of the last MPC solve (µs; on the worker thread with
    /// [`crate::MpcExecution::Background`]).
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
    /// Ticks whose commanded gait the configuration does not offer (the robot stood
    /// instead), since construction.
    pub refused_gaits: u64,
    /// Ticks whose commanded speed or yaw rate was above the gait's rating (speed, turning)
    /// and was clamped to it, since construction.
    pub clamped_commands: u64,
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

impl ControllerStatus {
    /// The status before the first tick.
    pub(crate) fn new(nc: usize, horizon: usize) -> Self {
        ControllerStatus {
            t: 0.0,
            ticks: 0,
            gait: Gait::Stand,
            phase: 0.0,
            contact: vec![true; nc],
            contact_schedule: vec![[false; MAX_LEGS]; horizon],
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
            refused_gaits: 0,
            clamped_commands: 0,
            planned_com: vec![[0.0; 3]; horizon],
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
        }
    }

    /// Starts a tick at time `t`.
    pub(crate) fn begin(&mut self, t: f64) {
        self.ticks += 1;
        self.t = t;
        self.mpc_ran = false;
        self.mpc_blocked = false;
        self.wbc_status = QpStatus::NotRun;
        self.fallback = Fallback::None;
    }

    /// The tick's gait, schedule, contacts, forces, targets and state, once it is done.
    pub(crate) fn fill(
        &mut self,
        gait: &GaitScheduler,
        schedule: &[[bool; MAX_LEGS]],
        est: &Estimate,
        reference: &Reference,
        targets: &LocomotionTargets,
    ) {
        self.gait = gait.pattern().gait;
        self.phase = gait.phase();
        for (k, row) in self.contact_schedule.iter_mut().enumerate() {
            *row = schedule[k];
        }
        let xyz = |v: &Vector3<f64>| [v.x, v.y, v.z];
        for c in 0..targets.stance.len() {
            self.contact[c] = targets.stance[c];
            self.forces[c] = xyz(&targets.force[c]);
            self.foot_targets[c] = xyz(&targets.motion[c].p);
            self.foot_positions[c] = xyz(&est.p_contact[c]);
            self.footholds[c] = xyz(&targets.foothold[c]);
        }
        self.com = xyz(&est.com);
        self.position_reference = [reference.p_ref.x, reference.p_ref.y, 0.0];
        self.com_velocity = xyz(&est.com_vel);
        self.rpy = xyz(&est.rpy);
    }
}
