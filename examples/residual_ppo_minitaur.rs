//! Residual PPO on the Minitaur against pure PPO with the same budget and seed, and the
//! controller alone: trains both, evaluates all three over 10 episodes, prints the table and
//! writes the run directory (metrics, learning curves, checkpoints, summary.json, MCAP).
//! The default budget, 300,000 steps per agent, takes under 10 minutes on 2 cores, the two
//! agents training side by side (the hybrid's cost is the controller: one MPC solve per
//! environment step).
//!
//! ```text
//! cargo run --release --example residual_ppo_minitaur
//! cargo run --release --example residual_ppo_minitaur -- --steps 2000000 --seed 3 --out runs/long
//! ```
//! Options (`--help` lists them): `--steps N` (per agent), `--seed S`, `--out DIR`,
//! `--env minitaur|minitaur-fast`, `--envs N` (parallel environments per agent),
//! `--threads T`, `--eval-episodes K`, `--config FILE` (TOML hyperparameters for both agents
//! instead of the tuned Minitaur set), `--no-record`, and the hybrid's setup over the
//! Minitaur preset (a 2 m/s trot whose speed the policy steers within ±1.5 m/s, residual
//! scale 0.25): `--speed V`, `--steer-speed S`, `--steer-yaw-rate S`, `--residual-scale X`,
//! `--parts both|residual|command`, `--explore-residual σ`, `--explore-steering σ`,
//! `--rated-speed V` (the trot's rating: 3.5 m/s in the preset, so the steering reaches
//! 3.5 m/s; `--rated-speed 3.0 --steer-speed 1.0` reproduces an earlier preset and
//! `--rated-speed 2.5 --steer-speed 1.0` the runs measured before it, see the README).

use std::process::ExitCode;

use centaur_lab::cli::{ExampleArgs, ExampleDefaults, run_example};
use centaur_rl::AlgoKind;
use clap::Parser;

/// Residual PPO against pure PPO and the controller alone on the Minitaur.
#[derive(Parser)]
#[command(
    name = "residual_ppo_minitaur",
    after_help = "Defaults: 300,000 steps per agent, 4 environments, run directory runs/residual_ppo_minitaur."
)]
struct Cli {
    #[command(flatten)]
    run: ExampleArgs,
    /// Environment: minitaur (MinitaurBulletEnv-v0 with its randomisation) or minitaur-fast
    #[arg(long, default_value = "minitaur", value_parser = ["minitaur", "minitaur-fast"])]
    env: String,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let defaults = ExampleDefaults {
        name: "residual_ppo_minitaur",
        env: &cli.env,
        algo: AlgoKind::Ppo,
        steps: 300_000,
        envs: 4,
    };
    let opts = match cli.run.options(&defaults) {
        Ok(opts) => opts,
        Err(e) => {
            eprintln!("{}: {e}", defaults.name);
            return ExitCode::from(2);
        }
    };
    run_example(defaults.name, &opts)
}
