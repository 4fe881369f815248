//! Residual TD3 on the Ant against pure TD3 with the same budget and seed, and the
//! controller alone: trains both, evaluates all three and writes the run directory
//! (`runs/residual_td3_ant` by default; summary.json, learning curves, checkpoints, MCAP).
//!
//! ```text
//! cargo run --release --example residual_td3_ant -- [--steps N] [--seed S] [--out DIR] [--no-record]
//! ```
//! TD3's update dominates the cost (one gradient step per environment step), so the default
//! budget is short; pass `--steps` for longer runs.

use std::path::PathBuf;

use centaur::experiment::{ExperimentOptions, OFF_POLICY_LOCOMOTION_CONFIG, run_experiment_with_progress};
use centaur::residual::ResidualConfig;
use centaur_rl::AlgoKind;

fn arg<T: std::str::FromStr>(args: &[String], name: &str) -> Option<T> {
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|s| s.parse().ok())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let steps: u64 = arg(&args, "--steps").unwrap_or(50_000);
    let opts = ExperimentOptions {
        env: "ant".to_string(),
        algo: AlgoKind::Td3,
        steps,
        seed: arg(&args, "--seed").unwrap_or(0),
        out: arg::<PathBuf>(&args, "--out").unwrap_or_else(|| PathBuf::from("runs/residual_td3_ant")),
        // Stable-Baselines3's defaults, with a 5000-step random warm-up.
        algo_config: Some(OFF_POLICY_LOCOMOTION_CONFIG.to_string()),
        n_envs: 1,
        threads: 1,
        eval_episodes: arg(&args, "--eval-episodes").unwrap_or(10),
        residual: ResidualConfig::for_env("ant"),
        record: !args.iter().any(|a| a == "--no-record"),
    };
    println!(
        "Residual TD3 vs pure TD3 on {}, {} steps each, seed {} → {}",
        opts.env,
        steps,
        opts.seed,
        opts.out.display()
    );
    let result = run_experiment_with_progress(&opts, "TD3");
    match result {
        Ok(r) => {
            println!("\nEvaluation over {} episodes:\n\n{}", opts.eval_episodes, r.summary.markdown_table());
            println!("Run directory: {}", opts.out.display());
        }
        Err(e) => {
            eprintln!("residual_td3_ant: {e}");
            std::process::exit(1);
        }
    }
}
