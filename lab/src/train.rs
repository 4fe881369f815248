//! `centaur train`: build a learner from a name and a TOML file, train it on a registered
//! environment, and write the run's artefacts — a run that can be killed at any moment and
//! resumed to the same result.
//!
//! Output directory:
//!
//! | file | content |
//! |---|---|
//! | `run.json` | the run's record ([`RunRecord`]), written first: every option, the config file's text and a modular body's text, so that `--resume` needs nothing else |
//! | `metrics.csv` | one [`UpdateMetrics`] row per update / log interval; flushed and `fsync`ed at every checkpoint |
//! | `episodes.csv` | every finished training episode: the run's step at its end, env index, return, length, terminated, each reward term summed over it |
//! | `checkpoint` | the learner ([`centaur_rl::Checkpoint`] format, plus the env name under `env`): act with `Policy::load`, resume with `centaur train --resume DIR`; rewritten atomically every `checkpoint_every` steps and at the end |
//! | `evaluations.csv` | with `eval_every`: `step,return_mean,return_std,length_mean,episodes`, the deterministic evaluation of the checkpoint taken every `eval_every` steps, at the end of the rollout that crosses each multiple (its `step`; the same episodes as the final one, which is its last row) |
//! | `summary.json` | `{"env", "algo", "seed", "steps", "wall_seconds", "steps_per_second", "final_return_mean", "final_return_std"}`, written (atomically) before the plots |
//! | `learning_curve.svg`, `learning_curve.png` | mean training episode return (± std band) against environment steps |
//! | `metrics.svg`, `metrics.png` | every logged metric the learner has (return, length, losses, entropy, KL, clip fraction, explained variance, Q, α, learning rate, speed) against environment steps |
//!
//! The final return is the mean over `eval_episodes` (≥ 10 by default) deterministic
//! episodes of the policy **loaded back from the checkpoint** (the deployment path), on a
//! fresh environment reset with seeds `1_000_000 + seed + k`.
//!
//! ## Checkpoints and resume
//! Training runs in segments of `checkpoint_every` environment steps (on-policy learners end
//! a segment at the first update boundary at or past it). Each segment starts on fresh
//! environments reset with seed `seed + steps done` — the episodes in flight at a checkpoint
//! are cut there, as a time limit would — so that a resumed run, which cannot restore the
//! simulator's state, continues exactly as the uninterrupted run does: with the same seed,
//! `--resume` ends with the same metrics, checkpoint and evaluation bit for bit (thread
//! counts do not change results). `checkpoint_every = 0` trains in one segment.
//!
//! A directory that already holds a run is refused unless the run is resumed or
//! `overwrite` is set (which removes the run's files, and only those).

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use centaur_gym::EpisodeLog;
use centaur_rl::{
    A2cConfig, AlgoConfig, AlgoKind, Algorithm, Checkpoint, DdpgConfig, MetricsCsv, Policy, PpoConfig,
    RlError, SacConfig, SacV1Config, Td3Config, UpdateMetrics, evaluate,
};
use serde::{Deserialize, Serialize};

use crate::plot::{Panel, PlotError, PlotLabels, Series, plot_curves, plot_panels};
use crate::registry::{EnvSource, RegistryError};
use crate::residual::start_as_controller;
use crate::rundir::{Claim, DirLock, claim, lock_dir, write_atomic};
use crate::settings::{EnvSettings, split_run_toml};
use crate::spec::ResolvedSpec;

/// The default checkpoint period of `centaur train`, in environment steps.
pub const DEFAULT_CHECKPOINT_EVERY: u64 = 100_000;

/// The largest config file read (1 MiB): `--config /dev/zero` is refused, not read forever.
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;

/// The files of a run directory, in the order a run writes them.
pub const RUN_FILES: [&str; 11] = [
    "run.json",
    "spec.json",
    "metrics.csv",
    "episodes.csv",
    "evaluations.csv",
    "checkpoint",
    "summary.json",
    "learning_curve.svg",
    "learning_curve.png",
    "metrics.svg",
    "metrics.png",
];

/// What to train.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainOptions {
    /// Environment name (see [`crate::registry`]).
    pub env: String,
    /// Algorithm.
    pub algo: AlgoKind,
    /// Environment steps.
    pub steps: u64,
    /// Seed; `None` keeps the config file's `seed` (the algorithm's default without one).
    pub seed: Option<u64>,
    /// Output directory (created if missing).
    pub out: PathBuf,
    /// TOML run file: the algorithm's hyperparameters (its config struct's fields) and an
    /// optional `[env]` table ([`crate::settings::EnvSettings`]).
    pub config: Option<PathBuf>,
    /// Threads stepping the environments (≥ 1; results do not depend on it).
    pub threads: usize,
    /// Number of environments (≥ 1).
    pub n_envs: usize,
    /// Deterministic evaluation episodes at the end (at least 10 are run).
    pub eval_episodes: usize,
    /// Environment steps between periodic checkpoints (0: only at the end).
    pub checkpoint_every: u64,
    /// Environment steps between deterministic evaluations (0: only at the end); a multiple
    /// of `checkpoint_every`, since each evaluates the checkpoint just written (so that
    /// training is the same with or without them).
    pub eval_every: u64,
    /// Replace a run already in `out` (its files only) instead of refusing.
    pub overwrite: bool,
    /// A resolved run spec ([`crate::spec::Purpose::Train`]) giving the learner's settings,
    /// the `[env]` settings and, on `<robot>-residual`, the hybrid's whole setup, instead of
    /// `config` (which must then be `None`); recorded in `run.json` and as `spec.json`.
    pub spec: Option<ResolvedSpec>,
}

