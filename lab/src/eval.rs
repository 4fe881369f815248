//! `centaur eval`: a trained policy's deterministic episodes on any configuration of its
//! environment — the seed study's judgement of one policy in a no-penalty and a
//! full-penalty environment — with a table and `eval.json`.
//!
//! The environment is the checkpoint's (its name, a modular body, its `[env]` settings as
//! trained) unless the options say otherwise: `--config FILE` takes the `[env]` table of a
//! run file (the algorithm's keys, if any, are ignored) in place of the training settings,
//! and `--env NAME` another environment whose spaces fit the policy. The output says which
//! settings differ from training.

use std::path::{Path, PathBuf};

use centaur_rl::{AlgoKind, Checkpoint, Policy, RlError};
use serde::Serialize;

use crate::experiment::{AgentStats, ExperimentError, evaluate_policy};
use crate::hybrid::{Fade, ResidualConfig};
use crate::registry::{EnvSource, RegistryError};
use crate::rundir::write_atomic;
use crate::settings::{EnvSettings, split_run_toml};
use crate::train::{TrainError, config_difference, read_config_file};

/// What to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalOptions {
    /// A checkpoint file, or a run directory holding `checkpoint`.
    pub checkpoint: PathBuf,
    /// A run file whose `[env]` table replaces the training settings.
    pub config: Option<PathBuf>,
    /// Another environment than the checkpoint's.
    pub env: Option<String>,
    /// Deterministic episodes (≥ 1).
    pub episodes: usize,
    /// Episode `k` resets with `seed + k`.
    pub seed: u64,
    /// Record the first episode to this MCAP file (robot environments).
    pub record: Option<PathBuf>,
    /// Where `eval.json` goes (default: beside the checkpoint).
    pub out: Option<PathBuf>,
    /// Evaluate even if the checkpoint's environment, as it records it, is no longer the
    /// one its name and settings build today (a preset or default changed since training).
    pub allow_env_change: bool,
    /// A hybrid's safety fade ([`crate::hybrid::ResidualConfig::fade`]), a filter on the
    /// trained policy; refused for an environment that is not a hybrid.
    pub fade: Option<Fade>,
}

/// The `eval.json` record.
#[derive(Clone, Debug, Serialize)]
pub struct EvalReport {
    /// The checkpoint evaluated.
    pub checkpoint: PathBuf,
    /// The environment.
    pub env: String,
    /// The `[env]` settings evaluated with.
    pub settings: EnvSettings,
    /// The `[env]` keys whose values differ from training.
    pub changed_from_training: Vec<&'static str>,
    /// First reset seed.
    pub seed: u64,
    /// The hybrid's safety fade, if it was evaluated behind one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fade: Option<Fade>,
    /// Episodes, return, speed, falls, energy, torque RMS (robots); return only otherwise.
    pub stats: AgentStats,
}

