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

    /// Sets a rising floor under the exploration σ ([`ExplorationFloor`]), counted from the
    /// learner's first training sample. Only learners with a per-entry Gaussian (PPO, A2C)
    /// take it; the others refuse with [`RlError::Incompatible`] (the default).
    fn set_exploration_floor(&mut self, floor: ExplorationFloor) -> Result<(), RlError> {
        let _ = floor;
        Err(RlError::Incompatible {
            algo: "off-policy",
            reason: "the learner's exploration is not a per-entry Gaussian; it takes no exploration floor"
                .into(),
        })
    }
}

/// A rising floor under a Gaussian learner's exploration σ, per action entry: from σ₀ at
/// the start of training to σ₁ after `steps` training samples, log-linearly, then none. At
/// the start of each rollout the learner raises every floored entry's σ to at least the
/// floor; its own updates move σ as always. A hybrid starts gently (σ₀ small, so its first
/// episodes walk like the controller) and is made to explore widely once learning is under
/// way (σ₁), after which the learner's σ is its own again. PPO and A2C take it
/// ([`Algorithm::set_exploration_floor`]) and keep it in their checkpoints.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExplorationFloor {
    /// Per action entry: the floor's `[σ₀, σ₁]`, or `None` for an entry without a floor.
    pub entries: Vec<Option<[f64; 2]>>,
    /// Training samples (environment steps, all environments together) over which the floor
    /// rises; after them it is released.
    pub steps: u64,
}

impl ExplorationFloor {
    /// Checks the floor against the action dimension: every σ finite and positive, σ₁ ≥ σ₀,
    /// at least one step.
    pub fn validate(&self, algo: &'static str, act_dim: usize) -> Result<(), RlError> {
        let bad = |field: &'static str, value: String, reason: &'static str| {
            Err(RlError::InvalidConfig { algo, field, value, reason })
        };
        if self.entries.len() != act_dim {
            return Err(RlError::Incompatible {
                algo,
                reason: format!(
                    "an exploration floor of {} entries for {act_dim} actions",
                    self.entries.len()
                ),
            });
        }
        if self.steps == 0 {
            return bad("exploration floor steps", "0".into(), "must be at least 1");
        }
        for [from, to] in self.entries.iter().flatten() {
            if !(from.is_finite() && *from > 0.0 && to.is_finite() && *to > 0.0) {
                return bad("exploration floor σ", format!("[{from}, {to}]"), "must be finite and positive");
            }
            if to < from {
                return bad("exploration floor σ", format!("[{from}, {to}]"), "must rise (σ₁ ≥ σ₀)");
            }
        }
        Ok(())
    }

    /// Raises `log_std` to the floor after `steps_done` training samples (nothing once the
    /// floor is released). Allocation-free.
    pub fn apply(&self, log_std: &mut [f32], steps_done: u64) {
        if steps_done >= self.steps {
            return;
        }
        let f = steps_done as f64 / self.steps as f64;
        for (ls, entry) in log_std.iter_mut().zip(&self.entries) {
            if let Some([from, to]) = entry {
                let floor = from.ln() + f * (to.ln() - from.ln());
                *ls = ls.max(floor as f32);
            }
        }
    }

    /// The floor kept in `c` (as metadata), if any, checked against `act_dim`.
    pub(crate) fn read(c: &Checkpoint, algo: &'static str, act_dim: usize) -> Result<Option<Self>, RlError> {
        if !c.meta.contains_key(Self::META) {
            return Ok(None);
        }
        let floor: ExplorationFloor = c.get_meta(Self::META)?;
        floor.validate(algo, act_dim)?;
        Ok(Some(floor))
    }

    /// Keeps `floor` in `c`, if any (nothing is written without one, so checkpoints of
    /// learners without a floor are as before).
    pub(crate) fn write(floor: &Option<Self>, c: &mut Checkpoint) {
        if let Some(f) = floor {
            c.set_meta(Self::META, f);
        }
    }

    const META: &'static str = "exploration_floor";
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

#[cfg(test)]
mod tests {
    use super::*;

    fn floor() -> ExplorationFloor {
        ExplorationFloor { entries: vec![Some([0.01, 0.3]), None], steps: 100 }
    }

    #[test]
    fn the_floor_rises_log_linearly_then_is_released() {
        let f = floor();
        let at = |steps: u64, start: f32| {
            let mut ls = [start, start];
            f.apply(&mut ls, steps);
            ls
        };
        let low = (0.001f64).ln() as f32;
        // At the start the floor is σ₀; halfway the geometric mean; the free entry is untouched.
        assert!((at(0, low)[0] as f64 - 0.01f64.ln()).abs() < 1e-6);
        assert!((at(50, low)[0] as f64 - (0.01f64 * 0.3).sqrt().ln()).abs() < 1e-6);
        assert_eq!(at(50, low)[1], low);
        // It only raises: a σ above the floor stays.
        assert_eq!(at(50, 0.0)[0], 0.0);
        // Released once the ramp is over.
        assert_eq!(at(100, low)[0], low);
        assert_eq!(at(10_000, low)[0], low);
    }

    #[test]
    fn bad_floors_are_refused() {
        assert!(floor().validate("ppo", 2).is_ok());
        assert!(matches!(floor().validate("ppo", 3), Err(RlError::Incompatible { .. })));
        for (entries, steps) in [
            (vec![Some([0.01, 0.3]), None], 0),
            (vec![Some([0.3, 0.01]), None], 100),
            (vec![Some([0.0, 0.3]), None], 100),
            (vec![Some([0.01, f64::NAN]), None], 100),
            (vec![Some([0.01, f64::INFINITY]), None], 100),
        ] {
            let f = ExplorationFloor { entries, steps };
            assert!(matches!(f.validate("ppo", 2), Err(RlError::InvalidConfig { .. })), "{f:?} accepted");
        }
    }
}
