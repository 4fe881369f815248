//! Picking a learner: [`AlgoKind`] by name, [`AlgoConfig`] (a kind with its typed
//! settings) to build one, and [`load`] / [`from_checkpoint`] to restore one from a
//! checkpoint. The one file that knows every algorithm; the algorithm files know only
//! the [`Algorithm`] trait.

use std::path::Path;

use centaur_gym::VecEnv;

use crate::a2c::{A2c, A2cConfig};
use crate::algorithm::Algorithm;
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::ddpg::{Ddpg, DdpgConfig};
use crate::error::RlError;
use crate::ppo::{Ppo, PpoConfig};
use crate::sac::{Sac, SacConfig};
use crate::sac_v1::{SacV1, SacV1Config};
use crate::td3::{Td3, Td3Config};

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
    /// Whether the learner explores with a per-entry Gaussian around its mean action, so
    /// that [`crate::Algorithm::set_exploration_std`] applies (PPO and A2C).
    pub fn takes_exploration_std(self) -> bool {
        matches!(self, AlgoKind::Ppo | AlgoKind::A2c)
    }

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
    let kind = AlgoKind::from_name(&c.algo).ok_or_else(|| CheckpointError::Metadata {
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

/// A learner's kind with its settings: what `centaur train --algo A --config F.toml`
/// describes, typed. The presets are named constructors of the config structs
/// ([`PpoConfig::minitaur`], [`SacConfig::locomotion`], …).
#[derive(Clone, Debug, PartialEq)]
pub enum AlgoConfig {
    /// PPO.
    Ppo(PpoConfig),
    /// A2C.
    A2c(A2cConfig),
    /// SAC v2.
    Sac(SacConfig),
    /// SAC v1.
    SacV1(SacV1Config),
    /// TD3.
    Td3(Td3Config),
    /// DDPG.
    Ddpg(DdpgConfig),
}

impl AlgoConfig {
    /// The algorithm's defaults (the paper's values).
    pub fn default_for(kind: AlgoKind) -> AlgoConfig {
        match kind {
            AlgoKind::Ppo => AlgoConfig::Ppo(PpoConfig::default()),
            AlgoKind::A2c => AlgoConfig::A2c(A2cConfig::default()),
            AlgoKind::Sac => AlgoConfig::Sac(SacConfig::default()),
            AlgoKind::SacV1 => AlgoConfig::SacV1(SacV1Config::default()),
            AlgoKind::Td3 => AlgoConfig::Td3(Td3Config::default()),
            AlgoKind::Ddpg => AlgoConfig::Ddpg(DdpgConfig::default()),
        }
    }

    /// The kind.
    pub fn kind(&self) -> AlgoKind {
        match self {
            AlgoConfig::Ppo(_) => AlgoKind::Ppo,
            AlgoConfig::A2c(_) => AlgoKind::A2c,
            AlgoConfig::Sac(_) => AlgoKind::Sac,
            AlgoConfig::SacV1(_) => AlgoKind::SacV1,
            AlgoConfig::Td3(_) => AlgoKind::Td3,
            AlgoConfig::Ddpg(_) => AlgoKind::Ddpg,
        }
    }

    /// Checks every field's range (the learner's own `validate`).
    pub fn validate(&self) -> Result<(), RlError> {
        match self {
            AlgoConfig::Ppo(c) => c.validate(),
            AlgoConfig::A2c(c) => c.validate(),
            AlgoConfig::Sac(c) => c.validate(),
            AlgoConfig::SacV1(c) => c.validate(),
            AlgoConfig::Td3(c) => c.validate(),
            AlgoConfig::Ddpg(c) => c.validate(),
        }
    }

    /// The seed of these settings.
    pub fn seed(&self) -> u64 {
        match self {
            AlgoConfig::Ppo(c) => c.seed,
            AlgoConfig::A2c(c) => c.seed,
            AlgoConfig::Sac(c) => c.seed,
            AlgoConfig::SacV1(c) => c.seed,
            AlgoConfig::Td3(c) => c.seed,
            AlgoConfig::Ddpg(c) => c.seed,
        }
    }

    /// The same settings with another seed.
    pub fn with_seed(mut self, seed: u64) -> AlgoConfig {
        match &mut self {
            AlgoConfig::Ppo(c) => c.seed = seed,
            AlgoConfig::A2c(c) => c.seed = seed,
            AlgoConfig::Sac(c) => c.seed = seed,
            AlgoConfig::SacV1(c) => c.seed = seed,
            AlgoConfig::Td3(c) => c.seed = seed,
            AlgoConfig::Ddpg(c) => c.seed = seed,
        }
        self
    }

    /// Sets the learning-rate schedule's horizon to `steps` where the settings leave it to
    /// the first `learn` call (PPO and A2C with `lr_decay_steps` unset), so that training
    /// in chunks anneals as one call to `steps` would; other settings are unchanged.
    pub fn with_default_lr_decay_steps(mut self, steps: u64) -> AlgoConfig {
        match &mut self {
            AlgoConfig::Ppo(c) => {
                c.lr_decay_steps.get_or_insert(steps.max(1));
            }
            AlgoConfig::A2c(c) => {
                c.lr_decay_steps.get_or_insert(steps.max(1));
            }
            AlgoConfig::Sac(_) | AlgoConfig::SacV1(_) | AlgoConfig::Td3(_) | AlgoConfig::Ddpg(_) => {}
        }
        self
    }

    /// A learner for `env` (its spaces and number of environments) with these settings.
    pub fn build(&self, env: &VecEnv) -> Result<Box<dyn Algorithm>, RlError> {
        Ok(match self {
            AlgoConfig::Ppo(c) => Box::new(Ppo::for_env(c.clone(), env)?),
            AlgoConfig::A2c(c) => Box::new(A2c::for_env(c.clone(), env)?),
            AlgoConfig::Sac(c) => Box::new(Sac::for_env(c.clone(), env)?),
            AlgoConfig::SacV1(c) => Box::new(SacV1::for_env(c.clone(), env)?),
            AlgoConfig::Td3(c) => Box::new(Td3::for_env(c.clone(), env)?),
            AlgoConfig::Ddpg(c) => Box::new(Ddpg::for_env(c.clone(), env)?),
        })
    }
}
