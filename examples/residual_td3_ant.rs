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

use centaur::experiment::{ExperimentOptions, OFF_POLICY_LOCOMOTION_CONFIG, Phase, run_experiment};
use centaur::residual::ResidualConfig;
use centaur_rl::AlgoKind;
use indicatif::{ProgressBar, ProgressStyle};

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
    let bar = ProgressBar::new(2 * steps);
    bar.set_style(
        ProgressStyle::with_template("{msg:>16} [{bar:40}] {pos}/{len} steps ({per_sec}, eta {eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let result = run_experiment(&opts, &mut |phase, m| {
        let (offset, label) = match phase {
            Phase::TrainPure => (0, "pure TD3"),
            Phase::TrainHybrid => (steps, "hybrid TD3"),
            Phase::Evaluate => (2 * steps, "evaluating"),
        };
        bar.set_message(format!("{label} {:.1}", m.episode_return_mean));
        bar.set_position(offset + m.env_steps.min(steps));
    });
    bar.finish_and_clear();
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
