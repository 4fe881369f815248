//! Pure RL against the hybrid (residual RL on the controller) on the same benchmark, with
//! the controller alone as a third agent.
//!
//! [`run_experiment`] trains a pure-RL agent on the robot environment and a hybrid agent on
//! its [`ResidualEnv`](crate::residual::ResidualEnv) with the same algorithm, hyperparameters, seed and step budget,
//! evaluates the two policies and the controller alone over the same evaluation seeds with
//! deterministic actions, and writes what follows. With more than one thread
//! ([`ExperimentOptions::threads`]) the two agents train side by side and the three are
//! evaluated side by side; every figure is the same as with one thread, only the wall times
//! (which then overlap) differ.
//!
//! | file | content |
//! |---|---|
//! | `summary.json` | `{"hybrid": {...}, "pure_rl": {...}, "controller": {...}}` ([`AgentStats`] each) |
//! | `{pure_rl,hybrid}/metrics.csv` | training metrics per update |
//! | `{pure_rl,hybrid}/checkpoint` | the trained learner (`Policy::load` acts with it) |
//! | `learning_curves.png`, `.svg` | training return against environment steps, both agents |
//! | `{pure_rl,hybrid,controller}.mcap` | the first evaluation episode of each agent, for Foxglove |
//!
//! Evaluation metrics per episode: return; mean forward speed (base displacement along x over
//! the episode's duration); fall (the episode terminated); energy `Σ |τ·q̇| dt`; torque RMS
//! over steps and actuators. The cost of transport is `E / (m g d)` over all episodes
//! (total energy over weight times total forward distance), reported only when the agent
//! moved forward.
//!
//! | file | what |
//! |---|---|
//! | `options.rs` | [`ExperimentOptions`], [`ExperimentResult`], [`ExperimentError`] |
//! | `runner.rs` | [`run_experiment`]: training, evaluation, outputs |
//! | `evaluation.rs` | deterministic evaluation of each agent |
//! | `summary.rs` | [`AgentStats`], [`ExperimentSummary`], `summary.json` and the learning curves |
//! | `presets.rs` | [`tuned_config`]: the typed hyperparameter presets |

mod evaluation;
mod options;
mod presets;
mod robustness;
mod runner;
mod summary;

pub use evaluation::evaluate_policy;
pub use options::{Curve, ExperimentError, ExperimentOptions, ExperimentResult, Phase};
pub use presets::tuned_config;
pub use robustness::{Condition, RobustnessOptions, RobustnessRow, robustness_table, run_robustness};
pub(crate) use runner::check_pure_source;
pub use runner::{
    EXPERIMENT_FILES, TrainedWith, check_resumable, check_trained_with, finished_experiment, recorded_hybrid,
    run_experiment,
};
pub use summary::{AgentStats, BudgetEval, ExperimentSummary, cost_of_transport};
