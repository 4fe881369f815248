//! # centaur-envs
//!
//! Benchmark environments simulated with Rapier: PyBullet's Minitaur and Gymnasium's Ant,
//! Walker2d, Hopper, HalfCheetah and Humanoid, built from the same URDF the controller uses;
//! and modular robots in the style of Revolve2 ([`modular`]: core, bricks, active hinges;
//! the gecko, ant and spider).

mod checks;
mod error;
pub mod locomotion;
pub mod minitaur;
pub mod modular;
pub mod mujoco;
pub mod robot;
pub mod sim;

pub use checks::{MAX_FRAME_SKIP, MAX_JOINT_HISTORY};
pub use error::RobotEnvError;
pub use locomotion::{LocomotionConfig, LocomotionEnv, LocomotionRobot};
pub use minitaur::{MinitaurConfig, MinitaurEnv};
pub use modular::{
    Body, Face, ModularConfig, ModularEnv, ModularError, ModularObservation, ModularReward, ModuleId,
    ModuleKind, ModuleSpecs,
};
pub use robot::{BODY_STATE_DIM, FootContact, ObsOptions, PushSchedule, RobotEnv, Servo, heading_body_state};
pub use sim::{ColliderSpec, LoopClosure, Sim, SimConfig, SimError};
