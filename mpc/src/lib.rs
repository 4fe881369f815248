//! # centaur-mpc
//!
//! Model-predictive locomotion control for legged robots, seeing the robot only through a
//! [`centaur_dynamics::Model`], a [`centaur_dynamics::RobotState`] and a [`Command`]:
//!
//! ```text
//! gait schedule ──> footholds + swing curves ──> convex MPC (forces over the horizon)
//!        │                                                │
//!        └──────────────> whole-body QP (or cheap τ = −Jᵀf) ──> JointCommand
//! ```
//!
//! | part | file | types | maths |
//! |---|---|---|---|
//! | gait schedule (stand, walk, trot, pace, bound, pronk, gallop; biped walk; a staggered trot for turning without abduction) | `gait.rs` | [`Gait`], [`GaitPattern`], [`GaitScheduler`], [`GaitPattern::staggered`] | offsets `oᵢ`, duty `dᵢ`, `ψᵢ = (φ − oᵢ) mod 1`, stance iff `ψᵢ < dᵢ` |
//! | friction | `friction.rs` | [`FrictionModel`] | `‖(f_x, f_y)‖ ≤ μ f_z` (SOC) or a 4-sided pyramid |
//! | convex MPC | `convex_mpc/` | [`ConvexMpc`], [`MpcConfig`], [`MpcSolver`] | Di Carlo et al. 2018, single rigid body, yaw-linearised; our interior point with a Riccati recursion (`ipm.rs`, `riccati.rs`, `cones.rs`), Clarabel as the reference (`clarabel.rs`) |
//! | whole-body QP | `wbc.rs` | [`WholeBodyQp`], [`WbcConfig`] | `[q̈, f, λ]`, floating-base rows as equalities, torque limits, weighted tasks |
//! | dense QP solver | `qp.rs` | [`DenseQp`] | Goldfarb–Idnani dual active set (the WBC default) |
//! | footholds, swing curves | `swing.rs` | (internal) | Raibert + capture point `√(h/g)(v − v_cmd)`; Bézier swing |
//! | robot description | `robot.rs`, `config.rs` | [`RobotSpec`], [`LeggedRobot`], [`ControllerConfig`] | contacts, actuated/passive joints, loop closures, presets |
//! | controller | `controller/` (one file per stage) | [`LocomotionController`], [`ControllerStatus`], [`Fallback`] | [`LocomotionController::tick`]: estimate → reference → contacts and swing → plan → torques → status |
//! | MPC on a worker thread | `background.rs` | [`MpcExecution::Background`] | ticks adopt plans as they finish |
//! | errors | `error.rs` | [`ConfigError`] | |
//! | Minitaur action mapping | `centaur_envs::minitaur` | PD targets → motor angles → PyBullet leg model |
//!
//! ## Conventions
//!
//! Those of `centaur-dynamics` (Pinocchio's): `q = [x, y, z, qx, qy, qz, qw, joints]`,
//! `v = [v_base, ω_base]` in the base frame. The controller's world quantities (contact
//! forces, foot positions, CoM) are in world axes, z up, flat ground. Contact forces are
//! the ground's reaction on the robot. The [`JointCommand`] lists the actuated joints in
//! model order ([`LocomotionController::joint_names`]); the torque it asks for is
//! `τ = tau + kp (q_des − q) + kd (qd_des − q̇)`.
//!
//! ## Per robot (presets in [`ControllerConfig`])
//!
//! * **Solo12**, **Ant**: quadruped MPC + WBC. Ant's legs have 2 dof, so forces a leg
//!   cannot produce are limited by the WBC's torque rows and no-slip task.
//! * **Minitaur**: the same, with the four 5-bar loops closed in the WBC by constraint
//!   forces `λ` along the two in-plane directions, passive knees (`τ = 0` rows), toe
//!   contacts; `centaur_envs::minitaur` maps the command to the env's motor-angle / leg-model actions.
//!   Without abduction it turns on a staggered trot up to 0.6 m/s and, faster, on its bound,
//!   which runs at its own CoM height ([`GaitOffer::com_height`]): with its two front or two
//!   hind feet planted, the body yaws about their midpoint without a foot slipping sideways.
//! * **Walker2d**: the **planar** MPC variant ([`MpcConfig::biped_planar`]: lateral force
//!   columns removed, feet projected to the sagittal plane) + WBC on its planar root
//!   joints, biped walk, heel and toe contacts per foot. The walk carries its own tuning in
//!   its offer ([`GaitOffer::duty`], [`GaitOffer::mpc_weights`],
//!   [`GaitOffer::body_angular_weight`]): each foot in stance for 0.35 of the cycle and the
//!   torso's pitch left to a weak WBC task. Its hip swings the leg only backwards from the
//!   torso's axis, so the torso leans back for a foot to land ahead, and the heavy legs
//!   need the longer swing to stay within the hips' torque; rated 1.0 m/s.
//! * **Humanoid**: balance on two point feet by stepping in place (a stand command walks on
//!   the spot, [`ControllerConfig::step_in_place`]): point feet support the robot along a
//!   line only and there are no ankles, so no standing controller can hold it still. It
//!   uses the 3D MPC + WBC, capture-point footholds carried with the CoM
//!   ([`ControllerConfig::foothold_from_com`]) with a position feedback
//!   ([`ControllerConfig::foothold_position_gain`]), a horizon of one gait cycle, and a
//!   whole-body posture task strong enough to keep the arms and abdomen from swinging the
//!   torso's heading. It walks (the same gait, moving) at 0.5 and 0.6 m/s on every seed
//!   tried and is rated 0.5 m/s (the preset's docs).
//!
//! Each preset offers only the gaits measured to work on its robot, each rated to a speed
//! and a turning range ([`GaitOffer`]: the largest yaw rate, up to a speed, and
//! optionally a smaller one up to a higher speed; straight above it).
//! [`ControllerConfig::check_command`] refuses a command outside them before a run, naming
//! the rating; inside `tick` a gait not offered stands, and a faster speed or yaw rate is
//! clamped to the rating and counted in [`ControllerStatus::clamped_commands`].
//!
//! ## Failures and fallbacks
//!
//! Solver outcomes are [`QpStatus`] values in [`ControllerStatus`]. The MPC falls back to
//! its last feasible forces decayed by `fallback_decay` per failure (or the weight split
//! over the stance feet); a failed whole-body QP falls back to the cheap path; a
//! non-finite state or command gives posture PD to the nominal pose with zero feed-forward.
//! The whole-body QP is feasible for every finite state by construction (see [`WholeBodyQp`]).
//!
//! ## Timing: where the MPC runs
//!
//! By default ([`MpcExecution::Inline`]) `tick` solves the MPC itself every `mpc_period`,
//! so the ticks that solve take the solve's ≈ 0.3 ms (the structured solver; Clarabel's
//! ≈ 2–4 ms) and the others the whole-body QP's tens of µs; the results are reproducible
//! bit for bit, which simulation and training need. On a robot, set [`ControllerConfig::mpc_execution`] to
//! [`MpcExecution::Background`]: the controller then owns a worker thread that solves
//! while the control loop goes on, each tick adopts the newest finished plan and follows
//! it from the time its state was measured (MIT Cheetah's arrangement), and a tick waits
//! for a solve only before the first plan (after construction or a reset), never after
//! failed solves. The ticks then never wait for a solve: in `mpc_bench` the ticks' p99
//! falls from the solve time to about 0.15 ms.
//!
//! ## Limits
//!
//! Flat ground (contact normal +z); with the default solvers `tick` allocates nothing
//! (Clarabel, where chosen for the MPC or the WBC, allocates once inside each solve — its
//! internal timers — which with [`MpcExecution::Background`] happens on the worker thread);
//! the dense WBC needs a pyramid friction model.
//!
//! ## Example
//!
//! ```
//! use centaur_dynamics::{BaseKind, Model};
//! use centaur_mpc::{Command, ControllerConfig, Gait, LocomotionController};
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/solo12/solo12.urdf");
//! let model = Model::from_urdf_file(path, BaseKind::Floating).unwrap();
//! let mut ctrl = LocomotionController::new(&model, ControllerConfig::solo12()).unwrap();
//! let state = ctrl.nominal_state();
//! let cmd = ctrl.tick(&state, &Command::forward(0.3, Gait::Trot), 0.0);
//! assert_eq!(cmd.tau.len(), 12);
//! assert!(ctrl.status().mpc_status.is_ok() && ctrl.status().wbc_status.is_ok());
//! ```

