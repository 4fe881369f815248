//! The one interface shared by all learners, so that the CLI (and the hybrid runner) can
//! drive any of them: [`Algorithm`], plus [`AlgoKind`] and [`load`] to pick one by name.
//!
//! It is deliberately flat: each algorithm is a plain struct in its own file implementing
//! these few methods; there is no base class and no shared training loop.

use std::ops::ControlFlow;
use std::path::Path;

use crate::checkpoint::Checkpoint;
use crate::env::VecEnv;
use crate::error::RlError;
use crate::metrics::UpdateMetrics;
use crate::policy::Policy;
use crate::{A2c, Ddpg, Ppo, Sac, SacV1, Td3};

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

/// The algorithms, by CLI name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlgoKind {
    /// [`Ppo`].
    Ppo,
    /// [`A2c`].
    A2c,
    /// [`Sac`] (v2).
    Sac,
    /// [`SacV1`].
    SacV1,
    /// [`Td3`].
    Td3,
    /// [`Ddpg`].
    Ddpg,
}

impl AlgoKind {
    /// All kinds.
    pub const ALL: [AlgoKind; 6] =
        [AlgoKind::Ppo, AlgoKind::A2c, AlgoKind::Sac, AlgoKind::SacV1, AlgoKind::Td3, AlgoKind::Ddpg];

    /// CLI / checkpoint name.
    pub fn name(self) -> &'static str {
        match self {
            AlgoKind::Ppo => "ppo",
            AlgoKind::A2c => "a2c",
            AlgoKind::Sac => "sac",
            AlgoKind::SacV1 => "sac1",
            AlgoKind::Td3 => "td3",
            AlgoKind::Ddpg => "ddpg",
        }
    }

    /// Parses a CLI name.
    pub fn from_name(name: &str) -> Option<AlgoKind> {
        AlgoKind::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// Loads any learner from a checkpoint file, by the algorithm recorded in it.
pub fn load(path: &Path) -> Result<Box<dyn Algorithm>, RlError> {
    let c = Checkpoint::read(path)?;
    from_checkpoint(&c)
}

/// Any learner from an in-memory checkpoint.
pub fn from_checkpoint(c: &Checkpoint) -> Result<Box<dyn Algorithm>, RlError> {
    let kind = AlgoKind::from_name(&c.algo).ok_or_else(|| crate::checkpoint::CheckpointError::Metadata {
        path: c.path().to_path_buf(),
        reason: format!("unknown algorithm `{}`", c.algo),
    })?;
    Ok(match kind {
        AlgoKind::Ppo => Box::new(Ppo::from_checkpoint(c)?),
        AlgoKind::Sac => Box::new(Sac::from_checkpoint(c)?),
        AlgoKind::Td3 => Box::new(Td3::from_checkpoint(c)?),
        AlgoKind::SacV1 => Box::new(SacV1::from_checkpoint(c)?),
        AlgoKind::Ddpg => Box::new(Ddpg::from_checkpoint(c)?),
        AlgoKind::A2c => Box::new(A2c::from_checkpoint(c)?),
    })
}