/// `run.json`: everything a run was started with, so that `--resume` rebuilds it exactly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunRecord {
    /// Environment name.
    pub env: String,
    /// Algorithm name.
    pub algo: String,
    /// Environment steps of the whole run.
    pub steps: u64,
    /// The learner's seed (the option's, or the config file's).
    pub seed: u64,
    /// Number of environments.
    pub n_envs: usize,
    /// Deterministic evaluation episodes at the end.
    pub eval_episodes: usize,
    /// Environment steps between periodic checkpoints (0: only at the end).
    pub checkpoint_every: u64,
    /// Environment steps between deterministic evaluations (0: only at the end).
    #[serde(default)]
    pub eval_every: u64,
    /// The config file as given.
    pub config_file: Option<PathBuf>,
    /// Its text as read at the start.
    pub config: Option<String>,
    /// The body of `modular:FILE.json` as read at the start.
    pub body: Option<String>,
    /// The `[env]` settings of the config file (empty: the preset).
    #[serde(default)]
    pub env_settings: EnvSettings,
    /// The version of Centaur that started the run.
    pub centaur_version: String,
    /// The environment's whole configuration as built, presets resolved
    /// ([`centaur_gym::Env::config_text`]): a resume or an evaluation checks that today's
    /// environment is the same. Absent in runs recorded before it was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env_config: Option<String>,
    /// The resolved run spec the run was started from (`centaur train --spec`): its learner,
    /// `[env]` settings and hybrid setup are what a resume rebuilds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spec: Option<ResolvedSpec>,
}

/// Where the environment a run recorded (`recorded`, [`centaur_gym::Env::config_text`])
/// differs from the one built today, or `None` when it does not: the first value of the
/// record that today's lacks or holds otherwise, by its path. Fields only today's has (added
/// since) are no difference, but for a hybrid's Minitaur (`robot.motor_inverse`): a record
/// without it was written before it existed, with the controller told the drawn motor
/// ([`centaur_envs::minitaur::MotorInverse::legacy`]), and today's default is the nominal one.
/// Lists of gait offers (objects with a `gait` key, `ControllerConfig::gaits`) are compared
/// by gait: an offer added since (the Minitaur's bound and pronk) is no
/// difference to a run that never commanded it, while an offer the record holds must be
/// today's. A record that is not JSON (an older one) is not compared.
pub fn config_difference(recorded: &str, today: &str) -> Option<String> {
    fn first(path: &str, r: &serde_json::Value, t: Option<&serde_json::Value>) -> Option<String> {
        match (r, t) {
            (serde_json::Value::Object(r), Some(serde_json::Value::Object(t))) => {
                let legacy_inverse = match (path, r.get("motor_inverse"), t.get("motor_inverse")) {
                    ("robot", None, Some(today)) if today != "drawn" => Some(format!(
                        "robot.motor_inverse: recorded absent (the drawn motor, the earlier default), today {today}"
                    )),
                    _ => None,
                };
                legacy_inverse.or_else(|| {
                    r.iter().find_map(|(k, v)| {
                        let sub = if path.is_empty() { k.clone() } else { format!("{path}.{k}") };
                        first(&sub, v, t.get(k))
                    })
                })
            }
            (serde_json::Value::Array(r), Some(serde_json::Value::Array(t)))
                if is_offers(r) && is_offers(t) =>
            {
                r.iter().find_map(|offer| {
                    let gait = &offer["gait"];
                    let sub = format!("{path}[gait {gait}]");
                    first(&sub, offer, t.iter().find(|o| o["gait"] == *gait))
                })
            }
            (serde_json::Value::Array(r), Some(serde_json::Value::Array(t))) if r.len() == t.len() => {
                r.iter().zip(t).enumerate().find_map(|(i, (r, t))| first(&format!("{path}[{i}]"), r, Some(t)))
            }
            (r, Some(t)) if r == t => None,
            (r, Some(t)) => Some(format!("{path}: recorded {r}, today {t}")),
            (r, None) => Some(format!("{path}: recorded {r}, today absent")),
        }
    }
    fn is_offers(list: &[serde_json::Value]) -> bool {
        !list.is_empty() && list.iter().all(|o| o.get("gait").is_some_and(|g| g.is_string()))
    }
    let recorded: serde_json::Value = serde_json::from_str(recorded).ok()?;
    let today: serde_json::Value = serde_json::from_str(today).ok()?;
    first("", &recorded, Some(&today))
}

