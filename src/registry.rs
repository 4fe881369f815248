//! Environments by name, for the CLI and experiment runners.
//!
//! | name | environment |
//! |---|---|
//! | `pendulum` | Gymnasium's Pendulum-v1 ([`centaur_rl::pendulum::Pendulum`]) |

use centaur_rl::pendulum::Pendulum;
use centaur_rl::{Env, EnvError, VecEnv};

/// Names accepted by [`make_env`].
pub const ENV_NAMES: &[&str] = &["pendulum"];

/// Why an environment could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RegistryError {
    /// No environment has this name.
    #[error("unknown environment `{name}` (available: {})", ENV_NAMES.join(", "))]
    UnknownEnv {
        /// The name asked for.
        name: String,
    },
    /// The environment refused to start.
    #[error("environment `{name}`: {source}")]
    Env {
        /// The environment.
        name: String,
        /// Cause.
        source: EnvError,
    },
}

/// A fresh environment by name.
pub fn make_env(name: &str) -> Result<Box<dyn Env>, RegistryError> {
    match name {
        "pendulum" => Ok(Box::new(Pendulum::new())),
        _ => Err(RegistryError::UnknownEnv { name: name.to_string() }),
    }
}

/// `n` copies of an environment stepped on `threads` threads.
pub fn make_vec_env(name: &str, n: usize, threads: usize) -> Result<VecEnv, RegistryError> {
    let envs = (0..n.max(1)).map(|_| make_env(name)).collect::<Result<Vec<_>, _>>()?;
    VecEnv::new(envs, threads).map_err(|source| RegistryError::Env { name: name.to_string(), source })
}
