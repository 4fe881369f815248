//! # centaur-gym
//!
//! The environment API every Centaur environment implements and every learner trains
//! on, with no learner and no simulator in it (Gymnasium apart from Stable-Baselines3):
//!
//! | item | file | what |
//! |---|---|---|
//! | [`Env`], [`Step`], [`StepInfo`], [`EnvError`] | `env.rs` | one environment, Gymnasium's `reset`/`step` with `terminated` and `truncated` kept apart |
//! | [`VecEnv`], [`VecStep`], [`EpisodeRecord`] | `vec_env.rs` | `n` environments stepped in parallel with auto-reset; results independent of the thread count |
//! | [`BoxSpace`] | `space.rs` | Gymnasium's `Box` of `f32` vectors |
//! | [`Rng`], [`RngState`] | `rng.rs` | xoshiro256++, seedable, with a saveable state |
//! | [`pendulum::Pendulum`] | `pendulum.rs` | Gymnasium's Pendulum-v1, for tests and examples |
//!
//! ## Semantics
//!
//! An episode ends either by **termination** (a terminal state: no value after it) or by
//! **truncation** (a time limit: the state still has a value, and value targets bootstrap
//! from the final observation). [`Env::step`] writes the final observation when an episode
//! ends; [`VecEnv::step`] resets finished environments itself and keeps their final
//! observations in [`VecStep::final_obs`]. Actions of the wrong length or with NaN are
//! refused with an [`EnvError`] and change nothing; an environment's own failures (a robot
//! file, a simulator) travel as [`EnvError::Env`] with their type as the source.
//!
//! ## Example
//!
//! ```
//! use centaur_gym::pendulum::Pendulum;
//! use centaur_gym::{Env, VecEnv};
//!
//! let envs: Vec<Box<dyn Env>> = (0..4).map(|_| Box::new(Pendulum::new()) as Box<dyn Env>).collect();
//! let mut venv = VecEnv::new(envs, 2)?;
//! let mut obs = vec![0.0f32; 4 * venv.observation_space().dim()];
//! venv.reset(0, &mut obs)?;
//! let mut out = venv.make_step_buffers();
//! venv.step(&[0.5f32; 4], &mut out)?;
//! assert!(out.rewards.iter().all(|r| r.is_finite()));
//! # Ok::<(), centaur_gym::EnvError>(())
//! ```

mod env;
pub mod pendulum;
mod rng;
mod space;
mod vec_env;

pub use env::{Env, EnvError, MAX_REWARD_TERMS, Step, StepInfo, check_action, check_observation};
pub use rng::{Rng, RngState};
pub use space::BoxSpace;
pub use vec_env::{EpisodeLog, EpisodeRecord, VecEnv, VecStep};
