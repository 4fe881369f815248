//! The algorithm variants the studies use: separate critic learning rates (every learner)
//! and PPO's adaptive KL penalty (Schulman et al. 2017, section 4).

use std::ops::ControlFlow;

use centaur_gym::pendulum::Pendulum;
use centaur_gym::{Env, VecEnv};
use centaur_rl::*;

fn pendulums(n: usize) -> VecEnv {
    VecEnv::new((0..n).map(|_| Box::new(Pendulum::new()) as Box<dyn Env>).collect(), 1).unwrap()
}

/// Trains to `total` steps; returns the metrics records.
fn learn(algo: &mut dyn Algorithm, env: &mut VecEnv, total: u64) -> Vec<UpdateMetrics> {
    let mut rows = Vec::new();
    algo.learn(env, total, &mut |m| {
        rows.push(*m);
        ControlFlow::Continue(())
    })
    .unwrap();
    rows
}

/// A parameter blob of the learner's checkpoint.
fn blob(algo: &dyn Algorithm, name: &str) -> Vec<f32> {
    algo.to_checkpoint().f32(name, None).unwrap().to_vec()
}

fn small_ppo() -> PpoConfig {
    PpoConfig {
        seed: 7,
        n_steps: 128,
        batch_size: 64,
        n_epochs: 4,
        actor_hidden: vec![16, 16],
        critic_hidden: vec![16, 16],
        ..PpoConfig::default()
    }
}

/// One PPO update with and without a separate critic rate: the critic moves differently,
/// the actor exactly alike (without global gradient clipping, the policy gradient of one
/// update does not depend on the critic's parameters: the advantages are computed first).
/// The same rate given explicitly is the unset default, bit for bit.
#[test]
fn ppo_critic_learning_rate_moves_only_the_critic() {
    let base = PpoConfig { clip_grad_norm: false, ..small_ppo() };
    let run = |c: PpoConfig| {
        let mut env = pendulums(2);
        let mut p = Ppo::for_env(c, &env).unwrap();
        let rows = learn(&mut p, &mut env, 256);
        (p, rows)
    };
    let (same, rows) = run(base.clone());
    let explicit = run(PpoConfig { critic_learning_rate: Some(base.learning_rate), ..base.clone() }).0;
    let (slow, slow_rows) =
        run(PpoConfig { critic_learning_rate: Some(base.learning_rate / 10.0), ..base.clone() });
    // Both rates are logged: equal when unset, the critic's own when set.
    assert!(rows.iter().all(|m| m.critic_learning_rate == m.learning_rate && m.learning_rate > 0.0));
    let tenth = |m: &UpdateMetrics| {
        (m.critic_learning_rate - m.learning_rate / 10.0).abs() <= 1e-12 * base.learning_rate
    };
    assert!(slow_rows.iter().all(tenth), "{slow_rows:?}");
    for name in ["actor", "log_std", "critic"] {
        assert_eq!(blob(&same, name), blob(&explicit, name), "{name}: explicit default differs");
    }
    assert_eq!(blob(&same, "actor"), blob(&slow, "actor"));
    assert_eq!(blob(&same, "log_std"), blob(&slow, "log_std"));
    assert_ne!(blob(&same, "critic"), blob(&slow, "critic"));
    // The slower critic moved less from the shared initialisation.
    let init = {
        let env = pendulums(2);
        Ppo::for_env(base.clone(), &env).unwrap()
    };
    let moved = |p: &Ppo| {
        blob(p, "critic")
            .iter()
            .zip(blob(&init, "critic"))
            .map(|(a, b)| f64::from(a - b).powi(2))
            .sum::<f64>()
    };
    assert!(moved(&slow) < moved(&same), "{} vs {}", moved(&slow), moved(&same));
    assert!(PpoConfig { critic_learning_rate: Some(-1.0), ..base }.validate().is_err());
}

