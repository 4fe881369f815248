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
    let mut algos = every_learner(&v);
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

/// Small learners of every kind for `v` (the off-policy ones learning from step 10).
fn every_learner(v: &VecEnv) -> Vec<Box<dyn Algorithm>> {
    let small = vec![16, 16];
    let mut algos = gaussian_learners(v);
    algos.extend::<Vec<Box<dyn Algorithm>>>(vec![
        Box::new(
            Sac::for_env(
                SacConfig {
                    actor_hidden: small.clone(),
                    critic_hidden: small.clone(),
                    learning_starts: 10,
                    batch_size: 8,
                    ..SacConfig::default()
                },
                v,
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
                v,
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
                v,
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
                v,
            )
            .unwrap(),
        ),
    ]);
    algos
}

/// Small PPO and A2C learners (the two with a per-entry Gaussian) for `v`.
fn gaussian_learners(v: &VecEnv) -> Vec<Box<dyn Algorithm>> {
    let small = vec![16, 16];
    vec![
        Box::new(
            Ppo::for_env(
                PpoConfig {
                    actor_hidden: small.clone(),
                    critic_hidden: small.clone(),
                    n_steps: 64,
                    ..PpoConfig::default()
                },
                v,
            )
            .unwrap(),
        ),
        Box::new(
            A2c::for_env(
                A2cConfig { actor_hidden: small.clone(), critic_hidden: small, ..A2cConfig::default() },
                v,
            )
            .unwrap(),
        ),
    ]
}

/// PPO and A2C raise their exploration σ to a rising floor at each rollout, keep the floor
/// in their checkpoints (a resumed run goes on with it), refuse a corrupt one, and the
/// off-policy learners refuse a floor.
#[test]
fn a_rising_exploration_floor_is_applied_and_kept() {
    use centaur_rl::{Checkpoint, ExplorationFloor, RlError};
    let venv = || VecEnv::new(vec![Box::new(Pendulum::new()) as Box<dyn Env>], 1).unwrap();
    let v = venv();
    let small = vec![16, 16];
    let floor = ExplorationFloor { entries: vec![Some([0.01, 1.0])], steps: 256 };
    let sigma = |c: &Checkpoint| c.f32("log_std", Some(1)).unwrap()[0].exp();
    let learners = gaussian_learners(&v);
    for (k, mut algo) in learners.into_iter().enumerate() {
        algo.set_exploration_std(&[0.01]).unwrap();
        algo.set_exploration_floor(floor.clone()).unwrap();
        let mut env = venv();
        // PPO's rollouts start at 0, 64, 128 and 192 samples (the last floor 0.01·100^0.75 ≈
        // 0.32), A2C's every 5 (the last at 250, ≈ 0.9).
        algo.learn(&mut env, 256, &mut |_| std::ops::ControlFlow::Continue(())).unwrap();
        let c = algo.to_checkpoint();
        assert!(sigma(&c) > 0.3, "{}: σ {} below the floor", algo.name(), sigma(&c));
        // Without a floor the same learner stays near its initial σ.
        let mut free = gaussian_learners(&v).swap_remove(k);
        free.set_exploration_std(&[0.01]).unwrap();
        free.learn(&mut venv(), 256, &mut |_| std::ops::ControlFlow::Continue(())).unwrap();
        assert!(sigma(&free.to_checkpoint()) < 0.05, "{}: σ rose without a floor", algo.name());
        // The checkpoint keeps the floor; one without a floor writes none.
        assert_eq!(c.get_meta::<ExplorationFloor>("exploration_floor").unwrap(), floor);
        assert!(!free.to_checkpoint().meta.contains_key("exploration_floor"));
        let dir = std::env::temp_dir().join(format!("centaur_floor_{}_{}", algo.name(), std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("ckpt");
        algo.save(&path).unwrap();
        let back = centaur_rl::learners::load(&path).unwrap();
        assert_eq!(back.to_checkpoint().get_meta::<ExplorationFloor>("exploration_floor").unwrap(), floor);
        // A corrupt floor is refused by name.
        let mut bad = c.clone();
        bad.set_meta("exploration_floor", ExplorationFloor { entries: vec![Some([0.01, 1.0])], steps: 0 });
        bad.write(&path).unwrap();
        assert!(matches!(
            centaur_rl::learners::load(&path),
            Err(RlError::InvalidConfig { field: "exploration floor steps", .. })
        ));
        std::fs::remove_dir_all(&dir).ok();
    }
    let mut sac = Sac::for_env(
        SacConfig { actor_hidden: small.clone(), critic_hidden: small, ..SacConfig::default() },
        &v,
    )
    .unwrap();
    assert!(matches!(sac.set_exploration_floor(floor), Err(RlError::Incompatible { .. })));
}

/// Pendulum, recording the training samples the learner tells it.
struct Told {
    inner: Pendulum,
    seen: std::sync::Arc<std::sync::Mutex<Vec<u64>>>,
}

impl Env for Told {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn observation_space(&self) -> &centaur_gym::BoxSpace {
        self.inner.observation_space()
    }
    fn action_space(&self) -> &centaur_gym::BoxSpace {
        self.inner.action_space()
    }
    fn max_episode_steps(&self) -> usize {
        self.inner.max_episode_steps()
    }
    fn dt(&self) -> f64 {
        self.inner.dt()
    }
    fn set_training_samples(&mut self, samples: u64) {
        self.seen.lock().unwrap().push(samples);
    }
    fn reset(&mut self, seed: Option<u64>, obs: &mut [f32]) -> Result<(), centaur_gym::EnvError> {
        self.inner.reset(seed, obs)
    }
    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> Result<centaur_gym::Step, centaur_gym::EnvError> {
        self.inner.step(action, obs)
    }
}

/// Every learner tells its environments its samples so far before they step (a hybrid's
/// rising residual bound runs on this clock): PPO and A2C before each rollout, the
/// off-policy learners before each step; a second `learn` goes on from its own count.
#[test]
fn every_learner_tells_its_environments_the_training_samples() {
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let told = || {
        let env = Told { inner: Pendulum::new(), seen: seen.clone() };
        VecEnv::new(vec![Box::new(env) as Box<dyn Env>], 1).unwrap()
    };
    for (k, mut algo) in every_learner(&told()).into_iter().enumerate() {
        seen.lock().unwrap().clear();
        let mut env = told();
        algo.learn(&mut env, 128, &mut |_| std::ops::ControlFlow::Continue(())).unwrap();
        algo.learn(&mut env, 256, &mut |_| std::ops::ControlFlow::Continue(())).unwrap();
        let got = seen.lock().unwrap().clone();
        // PPO's rollouts are 64 samples, A2C's 5 (its last ends at 130 and 260).
        let expected: Vec<u64> = match k {
            0 => (0..4).map(|r| 64 * r).collect(),
            1 => (0..26).chain(26..52).map(|r| 5 * r).collect(),
            _ => (0..256).collect(),
        };
        assert_eq!(got, expected, "{}", algo.name());
    }
}