/// Why an evaluation failed.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// The checkpoint could not be read or holds no policy.
    #[error(transparent)]
    Rl(#[from] RlError),
    /// A file could not be read or written, or the config is invalid.
    #[error(transparent)]
    Train(#[from] TrainError),
    /// The environment could not be made.
    #[error(transparent)]
    Registry(#[from] RegistryError),
    /// The episodes could not be run.
    #[error(transparent)]
    Experiment(#[from] ExperimentError),
    /// Something the options ask for does not fit.
    #[error("{0}")]
    Refused(String),
}

/// The keys of `a` and `b` whose values differ.
fn changed(a: &EnvSettings, b: &EnvSettings) -> Vec<&'static str> {
    let (ja, jb) = (serde_json::to_value(a), serde_json::to_value(b));
    let (Ok(serde_json::Value::Object(ja)), Ok(serde_json::Value::Object(jb))) = (ja, jb) else {
        return Vec::new();
    };
    let mut keys: Vec<&'static str> = a.given().into_iter().chain(b.given()).collect();
    keys.sort_unstable();
    keys.dedup();
    keys.retain(|k| ja.get(*k) != jb.get(*k));
    keys
}

/// The learner that wrote `checkpoint` (a hybrid is rebuilt with its residual preset where
/// the checkpoint records no setup).
fn checkpoint_learner(checkpoint: &Checkpoint, file: &Path) -> Result<AlgoKind, EvalError> {
    AlgoKind::from_name(&checkpoint.algo).ok_or_else(|| {
        EvalError::Refused(format!("{}: unknown algorithm `{}`", file.display(), checkpoint.algo))
    })
}

/// The environment `checkpoint` (read from `file`) was trained on, from what it records and
/// nothing else: its environment (a body file's too), the `[env]` settings, the learner and,
/// for a hybrid, the whole setup it trained with (a spec's or a comparison's; the learner's
/// preset for a checkpoint that records none). `centaur eval` checks today's build of it
/// against the checkpoint's record; the Python package's `CentaurEnv.from_checkpoint`
/// builds it. A checkpoint that names no environment, or whose record does not parse, is
/// refused.
pub fn trained_source(checkpoint: &Checkpoint, file: &Path) -> Result<EnvSource, EvalError> {
    let env: String = checkpoint
        .get_meta("env")
        .map_err(|_| EvalError::Refused(format!("{} does not name its environment", file.display())))?;
    let settings: EnvSettings = match checkpoint.has_meta("env_settings") {
        true => checkpoint.get_meta("env_settings").map_err(RlError::from)?,
        false => EnvSettings::default(),
    };
    let body: Option<String> = checkpoint.get_meta("body").ok();
    let mut source = EnvSource::with_body(&env, body)
        .for_learner(checkpoint_learner(checkpoint, file)?)?
        .with_settings(settings)?;
    if checkpoint.has_meta("residual") {
        source = source.with_residual(checkpoint.get_meta("residual").map_err(RlError::from)?)?;
    }
    Ok(source)
}

/// Runs the evaluation and writes `eval.json`.
pub fn run_eval(opts: &EvalOptions) -> Result<EvalReport, EvalError> {
    if opts.episodes == 0 || opts.episodes > 100_000 {
        return Err(EvalError::Refused(format!("--episodes {}: must be 1 to 100000", opts.episodes)));
    }
    let file =
        if opts.checkpoint.is_dir() { opts.checkpoint.join("checkpoint") } else { opts.checkpoint.clone() };
    let checkpoint = Checkpoint::read(&file).map_err(RlError::from)?;
    let trained_env: Option<String> = checkpoint.get_meta("env").ok();
    let env = match (&opts.env, &trained_env) {
        (Some(e), _) => e.clone(),
        (None, Some(e)) => e.clone(),
        (None, None) => {
            return Err(EvalError::Refused(format!(
                "{} does not name its environment; give --env",
                file.display()
            )));
        }
    };
    let trained: EnvSettings = checkpoint.get_meta("env_settings").unwrap_or_default();
    let settings = match &opts.config {
        Some(path) => {
            let text = read_config_file(path)?;
            split_run_toml(&text).map_err(|message| TrainError::Config { path: path.clone(), message })?.0
        }
        None => trained.clone(),
    };
    let body: Option<String> = checkpoint.get_meta("body").ok();
    let learner = checkpoint_learner(&checkpoint, &file)?;
    // A hybrid is rebuilt with the setup it recorded (a spec's or a comparison's), when
    // evaluated on the environment it was trained on; else with the learner's preset.
    // A recorded setup that does not parse is refused, not replaced by the preset.
    let recorded_residual: Option<ResidualConfig> = match checkpoint.has_meta("residual") {
        true if Some(&env) == trained_env.as_ref() => {
            Some(checkpoint.get_meta("residual").map_err(RlError::from)?)
        }
        _ => None,
    };
    // The environment trained on, rebuilt today, must be the one the checkpoint records
    // (whatever the evaluation changes on top of it with --config).
    if let Ok(recorded) = checkpoint.get_meta::<String>("env_config")
        && Some(&env) == trained_env.as_ref()
        && !opts.allow_env_change
    {
        let today = trained_source(&checkpoint, &file)?.make()?.config_text();
        if let Some(difference) = today.and_then(|today| config_difference(&recorded, &today)) {
            return Err(EvalError::Refused(format!(
                "{}: `{env}` is no longer the environment this policy was trained on (a preset or default changed since): {difference}; evaluate anyway with --allow-env-change",
                file.display()
            )));
        }
    }
    let mut source = EnvSource::with_body(&env, body).for_learner(learner)?.with_settings(settings)?;
    if let Some(residual) = recorded_residual.clone() {
        source = source.with_residual(residual)?;
    }
    let policy = Policy::from_checkpoint(&checkpoint).map_err(RlError::from)?;
    let stats = if env == "pendulum" || env.starts_with("modular:") {
        if opts.fade.is_some() {
            return Err(ExperimentError::NotAHybrid { env, option: "a safety fade" }.into());
        }
        if opts.record.is_some() {
            return Err(EvalError::Refused(format!(
                "--record: {env} is not recorded (robot environments are)"
            )));
        }
        plain_stats(source.make()?.as_mut(), policy, opts)?
    } else {
        let record = opts.record.as_deref();
        evaluate_policy(&source, policy, opts.episodes, opts.seed, record, opts.fade)?
    };
    let report = EvalReport {
        checkpoint: file.clone(),
        env,
        changed_from_training: changed(source.settings(), &trained),
        settings: source.settings().clone(),
        seed: opts.seed,
        fade: opts.fade,
        stats,
    };
    let out =
        opts.out.clone().unwrap_or_else(|| file.parent().unwrap_or(Path::new(".")).join(default_name(opts)));
    let json = serde_json::to_string_pretty(&report).expect("the report serialises") + "\n";
    write_atomic(&out, &json).map_err(|source| TrainError::Io { path: out.clone(), source })?;
    Ok(report)
}

/// `eval.json` for the checkpoint as trained; with `--config FILE` or `--env NAME`,
/// `eval_FILE.json` / `eval_NAME.json` (both: `eval_NAME_FILE.json`), with `_fade` before
/// `.json` behind a safety fade, so that judging one policy in several configurations keeps
/// every judgement.
fn default_name(opts: &EvalOptions) -> String {
    let mut name = String::from("eval");
    if let Some(env) = &opts.env {
        // `modular:dir/body.json` → `modular_body`.
        let env = match env.strip_prefix("modular:") {
            Some(file) => {
                format!("modular_{}", Path::new(file).file_stem().unwrap_or_default().to_string_lossy())
            }
            None => env.clone(),
        };
        name.push('_');
        name.push_str(&env.replace(['/', ':', '\\'], "_"));
    }
    if let Some(stem) = opts.config.as_deref().and_then(Path::file_stem) {
        name.push('_');
        name.push_str(&stem.to_string_lossy());
    }
    if opts.fade.is_some() {
        name.push_str("_fade");
    }
    name + ".json"
}

/// Return statistics on an environment without a robot (the Pendulum, a body file's robot).
fn plain_stats(
    env: &mut dyn centaur_gym::Env,
    mut policy: Policy,
    opts: &EvalOptions,
) -> Result<AgentStats, EvalError> {
    let e = centaur_rl::evaluate(&mut policy, env, opts.episodes, opts.seed)?;
    Ok(AgentStats {
        return_mean: e.mean,
        return_std: e.std,
        episodes: e.returns.len(),
        length_mean: e.length_mean(),
        ..AgentStats::default()
    })
}

/// The report as a Markdown table.
pub fn markdown(r: &EvalReport) -> String {
    let s = &r.stats;
    let changed = if r.changed_from_training.is_empty() {
        "none".to_string()
    } else {
        r.changed_from_training.join(", ")
    };
    format!(
        "| env | episodes | return | length | speed (m/s) | falls | cost of transport | torque RMS |\n|---|---:|---:|---:|---:|---:|---:|---:|\n| {} | {} | {:.2} ± {:.2} | {:.0} | {:.3} | {}/{} | {} | {:.2} |\n\n[env] settings changed from training: {changed}\n",
        r.env,
        s.episodes,
        s.return_mean,
        s.return_std,
        s.length_mean,
        s.mean_speed,
        s.falls,
        s.episodes,
        s.cost_of_transport.map_or("—".to_string(), |c| format!("{c:.2}")),
        s.torque_rms,
    )
}