/// The critic's burn-in: for its steps the actor and log-std keep their initial parameters
/// bit for bit (logged learning rate 0) while the critic learns at its own rate; after it
/// the actor learns. A burn-in at or past the learning-rate horizon is refused, naming the
/// field, by `validate` (against `lr_decay_steps`) and by `learn` (against its total).
#[test]
fn ppo_actor_burn_in_trains_only_the_critic_first() {
    let base = small_ppo();
    let init = {
        let env = pendulums(2);
        Ppo::for_env(base.clone(), &env).unwrap()
    };
    // 256 steps per update (128 × 2 envs): two updates of burn-in, then two of both.
    let mut env = pendulums(2);
    let mut p = Ppo::for_env(
        PpoConfig { actor_burn_in_steps: 512, lr_decay_steps: Some(1024), ..base.clone() },
        &env,
    )
    .unwrap();
    let rows = learn(&mut p, &mut env, 512);
    assert_eq!(rows.len(), 2);
    assert!(rows.iter().all(|m| m.learning_rate == 0.0 && m.critic_learning_rate > 0.0), "{rows:?}");
    assert_eq!(blob(&p, "actor"), blob(&init, "actor"));
    assert_eq!(blob(&p, "log_std"), blob(&init, "log_std"));
    assert_ne!(blob(&p, "critic"), blob(&init, "critic"));
    let rows = learn(&mut p, &mut env, 1024);
    assert_eq!(rows.len(), 2);
    assert!(rows.iter().all(|m| m.learning_rate > 0.0), "{rows:?}");
    assert_ne!(blob(&p, "actor"), blob(&init, "actor"));
    // Without burn-in the same seed's actor moves in the first update.
    let mut env = pendulums(2);
    let mut q = Ppo::for_env(base.clone(), &env).unwrap();
    learn(&mut q, &mut env, 256);
    assert_ne!(blob(&q, "actor"), blob(&init, "actor"));

    let bad = PpoConfig { actor_burn_in_steps: 1000, lr_decay_steps: Some(1000), ..base.clone() };
    let e = bad.validate().unwrap_err().to_string();
    assert!(e.contains("actor_burn_in_steps"), "{e}");
    let mut env = pendulums(2);
    let mut r = Ppo::for_env(PpoConfig { actor_burn_in_steps: 1024, ..base }, &env).unwrap();
    let e = r.learn(&mut env, 1024, &mut |_| ControlFlow::Continue(())).unwrap_err().to_string();
    assert!(e.contains("actor_burn_in_steps") && e.contains("horizon"), "{e}");
}

