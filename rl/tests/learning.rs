//! Learning tests on Gymnasium's Pendulum-v1 (`centaur_gym::pendulum`), fixed seeds,
//! mean return of 10 deterministic evaluation episodes (seeds 1000–1009).
//!
//! Run by `cargo test --release` (about a minute on 2 cores): the thresholds within
//! the budgets — SAC v2 and TD3 ≥ −250 in 20k steps, DDPG and SAC v1 ≥ −300 in
//! 20k, PPO ≥ −400 in 200k, A2C ≥ −600 in 500k — with the off-policy networks narrowed to
//! [64, 64] to keep CI short.
//!
//! `#[ignore]`d (run with `cargo test --release -p centaur-rl --test learning -- --ignored`):
//! the same budgets with each algorithm's default networks ([256, 256] SAC, [400, 300]
//! TD3/DDPG; several minutes each on this machine).

use std::ops::ControlFlow;

use centaur_gym::pendulum::Pendulum;
use centaur_gym::{Env, VecEnv};
use centaur_rl::*;

fn pendulums(n: usize) -> VecEnv {
    VecEnv::new((0..n).map(|_| Box::new(Pendulum::new()) as Box<dyn Env>).collect(), 1).unwrap()
}

/// Trains for `steps`, evaluates 10 deterministic episodes, returns the mean return.
fn train_and_evaluate(algo: &mut dyn Algorithm, env: &mut VecEnv, steps: u64) -> f64 {
    let t = std::time::Instant::now();
    algo.learn(env, steps, &mut |_| ControlFlow::Continue(())).unwrap();
    let mut policy = algo.policy();
    let eval = evaluate(&mut policy, &mut Pendulum::new(), 10, 1000).unwrap();
    eprintln!(
        "{}: {} steps, eval return {:.1} ± {:.1}, {:.1} s",
        algo.name(),
        algo.steps_done(),
        eval.mean,
        eval.std,
        t.elapsed().as_secs_f64()
    );
    eval.mean
}

#[test]
fn sac_reaches_minus_250_in_20k_steps() {
    let mut env = pendulums(1);
    let cfg = SacConfig { actor_hidden: vec![64, 64], critic_hidden: vec![64, 64], ..SacConfig::default() };
    let mut algo = Sac::for_env(cfg, &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 20_000) >= -250.0);
}

#[test]
fn td3_reaches_minus_250_in_20k_steps() {
    let mut env = pendulums(1);
    let cfg = Td3Config { actor_hidden: vec![64, 64], critic_hidden: vec![64, 64], ..Td3Config::default() };
    let mut algo = Td3::for_env(cfg, &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 20_000) >= -250.0);
}

#[test]
fn ddpg_reaches_minus_300_in_20k_steps() {
    let mut env = pendulums(1);
    let cfg = DdpgConfig { actor_hidden: vec![64, 64], critic_hidden: vec![64, 64], ..DdpgConfig::default() };
    let mut algo = Ddpg::for_env(cfg, &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 20_000) >= -300.0);
}

#[test]
fn sac_v1_reaches_minus_300_in_20k_steps() {
    let mut env = pendulums(1);
    let cfg =
        SacV1Config { actor_hidden: vec![64, 64], critic_hidden: vec![64, 64], ..SacV1Config::default() };
    let mut algo = SacV1::for_env(cfg, &env).unwrap();
    // Its V network's mean estimate is logged as `value_mean` once updates run.
    let mut values = Vec::new();
    algo.learn(&mut env, 2_000, &mut |m| {
        values.push(m.value_mean);
        ControlFlow::Continue(())
    })
    .unwrap();
    assert!(values.last().is_some_and(|v| v.is_finite()), "{values:?}");
    assert!(train_and_evaluate(&mut algo, &mut env, 20_000) >= -300.0);
}

/// CleanRL's continuous-control defaults, one environment.
#[test]
fn ppo_reaches_minus_400_in_200k_steps() {
    let mut env = pendulums(1);
    let mut algo = Ppo::for_env(PpoConfig::default(), &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 200_000) >= -400.0);
}

/// SB3's A2C defaults do not learn Pendulum (−1472 here after 500k steps with 8 envs, as
/// in SB3 itself: RL Zoo tunes it). The RL Zoo's Pendulum settings minus gSDE: 8 envs,
/// 8 steps, γ = 0.9, normalised observations and rewards.
#[test]
fn a2c_reaches_minus_600_in_500k_steps() {
    let mut env = pendulums(8);
    let cfg = A2cConfig { n_steps: 8, gamma: 0.9, norm_obs: true, norm_reward: true, ..A2cConfig::default() };
    let mut algo = A2c::for_env(cfg, &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 500_000) >= -600.0);
}

#[test]
#[ignore = "several minutes: default [256, 256] networks"]
fn sac_default_networks_reach_minus_250_in_20k_steps() {
    let mut env = pendulums(1);
    let mut algo = Sac::for_env(SacConfig::default(), &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 20_000) >= -250.0);
}

#[test]
#[ignore = "several minutes: default [400, 300] networks"]
fn td3_default_networks_reach_minus_250_in_20k_steps() {
    let mut env = pendulums(1);
    let mut algo = Td3::for_env(Td3Config::default(), &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 20_000) >= -250.0);
}

#[test]
#[ignore = "several minutes: default [400, 300] networks"]
fn ddpg_default_networks_reach_minus_300_in_20k_steps() {
    let mut env = pendulums(1);
    let mut algo = Ddpg::for_env(DdpgConfig::default(), &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 20_000) >= -300.0);
}

#[test]
#[ignore = "several minutes: default [256, 256] networks"]
fn sac_v1_default_networks_reach_minus_300_in_20k_steps() {
    let mut env = pendulums(1);
    let mut algo = SacV1::for_env(SacV1Config::default(), &env).unwrap();
    assert!(train_and_evaluate(&mut algo, &mut env, 20_000) >= -300.0);
}
