//! `centaur train`: build a learner from a name and a TOML file, train it on a registered
//! environment, and write the run's artefacts.
//!
//! Output directory:
//!
//! | file | content |
//! |---|---|
//! | `metrics.csv` | one [`UpdateMetrics`] row per update / log interval |
//! | `checkpoint` | the learner ([`centaur_rl::Checkpoint`] format, plus the env name under `env`): act with `Policy::load`, resume with `centaur_rl::learners::load` |
//! | `learning_curve.svg`, `learning_curve.png` | mean training episode return (± std band) against environment steps |
//! | `summary.json` | `{"env", "algo", "seed", "steps", "wall_seconds", "steps_per_second", "final_return_mean", "final_return_std"}` |
//!
//! The final return is the mean over `eval_episodes` (≥ 10 by default) deterministic
//! episodes of the policy **loaded back from the checkpoint** (the deployment path), on a
//! fresh environment reset with seeds `1_000_000 + seed + k`.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use centaur_rl::{
    A2cConfig, AlgoConfig, AlgoKind, DdpgConfig, MetricsCsv, Policy, PpoConfig, RlError, SacConfig,
    SacV1Config, Td3Config, UpdateMetrics, evaluate,
};
use serde::Serialize;

use crate::plot::{PlotError, PlotLabels, Series, plot_curves};
use crate::registry::{RegistryError, make_env, make_vec_env};
use crate::residual::start_as_controller;

/// What to train.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainOptions {
    /// Environment name (see [`crate::registry`]).
    pub env: String,
    /// Algorithm.
    pub algo: AlgoKind,
    /// Environment steps.
    pub steps: u64,
    /// Seed (overrides the config file's `seed`).
    pub seed: u64,
    /// Output directory (created if missing).
    pub out: PathBuf,
    /// TOML file with the algorithm's hyperparameters (its config struct's fields).
    pub config: Option<PathBuf>,
    /// Threads stepping the environments.
    pub threads: usize,
    /// Number of environments.
    pub n_envs: usize,
    /// Deterministic evaluation episodes at the end (at least 10 are run).
    pub eval_episodes: usize,
}

/// The `summary.json` record.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Environment name.
    pub env: String,
    /// Algorithm name.
    pub algo: String,
    /// Seed.
    pub seed: u64,
    /// Environment steps taken.
    pub steps: u64,
    /// Wall-clock seconds of training (evaluation excluded).
    pub wall_seconds: f64,
    /// `steps / wall_seconds`.
    pub steps_per_second: f64,
    /// Mean return of the deterministic evaluation episodes.
    pub final_return_mean: f64,
    /// Their standard deviation.
    pub final_return_std: f64,
}