/// The `summary.json` record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Environment name.
    pub env: String,
    /// Algorithm name.
    pub algo: String,
    /// Seed.
    pub seed: u64,
    /// Environment steps taken.
    pub steps: u64,
    /// Wall-clock seconds of training (evaluation excluded; summed over resumed sessions).
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
    /// A numeric option is out of its range.
    #[error("--{option} {value}: {reason}")]
    BadOption {
        /// The option.
        option: &'static str,
        /// Its value.
        value: String,
        /// The range it must be in.
        reason: &'static str,
    },
    /// The output directory already holds a run.
    #[error(
        "{dir} already holds a run ({file}); resume it with `--resume {dir}`, replace it with `--overwrite`, or choose another --out"
    )]
    RunExists {
        /// The directory.
        dir: PathBuf,
        /// The run file found there.
        file: &'static str,
    },
    /// Another process is writing a run in the directory.
    #[error(
        "another process is writing a run in {dir} (it holds {dir}/{lock}); wait for it to end or choose another --out",
        lock = crate::rundir::LOCK_FILE
    )]
    Busy {
        /// The directory.
        dir: PathBuf,
    },
    /// The directory to resume holds no run, or one that does not fit together.
    #[error("cannot resume {dir}: {reason}")]
    Resume {
        /// The directory.
        dir: PathBuf,
        /// Why.
        reason: String,
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

/// The algorithm's settings from an already parsed table (a run file less its `[env]`).
fn parse_table<T: serde::de::DeserializeOwned>(table: toml::Table, path: &Path) -> Result<T, TrainError> {
    T::deserialize(toml::Value::Table(table))
        .map_err(|e| TrainError::Config { path: path.to_path_buf(), message: e.to_string() })
}

/// A run file: the algorithm's settings at the top level (as [`parse_algo_config`]) and the
/// environment's in an optional `[env]` table ([`crate::settings`]).
pub fn parse_run_config(
    kind: AlgoKind,
    text: &str,
    path: &Path,
) -> Result<(AlgoConfig, EnvSettings), TrainError> {
    let (settings, rest) =
        split_run_toml(text).map_err(|message| TrainError::Config { path: path.to_path_buf(), message })?;
    let Some(table) = rest else {
        return Ok((parse_algo_config(kind, text, path)?, settings));
    };
    let algo = match kind {
        AlgoKind::Ppo => AlgoConfig::Ppo(parse_table::<PpoConfig>(table, path)?),
        AlgoKind::A2c => AlgoConfig::A2c(parse_table::<A2cConfig>(table, path)?),
        AlgoKind::Sac => AlgoConfig::Sac(parse_table::<SacConfig>(table, path)?),
        AlgoKind::SacV1 => AlgoConfig::SacV1(parse_table::<SacV1Config>(table, path)?),
        AlgoKind::Td3 => AlgoConfig::Td3(parse_table::<Td3Config>(table, path)?),
        AlgoKind::Ddpg => AlgoConfig::Ddpg(parse_table::<DdpgConfig>(table, path)?),
    };
    Ok((algo, settings))
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

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> TrainError + '_ {
    move |source| TrainError::Io { path: path.to_path_buf(), source }
}

/// Reads a config file once, bounded by [`MAX_CONFIG_BYTES`].
pub fn read_config_file(path: &Path) -> Result<String, TrainError> {
    crate::rundir::read_text_bounded(path, MAX_CONFIG_BYTES).map_err(|e| match e {
        crate::rundir::ReadError::Io(source) => TrainError::Io { path: path.to_path_buf(), source },
        other => TrainError::Config { path: path.to_path_buf(), message: other.to_string() },
    })
}

/// `source` with the hybrid setup of `spec`, where it has one.
fn spec_source(source: EnvSource, spec: Option<&ResolvedSpec>) -> Result<EnvSource, TrainError> {
    match spec.and_then(|s| s.hybrid.clone()) {
        Some(residual) => Ok(source.with_residual(residual)?),
        None => Ok(source),
    }
}

/// Makes `dir` ready for a new run: creates it, refuses one that already holds a run unless
/// `overwrite` (then removes the run's files, nothing else).
fn prepare_new_run_dir(dir: &Path, overwrite: bool) -> Result<DirLock, TrainError> {
    claim(dir, &RUN_FILES, overwrite).map_err(|c| claim_err(dir, c))
}

fn claim_err(dir: &Path, c: Claim) -> TrainError {
    match c {
        Claim::Taken(file) => TrainError::RunExists { dir: dir.to_path_buf(), file },
        Claim::Busy => TrainError::Busy { dir: dir.to_path_buf() },
        Claim::Io(path, source) => TrainError::Io { path, source },
    }
}

/// Checks the numeric options (no silent `0 → 1`).
fn validate(opts: &TrainOptions) -> Result<(), TrainError> {
    let bad = |option, value: usize, reason| {
        Err(TrainError::BadOption { option, value: value.to_string(), reason })
    };
    if opts.n_envs == 0 || opts.n_envs > 4096 {
        return bad("envs", opts.n_envs, "must be 1 to 4096");
    }
    if opts.threads == 0 || opts.threads > 1024 {
        return bad("threads", opts.threads, "must be 1 to 1024");
    }
    if opts.eval_episodes == 0 || opts.eval_episodes > 100_000 {
        return bad("eval-episodes", opts.eval_episodes, "must be 1 to 100000 (at least 10 are run)");
    }
    if opts.eval_every > 0
        && (opts.checkpoint_every == 0 || !opts.eval_every.is_multiple_of(opts.checkpoint_every))
    {
        return Err(TrainError::BadOption {
            option: "eval-every",
            value: opts.eval_every.to_string(),
            reason: "must be a multiple of --checkpoint-every (each evaluation is of the checkpoint just written)",
        });
    }
    Ok(())
}

/// Refuses a checkpoint period shorter than one episode of every env when the run has more
/// than one segment: each segment starts fresh episodes, so such a period would cut every
/// episode short and train on another task than the one asked for, silently. An on-policy
/// learner's segment ends at a whole rollout (`n_steps` per env), which counts.
fn check_checkpoint_period(
    opts: &TrainOptions,
    config: &AlgoConfig,
    episode: usize,
) -> Result<(), TrainError> {
    if opts.checkpoint_every == 0 || opts.checkpoint_every >= opts.steps {
        return Ok(());
    }
    let n_envs = opts.n_envs as u64;
    let rollout = match config {
        AlgoConfig::Ppo(c) => c.n_steps as u64,
        AlgoConfig::A2c(c) => c.n_steps as u64,
        _ => 1,
    };
    let per_env = opts.checkpoint_every.div_ceil(n_envs * rollout) * rollout;
    if per_env < episode as u64 {
        return Err(TrainError::BadOption {
            option: "checkpoint-every",
            value: format!("{} ({} per env; an episode is {episode} steps)", opts.checkpoint_every, per_env),
            reason: "must give every env at least one whole episode per segment (each checkpoint starts fresh episodes); 0: only at the end",
        });
    }
    Ok(())
}

/// The learner a run starts with: `config` with `seed`, its learning-rate schedule over the
/// whole budget (so that training in segments anneals as one call would), and for a hybrid
/// env the controller's start (zero mean output, the preset's exploration).
fn new_learner(
    config: AlgoConfig,
    seed: u64,
    steps: u64,
    source: &EnvSource,
    n_envs: usize,
) -> Result<Box<dyn Algorithm>, TrainError> {
    let kind = config.kind();
    let probe = source.make_vec(n_envs, 1)?;
    let mut algo = config.with_seed(seed).with_default_lr_decay_steps(steps).build(&probe)?;
    if let Some(preset) = source.residual() {
        start_as_controller(algo.as_mut(), kind, &preset, probe.action_space().dim())?;
    }
    Ok(algo)
}

/// Trains as `opts` says and writes the output directory; `progress` sees every metrics
/// record (the CLI draws its progress bar from it).
pub fn train(opts: &TrainOptions, progress: &mut dyn FnMut(&UpdateMetrics)) -> Result<Summary, TrainError> {
    validate(opts)?;
    let config_text = opts.config.as_deref().map(read_config_file).transpose()?;
    let (config, settings) = match (&opts.spec, &opts.config, &config_text) {
        (Some(_), Some(path), _) => {
            return Err(TrainError::Config {
                path: path.clone(),
                message: "a run spec holds the learner's settings: give --spec or --config, not both".into(),
            });
        }
        (Some(spec), ..) => (spec.learner_config(), spec.env.clone()),
        (None, Some(p), Some(text)) => parse_run_config(opts.algo, text, p)?,
        _ => (AlgoConfig::default_for(opts.algo), EnvSettings::default()),
    };
    let source = spec_source(
        EnvSource::read(&opts.env)?.for_learner(opts.algo)?.with_settings(settings)?,
        opts.spec.as_ref(),
    )?;
    let built = source.make()?;
    check_checkpoint_period(opts, &config, built.max_episode_steps())?;
    let env_config = built.config_text();
    drop(built);
    let seed = opts.seed.unwrap_or(config.seed());
    // The learner is built (its settings checked) before anything is written.
    let algo = new_learner(config, seed, opts.steps, &source, opts.n_envs)?;
    let _held = prepare_new_run_dir(&opts.out, opts.overwrite)?;
    let record = RunRecord {
        env: opts.env.clone(),
        algo: opts.algo.name().to_string(),
        steps: opts.steps,
        seed,
        n_envs: opts.n_envs,
        eval_episodes: opts.eval_episodes,
        checkpoint_every: opts.checkpoint_every,
        eval_every: opts.eval_every,
        config_file: opts.config.clone(),
        config: config_text,
        body: source.body().map(str::to_string),
        env_settings: source.settings().clone(),
        centaur_version: env!("CARGO_PKG_VERSION").to_string(),
        env_config,
        spec: opts.spec.clone(),
    };
    if let Some(spec) = &opts.spec {
        let path = opts.out.join("spec.json");
        write_atomic(&path, &spec.record_json()).map_err(io_err(&path))?;
    }
    let run_json = opts.out.join("run.json");
    write_atomic(&run_json, &(serde_json::to_string_pretty(&record).expect("the record serialises") + "\n"))
        .map_err(io_err(&run_json))?;
    let logs = RunLogs::create(&opts.out, &source)?;
    run_segments(&record, &source, &opts.out, opts.threads, algo, logs, progress)
}

/// The record (`run.json`) of the run in `dir`.
pub fn read_run_record(dir: &Path) -> Result<RunRecord, TrainError> {
    let fail = |reason: String| TrainError::Resume { dir: dir.to_path_buf(), reason };
    let run_json = dir.join("run.json");
    let text = std::fs::read_to_string(&run_json)
        .map_err(|e| fail(format!("no run record ({}: {e})", run_json.display())))?;
    serde_json::from_str(&text).map_err(|e| fail(format!("{}: {e}", run_json.display())))
}

/// Continues the run in `dir` from its last checkpoint (or from the start if it was killed
/// before its first one), with `threads` threads; a finished run returns its summary.
pub fn resume(
    dir: &Path,
    threads: usize,
    progress: &mut dyn FnMut(&UpdateMetrics),
) -> Result<Summary, TrainError> {
    let fail = |reason: String| TrainError::Resume { dir: dir.to_path_buf(), reason };
    if threads == 0 || threads > 1024 {
        return Err(TrainError::BadOption {
            option: "threads",
            value: threads.to_string(),
            reason: "must be 1 to 1024",
        });
    }
    let record = read_run_record(dir)?;
    let summary_path = dir.join("summary.json");
    if let Ok(text) = std::fs::read_to_string(&summary_path) {
        // Finished: nothing is written (also on a read-only copy).
        return serde_json::from_str(&text).map_err(|e| fail(format!("{}: {e}", summary_path.display())));
    }
    let _held = lock_dir(dir).map_err(|c| claim_err(dir, c))?;
    if let Some(spec) = &record.spec {
        // The record may have been edited: its spec is checked as a spec file is.
        spec.check().map_err(|e| fail(format!("run.json's spec: {e}")))?;
        if spec.robot != record.env || spec.algo != record.algo {
            return Err(fail(format!(
                "run.json's spec is of {} on {}, the record of {} on {}",
                spec.algo, spec.robot, record.algo, record.env
            )));
        }
    }
    let kind = AlgoKind::from_name(&record.algo)
        .ok_or_else(|| fail(format!("unknown algorithm `{}`", record.algo)))?;
    let source = spec_source(
        EnvSource::with_body(&record.env, record.body.clone())
            .for_learner(kind)?
            .with_settings(record.env_settings.clone())?,
        record.spec.as_ref(),
    )?;
    if let (Some(recorded), Some(today)) = (&record.env_config, source.make()?.config_text())
        && let Some(difference) = config_difference(recorded, &today)
    {
        return Err(fail(format!(
            "the environment is not the one the run started with (a preset or default changed since): {difference}"
        )));
    }
    let ckpt_path = dir.join("checkpoint");
    let csv_path = dir.join("metrics.csv");
    if !ckpt_path.exists() {
        // Killed before its first checkpoint: start again, exactly as the run began.
        let config_file = record.config_file.clone().unwrap_or_else(|| PathBuf::from("run.json"));
        let config = match (&record.spec, &record.config) {
            (Some(spec), _) => spec.learner_config(),
            (None, Some(text)) => parse_run_config(kind, text, &config_file)?.0,
            (None, None) => AlgoConfig::default_for(kind),
        };
        let algo = new_learner(config, record.seed, record.steps, &source, record.n_envs)?;
        let logs = RunLogs::create(dir, &source)?;
        return run_segments(&record, &source, dir, threads, algo, logs, progress);
    }
    let checkpoint = Checkpoint::read(&ckpt_path).map_err(RlError::from)?;
    let env: String = checkpoint.get_meta("env").map_err(RlError::from)?;
    if env != record.env || checkpoint.algo != record.algo {
        return Err(fail(format!(
            "the checkpoint is a `{}` learner on `{env}`, the run record says `{}` on `{}`",
            checkpoint.algo, record.algo, record.env
        )));
    }
    let rows_done: usize = checkpoint.get_meta("run_metrics_rows").map_err(RlError::from)?;
    let episodes_done: usize = checkpoint.get_meta("run_episode_rows").map_err(RlError::from)?;
    let wall_done: f64 = checkpoint.get_meta("run_wall_seconds").map_err(RlError::from)?;
    let algo = centaur_rl::learners::from_checkpoint(&checkpoint)?;
    let mut rows = MetricsCsv::read(&csv_path).map_err(io_err(&csv_path))?;
    if rows.len() < rows_done {
        return Err(fail(format!(
            "{} holds {} rows, the checkpoint was taken after {rows_done}",
            csv_path.display(),
            rows.len()
        )));
    }
    // Rows past the checkpoint were trained by the killed session; they are trained again.
    rows.truncate(rows_done);
    let mut text = UpdateMetrics::csv_header() + "\n";
    for m in &rows {
        text += &(m.csv_row() + "\n");
    }
    write_atomic(&csv_path, &text).map_err(io_err(&csv_path))?;
    let csv = MetricsCsv::append(&csv_path).map_err(io_err(&csv_path))?;
    let episodes =
        EpisodeCsv::truncated(&dir.join("episodes.csv"), episodes_done).map_err(|e| fail(e.to_string()))?;
    let evals_path = dir.join("evaluations.csv");
    let steps_done = algo.steps_done();
    let evaluations = if record.eval_every > 0 {
        // Evaluations past the checkpoint were of the killed session's later checkpoints.
        let mut kept = read_evaluations(&evals_path).map_err(io_err(&evals_path))?;
        kept.retain(|e| e.step <= steps_done);
        write_evaluations(&evals_path, &kept).map_err(io_err(&evals_path))?;
        kept
    } else {
        Vec::new()
    };
    let logs = RunLogs { csv, rows, episodes, evaluations, wall_seconds: wall_done };
    run_segments(&record, &source, dir, threads, algo, logs, progress)
}

/// `episodes.csv`: every finished training episode — the environment step at which it
/// ended (over the whole run), the environment index, return, length, whether it ended by
/// termination, and each reward term summed over the episode.
struct EpisodeCsv {
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    terms: usize,
    rows: usize,
}

impl EpisodeCsv {
    /// Creates the file with its header for an env whose reward terms are `names`.
    fn create(path: &Path, names: &[&str]) -> std::io::Result<EpisodeCsv> {
        use std::io::Write;
        let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
        let terms: Vec<String> = names.iter().map(|n| format!(",{n}")).collect();
        writeln!(out, "step,env,return,length,terminated{}", terms.concat())?;
        Ok(EpisodeCsv { path: path.to_path_buf(), out, terms: names.len(), rows: 0 })
    }

    /// The file of a killed run cut back to its first `rows` episodes, open for appending.
    fn truncated(path: &Path, rows: usize) -> std::io::Result<EpisodeCsv> {
        let text = std::fs::read_to_string(path)?;
        let mut lines = text.lines();
        let header = lines.next().unwrap_or_default();
        let kept: Vec<&str> = lines.take(rows).collect();
        if kept.len() < rows {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "{} holds {} episodes, the checkpoint was taken after {rows}",
                    path.display(),
                    kept.len()
                ),
            ));
        }
        let terms = header.split(',').count().saturating_sub(5);
        let mut text = format!("{header}\n");
        for l in &kept {
            text += l;
            text.push('\n');
        }
        write_atomic(path, &text)?;
        let file = std::fs::OpenOptions::new().append(true).open(path)?;
        Ok(EpisodeCsv { path: path.to_path_buf(), out: std::io::BufWriter::new(file), terms, rows })
    }

    /// Appends the episodes of `log`, their steps offset by `offset` (the run's steps before
    /// the segment's environments were made).
    fn drain(&mut self, log: &EpisodeLog, offset: u64) -> std::io::Result<()> {
        use std::io::Write;
        let mut log = log.lock().unwrap_or_else(|e| e.into_inner());
        for e in log.drain(..) {
            write!(
                self.out,
                "{},{},{},{},{}",
                offset + e.step,
                e.env,
                e.ret,
                e.length,
                u8::from(e.terminated)
            )?;
            for t in &e.terms[..self.terms.min(e.terms.len())] {
                write!(self.out, ",{t}")?;
            }
            writeln!(self.out)?;
            self.rows += 1;
        }
        Ok(())
    }

    /// Flushes and `fsync`s.
    fn sync(&mut self) -> std::io::Result<()> {
        use std::io::Write;
        self.out.flush()?;
        self.out.get_ref().sync_data()
    }
}

