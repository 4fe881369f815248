//! Training throughput (environment steps per second, updates included) of a Centaur
//! learner with Stable-Baselines3's default hyperparameters, for side-by-side comparison
//! with `tools/sb3_bench.py`:
//!
//! `cargo run --release --example bench_rl -- --env pendulum --algo sac --steps 6000 --learning-starts 1000`
//!
//! Prints one JSON line: total wall time and steps/s, and for off-policy learners the rate
//! after `learning_starts` (one gradient step per env step).

use std::ops::ControlFlow;
use std::time::Instant;

use centaur::registry::make_vec_env;
use centaur_rl::{
    A2c, A2cConfig, AlgoKind, Algorithm, Ddpg, DdpgConfig, Ppo, PpoConfig, Sac, SacConfig, SacV1,
    SacV1Config, Td3, Td3Config,
};

fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> T {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map(|v| v.parse().unwrap_or_else(|_| panic!("bad value for {name}: {v}")))
        .unwrap_or(default)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let env_name: String = arg(&args, "--env", "pendulum".to_string());
    let algo_name: String = arg(&args, "--algo", "ppo".to_string());
    let steps: u64 = arg(&args, "--steps", 20_480);
    let seed: u64 = arg(&args, "--seed", 0);
    let ls: u64 = arg(&args, "--learning-starts", 1000);
    let kind = AlgoKind::from_name(&algo_name).expect("algo: ppo, a2c, sac, sac1, td3 or ddpg");
    let mut env = make_vec_env(&env_name, 1, 1).expect("known env");
    // Stable-Baselines3 defaults (PPO without the normalisation wrappers, annealing or value
    // clipping that SB3 does not apply by default).
    let mut algo: Box<dyn Algorithm> = match kind {
        AlgoKind::Ppo => {
            let c = PpoConfig {
                seed,
                anneal_lr: false,
                clip_vloss: false,
                norm_obs: false,
                norm_reward: false,
                ..PpoConfig::default()
            };
            Box::new(Ppo::for_env(c, &env).unwrap())
        }
        AlgoKind::A2c => Box::new(A2c::for_env(A2cConfig { seed, ..A2cConfig::default() }, &env).unwrap()),
        AlgoKind::Sac => Box::new(
            Sac::for_env(SacConfig { seed, learning_starts: ls, ..SacConfig::default() }, &env).unwrap(),
        ),
        AlgoKind::SacV1 => Box::new(
            SacV1::for_env(SacV1Config { seed, learning_starts: ls, ..SacV1Config::default() }, &env)
                .unwrap(),
        ),
        AlgoKind::Td3 => Box::new(
            Td3::for_env(Td3Config { seed, learning_starts: ls, ..Td3Config::default() }, &env).unwrap(),
        ),
        AlgoKind::Ddpg => Box::new(
            Ddpg::for_env(DdpgConfig { seed, learning_starts: ls, ..DdpgConfig::default() }, &env).unwrap(),
        ),
    };
    let off_policy = !matches!(kind, AlgoKind::Ppo | AlgoKind::A2c);
    let mut cb = |_: &centaur_rl::UpdateMetrics| ControlFlow::Continue(());
    let t0 = Instant::now();
    let mut warm = 0.0;
    if off_policy {
        algo.learn(&mut env, ls, &mut cb).unwrap();
        warm = t0.elapsed().as_secs_f64();
    }
    algo.learn(&mut env, steps, &mut cb).unwrap();
    let wall = t0.elapsed().as_secs_f64();
    let done = algo.steps_done();
    let after = if off_policy { format!("{:.1}", (done - ls) as f64 / (wall - warm)) } else { "null".into() };
    println!(
        "{{\"impl\": \"centaur\", \"algo\": \"{}\", \"env\": \"{env_name}\", \"steps\": {done}, \"wall\": {wall:.3}, \"fps\": {:.1}, \"fps_after_learning_starts\": {after}}}",
        algo.name(),
        done as f64 / wall
    );
}
