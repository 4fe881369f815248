//! Residual PPO on the Minitaur against pure PPO with the same budget and seed, and the
//! controller alone: trains both, evaluates all three over 10 episodes, prints the table and
//! writes the run directory (metrics, learning curves, checkpoints, summary.json, MCAP).
//! The default budget, 300,000 steps per agent, takes about 9 minutes on 2 cores (the
//! hybrid's cost is the controller: one MPC solve per environment step).
//!
//! ```text
//! cargo run --release --example residual_ppo_minitaur
//! cargo run --release --example residual_ppo_minitaur -- --steps 2000000 --seed 3 --out runs/long
//! ```
//! Options: `--steps N` (per agent), `--seed S`, `--out DIR`, `--env minitaur|minitaur-fast`,
//! `--envs N` (parallel environments per agent), `--threads T`, `--eval-episodes K`,
//! `--residual-scale X`, `--speed V` (the controller's commanded speed), `--config FILE`
//! (TOML hyperparameters for both agents instead of the tuned Minitaur set), `--no-record`.

use std::path::PathBuf;
use std::time::Instant;

use centaur::experiment::{ExperimentOptions, run_experiment_with_progress, tuned_config};
use centaur::residual::ResidualConfig;
use centaur_mpc::{Command, Gait};
use centaur_rl::AlgoKind;

fn arg<T: std::str::FromStr>(args: &[String], name: &str) -> Option<T> {
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|s| s.parse().ok())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let threads = arg(&args, "--threads")
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let env: String = arg(&args, "--env").unwrap_or_else(|| "minitaur".to_string());
    let mut residual = ResidualConfig::for_env(&env);
    if let Some(s) = arg::<f64>(&args, "--residual-scale") {
        residual.scale = vec![s];
    }
    if let Some(v) = arg::<f64>(&args, "--speed") {
        residual.command = Command::forward(v, Gait::Trot);
    }
    let algo_config = match arg::<PathBuf>(&args, "--config") {
        Some(path) => match std::fs::read_to_string(&path) {
            Ok(text) => Some(text),
            Err(e) => {
                eprintln!("residual_ppo_minitaur: cannot read --config {}: {e}", path.display());
                std::process::exit(2);
            }
        },
        None => tuned_config(&env, AlgoKind::Ppo).map(str::to_string),
    };
    let opts = ExperimentOptions {
        env: env.clone(),
        algo: AlgoKind::Ppo,
        steps: arg(&args, "--steps").unwrap_or(300_000),
        seed: arg(&args, "--seed").unwrap_or(0),
        out: arg::<PathBuf>(&args, "--out").unwrap_or_else(|| PathBuf::from("runs/residual_ppo_minitaur")),
        algo_config,
        n_envs: arg(&args, "--envs").unwrap_or(4),
        threads,
        eval_episodes: arg(&args, "--eval-episodes").unwrap_or(10),
        residual,
        record: !args.iter().any(|a| a == "--no-record"),
    };
    println!(
        "Residual PPO vs pure PPO on {} — {} steps each, seed {}, {} envs on {} threads → {}",
        opts.env,
        opts.steps,
        opts.seed,
        opts.n_envs,
        opts.threads,
        opts.out.display()
    );
    let t0 = Instant::now();
    let result = run_experiment_with_progress(&opts, "PPO");
    let summary = match result {
        Ok(r) => r.summary,
        Err(e) => {
            eprintln!("residual_ppo_minitaur: {e}");
            std::process::exit(1);
        }
    };
    println!(
        "\nEvaluation over {} episodes (deterministic actions, same seeds for every agent):\n",
        opts.eval_episodes
    );
    print!("{}", summary.markdown_table());
    println!(
        "\nTraining: hybrid {} steps in {:.0} s, pure {} steps in {:.0} s; total wall time {:.0} s.",
        summary.hybrid.env_steps,
        summary.hybrid.wall_seconds,
        summary.pure_rl.env_steps,
        summary.pure_rl.wall_seconds,
        t0.elapsed().as_secs_f64()
    );
    println!(
        "Run directory: {} (summary.json, learning_curves.png, */metrics.csv, */checkpoint, *.mcap)",
        opts.out.display()
    );
}
