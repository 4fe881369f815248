//! The one interface shared by all learners, so that the CLI (and the hybrid runner) can
//! drive any of them: [`Algorithm`] (`learners.rs` picks one by name or checkpoint).
//!
//! It is deliberately flat: each algorithm is a plain struct in its own file implementing
//! these few methods; there is no base class and no shared training loop.

use std::ops::ControlFlow;
use std::path::Path;

use crate::checkpoint::Checkpoint;
use crate::error::RlError;
use crate::metrics::UpdateMetrics;
use crate::policy::Policy;
use centaur_gym::VecEnv;

/// What every learner offers.
pub trait Algorithm {
    /// Short name: `"ppo"`, `"a2c"`, `"sac"`, `"sac1"`, `"td3"`, `"ddpg"`.
    fn name(&self) -> &'static str;

    /// Trains on `env` until [`Algorithm::steps_done`] reaches `total_steps` (a total, not
    /// an increment: after a resume, pass the run's overall budget). On-policy learners stop
    /// at the first update boundary at or past it. `callback` sees every metrics record;
    /// returning `ControlFlow::Break(())` stops after that update.
    ///
    /// A VecEnv that has already been stepped (its [`VecEnv::observations`] is `Some`) is
    /// continued where it is; a fresh one is reset with seed `config.seed + steps_done`.
    fn learn(
        &mut self,
        env: &mut VecEnv,
        total_steps: u64,
        callback: &mut dyn FnMut(&UpdateMetrics) -> ControlFlow<()>,
    ) -> Result<(), RlError>;

    /// Everything needed to act and to resume.
    fn to_checkpoint(&self) -> Checkpoint;

    /// Writes [`Algorithm::to_checkpoint`] atomically to `path`.
    fn save(&self, path: &Path) -> Result<(), RlError> {
        self.to_checkpoint().write(path)?;
        Ok(())
    }

    /// The current deterministic policy (what [`Policy::load`] returns after `save`).
    fn policy(&self) -> Policy;

    /// Environment steps taken so far.
    fn steps_done(&self) -> u64;

    /// Makes the policy's (mean) action exactly zero for every observation by zeroing the
    /// actor's output rows (and its target copy): a residual policy then starts as a no-op
    /// on top of its reference controller. Exploration noise is unchanged.
    fn zero_policy_output(&mut self);
}
