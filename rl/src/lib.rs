//! # centaur-rl
//!
//! Reinforcement learning for continuous control: the [`Env`] / [`VecEnv`] API shared by
//! every environment, and (issue 4) small neural networks with analytic gradients and
//! PPO, A2C, SAC (v1 and v2), TD3 and DDPG, one file per algorithm.

pub mod a2c;
pub mod algorithm;
pub mod buffer;
pub mod checkpoint;
pub mod ddpg;
pub mod distributions;
pub mod env;
pub mod error;
pub mod metrics;
pub mod nn;
pub mod normalizer;
pub mod optim;
pub mod pendulum;
pub mod policy;
pub mod ppo;
pub mod rng;
pub mod sac;
pub mod sac_v1;
pub mod td3;

pub use a2c::{A2c, A2cConfig};
pub use algorithm::{AlgoKind, Algorithm};
pub use checkpoint::{Checkpoint, CheckpointError};
pub use ddpg::{Ddpg, DdpgConfig};
pub use env::{BoxSpace, Env, EnvError, EpisodeRecord, MAX_REWARD_TERMS, Step, StepInfo, VecEnv, VecStep};
pub use error::RlError;
pub use metrics::{MetricsCsv, UpdateMetrics};
pub use policy::{EvalStats, Policy, PolicyHead, evaluate};
pub use ppo::{Ppo, PpoConfig};
pub use rng::{Rng, RngState};
pub use sac::{Sac, SacConfig};
pub use sac_v1::{SacV1, SacV1Config};
pub use td3::{Td3, Td3Config};
