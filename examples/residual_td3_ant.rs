//! Residual TD3 on the Ant against pure TD3 with the same budget and seed, and the
//! controller alone: trains both, evaluates all three and writes the run directory
//! (`runs/residual_td3_ant` by default; summary.json, learning curves, checkpoints, MCAP).
//!
//! ```text
//! cargo run --release --example residual_td3_ant -- [--steps N] [--seed S] [--out DIR] [--no-record]
//! ```
//! TD3's update dominates the cost (one gradient step per vectorised environment step), so the default
//! budget is short; pass `--steps` for longer runs, `--help` for every option.

use std::process::ExitCode;

use centaur_lab::cli::{ExampleArgs, ExampleDefaults, run_example};
use centaur_rl::AlgoKind;
use clap::Parser;

/// Residual TD3 against pure TD3 and the controller alone on the Ant.
#[derive(Parser)]
#[command(
    name = "residual_td3_ant",
    after_help = "Defaults: 50,000 steps per agent, 1 environment, run directory runs/residual_td3_ant."
)]
struct Cli {
    #[command(flatten)]
    run: ExampleArgs,
}

fn main() -> ExitCode {
    let defaults =
        ExampleDefaults { name: "residual_td3_ant", env: "ant", algo: AlgoKind::Td3, steps: 50_000, envs: 1 };
    match Cli::parse().run.options(&defaults) {
        Ok(opts) => run_example(defaults.name, &opts),
        Err(e) => {
            eprintln!("{}: {e}", defaults.name);
            ExitCode::from(2)
        }
    }
}