/// What a run has written so far, open for appending: its metrics rows, its episode log
/// and its training wall time.
struct RunLogs {
    csv: MetricsCsv,
    rows: Vec<UpdateMetrics>,
    episodes: EpisodeCsv,
    /// The rows of `evaluations.csv`.
    evaluations: Vec<Evaluation>,
    wall_seconds: f64,
}

/// One row of `evaluations.csv`: the deterministic evaluation of the checkpoint at `step`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    /// Environment steps trained.
    pub step: u64,
    /// Mean return.
    pub return_mean: f64,
    /// Its standard deviation.
    pub return_std: f64,
    /// Mean episode length.
    pub length_mean: f64,
    /// Episodes.
    pub episodes: usize,
}

const EVALUATIONS_HEADER: &str = "step,return_mean,return_std,length_mean,episodes";

/// Reads `evaluations.csv` (a missing file has no rows).
pub fn read_evaluations(path: &Path) -> std::io::Result<Vec<Evaluation>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    let bad = |line: &str| {
        std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not an evaluations.csv row: `{line}`"))
    };
    let mut lines = text.lines();
    if lines.next() != Some(EVALUATIONS_HEADER) {
        return Err(bad("header"));
    }
    lines
        .map(|line| {
            let c: Vec<&str> = line.split(',').collect();
            let [step, mean, std, length, episodes] = c[..] else { return Err(bad(line)) };
            let f = |s: &str| s.parse::<f64>().map_err(|_| bad(line));
            Ok(Evaluation {
                step: step.parse().map_err(|_| bad(line))?,
                return_mean: f(mean)?,
                return_std: f(std)?,
                length_mean: f(length)?,
                episodes: episodes.parse().map_err(|_| bad(line))?,
            })
        })
        .collect()
}