/// Every other learner: the critic's rate is its own (the default is the shared rate, bit
/// for bit) and a bad one is refused naming the field.
#[test]
fn off_policy_and_a2c_critic_learning_rates() {
    type Make = dyn Fn(Option<f64>, &VecEnv) -> Result<Box<dyn Algorithm>, RlError>;
    let small = |h: usize| vec![h, h];
    // An off-policy learner with small networks and an early start.
    macro_rules! off_policy {
        ($learner:ident, $config:ident) => {
            Box::new(move |lr, e| {
                let c = $config {
                    seed: 2,
                    batch_size: 32,
                    learning_starts: 100,
                    log_interval: 100,
                    actor_hidden: small(16),
                    critic_hidden: small(16),
                    critic_learning_rate: lr,
                    ..$config::default()
                };
                Ok(Box::new($learner::for_env(c, e)?) as Box<dyn Algorithm>)
            })
        };
    }
    let makers: Vec<(&str, &str, Box<Make>)> = vec![
        ("sac", "q0", off_policy!(Sac, SacConfig)),
        ("sac_v1", "v", off_policy!(SacV1, SacV1Config)),
        ("td3", "q0", off_policy!(Td3, Td3Config)),
        ("ddpg", "q", off_policy!(Ddpg, DdpgConfig)),
        (
            "a2c",
            "critic",
            Box::new(move |lr, e| {
                let c = A2cConfig {
                    seed: 2,
                    log_interval: 20,
                    actor_hidden: vec![16],
                    critic_hidden: vec![16],
                    critic_learning_rate: lr,
                    ..A2cConfig::default()
                };
                Ok(Box::new(A2c::for_env(c, e)?) as Box<dyn Algorithm>)
            }),
        ),
    ];
    for (algo, critic, make) in &makers {
        let run = |lr: Option<f64>| {
            let mut env = pendulums(1);
            let mut a = make(lr, &env).unwrap();
            let rows = learn(a.as_mut(), &mut env, 300);
            (a, rows)
        };
        let (default, default_rows) = run(None);
        let shared = default.to_checkpoint();
        let rate: f64 =
            match shared.get_meta::<serde_json::Value>("config").unwrap()["learning_rate"].as_f64() {
                Some(r) => r,
                None => panic!("{algo}: no learning_rate in the config"),
            };
        let explicit = run(Some(rate)).0;
        assert_eq!(blob(default.as_ref(), critic), blob(explicit.as_ref(), critic), "{algo}");
        let (other, other_rows) = run(Some(rate * 0.1));
        assert_ne!(blob(default.as_ref(), critic), blob(other.as_ref(), critic), "{algo}");
        // Both rates are logged: equal when unset, the critic's own when set.
        assert!(!default_rows.is_empty() && !other_rows.is_empty(), "{algo}: no metrics");
        assert!(default_rows.iter().all(|m| m.critic_learning_rate == m.learning_rate), "{algo}");
        // (A tenth of the actor's, which may be annealed.)
        let tenth =
            |m: &UpdateMetrics| (m.critic_learning_rate - 0.1 * m.learning_rate).abs() <= 1e-12 * rate;
        assert!(other_rows.iter().all(tenth), "{algo}: {other_rows:?}");
        let e = make(Some(f64::NAN), &pendulums(1)).err().unwrap();
        assert!(e.to_string().contains("critic_learning_rate"), "{algo}: {e}");
    }
}

/// Section 4's rule: β doubles while the measured KL is above 1.5 × the target and halves
/// while it is below target / 1.5; the coefficient is logged per update.
#[test]
fn ppo_kl_coefficient_adapts_to_its_target() {
    for (target, factor) in [(1e-9, 2.0), (10.0, 0.5)] {
        let c = PpoConfig { kl_penalty: true, clip_policy: false, kl_target: target, ..small_ppo() };
        let mut env = pendulums(2);
        let mut p = Ppo::for_env(c, &env).unwrap();
        let rows = learn(&mut p, &mut env, 4 * 256);
        let betas: Vec<f64> = rows.iter().map(|m| m.kl_coef).collect();
        assert_eq!(betas, [1.0, factor, factor * factor, factor * factor * factor], "target {target}");
    }
    // Without the penalty the column is empty.
    let mut env = pendulums(2);
    let mut p = Ppo::for_env(small_ppo(), &env).unwrap();
    assert!(learn(&mut p, &mut env, 256).iter().all(|m| m.kl_coef.is_nan()));
    for bad in [PpoConfig { kl_target: 0.0, ..small_ppo() }, PpoConfig { kl_coef_init: -1.0, ..small_ppo() }]
    {
        assert!(bad.validate().is_err());
    }
}

/// The penalty's gradient pulls the new policy towards the old one: with the unclipped
/// surrogate and many epochs at a high rate, a heavy penalty keeps the update's KL far below
/// the unpenalised one.
#[test]
fn ppo_kl_penalty_restrains_the_update() {
    let kl = |penalty: bool| {
        let c = PpoConfig {
            clip_policy: false,
            kl_penalty: penalty,
            kl_coef_init: 30.0,
            learning_rate: 3e-3,
            n_epochs: 20,
            clip_grad_norm: false,
            anneal_lr: false,
            ..small_ppo()
        };
        let mut env = pendulums(2);
        let mut p = Ppo::for_env(c, &env).unwrap();
        learn(&mut p, &mut env, 256)[0].approx_kl
    };
    let (free, penalised) = (kl(false), kl(true));
    assert!(penalised < 0.5 * free, "KL with the penalty {penalised}, without {free}");
}
