//! Environments by name, for the CLI and experiment runners.
//!
//! | name | environment |
//! |---|---|
//! | `pendulum` | Gymnasium's Pendulum-v1 ([`centaur_rl::pendulum::Pendulum`]) |
//! | `minitaur`, `minitaur-fast` | PyBullet's MinitaurBulletEnv-v0 ([`centaur_envs::MinitaurEnv`]; `-fast`: 3.3 ms physics steps) |
//! | `ant`, `ant27` | Gymnasium Ant-v5 (`ant27`: the 27-d observation without contact forces) |
//! | `walker2d`, `hopper`, `halfcheetah`, `humanoid` | Gymnasium Walker2d-, Hopper-, HalfCheetah-, Humanoid-v5 |
//! | `gecko`, `modular-ant`, `spider` | Revolve2's modular robots of those names ([`centaur_envs::ModularEnv`]) |
//! | `modular:FILE.json` | a modular robot described in a JSON file ([`centaur_envs::Body::from_json`]) |
//! | `<robot>-residual` | the hybrid: a residual policy on the controller ([`crate::residual::ResidualEnv`]; minitaur, ant, walker2d, humanoid) |

use centaur_rl::pendulum::Pendulum;
use centaur_rl::{Env, EnvError, VecEnv};

/// Names accepted by [`make_env`].
pub const ENV_NAMES: &[&str] = &[
    "pendulum",
    "minitaur",
    "minitaur-fast",
    "ant",
    "ant27",
    "walker2d",
    "hopper",
    "halfcheetah",
    "humanoid",
    "gecko",
    "modular-ant",
    "spider",
    "minitaur-residual",
    "minitaur-fast-residual",
    "ant-residual",
    "walker2d-residual",
    "humanoid-residual",
];

/// Why an environment could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RegistryError {
    /// No environment has this name.
    #[error("unknown environment `{name}` (available: {}, modular:FILE.json)", ENV_NAMES.join(", "))]
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
    let control = |e: crate::control::ControlError| match e {
        crate::control::ControlError::Env(source) => RegistryError::Env { name: name.to_string(), source },
        other => RegistryError::Env { name: name.to_string(), source: EnvError::Other(other.to_string()) },
    };
    match name {
        "pendulum" => Ok(Box::new(Pendulum::new())),
        _ if name.starts_with("modular:") => Ok(crate::control::make_robot_env(name, None).map_err(control)?),
        _ if !ENV_NAMES.contains(&name) => Err(RegistryError::UnknownEnv { name: name.to_string() }),
        _ => match name.strip_suffix("-residual") {
            Some(robot) => {
                let config = crate::residual::ResidualConfig::for_env(robot);
                Ok(Box::new(crate::residual::ResidualEnv::for_env(robot, config).map_err(control)?))
            }
            None => Ok(crate::control::make_robot_env(name, None).map_err(control)?),
        },
    }
}

/// `n` copies of an environment stepped on `threads` threads.
pub fn make_vec_env(name: &str, n: usize, threads: usize) -> Result<VecEnv, RegistryError> {
    let envs = (0..n.max(1)).map(|_| make_env(name)).collect::<Result<Vec<_>, _>>()?;
    VecEnv::new(envs, threads).map_err(|source| RegistryError::Env { name: name.to_string(), source })
}
