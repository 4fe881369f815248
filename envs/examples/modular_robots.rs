//! Prints the README's table of the modular robots: their make-up, and what random actions
//! achieve (10 episodes of 30 s) and how fast the environment steps on one core.
//!
//! `cargo run --release -p centaur-envs --example modular_robots`

use std::time::Instant;

use centaur_envs::modular::{ModularConfig, ModularEnv};
use centaur_gym::{Env, Rng};

fn main() {
    println!("| robot | modules | hinges | mass (kg) | random actions: return (m) | env steps/s |");
    println!("|---|---:|---:|---:|---:|---:|");
    for config in [ModularConfig::gecko(), ModularConfig::ant(), ModularConfig::spider()] {
        let (name, body) = (config.name.clone(), config.body.clone());
        let mut env = match ModularEnv::new(config) {
            Ok(env) => env,
            Err(e) => {
                eprintln!("{name}: {e}");
                std::process::exit(1);
            }
        };
        let mut obs = vec![0.0; env.observation_space().dim()];
        let mut action = vec![0.0f32; env.action_space().dim()];
        let mut rng = Rng::seed_from_u64(0);
        let mut returns = Vec::new();
        let mut steps = 0usize;
        let t0 = Instant::now();
        for episode in 0..10 {
            if let Err(e) = env.reset(Some(episode), &mut obs) {
                eprintln!("{name}: {e}");
                std::process::exit(1);
            }
            let mut ret = 0.0;
            loop {
                action.iter_mut().for_each(|a| *a = rng.range(-1.0, 1.0) as f32);
                let step = match env.step(&action, &mut obs) {
                    Ok(s) => s,
                    Err(e) => {
                        eprintln!("{name}: {e}");
                        std::process::exit(1);
                    }
                };
                ret += step.reward;
                steps += 1;
                if step.done() {
                    break;
                }
            }
            returns.push(ret);
        }
        let rate = steps as f64 / t0.elapsed().as_secs_f64();
        let mean = returns.iter().sum::<f64>() / returns.len() as f64;
        let std = (returns.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / returns.len() as f64).sqrt();
        println!(
            "| {name} | {} | {} | {:.3} | {mean:.2} ± {std:.2} | {rate:.0} |",
            body.num_modules(),
            body.hinges().len(),
            body.mass()
        );
    }
}
