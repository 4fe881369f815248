//! `Algorithm::zero_policy_output` makes every learner's deterministic action exactly zero,
//! whatever the observation — the starting point of a residual policy.

use centaur_gym::pendulum::Pendulum;
use centaur_gym::{Env, Rng, VecEnv};
use centaur_rl::{
    A2c, A2cConfig, Algorithm, Ddpg, DdpgConfig, Ppo, PpoConfig, Sac, SacConfig, SacV1, SacV1Config, Td3,
    Td3Config,
};

#[test]
fn zeroed_policies_output_zero_and_still_learn() {
    let venv = || VecEnv::new(vec![Box::new(Pendulum::new()) as Box<dyn Env>], 1).unwrap();
    let v = venv();
    let small = vec![16, 16];
    let mut algos: Vec<Box<dyn Algorithm>> = vec![
        Box::new(
            Ppo::for_env(
                PpoConfig {
                    actor_hidden: small.clone(),
                    critic_hidden: small.clone(),
                    n_steps: 64,
                    ..PpoConfig::default()
                },
                &v,
            )
            .unwrap(),
        ),
        Box::new(
            A2c::for_env(
                A2cConfig {
                    actor_hidden: small.clone(),
                    critic_hidden: small.clone(),
                    ..A2cConfig::default()
                },
                &v,
            )
            .unwrap(),
        ),
        Box::new(
            Sac::for_env(
                SacConfig {
                    actor_hidden: small.clone(),
                    critic_hidden: small.clone(),
                    learning_starts: 10,
                    batch_size: 8,
                    ..SacConfig::default()
                },
                &v,
            )
            .unwrap(),
        ),
        Box::new(
            SacV1::for_env(
                SacV1Config {
                    actor_hidden: small.clone(),
                    critic_hidden: small.clone(),
                    learning_starts: 10,
                    batch_size: 8,
                    ..SacV1Config::default()
                },
                &v,
            )
            .unwrap(),
        ),
        Box::new(
            Td3::for_env(
                Td3Config {
                    actor_hidden: small.clone(),
                    critic_hidden: small.clone(),
                    learning_starts: 10,
                    batch_size: 8,
                    ..Td3Config::default()
                },
                &v,
            )
            .unwrap(),
        ),
        Box::new(
            Ddpg::for_env(
                DdpgConfig {
                    actor_hidden: small.clone(),
                    critic_hidden: small.clone(),
                    learning_starts: 10,
                    batch_size: 8,
                    ..DdpgConfig::default()
                },
                &v,
            )
            .unwrap(),
        ),
    ];
    let mut rng = Rng::seed_from_u64(0);
    for algo in algos.iter_mut() {
        algo.zero_policy_output();
        let mut policy = algo.policy();
        let mut out = [1.0f32];
        for _ in 0..20 {
            let obs = [rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32, rng.range(-8.0, 8.0) as f32];
            policy.act(&obs, &mut out);
            assert_eq!(out[0], 0.0, "{}: zeroed policy acted {}", algo.name(), out[0]);
        }
        // Training moves it away from zero again (the gradients reach the zeroed weights).
        let mut env = venv();
        algo.learn(&mut env, 600, &mut |_| std::ops::ControlFlow::Continue(())).unwrap();
        let mut trained = algo.policy();
        let mut moved = false;
        for _ in 0..20 {
            let obs = [rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32, rng.range(-8.0, 8.0) as f32];
            trained.act(&obs, &mut out);
            moved |= out[0] != 0.0;
        }
        assert!(moved, "{}: the policy never left zero", algo.name());
    }
}