mod background;
mod config;
mod controller;
mod convex_mpc;
mod error;
mod friction;
mod gait;
mod qp;
mod robot;
mod swing;
mod wbc;

pub use config::{Command, ControlMode, ControllerConfig, GaitOffer, HeightRise, MpcExecution, TurnRating};
pub use controller::{
    BODY_HEIGHT_RANGE, ControllerStatus, Fallback, JointCommand, LANDING_HEIGHT, LocomotionController,
    MAX_FOOTHOLD_OFFSET, SWING_SCALE_RANGE, wrap_pi,
};
pub use convex_mpc::{ConvexMpc, HardConstraints, MpcConfig, MpcInput, MpcSolver, NX, state_index};
pub use error::ConfigError;
pub use friction::FrictionModel;
pub use gait::{
    DUTY_RANGE, DUTY_SHIFT_SLEW, GAIT_RATE_RANGE, GAIT_RATE_SLEW, Gait, GaitPattern, GaitScheduler,
    MAX_DUTY_SHIFT, MAX_LEGS, MAX_STAGGER, duty_shift_in_range,
};
pub use qp::{DenseQp, DenseQpData, QpStatus};
pub use robot::{BaseSpec, ContactSpec, LeggedRobot, LoopClosure, LoopClosureSpec, MAX_CONTACTS, RobotSpec};
pub use wbc::{LimitedJoint, QpBackend, WbcConfig, WbcInput, WbcOutput, WholeBodyQp};