/// Writes `evaluations.csv` atomically (shortest round-trip floats).
fn write_evaluations(path: &Path, rows: &[Evaluation]) -> std::io::Result<()> {
    let mut text = format!("{EVALUATIONS_HEADER}\n");
    for e in rows {
        text += &format!("{},{},{},{},{}\n", e.step, e.return_mean, e.return_std, e.length_mean, e.episodes);
    }
    write_atomic(path, &text)
}

impl Evaluation {
    fn new(step: u64, stats: &centaur_rl::EvalStats) -> Evaluation {
        Evaluation {
            step,
            return_mean: stats.mean,
            return_std: stats.std,
            length_mean: stats.length_mean(),
            episodes: stats.lengths.len(),
        }
    }
}

impl RunLogs {
    /// Fresh `metrics.csv` and `episodes.csv` in `dir`.
    fn create(dir: &Path, source: &EnvSource) -> Result<RunLogs, TrainError> {
        let csv_path = dir.join("metrics.csv");
        let csv = MetricsCsv::create(&csv_path).map_err(io_err(&csv_path))?;
        let names = source.make()?.reward_term_names();
        let ep_path = dir.join("episodes.csv");
        let episodes = EpisodeCsv::create(&ep_path, names).map_err(io_err(&ep_path))?;
        Ok(RunLogs { csv, rows: Vec::new(), episodes, evaluations: Vec::new(), wall_seconds: 0.0 })
    }
}