/// Why a training run failed.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The config file is unreadable or invalid (unknown keys are named).
    #[error("config {path}: {message}")]
    Config {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The environment could not be made.
    #[error(transparent)]
    Registry(#[from] RegistryError),
    /// Learning failed.
    #[error(transparent)]
    Rl(#[from] RlError),
    /// An output could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

fn parse<T: serde::de::DeserializeOwned>(text: &str, path: &Path) -> Result<T, TrainError> {
    toml::from_str(text).map_err(|e| TrainError::Config { path: path.to_path_buf(), message: e.to_string() })
}

/// The settings of a learner of kind `kind` from the TOML text of `path` (the fields of the
/// algorithm's config struct over its defaults; unknown keys are an error naming the key).
pub fn parse_algo_config(kind: AlgoKind, text: &str, path: &Path) -> Result<AlgoConfig, TrainError> {
    Ok(match kind {
        AlgoKind::Ppo => AlgoConfig::Ppo(parse::<PpoConfig>(text, path)?),
        AlgoKind::A2c => AlgoConfig::A2c(parse::<A2cConfig>(text, path)?),
        AlgoKind::Sac => AlgoConfig::Sac(parse::<SacConfig>(text, path)?),
        AlgoKind::SacV1 => AlgoConfig::SacV1(parse::<SacV1Config>(text, path)?),
        AlgoKind::Td3 => AlgoConfig::Td3(parse::<Td3Config>(text, path)?),
        AlgoKind::Ddpg => AlgoConfig::Ddpg(parse::<DdpgConfig>(text, path)?),
    })
}

/// Trains as `opts` says and writes the output directory; `progress` sees every metrics
/// record (the CLI draws its progress bar from it).
pub fn train(opts: &TrainOptions, progress: &mut dyn FnMut(&UpdateMetrics)) -> Result<Summary, TrainError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| TrainError::Io { path, source }
    };
    let config = match &opts.config {
        Some(p) => parse_algo_config(opts.algo, &std::fs::read_to_string(p).map_err(io(p))?, p)?,
        None => AlgoConfig::default_for(opts.algo),
    };
    let mut env = make_vec_env(&opts.env, opts.n_envs, opts.threads)?;
    let mut algo = config.with_seed(opts.seed).build(&env)?;
    if let Some(robot) = opts.env.strip_suffix("-residual") {
        let preset = crate::registry::residual_config(robot)?;
        start_as_controller(algo.as_mut(), opts.algo, &preset, env.action_space().dim())?;
    }
    std::fs::create_dir_all(&opts.out).map_err(io(&opts.out))?;

    let csv_path = opts.out.join("metrics.csv");
    let mut csv = MetricsCsv::create(&csv_path).map_err(io(&csv_path))?;
    let mut rows: Vec<UpdateMetrics> = Vec::new();
    let mut csv_error = None;
    let t0 = Instant::now();
    algo.learn(&mut env, opts.steps, &mut |m| {
        if let Err(e) = csv.write(m) {
            csv_error = Some(e);
            return ControlFlow::Break(());
        }
        rows.push(*m);
        progress(m);
        ControlFlow::Continue(())
    })?;
    let wall_seconds = t0.elapsed().as_secs_f64();
    if let Some(e) = csv_error {
        return Err(TrainError::Io { path: csv_path, source: e });
    }
    csv.flush().map_err(io(&csv_path))?;

    let ckpt = opts.out.join("checkpoint");
    let mut checkpoint = algo.to_checkpoint();
    checkpoint.set_meta("env", &opts.env);
    if let Some(path) = opts.env.strip_prefix("modular:") {
        // The body itself, so that the policy stays tied to it if the file changes.
        if let Ok(body) = std::fs::read_to_string(path) {
            checkpoint.set_meta("body", body);
        }
    }
    checkpoint.write(&ckpt).map_err(RlError::from)?;
    let mut policy = Policy::load(&ckpt).map_err(RlError::from)?;
    let mut eval_env = make_env(&opts.env)?;
    let eval = evaluate(&mut policy, eval_env.as_mut(), opts.eval_episodes.max(10), 1_000_000 + opts.seed)?;

    let curve = Series {
        label: format!("{} seed {}", algo.name(), opts.seed),
        x: rows.iter().map(|m| m.env_steps as f64).collect(),
        y: rows.iter().map(|m| m.episode_return_mean).collect(),
        lower: Some(rows.iter().map(|m| m.episode_return_mean - m.episode_return_std).collect()),
        upper: Some(rows.iter().map(|m| m.episode_return_mean + m.episode_return_std).collect()),
    };
    let labels = PlotLabels {
        title: format!("{} on {}", algo.name(), opts.env),
        x: "environment steps".into(),
        y: "episode return (training, mean ± std)".into(),
    };
    for ext in ["svg", "png"] {
        match plot_curves(
            &opts.out.join(format!("learning_curve.{ext}")),
            &labels,
            std::slice::from_ref(&curve),
        ) {
            Ok(()) | Err(PlotError::Empty { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }

    let steps = algo.steps_done();
    let summary = Summary {
        env: opts.env.clone(),
        algo: algo.name().to_string(),
        seed: opts.seed,
        steps,
        wall_seconds,
        steps_per_second: steps as f64 / wall_seconds.max(1e-9),
        final_return_mean: eval.mean,
        final_return_std: eval.std,
    };
    let path = opts.out.join("summary.json");
    let json = serde_json::to_string_pretty(&summary).expect("summary serialises");
    std::fs::write(&path, json + "\n").map_err(io(&path))?;
    Ok(summary)
}
