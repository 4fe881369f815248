//! # Centaur
//!
//! Legged-robot locomotion that joins model-based control and reinforcement learning.
//! This is what robot software links: the workspace crates re-exported and what joins
//! them, with no command line, plotting or run-directory code (those are the lab's,
//! `centaur-lab`, which holds the `centaur` binary and the studies).
//!
//! | module | what |
//! |---|---|
//! | [`hybrid`] | the one residual core: the law `a = clip(a_ref + scale ⊙ r)`, the policy's observation, the step training and deployment share, the controller's overrides, the controller → action glue |
//! | [`registry`] | every environment by name, with its controller and residual presets |
//! | [`residual`] | [`residual::ResidualEnv`]: the hybrid as an environment, for training |
//! | [`deploy`] | [`deploy::HybridStack`]: the controller and a trained policy behind a robot interface |
//! | [`recording`] | MCAP recordings for Foxglove |
//! | [`settings`] | `[env]`: a robot environment's settings over its preset, from a run's TOML |
//!
//! Beyond the workspace crates it depends on thiserror (typed errors), serde and
//! serde_json (setups and settings recorded in checkpoints and run records, floats round
//! trip), toml (`[env]` tables) and mcap (recordings for Foxglove).

pub use centaur_dynamics as dynamics;
pub use centaur_envs as envs;
pub use centaur_gym as gym;
pub use centaur_mpc as mpc;
pub use centaur_rl as rl;

pub mod deploy;
pub mod hybrid;
pub mod recording;
pub mod registry;
pub mod residual;
pub mod settings;