/// Writes the learner as the run's checkpoint, with the run's position in its metadata.
fn write_checkpoint(
    algo: &dyn Algorithm,
    record: &RunRecord,
    path: &Path,
    logs: &RunLogs,
) -> Result<(), TrainError> {
    let mut checkpoint = algo.to_checkpoint();
    checkpoint.set_meta("env", &record.env);
    if let Some(body) = &record.body {
        // The body itself, so that the policy stays tied to it if the file changes.
        checkpoint.set_meta("body", body);
    }
    if !record.env_settings.is_empty() {
        checkpoint.set_meta("env_settings", &record.env_settings);
    }
    if let Some(config) = &record.env_config {
        checkpoint.set_meta("env_config", config);
    }
    if let Some(residual) = record.spec.as_ref().and_then(|s| s.hybrid.as_ref()) {
        // The hybrid's whole setup, so that an evaluation rebuilds it without the spec.
        checkpoint.set_meta("residual", residual);
    }
    checkpoint.set_meta("run_metrics_rows", logs.rows.len());
    checkpoint.set_meta("run_episode_rows", logs.episodes.rows);
    checkpoint.set_meta("run_wall_seconds", logs.wall_seconds);
    checkpoint.write(path).map_err(RlError::from)?;
    Ok(())
}

/// The deterministic evaluation of the policy in `ckpt` (loaded as deployed): the record's
/// episodes (at least 10), episode `k` reset with seed `1 000 000 + seed + k`.
fn evaluate_checkpoint(
    ckpt: &Path,
    source: &EnvSource,
    record: &RunRecord,
) -> Result<centaur_rl::EvalStats, TrainError> {
    let mut policy = Policy::load(ckpt).map_err(RlError::from)?;
    let mut eval_env = source.make()?;
    Ok(evaluate(&mut policy, eval_env.as_mut(), record.eval_episodes.max(10), 1_000_000 + record.seed)?)
}

