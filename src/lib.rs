//! # Centaur
//!
//! Legged-robot locomotion that joins model-based control and reinforcement learning.
//! This facade re-exports the workspace crates.

pub use centaur_dynamics as dynamics;
pub use centaur_envs as envs;
pub use centaur_mpc as mpc;
pub use centaur_rl as rl;

pub mod compare;
pub mod control;
pub mod deploy;
pub mod experiment;
pub mod plot;
pub mod recording;
pub mod registry;
pub mod residual;
pub mod train;
