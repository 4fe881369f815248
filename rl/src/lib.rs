//! # centaur-rl
//!
//! Reinforcement learning for continuous control on the environment API of `centaur-gym`
//! ([`centaur_gym::Env`], [`centaur_gym::VecEnv`]): small neural networks with analytic
//! gradients, and six learners — [`Ppo`], [`A2c`], [`Sac`] (v2), [`SacV1`], [`Td3`], [`Ddpg`] — one file per
//! algorithm, each readable top to bottom like CleanRL. The four replay-buffer learners
//! share one collection loop (warm-up, replay, logging; `off_policy.rs`) and differ in
//! their exploration and gradient step.
//!
//! ## The problem
//!
//! An agent maximises the expected discounted return `E[Σ_t γᵗ r_t]` of a Markov decision
//! process with observations `s ∈ ℝⁿ` and actions `a ∈ [low, high] ⊂ ℝᵐ`, where an episode
//! ends either by **termination** (a terminal state: no value after it) or by
//! **truncation** (a time limit: the state still has a value, and targets bootstrap from
//! the final observation) — Gymnasium's semantics, kept separate everywhere
//! ([`centaur_gym::Step`], [`centaur_gym::VecStep::final_obs`], [`buffer::StepEnd`],
//! [`buffer::ReplayBuffer`]).
//!
//! ## Pieces
//!
//! | module | content |
//! |---|---|
//! | [`nn`] | [`nn::Mlp`]: batched forward/backward on faer (`Par::Seq`), fast tanh, orthogonal init |
//! | [`optim`] | Adam, RMSprop, global gradient clipping, linear decay |
//! | [`distributions`] | diagonal Gaussian, tanh-squashed Gaussian (stable log-det), tanh head |
//! | [`buffer`] | GAE(λ), n-step returns, rollout buffer, circular replay buffer |
//! | [`normalizer`] | running mean/variance (Chan et al. merge), observation normalisation, reward scaling |
//! | [`ppo`], [`a2c`], [`sac`], [`sac_v1`], [`td3`], [`ddpg`] | the learners and their typed configs |
//! | [`algorithm`] | the [`Algorithm`] trait all learners implement |
//! | [`learners`] | [`AlgoKind`] by name, [`AlgoConfig`] (typed settings with presets), [`learners::load`] from a checkpoint |
//! | [`checkpoint`] | versioned, checksummed, atomically written checkpoint files |
//! | [`policy`] | [`Policy`]: deployment without training code; [`evaluate`] |
//! | [`metrics`] | [`UpdateMetrics`] per update and its CSV form |
//!
//! ## Conventions
//!
//! * Observations and actions are `f32` (networks compute in `f32`); rewards and returns
//!   are `f64` in the env API. A batch of vectors is stored sample after sample
//!   (`batch × dim`, i.e. a column-major `dim × batch` matrix).
//! * On-policy learners (PPO, A2C) sample from a Gaussian in the env's units and clip to
//!   the bounds; off-policy learners (SAC, TD3, DDPG) act in `[−1, 1]^m`, rescaled to the
//!   bounds (they require a bounded action space).
//! * Every random choice — initialisation, exploration, minibatches, env resets — flows
//!   from the config's `seed`: the same seed and thread count give the same learning curve
//!   bit for bit, and a checkpoint resumes it exactly (`tests/reproducibility.rs`).
//! * Training loops allocate nothing after warm-up (`tests/no_alloc.rs`).
//!
//! ## Not supported
//!
//! Discrete or dictionary action/observation spaces; image observations; recurrent
//! policies; gSDE; a shared actor–critic trunk (PPO always uses separate networks);
//! learning on a GPU.
//!
//! ## Example
//!
//! ```
//! use std::ops::ControlFlow;
//! use centaur_gym::pendulum::Pendulum;
//! use centaur_gym::{Env, VecEnv};
//! use centaur_rl::{Algorithm, Policy, Ppo, PpoConfig, evaluate};
//!
//! let envs: Vec<Box<dyn Env>> = (0..2).map(|_| Box::new(Pendulum::new()) as Box<dyn Env>).collect();
//! let mut venv = VecEnv::new(envs, 1)?;
//! let config = PpoConfig { n_steps: 256, actor_hidden: vec![32, 32], critic_hidden: vec![32, 32], ..PpoConfig::default() };
//! let mut ppo = Ppo::for_env(config, &venv)?;
//! ppo.learn(&mut venv, 1024, &mut |m| {
//!     println!("{} steps: return {:.1}", m.env_steps, m.episode_return_mean);
//!     ControlFlow::Continue(())
//! })?;
//! let path = std::env::temp_dir().join("centaur-doc-ppo.ckpt");
//! ppo.save(&path)?;
//! let mut policy = Policy::load(&path)?; // what a robot would run
//! let mut action = [0.0f32];
//! policy.act(&[1.0, 0.0, 0.0], &mut action);
//! let eval = evaluate(&mut policy, &mut Pendulum::new(), 10, 0)?;
//! assert!(eval.mean.is_finite());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod a2c;
pub mod algorithm;
pub mod buffer;
pub mod checkpoint;
pub mod ddpg;
pub mod distributions;
pub mod error;
pub mod learners;
pub mod metrics;
pub mod nn;
pub mod normalizer;
mod off_policy;
mod on_policy;
pub mod optim;
pub mod policy;
pub mod ppo;
pub mod sac;
pub mod sac_v1;
pub mod td3;

pub use a2c::{A2c, A2cConfig};
pub use algorithm::{Algorithm, ExplorationFloor};
pub use checkpoint::{Checkpoint, CheckpointError};
pub use ddpg::{Ddpg, DdpgConfig};
pub use error::RlError;
pub use learners::{AlgoConfig, AlgoKind};
pub use metrics::{MetricsCsv, UpdateMetrics};
pub use policy::{EvalStats, Policy, PolicyHead, evaluate};
pub use ppo::{Ppo, PpoConfig};
pub use sac::{Sac, SacConfig};
pub use sac_v1::{SacV1, SacV1Config};
pub use td3::{Td3, Td3Config};
