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

    /// Makes an off-policy learner's warm-up (its first `learning_starts` steps) act with
    /// its own exploration instead of uniformly random actions (the config's
    /// `warmup_with_policy`; kept in its checkpoints). On-policy learners refuse with
    /// [`RlError::Incompatible`] (the default).
    fn set_warmup_with_policy(&mut self) -> Result<(), RlError> {
        Err(RlError::Incompatible {
            algo: "on-policy",
            reason: "the learner has no warm-up phase (only SAC, SAC v1, TD3 and DDPG have one)".into(),
        })
    }

    /// Sets the initial exploration, per action entry, as the standard deviation of the
    /// Gaussian the learner samples around its mean action (in the [−1, 1] action scale):
    /// a hybrid starts with little noise on the parts that would knock its controller over.
    /// Learners whose exploration is not a per-entry Gaussian around the policy's mean
    /// (SAC, TD3, DDPG: a state-dependent or fixed noise and uniform warm-up actions)
    /// refuse with [`RlError::Incompatible`]. The default refuses.
    fn set_exploration_std(&mut self, std: &[f64]) -> Result<(), RlError> {
        let _ = std;
        Err(RlError::Incompatible {
            algo: "off-policy",
            reason:
                "the learner's exploration is not a per-entry Gaussian; it cannot be set per action entry"
                    .into(),
        })
    }
}

/// Checks a per-entry exploration std (length `act_dim`, every entry finite and positive) and
/// returns its logarithms.
pub(crate) fn exploration_log_std(
    algo: &'static str,
    std: &[f64],
    act_dim: usize,
) -> Result<Vec<f32>, RlError> {
    if std.len() != act_dim {
        return Err(RlError::Incompatible {
            algo,
            reason: format!("{} exploration stds for {act_dim} actions", std.len()),
        });
    }
    if let Some(&bad) = std.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
        return Err(RlError::InvalidConfig {
            algo,
            field: "exploration std",
            value: bad.to_string(),
            reason: "must be finite and positive",
        });
    }
    Ok(std.iter().map(|s| s.ln() as f32).collect())
}
