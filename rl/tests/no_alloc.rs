//! Training loops allocate nothing once warmed up, and deployment allocates nothing per
//! action: a counting global allocator (counting this thread's allocations) proves it.
//!
//! `learn` may allocate a constant amount when it starts (e.g. a copy of the VecEnv's
//! current observations); the number of allocations must not grow with the number of
//! updates.

use std::ops::ControlFlow;

use centaur_gym::pendulum::Pendulum;
use centaur_gym::{Env, Rng, VecEnv};
use centaur_rl::nn::{Activation, Init, Mlp};
use centaur_rl::*;
use centaur_test_support::{CountingAllocator, allocations};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn pendulums(n: usize) -> VecEnv {
    VecEnv::new((0..n).map(|_| Box::new(Pendulum::new()) as Box<dyn Env>).collect(), 1).unwrap()
}

/// Allocations of `learn` for `short` and for `long` more steps, after a warm-up.
fn learn_allocations(
    algo: &mut dyn Algorithm,
    env: &mut VecEnv,
    warmup: u64,
    short: u64,
    long: u64,
) -> (usize, usize) {
    let mut cb = |_: &UpdateMetrics| ControlFlow::Continue(());
    algo.learn(env, warmup, &mut cb).unwrap();
    let s = allocations(|| algo.learn(env, warmup + short, &mut cb).unwrap());
    let l = allocations(|| algo.learn(env, warmup + short + long, &mut cb).unwrap());
    (s, l)
}

#[test]
fn update_loops_do_not_allocate() {
    let h = || vec![32, 32];
    let mut env = pendulums(2);
    let mut ppo = Ppo::for_env(
        PpoConfig { n_steps: 64, actor_hidden: h(), critic_hidden: h(), ..PpoConfig::default() },
        &env,
    )
    .unwrap();
    let (s, l) = learn_allocations(&mut ppo, &mut env, 256, 128, 1280);
    assert_eq!(s, l, "ppo: {s} allocations for 1 update, {l} for 10");
    assert!(s <= 2, "ppo: {s} allocations at learn start");

    let mut env = pendulums(2);
    let mut a2c =
        A2c::for_env(A2cConfig { norm_obs: true, norm_reward: true, ..A2cConfig::default() }, &env).unwrap();
    let (s, l) = learn_allocations(&mut a2c, &mut env, 100, 100, 1000);
    assert_eq!(s, l, "a2c");

    let mut env = pendulums(2);
    let c = SacConfig {
        batch_size: 64,
        learning_starts: 50,
        log_interval: 50,
        actor_hidden: h(),
        critic_hidden: h(),
        ..SacConfig::default()
    };
    let mut sac = Sac::for_env(c, &env).unwrap();
    let (s, l) = learn_allocations(&mut sac, &mut env, 200, 100, 1000);
    assert_eq!((s, l), (0, 0), "sac");

    let mut env = pendulums(1);
    let c = SacV1Config {
        batch_size: 64,
        learning_starts: 50,
        actor_hidden: h(),
        critic_hidden: h(),
        ..SacV1Config::default()
    };
    let mut sac1 = SacV1::for_env(c, &env).unwrap();
    let (s, l) = learn_allocations(&mut sac1, &mut env, 200, 100, 1000);
    assert_eq!((s, l), (0, 0), "sac1");

    let mut env = pendulums(1);
    let c = Td3Config {
        batch_size: 64,
        learning_starts: 50,
        actor_hidden: h(),
        critic_hidden: h(),
        ..Td3Config::default()
    };
    let mut td3 = Td3::for_env(c, &env).unwrap();
    let (s, l) = learn_allocations(&mut td3, &mut env, 200, 100, 1000);
    assert_eq!((s, l), (0, 0), "td3");

    let mut env = pendulums(1);
    let c = DdpgConfig {
        batch_size: 64,
        learning_starts: 50,
        noise: centaur_rl::ddpg::NoiseKind::OrnsteinUhlenbeck,
        actor_hidden: h(),
        critic_hidden: h(),
        ..DdpgConfig::default()
    };
    let mut ddpg = Ddpg::for_env(c, &env).unwrap();
    let (s, l) = learn_allocations(&mut ddpg, &mut env, 200, 100, 1000);
    assert_eq!((s, l), (0, 0), "ddpg");
}

#[test]
fn acting_and_network_passes_do_not_allocate() {
    let env = pendulums(1);
    let algo = Ppo::for_env(PpoConfig::default(), &env).unwrap();
    let mut policy = algo.policy();
    let mut out = [0.0f32];
    let n = allocations(|| {
        for k in 0..100 {
            policy.act(&[1.0, 0.0, k as f32 * 0.01], &mut out);
        }
    });
    assert_eq!(n, 0);

    let mut rng = Rng::seed_from_u64(0);
    let mut net = Mlp::new(&[17, 256, 256, 12], Activation::Tanh, Init::TorchDefault, &mut rng);
    let mut buf = net.buffers(64);
    let x = vec![0.5f32; 17 * 64];
    let dy = vec![0.1f32; 12 * 64];
    let mut dx = vec![0.0f32; 17 * 64];
    // The first products of a thread may allocate gemm's packing buffers (thread-local,
    // kept): warm up once.
    net.forward(&mut buf, &x, 64);
    net.backward(&mut buf, &x, &dy, 64, Some(&mut dx));
    let n = allocations(|| {
        net.forward(&mut buf, &x, 64);
        net.backward(&mut buf, &x, &dy, 64, Some(&mut dx));
        net.input_grad(&mut buf, &dy, 64, &mut dx);
    });
    assert_eq!(n, 0);
}
