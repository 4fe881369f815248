//! # Centaur
//!
//! Legged-robot locomotion that joins model-based control and reinforcement learning.
//! This facade re-exports the workspace crates and holds what joins them:
//!
//! | module | what |
//! |---|---|
//! | [`hybrid`] | the one residual core: the law `a = clip(a_ref + scale ⊙ r)`, the policy's observation, the controller → action glue |
//! | [`registry`] | every environment by name, with its controller and residual presets |
//! | [`residual`] | [`residual::ResidualEnv`]: the hybrid as an environment, for training |
//! | [`deploy`] | [`deploy::HybridStack`]: the controller and a trained policy behind a robot interface |
//! | [`control`] | closed-loop runs of the controller alone (`centaur control`) |
//! | [`sweep`] | `centaur sweep`: a grid of run settings × seeds, in parallel, resumable |
//! | [`eval`] | `centaur eval`: a checkpoint on any configuration of its environment |
//! | [`experiment`], [`compare`], [`train`] | pure RL against the hybrid, over seeds; `centaur train` |
//! | [`recording`], [`plot`] | MCAP recordings for Foxglove; learning-curve plots |
//! | [`spec`] | run specs: one TOML file holds everything a run is, resolved once and recorded as `spec.json` |
//! | [`settings`] | `[env]`: a robot environment's settings over its preset, from a run's TOML |
//! | [`rundir`] | atomic writes; run directories refused when taken, unless replaced |
//! | `cli` (feature `cli`, default) | the examples' and the binary's command line and progress bars |

pub use centaur_dynamics as dynamics;
pub use centaur_envs as envs;
pub use centaur_gym as gym;
pub use centaur_mpc as mpc;
pub use centaur_rl as rl;

#[cfg(feature = "cli")]
pub mod cli;
pub mod compare;
pub mod control;
pub mod deploy;
pub mod eval;
pub mod experiment;
pub mod hybrid;
mod jobs;
pub mod plot;
pub mod recording;
pub mod registry;
pub mod residual;
pub mod rundir;
pub mod settings;
pub mod spec;
pub mod stats;
pub mod sweep;
pub mod train;
