//! Seeds control everything, checkpoints resume the same learning curve, and a saved
//! policy acts exactly as before saving.

use std::ops::ControlFlow;
use std::path::PathBuf;

use centaur_gym::pendulum::Pendulum;
use centaur_gym::{Env, Rng, VecEnv};
use centaur_rl::*;

fn pendulums(n: usize, threads: usize) -> VecEnv {
    VecEnv::new((0..n).map(|_| Box::new(Pendulum::new()) as Box<dyn Env>).collect(), threads).unwrap()
}

type MakeLearner = dyn Fn(&VecEnv) -> Box<dyn Algorithm>;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("centaur-rl-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Trains to `total` steps, returning the metrics' deterministic bits.
fn learn(algo: &mut dyn Algorithm, env: &mut VecEnv, total: u64) -> Vec<Vec<u64>> {
    let mut curve = Vec::new();
    algo.learn(env, total, &mut |m| {
        curve.push(m.deterministic_bits());
        ControlFlow::Continue(())
    })
    .unwrap();
    curve
}

/// Every parameter and optimiser blob of a learner's checkpoint (everything but timings).
fn state_bits(algo: &dyn Algorithm) -> Vec<u8> {
    let mut c = algo.to_checkpoint();
    c.set_meta("wall_time", 0.0);
    c.to_bytes()
}

fn small_ppo() -> PpoConfig {
    PpoConfig {
        seed: 5,
        n_steps: 64,
        batch_size: 32,
        n_epochs: 2,
        lr_decay_steps: Some(1024),
        actor_hidden: vec![16, 16],
        critic_hidden: vec![16, 16],
        ..PpoConfig::default()
    }
}

fn small_sac() -> SacConfig {
    SacConfig {
        seed: 5,
        batch_size: 32,
        buffer_size: 5000,
        learning_starts: 100,
        log_interval: 100,
        actor_hidden: vec![16, 16],
        critic_hidden: vec![16, 16],
        ..SacConfig::default()
    }
}

#[test]
fn ppo_same_seed_same_curve_bit_for_bit() {
    let run = |threads| {
        let mut env = pendulums(2, threads);
        let mut algo = Ppo::for_env(small_ppo(), &env).unwrap();
        let curve = learn(&mut algo, &mut env, 1024);
        (curve, state_bits(&algo))
    };
    let a = run(2);
    assert_eq!(a.0.len(), 8);
    assert_eq!(a, run(2));
    // The learner is single-threaded and VecEnv is thread-count independent.
    assert_eq!(a, run(1));
    let mut other = small_ppo();
    other.seed = 6;
    let mut env = pendulums(2, 1);
    let mut algo = Ppo::for_env(other, &env).unwrap();
    assert_ne!(learn(&mut algo, &mut env, 1024), a.0);
}

#[test]
fn sac_same_seed_same_curve_bit_for_bit() {
    let run = |threads| {
        let mut env = pendulums(2, threads);
        let mut algo = Sac::for_env(small_sac(), &env).unwrap();
        let curve = learn(&mut algo, &mut env, 1200);
        (curve, state_bits(&algo))
    };
    let a = run(2);
    assert_eq!(a.0.len(), 12);
    assert_eq!(a, run(2));
}

/// train(N) → save → load → train(M) equals train(N + M), at an update boundary, on the
/// same (live) VecEnv.
fn resume_equals_uninterrupted(
    make: &dyn Fn(&VecEnv) -> Box<dyn Algorithm>,
    n_envs: usize,
    n: u64,
    total: u64,
) {
    let mut env_a = pendulums(n_envs, 1);
    let mut a = make(&env_a);
    let curve_a = learn(a.as_mut(), &mut env_a, total);

    let mut env_b = pendulums(n_envs, 1);
    let mut b = make(&env_b);
    let mut curve_b = learn(b.as_mut(), &mut env_b, n);
    let path = tmp(&format!("{}-resume.ckpt", b.name()));
    b.save(&path).unwrap();
    drop(b);
    let mut b = centaur_rl::learners::load(&path).unwrap();
    assert_eq!(b.steps_done(), n);
    curve_b.extend(learn(b.as_mut(), &mut env_b, total));
    if let Some(i) = (0..curve_a.len().min(curve_b.len())).find(|&i| curve_a[i] != curve_b[i]) {
        panic!(
            "{}: learning curves differ after resume at record {i} of {} / {}: {:?} vs {:?}",
            a.name(),
            curve_a.len(),
            curve_b.len(),
            curve_a[i].iter().map(|b| f64::from_bits(*b)).collect::<Vec<_>>(),
            curve_b[i].iter().map(|b| f64::from_bits(*b)).collect::<Vec<_>>()
        );
    }
    assert_eq!(curve_a.len(), curve_b.len(), "{}: numbers of records differ after resume", a.name());
    assert_eq!(state_bits(a.as_ref()), state_bits(b.as_ref()), "{}: states differ after resume", a.name());
}

#[test]
fn resumed_training_continues_the_same_learning_curve() {
    resume_equals_uninterrupted(&|e| Box::new(Ppo::for_env(small_ppo(), e).unwrap()), 2, 512, 1024);
    // The adaptive KL coefficient is state too.
    let kl = PpoConfig { kl_penalty: true, clip_policy: false, kl_target: 1e-3, ..small_ppo() };
    resume_equals_uninterrupted(&|e| Box::new(Ppo::for_env(kl.clone(), e).unwrap()), 2, 512, 1024);
    let shared = PpoConfig { separate_networks: false, ..small_ppo() };
    resume_equals_uninterrupted(&|e| Box::new(Ppo::for_env(shared.clone(), e).unwrap()), 2, 512, 1024);
    resume_equals_uninterrupted(&|e| Box::new(Sac::for_env(small_sac(), e).unwrap()), 2, 600, 1200);
    let a2c = A2cConfig {
        seed: 3,
        norm_obs: true,
        norm_reward: true,
        log_interval: 10,
        // The schedule horizon is part of the state (unset, the first `learn` call's
        // total would be used: 500 here, 1000 uninterrupted).
        lr_decay_steps: Some(1000),
        actor_hidden: vec![16],
        critic_hidden: vec![16],
        ..A2cConfig::default()
    };
    resume_equals_uninterrupted(&|e| Box::new(A2c::for_env(a2c.clone(), e).unwrap()), 2, 500, 1000);
    let small = |h: usize| vec![h, h];
    // An odd number of gradient steps before the save (the delayed actor update's phase is
    // state too); a record every step so that the split falls on a record boundary.
    let td3 = Td3Config {
        seed: 3,
        batch_size: 32,
        buffer_size: 4000,
        log_interval: 1,
        actor_hidden: small(16),
        critic_hidden: small(16),
        ..Td3Config::default()
    };
    resume_equals_uninterrupted(&|e| Box::new(Td3::for_env(td3.clone(), e).unwrap()), 1, 501, 900);
    let ddpg = DdpgConfig {
        seed: 3,
        batch_size: 32,
        buffer_size: 4000,
        log_interval: 100,
        noise: centaur_rl::ddpg::NoiseKind::OrnsteinUhlenbeck,
        actor_hidden: small(16),
        critic_hidden: small(16),
        ..DdpgConfig::default()
    };
    resume_equals_uninterrupted(&|e| Box::new(Ddpg::for_env(ddpg.clone(), e).unwrap()), 1, 500, 900);
    let sac1 = SacV1Config {
        seed: 3,
        batch_size: 32,
        buffer_size: 4000,
        log_interval: 100,
        actor_hidden: small(16),
        critic_hidden: small(16),
        ..SacV1Config::default()
    };
    resume_equals_uninterrupted(&|e| Box::new(SacV1::for_env(sac1.clone(), e).unwrap()), 1, 500, 900);
}

#[test]
fn loaded_policy_acts_exactly_as_before_saving() {
    let small = || vec![16, 16];
    let learners: Vec<Box<MakeLearner>> = vec![
        Box::new(|e| Box::new(Ppo::for_env(small_ppo(), e).unwrap())),
        Box::new(|e| {
            Box::new(A2c::for_env(A2cConfig { norm_obs: true, ..A2cConfig::default() }, e).unwrap())
        }),
        Box::new(|e| Box::new(Sac::for_env(small_sac(), e).unwrap())),
        Box::new(move |e| {
            Box::new(
                SacV1::for_env(
                    SacV1Config {
                        batch_size: 32,
                        actor_hidden: small(),
                        critic_hidden: small(),
                        ..SacV1Config::default()
                    },
                    e,
                )
                .unwrap(),
            )
        }),
        Box::new(move |e| {
            Box::new(
                Td3::for_env(
                    Td3Config {
                        batch_size: 32,
                        actor_hidden: small(),
                        critic_hidden: small(),
                        ..Td3Config::default()
                    },
                    e,
                )
                .unwrap(),
            )
        }),
        Box::new(move |e| {
            Box::new(
                Ddpg::for_env(
                    DdpgConfig {
                        batch_size: 32,
                        actor_hidden: small(),
                        critic_hidden: small(),
                        ..DdpgConfig::default()
                    },
                    e,
                )
                .unwrap(),
            )
        }),
    ];
    let mut rng = Rng::seed_from_u64(11);
    for make in learners {
        let mut env = pendulums(2, 1);
        let mut algo = make(&env);
        algo.learn(&mut env, 600, &mut |_| ControlFlow::Continue(())).unwrap();
        let path = tmp(&format!("{}-policy.ckpt", algo.name()));
        algo.save(&path).unwrap();
        let mut before = algo.policy();
        let mut after = Policy::load(&path).unwrap();
        let (mut a, mut b) = ([0.0f32], [0.0f32]);
        for _ in 0..50 {
            let th = rng.range(-4.0, 4.0);
            let obs = [th.cos() as f32, th.sin() as f32, rng.range(-8.0, 8.0) as f32];
            before.act(&obs, &mut a);
            after.act(&obs, &mut b);
            assert_eq!(a[0].to_bits(), b[0].to_bits(), "{}", algo.name());
            assert!((-2.0..=2.0).contains(&a[0]), "{}: action {} outside the bounds", algo.name(), a[0]);
        }
        let eval_a = evaluate(&mut before, &mut Pendulum::new(), 2, 7).unwrap();
        let eval_b = evaluate(&mut after, &mut Pendulum::new(), 2, 7).unwrap();
        assert_eq!(eval_a, eval_b);
    }
}

#[test]
fn bad_files_and_configs_are_typed_errors() {
    // Corrupt checkpoint.
    let env = pendulums(1, 1);
    let algo = Ppo::for_env(small_ppo(), &env).unwrap();
    let path = tmp("corrupt.ckpt");
    algo.save(&path).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let k = bytes.len() - 100;
    bytes[k] ^= 1;
    std::fs::write(&path, &bytes).unwrap();
    assert!(matches!(Policy::load(&path), Err(CheckpointError::Checksum { .. })));
    assert!(matches!(
        centaur_rl::learners::load(&path),
        Err(RlError::Checkpoint(CheckpointError::Checksum { .. }))
    ));
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    assert!(matches!(Ppo::load(&path), Err(RlError::Checkpoint(CheckpointError::Truncated { .. }))));
    // A SAC checkpoint is not a PPO one.
    let sac = Sac::for_env(small_sac(), &env).unwrap();
    sac.save(&path).unwrap();
    assert!(matches!(Ppo::load(&path), Err(RlError::Checkpoint(CheckpointError::WrongAlgorithm { .. }))));
    // Out-of-range configuration values name their field.
    let bad = PpoConfig { gamma: 1.5, ..PpoConfig::default() };
    match Ppo::for_env(bad, &env) {
        Err(RlError::InvalidConfig { field: "gamma", .. }) => {}
        other => panic!("expected InvalidConfig(gamma), got {:?}", other.err()),
    }
    let bad = SacConfig { batch_size: 0, ..SacConfig::default() };
    assert!(matches!(Sac::for_env(bad, &env), Err(RlError::InvalidConfig { field: "batch_size", .. })));
    // Regression (reliability probe, panics and aborts): sizes whose products overflow or
    // would allocate without bound are refused, naming the field, before allocating.
    let field = |r: Result<Box<dyn Algorithm>, RlError>| match r {
        Err(RlError::InvalidConfig { field, .. }) => field,
        Err(other) => panic!("expected InvalidConfig, got {other}"),
        Ok(_) => panic!("an absurd size was accepted"),
    };
    let four = pendulums(4, 1);
    let huge = 4_611_686_018_427_387_904;
    let ppo = |c: PpoConfig| field(AlgoConfig::Ppo(c).build(&four));
    assert_eq!(ppo(PpoConfig { n_steps: huge, ..small_ppo() }), "n_steps");
    assert_eq!(ppo(PpoConfig { actor_hidden: vec![100_000, 100_000], ..small_ppo() }), "actor_hidden");
    assert_eq!(ppo(PpoConfig { batch_size: 6_148_914_691_236_517_206, ..small_ppo() }), "batch_size");
    let a2c = A2cConfig { n_steps: 1 << 40, ..A2cConfig::default() };
    assert_eq!(field(AlgoConfig::A2c(a2c).build(&four)), "n_steps");
    let sac = SacConfig { buffer_size: 1_000_000_000_000, ..small_sac() };
    assert_eq!(field(AlgoConfig::Sac(sac).build(&env)), "buffer_size");
    let sac = SacConfig { batch_size: 6_148_914_691_236_517_206, ..small_sac() };
    assert_eq!(field(AlgoConfig::Sac(sac).build(&env)), "batch_size");
    for kind in [AlgoKind::SacV1, AlgoKind::Td3, AlgoKind::Ddpg] {
        let mut config = AlgoConfig::default_for(kind);
        match &mut config {
            AlgoConfig::SacV1(c) => c.critic_hidden = vec![1 << 20, 1 << 20],
            AlgoConfig::Td3(c) => c.critic_hidden = vec![1 << 20, 1 << 20],
            AlgoConfig::Ddpg(c) => c.critic_hidden = vec![1 << 20, 1 << 20],
            _ => unreachable!(),
        }
        assert_eq!(field(config.build(&env)), "critic_hidden", "{}", kind.name());
    }
    // Regression (reliability probe, silent acceptance): finite but absurd scales that make
    // a run meaningless are refused by name, and no message shows Rust's `Some(…)`.
    assert_eq!(ppo(PpoConfig { ent_coef: 1e30, ..small_ppo() }), "ent_coef");
    assert_eq!(ppo(PpoConfig { max_grad_norm: 1e-300, ..small_ppo() }), "max_grad_norm");
    assert_eq!(ppo(PpoConfig { clip_reward: 1e-300, ..small_ppo() }), "clip_reward");
    assert_eq!(ppo(PpoConfig { vf_coef: 1e9, ..small_ppo() }), "vf_coef");
    let a2c = A2cConfig { clip_obs: 1e-300, ..A2cConfig::default() };
    assert_eq!(field(AlgoConfig::A2c(a2c).build(&four)), "clip_obs");
    let td3 = |c: Td3Config| field(AlgoConfig::Td3(c).build(&env));
    assert_eq!(td3(Td3Config { exploration_noise: 1e300, ..Td3Config::default() }), "exploration_noise");
    assert_eq!(td3(Td3Config { target_policy_noise: 1e300, ..Td3Config::default() }), "target_policy_noise");
    let ddpg = |c: DdpgConfig| field(AlgoConfig::Ddpg(c).build(&env));
    assert_eq!(ddpg(DdpgConfig { exploration_noise: 1e300, ..DdpgConfig::default() }), "exploration_noise");
    assert_eq!(ddpg(DdpgConfig { ou_dt: 1e300, ..DdpgConfig::default() }), "ou_dt");
    assert_eq!(ddpg(DdpgConfig { ou_theta: 500.0, ..DdpgConfig::default() }), "ou_theta");
    let msg =
        Ppo::for_env(PpoConfig { target_kl: Some(0.0), ..small_ppo() }, &four).err().unwrap().to_string();
    assert!(!msg.contains("Some("), "{msg}");
    // A learner refuses an environment with other spaces or a different count.
    let mut algo = Ppo::for_env(small_ppo(), &env).unwrap();
    let mut two = pendulums(2, 1);
    assert!(matches!(
        algo.learn(&mut two, 100, &mut |_| ControlFlow::Continue(())),
        Err(RlError::Incompatible { .. })
    ));
}
