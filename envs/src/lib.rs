//! # centaur-envs
//!
//! Benchmark environments simulated with Rapier: PyBullet's Minitaur and Gymnasium's Ant,
//! Walker2d, Hopper, HalfCheetah and Humanoid, built from the same URDF the controller uses.

pub mod locomotion;
pub mod minitaur;
pub mod mujoco;
pub mod robot;
pub mod sim;

pub use locomotion::{LocomotionConfig, LocomotionEnv, LocomotionRobot};
pub use minitaur::{MinitaurConfig, MinitaurEnv};
pub use robot::{FootContact, JointTarget, ObsOptions, RobotEnv};
pub use sim::{ColliderSpec, LoopClosure, Sim, SimConfig, SimError};
