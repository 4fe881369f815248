//! # centaur-rl
//!
//! Reinforcement learning for continuous control: the `Env` / `VecEnv` API, small neural
//! networks with analytic gradients, and PPO, A2C, SAC (v1 and v2), TD3 and DDPG, one file
//! per algorithm.
//!
//! Status: not yet implemented (issue 4). This crate holds only its documentation so far.
