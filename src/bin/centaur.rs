//! The `centaur` command line: `centaur train --env pendulum --algo sac --steps 20000 --seed 0 --out runs/sac`.

use std::path::PathBuf;
use std::process::ExitCode;

use centaur::registry::ENV_NAMES;
use centaur::train::{TrainOptions, train};
use centaur_rl::AlgoKind;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

#[derive(Parser)]
#[command(
    name = "centaur",
    version,
    about = "Legged-robot locomotion: model-based control + reinforcement learning"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Train a learner on an environment; writes metrics.csv, checkpoint,
    /// learning_curve.{svg,png} and summary.json into --out.
    Train {
        /// Environment name (pendulum).
        #[arg(long)]
        env: String,
        /// Algorithm: ppo, a2c, sac, sac1, td3 or ddpg.
        #[arg(long, value_parser = parse_algo)]
        algo: AlgoKind,
        /// Environment steps to train for.
        #[arg(long)]
        steps: u64,
        /// Seed (overrides `seed` in the config file).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// TOML file setting any of the algorithm's hyperparameters.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Threads stepping the environments.
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Number of parallel environments.
        #[arg(long, default_value_t = 1)]
        envs: usize,
        /// Deterministic evaluation episodes at the end (at least 10).
        #[arg(long, default_value_t = 10)]
        eval_episodes: usize,
    },
}

fn parse_algo(s: &str) -> Result<AlgoKind, String> {
    AlgoKind::from_name(s).ok_or_else(|| {
        format!("unknown algorithm `{s}` (one of: {})", AlgoKind::ALL.map(|k| k.name()).join(", "))
    })
}

fn main() -> ExitCode {
    let Command::Train { env, algo, steps, seed, out, config, threads, envs, eval_episodes } =
        Cli::parse().command;
    let opts = TrainOptions { env, algo, steps, seed, out, config, threads, n_envs: envs, eval_episodes };
    let bar = ProgressBar::new(steps);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} steps {per_sec} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let result = train(&opts, &mut |m| {
        bar.set_position(m.env_steps.min(steps));
        if m.episode_return_mean.is_finite() {
            bar.set_message(format!("return {:.1}", m.episode_return_mean));
        }
    });
    bar.finish_and_clear();
    match result {
        Ok(s) => {
            println!(
                "{} on {}: {} steps in {:.1} s ({:.0} steps/s); final return {:.1} ± {:.1} over {} episodes; wrote {}",
                s.algo,
                s.env,
                s.steps,
                s.wall_seconds,
                s.steps_per_second,
                s.final_return_mean,
                s.final_return_std,
                opts.eval_episodes.max(10),
                opts.out.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            if matches!(e, centaur::train::TrainError::Registry(_)) {
                eprintln!("available environments: {}", ENV_NAMES.join(", "));
            }
            ExitCode::FAILURE
        }
    }
}
