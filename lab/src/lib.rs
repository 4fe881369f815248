//! # Centaur's lab
//!
//! The application over the [`centaur`] library: the `centaur` command line and what it
//! runs. A run is one spec ([`spec`]), resolved once on the way in and recorded in its run
//! directory ([`rundir`]); every consumer (resume, eval, robustness, the examples) builds
//! from the record.
//!
//! | module | what |
//! |---|---|
//! | [`spec`] | run specs: one TOML file holds everything a run is, resolved once and recorded as `spec.json` |
//! | [`train`] | `centaur train`: one agent, resumable |
//! | [`experiment`], [`compare`] | pure RL against the hybrid, over seeds; the robustness study |
//! | [`sweep`] | `centaur sweep`: a grid of run settings × seeds, in parallel, resumable |
//! | [`eval`] | `centaur eval`: a checkpoint on any configuration of its environment |
//! | [`control`] | closed-loop runs of the controller alone (`centaur control`) |
//! | [`plot`], [`stats`] | learning-curve plots; interquartile means with bootstrap intervals |
//! | [`rundir`] | atomic writes; run directories refused when taken, unless replaced |
//! | [`cli`] | the examples' and the binary's command line and progress bars |
//!
//! The library's modules are re-exported here, so that `centaur_lab::hybrid` is
//! `centaur::hybrid`.
//!
//! Beyond the library's, the lab depends on clap (the command line: derive-based parsing
//! with typed errors, which we would otherwise write by hand for 67 flags), indicatif
//! (progress bars), plotters and png (learning-curve plots with a bundled font, no system
//! font library) and toml (run specs and grid files).

pub use centaur::{deploy, dynamics, envs, gym, hybrid, mpc, recording, registry, residual, rl, settings};

pub mod cli;
pub mod compare;
pub mod control;
pub mod eval;
pub mod experiment;
mod jobs;
pub mod plot;
pub mod rundir;
pub mod spec;
pub mod stats;
pub mod sweep;
pub mod train;
