//! The crate's error type: bad configuration, incompatible environments, environment
//! failures, unreadable checkpoints, diverged training.

use crate::checkpoint::CheckpointError;
use centaur_gym::EnvError;

/// Why a learner refused to start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum RlError {
    /// A configuration value is out of its valid range.
    #[error("invalid {algo} config: `{field}` = {value}: {reason}")]
    InvalidConfig {
        /// Algorithm name.
        algo: &'static str,
        /// Field name as in the TOML file.
        field: &'static str,
        /// The offending value.
        value: String,
        /// What was expected.
        reason: &'static str,
    },
    /// The environment does not fit the learner (spaces, number of environments).
    #[error("environment does not fit the {algo} learner: {reason}")]
    Incompatible {
        /// Algorithm name.
        algo: &'static str,
        /// What differs.
        reason: String,
    },
    /// A policy used on an environment of other dimensions.
    #[error("a policy for {} observations and {} actions used on an environment with {} and {}", policy.0, policy.1, env.0, env.1)]
    PolicyMismatch {
        /// The policy's observation and action dimensions.
        policy: (usize, usize),
        /// The environment's.
        env: (usize, usize),
    },
    /// The environment refused a call.
    #[error("environment error: {0}")]
    Env(#[from] EnvError),
    /// A checkpoint could not be written or read.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// A loss or parameter became NaN or infinite.
    #[error("{algo} diverged at update {update}: {what} is not finite")]
    Diverged {
        /// Algorithm name.
        algo: &'static str,
        /// Update index.
        update: u64,
        /// What became non-finite.
        what: &'static str,
    },
}

/// `Err(InvalidConfig)` unless `ok`.
pub(crate) fn check(
    ok: bool,
    algo: &'static str,
    field: &'static str,
    value: impl std::fmt::Debug,
    reason: &'static str,
) -> Result<(), RlError> {
    if ok { Ok(()) } else { Err(RlError::InvalidConfig { algo, field, value: format!("{value:?}"), reason }) }
}