/// Trains `algo` from where it is to the record's budget in checkpointed segments, then
/// evaluates, writes the summary and plots.
#[allow(clippy::too_many_arguments)]
fn run_segments(
    record: &RunRecord,
    source: &EnvSource,
    dir: &Path,
    threads: usize,
    mut algo: Box<dyn Algorithm>,
    mut logs: RunLogs,
    progress: &mut dyn FnMut(&UpdateMetrics),
) -> Result<Summary, TrainError> {
    let csv_path = dir.join("metrics.csv");
    let ckpt = dir.join("checkpoint");
    let every = record.checkpoint_every;
    let mut targets: Vec<u64> = if every > 0 {
        (1..)
            .map_while(|i: u64| i.checked_mul(every))
            .take_while(|&b| b < record.steps)
            .filter(|&b| b > algo.steps_done())
            .collect()
    } else {
        Vec::new()
    };
    targets.push(record.steps);
    let evals_path = dir.join("evaluations.csv");
    // Whether the checkpoint of the segment that ran to `target` (a multiple of
    // `checkpoint_every`, or the run's end) is evaluated. A learner finishes the rollout
    // that crosses a target, so its checkpoint (and the evaluation's row) may come a few
    // steps after it: the target decides, not the steps done (formerly the steps
    // done did, and a rollout that did not divide `eval_every` silently evaluated nothing).
    let due = |target: u64| {
        record.eval_every > 0
            && target > 0
            && target < record.steps
            && target.is_multiple_of(record.eval_every)
    };
    let resumed_at = algo.steps_done();
    // The target whose segment wrote the checkpoint resumed from.
    let resumed_target = resumed_at.checked_div(every).map_or(0, |k| k * every);
    if due(resumed_target) && ckpt.exists() && !logs.evaluations.iter().any(|e| e.step == resumed_at) {
        // Killed between the checkpoint and its evaluation.
        let stats = evaluate_checkpoint(&ckpt, source, record)?;
        logs.evaluations.push(Evaluation::new(resumed_at, &stats));
        write_evaluations(&evals_path, &logs.evaluations).map_err(io_err(&evals_path))?;
    }
    let log: EpisodeLog = Default::default();
    for target in targets {
        if algo.steps_done() >= target {
            continue;
        }
        let mut env = source.make_vec(record.n_envs, threads)?;
        env.log_episodes(log.clone());
        let offset = algo.steps_done();
        let mut write_error = None;
        let t0 = Instant::now();
        let RunLogs { csv, rows, episodes, .. } = &mut logs;
        algo.learn(&mut env, target, &mut |m| {
            if let Err(e) = csv.write(m) {
                write_error = Some((csv_path.clone(), e));
                return ControlFlow::Break(());
            }
            if let Err(e) = episodes.drain(&log, offset) {
                write_error = Some((episodes.path.clone(), e));
                return ControlFlow::Break(());
            }
            rows.push(*m);
            progress(m);
            ControlFlow::Continue(())
        })?;
        logs.wall_seconds += t0.elapsed().as_secs_f64();
        if let Some((path, source)) = write_error {
            return Err(TrainError::Io { path, source });
        }
        // Episodes that ended after the last record of the segment.
        logs.episodes.drain(&log, offset).map_err(io_err(&logs.episodes.path))?;
        logs.csv.sync().map_err(io_err(&csv_path))?;
        logs.episodes.sync().map_err(io_err(&logs.episodes.path))?;
        write_checkpoint(algo.as_ref(), record, &ckpt, &logs)?;
        if due(target) {
            let stats = evaluate_checkpoint(&ckpt, source, record)?;
            logs.evaluations.push(Evaluation::new(algo.steps_done(), &stats));
            write_evaluations(&evals_path, &logs.evaluations).map_err(io_err(&evals_path))?;
        }
    }
    if algo.steps_done() == 0 || !ckpt.exists() {
        // A zero-step run still leaves its (untrained) checkpoint.
        write_checkpoint(algo.as_ref(), record, &ckpt, &logs)?;
    }
    let (rows, wall_seconds) = (logs.rows, logs.wall_seconds);
    let eval = evaluate_checkpoint(&ckpt, source, record)?;
    if record.eval_every > 0 {
        let mut evaluations = logs.evaluations;
        evaluations.retain(|e| e.step < algo.steps_done());
        evaluations.push(Evaluation::new(algo.steps_done(), &eval));
        write_evaluations(&evals_path, &evaluations).map_err(io_err(&evals_path))?;
    }

    let steps = algo.steps_done();
    let summary = Summary {
        env: record.env.clone(),
        algo: algo.name().to_string(),
        seed: record.seed,
        steps,
        wall_seconds,
        steps_per_second: steps as f64 / wall_seconds.max(1e-9),
        final_return_mean: eval.mean,
        final_return_std: eval.std,
    };
    let json = serde_json::to_string_pretty(&summary).expect("summary serialises");
    let summary_path = dir.join("summary.json");
    write_atomic(&summary_path, &(json + "\n")).map_err(io_err(&summary_path))?;

    let curve = Series {
        label: format!("{} seed {}", algo.name(), record.seed),
        x: rows.iter().map(|m| m.env_steps as f64).collect(),
        y: rows.iter().map(|m| m.episode_return_mean).collect(),
        lower: Some(rows.iter().map(|m| m.episode_return_mean - m.episode_return_std).collect()),
        upper: Some(rows.iter().map(|m| m.episode_return_mean + m.episode_return_std).collect()),
    };
    let labels = PlotLabels {
        title: format!("{} on {}", algo.name(), record.env),
        x: "environment steps".into(),
        y: "episode return (training, mean ± std)".into(),
    };
    for ext in ["svg", "png"] {
        match plot_curves(&dir.join(format!("learning_curve.{ext}")), &labels, std::slice::from_ref(&curve)) {
            Ok(()) | Err(PlotError::Empty { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    // Every logged metric against the steps (the ones the learner does not have are NaN
    // and left out).
    let panels: Vec<Panel> = UpdateMetrics::COLUMNS
        .iter()
        .enumerate()
        .filter(|(k, _)| !matches!(k, 0 | 1 | 2 | 4))
        .map(|(k, name)| Panel {
            title: name.replace('_', " "),
            points: rows.iter().map(|m| (m.env_steps as f64, m.values()[k])).collect(),
        })
        .collect();
    let title = format!("{} on {}: training metrics", algo.name(), record.env);
    for ext in ["svg", "png"] {
        match plot_panels(&dir.join(format!("metrics.{ext}")), &title, "environment steps", &panels) {
            Ok(()) | Err(PlotError::Empty { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::config_difference;

    #[test]
    fn a_field_added_since_is_no_difference_but_a_hybrids_legacy_motor_inverse_is() {
        let (old, new) = (r#"{"a": 1, "b": {"c": 2}}"#, r#"{"a": 1, "b": {"c": 2, "d": 3}}"#);
        assert_eq!(config_difference(old, new), None);
        assert_eq!(config_difference(new, old).unwrap(), "b.d: recorded 3, today absent");
        assert_eq!(config_difference(r#"{"a": 1}"#, r#"{"a": 2}"#).unwrap(), "a: recorded 1, today 2");
        // A pure learner's Minitaur never uses the inverse: a record without it is the same env.
        assert_eq!(config_difference(r#"{"x": 1}"#, r#"{"x": 1, "motor_inverse": "nominal"}"#), None);
        // A hybrid recorded before the field existed was told the drawn motor.
        let hybrid = |robot: &str| format!(r#"{{"robot": {robot}, "residual": {{"scale": 0.25}}}}"#);
        let (legacy, nominal, drawn) = (
            hybrid(r#"{"x": 1}"#),
            hybrid(r#"{"x": 1, "motor_inverse": "nominal"}"#),
            hybrid(r#"{"x": 1, "motor_inverse": "drawn"}"#),
        );
        let d = config_difference(&legacy, &nominal).unwrap();
        assert!(
            d.starts_with("robot.motor_inverse: recorded absent") && d.ends_with("today \"nominal\""),
            "{d}"
        );
        assert_eq!(config_difference(&legacy, &drawn), None);
        assert_eq!(config_difference(&nominal, &nominal), None);
        assert!(config_difference(&drawn, &nominal).unwrap().contains("recorded \"drawn\""));
    }

    #[test]
    fn gait_offers_are_compared_by_gait_and_an_offer_added_since_is_no_difference() {
        let offers = |list: &str| format!(r#"{{"controller": {{"gaits": [{list}], "k": 1}}}}"#);
        let (stand, trot) =
            (r#"{"gait": "Stand", "max_speed": 0.0}"#, r#"{"gait": "Trot", "max_speed": 2.5}"#);
        let bound = r#"{"gait": "Bound", "max_speed": 2.0, "com_height": 0.19}"#;
        let old = offers(&format!("{stand}, {trot}"));
        assert_eq!(config_difference(&old, &offers(&format!("{stand}, {trot}, {bound}"))), None);
        assert_eq!(config_difference(&old, &offers(&format!("{bound}, {trot}, {stand}"))), None, "order");
        // An offer the run had must still be there, and the same.
        let d = config_difference(&old, &offers(stand)).unwrap();
        assert_eq!(
            d,
            r#"controller.gaits[gait "Trot"]: recorded {"gait":"Trot","max_speed":2.5}, today absent"#
        );
        let faster = r#"{"gait": "Trot", "max_speed": 3.0}"#;
        let d = config_difference(&old, &offers(&format!("{stand}, {faster}"))).unwrap();
        assert_eq!(d, r#"controller.gaits[gait "Trot"].max_speed: recorded 2.5, today 3.0"#);
        // Other lists are compared element by element, their lengths included.
        assert!(config_difference(r#"{"w": [1, 2]}"#, r#"{"w": [1, 2, 3]}"#).is_some());
    }
}
