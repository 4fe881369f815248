//! # centaur-envs
//!
//! Benchmark environments simulated with Rapier: PyBullet's Minitaur and Gymnasium's Ant,
//! Walker2d, Hopper, HalfCheetah and Humanoid, built from the same URDF the controller uses.

pub mod sim;

pub use sim::{ColliderSpec, LoopClosure, Sim, SimConfig, SimError};
