//! # centaur-rl
//!
//! Reinforcement learning for continuous control: the [`Env`] / [`VecEnv`] API shared by
//! every environment, and (issue 4) small neural networks with analytic gradients and
//! PPO, A2C, SAC (v1 and v2), TD3 and DDPG, one file per algorithm.

pub mod buffer;
pub mod distributions;
pub mod env;
pub mod nn;
pub mod normalizer;
pub mod optim;
pub mod pendulum;
pub mod rng;

pub use env::{BoxSpace, Env, EnvError, EpisodeRecord, MAX_REWARD_TERMS, Step, StepInfo, VecEnv, VecStep};
pub use rng::{Rng, RngState};
