//! Training the two agents (side by side when there are threads to spare) and evaluating
//! the three: [`run_experiment`].

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use centaur_envs::minitaur::MotorInverse;
use centaur_gym::{Env, VecEnv};
use centaur_mpc::LocomotionController;
use centaur_rl::{Algorithm, MetricsCsv, Policy, RlError, UpdateMetrics};

use super::evaluation::{Driver, evaluate};
use super::options::{Curve, ExperimentError, ExperimentOptions, ExperimentResult, Phase, io_err};
use super::summary::{AgentStats, BudgetEval, ExperimentSummary};
use crate::hybrid::{ActionMapping, HybridError, ResidualConfig};
use crate::plot::{PlotError, PlotLabels, Series, plot_curves};
use crate::registry::{controller_config, controller_motor, make_residual_env_with, make_robot_env_with};
use crate::residual::start_as_controller;
use crate::rundir::{Claim, DirLock, claim, write_atomic};
use crate::settings::EnvSettings;

fn vec_env_of(
    make: &mut dyn FnMut() -> Result<Box<dyn Env>, ExperimentError>,
    n: usize,
    threads: usize,
) -> Result<VecEnv, ExperimentError> {
    let envs = (0..n.max(1)).map(|_| make()).collect::<Result<Vec<_>, _>>()?;
    Ok(VecEnv::new(envs, threads)?)
}

/// What training one agent produced.
struct Trained {
    checkpoint: PathBuf,
    rows: Vec<UpdateMetrics>,
    wall: f64,
    steps: u64,
    budgets: Vec<BudgetEval>,
}

/// The budgets at which training pauses for an evaluation (before the final one).
fn budgets(opts: &ExperimentOptions) -> Vec<u64> {
    match opts.eval_every {
        Some(k) if k > 0 => (1..).map(|i| i * k).take_while(|&b| b < opts.steps).collect(),
        _ => Vec::new(),
    }
}

/// Trains one agent; returns its checkpoint path, metrics, wall time and the evaluations
/// at the intermediate budgets.
fn train_one(
    opts: &ExperimentOptions,
    dir: &Path,
    env: &mut VecEnv,
    phase: Phase,
    progress: &mut dyn FnMut(Phase, &UpdateMetrics),
    stop: &AtomicBool,
) -> Result<Trained, ExperimentError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let pauses = budgets(opts);
    let learner = if phase == Phase::TrainHybrid { opts.hybrid_learner() } else { &opts.algo };
    let mut config = learner.clone().with_seed(opts.seed);
    if !pauses.is_empty() {
        // Chunks of training with the schedule of the whole budget.
        config = config.with_default_lr_decay_steps(opts.steps);
    }
    let mut algo: Box<dyn Algorithm> = config.build(env)?;
    if phase == Phase::TrainHybrid {
        start_as_controller(algo.as_mut(), opts.algo.kind(), &opts.residual, env.action_space().dim())?;
    }
    let csv_path = dir.join("metrics.csv");
    let mut csv = MetricsCsv::create(&csv_path).map_err(io_err(&csv_path))?;
    let mut rows = Vec::new();
    let mut csv_error = None;
    let mut evals = Vec::new();
    let mut eval_time = 0.0;
    let t0 = Instant::now();
    for target in pauses.iter().copied().chain(std::iter::once(opts.steps)) {
        algo.learn(env, target, &mut |m| {
            if stop.load(Ordering::Relaxed) {
                return ControlFlow::Break(());
            }
            if let Err(e) = csv.write(m) {
                csv_error = Some(e);
                return ControlFlow::Break(());
            }
            rows.push(*m);
            progress(phase, m);
            ControlFlow::Continue(())
        })?;
        if stop.load(Ordering::Relaxed) || csv_error.is_some() || target == opts.steps {
            break;
        }
        let t_eval = Instant::now();
        let wall_seconds = t0.elapsed().as_secs_f64() - eval_time;
        let mut driver = match phase {
            Phase::TrainHybrid => Driver::Hybrid {
                env: Box::new(make_residual_env_with(&opts.env, opts.residual.clone(), &opts.env_settings)?),
                policy: algo.policy(),
            },
            _ => Driver::Pure {
                env: make_robot_env_with(&opts.env, &opts.env_settings)?,
                policy: algo.policy(),
            },
        };
        let stats = evaluate(&mut driver, opts.eval_episodes, 1_000_000 + opts.seed, None)?;
        evals.push(BudgetEval {
            env_steps: algo.steps_done(),
            wall_seconds,
            return_mean: stats.return_mean,
            falls: stats.falls,
            episodes: stats.episodes,
        });
        eval_time += t_eval.elapsed().as_secs_f64();
    }
    let wall = t0.elapsed().as_secs_f64() - eval_time;
    if stop.load(Ordering::Relaxed) {
        return Err(ExperimentError::Stopped);
    }
    if let Some(e) = csv_error {
        return Err(ExperimentError::Io { path: csv_path, source: e });
    }
    csv.flush().map_err(io_err(&csv_path))?;
    let checkpoint = dir.join("checkpoint");
    // The checkpoint names what it acts on, so that `centaur eval` and an embedding need no
    // flag: the environment (the hybrid's `<robot>-residual`), its settings and the hybrid's
    // whole setup.
    let mut saved = algo.to_checkpoint();
    let hybrid = phase == Phase::TrainHybrid;
    saved.set_meta("env", if hybrid { format!("{}-residual", opts.env) } else { opts.env.clone() });
    if !opts.env_settings.is_empty() {
        saved.set_meta("env_settings", &opts.env_settings);
    }
    if hybrid {
        saved.set_meta("residual", &opts.residual);
    }
    saved.write(&checkpoint).map_err(RlError::from)?;
    Ok(Trained { checkpoint, rows, wall, steps: algo.steps_done(), budgets: evals })
}

/// The files and folders an experiment writes into its directory.
pub const EXPERIMENT_FILES: [&str; 11] = [
    "experiment.json",
    "summary.json",
    "learning_curves.png",
    "learning_curves.svg",
    "pure_rl",
    "hybrid",
    "pure_rl.mcap",
    "hybrid.mcap",
    "controller.mcap",
    "robustness.json",
    "robustness_nominal_motor.json",
];

/// `experiment.json`: what a run directory was run with.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct ExperimentRecord {
    env: String,
    algo: String,
    steps: u64,
    seed: u64,
    /// [`ExperimentOptions::identity`]; records of an older Centaur lack it (they are
    /// refused as such: [`ExperimentError::OlderRecord`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    identity: Option<String>,
    /// [`ExperimentOptions::pure_identity`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pure_identity: Option<String>,
    /// [`ExperimentOptions::options`], whose identity the record holds: a difference is
    /// named by its key.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    options: Option<serde_json::Value>,
    /// The hybrid's setup, as data.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    residual: Option<ResidualConfig>,
    /// The `[env]` settings of both agents (absent: the preset).
    #[serde(default, skip_serializing_if = "EnvSettings::is_empty")]
    env_settings: EnvSettings,
    /// The run whose pure-RL agent this one reused ([`ExperimentOptions::pure_from`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pure_from: Option<PathBuf>,
    /// The motor the controller was told, on a Minitaur ([`controller_motor`]; `None`:
    /// another robot).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    controller_motor: Option<MotorInverse>,
    /// The robot's controller preset the hybrid ran on (`ControllerConfig`, every gain and
    /// weight).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    controller: Option<serde_json::Value>,
}

impl ExperimentRecord {
    /// The record as this Centaur writes it: refused as [`ExperimentError::OlderRecord`]
    /// where it lacks the identity, the options or the hybrid's setup.
    fn current(self, dir: &Path) -> Result<CurrentRecord, ExperimentError> {
        match (self.identity.clone(), self.pure_identity.clone(), self.options.clone(), self.residual.clone())
        {
            (Some(identity), Some(pure_identity), Some(options), Some(residual)) => {
                Ok(CurrentRecord { identity, pure_identity, options, residual, record: self })
            }
            _ => Err(ExperimentError::OlderRecord { dir: dir.to_path_buf() }),
        }
    }
}

/// An [`ExperimentRecord`] with every part this Centaur writes.
struct CurrentRecord {
    identity: String,
    pure_identity: String,
    options: serde_json::Value,
    residual: ResidualConfig,
    record: ExperimentRecord,
}

/// What a run's hybrid was trained with, as far as the studies that reuse it need to know
/// ([`check_trained_with`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TrainedWith {
    /// The motor the controller was told, on a Minitaur (`None`: another robot); the studies
    /// tell it the same unless asked otherwise.
    pub controller_motor: Option<MotorInverse>,
    /// Whether both agents observed the robot's body state (`[env] observe_body_state`,
    /// the Minitaur's); the studies build their environments with it.
    pub observe_body_state: bool,
    /// Where the robot's controller preset differs from the one the run recorded (a preset
    /// changed since it trained): the first difference, `key: recorded …, given …`. The
    /// studies run today's preset and warn with it.
    pub controller_changed: Option<String>,
}

/// Creates the run directory, refusing one that already holds a run unless `overwrite`
/// (which removes the run's files and folders, nothing else), and writes `experiment.json`.
fn prepare_run_dir(opts: &ExperimentOptions) -> Result<DirLock, ExperimentError> {
    let dir = &opts.out;
    let lock = claim(dir, &EXPERIMENT_FILES, opts.overwrite).map_err(|c| match c {
        Claim::Taken(file) => ExperimentError::RunExists { dir: dir.clone(), file },
        Claim::Busy => ExperimentError::Busy { dir: dir.clone() },
        Claim::Io(path, source) => ExperimentError::Io { path, source },
    })?;
    let record = ExperimentRecord {
        env: opts.env.clone(),
        algo: opts.algo.kind().name().to_string(),
        steps: opts.steps,
        seed: opts.seed,
        identity: Some(opts.identity()),
        pure_identity: Some(opts.pure_identity()),
        options: Some(opts.options()),
        residual: Some(opts.residual.clone()),
        env_settings: opts.env_settings.clone(),
        pure_from: opts.pure_from.as_deref().map(crate::rundir::recorded_path),
        controller_motor: controller_motor(&opts.env, &opts.env_settings),
        controller: controller_config(&opts.env).ok().and_then(|c| serde_json::to_value(c).ok()),
    };
    let path = dir.join("experiment.json");
    let text = serde_json::to_string_pretty(&record).expect("the record serialises") + "\n";
    write_atomic(&path, &text).map_err(io_err(&path))?;
    Ok(lock)
}

/// The hybrid a run directory (one seed of `centaur compare`, or an example's run)
/// recorded in its `experiment.json`: the robot and the hybrid's whole setup, which the
/// studies that reuse the run build from, so that no flag has to be typed again. A record
/// of an older Centaur is [`ExperimentError::OlderRecord`].
pub fn recorded_hybrid(dir: &Path) -> Result<(String, ResidualConfig), ExperimentError> {
    let record = read_record(dir)?.current(dir)?;
    Ok((record.record.env, record.residual))
}

fn read_record(dir: &Path) -> Result<ExperimentRecord, ExperimentError> {
    let path = dir.join("experiment.json");
    let text = crate::train::read_config_file(&path).map_err(|e| match e {
        crate::train::TrainError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            ExperimentError::NotAnExperiment { dir: dir.to_path_buf() }
        }
        other => ExperimentError::Io {
            path: path.clone(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, other.to_string()),
        },
    })?;
    serde_json::from_str(&text).map_err(|e| ExperimentError::Io {
        path: path.clone(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
    })
}

/// Checks that the run in `dir` trained its hybrid with `residual`, the setup its
/// `experiment.json` records. A run evaluated with another setup (a different rating,
/// steering span or parts) would be judged on a controller it never saw. A rating equal to
/// the controller's own for the gait is the same controller as none
/// (`the_trots_own_rating_reproduces_the_old_preset_bit_for_bit`), so the two match. A run
/// trained with `[env]` settings is refused unless they only perturbed training
/// ([`crate::settings::TRAINING_ONLY`]: motor strength drawn at reset, pushes), set the
/// motor the controller is told or put the body state in the observation, both returned
/// ([`TrainedWith`]), since the callers run the robot's preset environment with them. Where
/// today's controller preset differs from the one recorded, the first difference is
/// returned for a warning ([`TrainedWith::controller_changed`]). The safety fade
/// ([`crate::hybrid::Fade`]) is not compared: a run may be evaluated with or without it.
/// A record of an older Centaur is [`ExperimentError::OlderRecord`]. `centaur robustness`
/// and `examples/embed_controller` check with it.
pub fn check_trained_with(dir: &Path, residual: &ResidualConfig) -> Result<TrainedWith, ExperimentError> {
    let CurrentRecord { residual: trained, record, .. } = read_record(dir)?.current(dir)?;
    // The studies that check with this run the robot's preset environment: settings that
    // only perturbed training (motor strength drawn at reset, pushes) leave its policies
    // fit for it, they tell the controller the motor it was told and give the policies the
    // observation they were trained on (the body state or not); any other changes the task.
    let task_keys: Vec<_> = record
        .env_settings
        .task_keys()
        .into_iter()
        .filter(|k| !["motor_inverse", "observe_body_state"].contains(k))
        .collect();
    if !task_keys.is_empty() {
        return Err(ExperimentError::EnvSettingsNotCovered {
            run: dir.to_path_buf(),
            keys: task_keys.join(", "),
        });
    }
    let own_rating = controller_config(&record.env)
        .ok()
        .and_then(|c| c.offer(residual.command.gait).ok().map(|o| o.max_speed));
    // The rating as the controller sees it: its own rating is no rating. The safety fade
    // is a filter on the trained policy, not part of what it was trained for.
    let unrated_if_own = |r: &ResidualConfig| match r.rated_speed {
        Some(v) if Some(v) == own_rating => ResidualConfig { rated_speed: None, fade: None, ..r.clone() },
        _ => ResidualConfig { fade: None, ..r.clone() },
    };
    if unrated_if_own(&trained) != unrated_if_own(residual) {
        return Err(ExperimentError::SetupMismatch {
            run: dir.to_path_buf(),
            trained: format!("{trained:?}"),
            given: format!("{residual:?}"),
        });
    }
    let controller_changed = match (&record.controller, controller_config(&record.env)) {
        (Some(recorded), Ok(today)) => {
            let today = serde_json::to_value(&today).expect("a controller preset serialises");
            crate::spec::first_difference(recorded, &today)
        }
        _ => None,
    };
    Ok(TrainedWith {
        controller_motor: record.controller_motor,
        observe_body_state: record.env_settings.observe_body_state == Some(true),
        controller_changed,
    })
}

/// Checks, reading only, that `from` holds a finished run whose pure-RL agent was trained as
/// `opts` would train it: the same options but for the hybrid's setup
/// ([`ExperimentOptions::pure_identity`]), a `summary.json`, and the agent's metrics and
/// checkpoint, the metrics reaching the summary's steps. Returns its summary.
pub(crate) fn check_pure_source(
    from: &Path,
    opts: &ExperimentOptions,
) -> Result<ExperimentSummary, ExperimentError> {
    let unfinished =
        |missing: &'static str| ExperimentError::PureRunUnfinished { from: from.to_path_buf(), missing };
    let read = |file: &'static str| {
        std::fs::read_to_string(from.join(file)).map_err(|source| match source.kind() {
            std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory if file == "experiment.json" => {
                ExperimentError::NoPureRun { dir: from.to_path_buf() }
            }
            std::io::ErrorKind::NotFound => unfinished(file),
            _ => ExperimentError::Io { path: from.join(file), source },
        })
    };
    let invalid = |file: &str, e: serde_json::Error| ExperimentError::Io {
        path: from.join(file),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
    };
    let record: ExperimentRecord =
        serde_json::from_str(&read("experiment.json")?).map_err(|e| invalid("experiment.json", e))?;
    let record = record.current(from)?;
    if record.pure_identity != opts.pure_identity() {
        let pure = |v: &serde_json::Value| {
            let mut v = v.clone();
            if let Some(o) = v.as_object_mut() {
                for hybrid_side in ["residual", "hybrid_learner", "controller_motor"] {
                    o.remove(hybrid_side);
                }
            }
            v
        };
        let difference = crate::spec::first_difference(&pure(&record.options), &opts.pure_options())
            .unwrap_or_else(|| {
                format!("identity: recorded {}, given {}", record.pure_identity, opts.pure_identity())
            });
        return Err(ExperimentError::PureRunDiffers { from: from.to_path_buf(), difference });
    }
    let summary: ExperimentSummary =
        serde_json::from_str(&read("summary.json")?).map_err(|e| invalid("summary.json", e))?;
    if !from.join("pure_rl").join("checkpoint").is_file() {
        return Err(unfinished("pure_rl/checkpoint"));
    }
    let csv = from.join("pure_rl").join("metrics.csv");
    let rows = MetricsCsv::read(&csv).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => unfinished("pure_rl/metrics.csv"),
        _ => ExperimentError::Io { path: csv.clone(), source },
    })?;
    if rows.last().map(|m| m.env_steps) != Some(summary.pure_rl.env_steps) {
        return Err(unfinished("the last rows of pure_rl/metrics.csv"));
    }
    Ok(summary)
}

/// Copies the pure-RL agent of the finished run in `from` into `opts.out` (its `pure_rl`
/// files, with `from` held for reading meanwhile: other comparisons may reuse it at the same
/// time, no process may rewrite it) after checking it ([`check_pure_source`]), evaluates the
/// copy as the run evaluated it and refuses it if the figures differ (the environment or the
/// code changed since), and returns its training as if it had just run here: the metrics,
/// the evaluations during training, the recorded wall time and steps. Its final evaluation
/// is made again by the caller.
fn reuse_pure(from: &Path, opts: &ExperimentOptions) -> Result<Trained, ExperimentError> {
    // A read-only source cannot be locked, and nothing can rewrite it either.
    let _source = match crate::rundir::read_lock_dir(from) {
        Ok(lock) => Some(lock),
        Err(Claim::Busy) => return Err(ExperimentError::PureRunBusy { from: from.to_path_buf() }),
        Err(Claim::Taken(_) | Claim::Io(..)) => None,
    };
    let summary = check_pure_source(from, opts)?;
    let dir = opts.out.join("pure_rl");
    std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
    for file in ["metrics.csv", "checkpoint"] {
        let dst = dir.join(file);
        std::fs::copy(from.join("pure_rl").join(file), &dst).map_err(io_err(&dst))?;
    }
    let csv = dir.join("metrics.csv");
    let rows = MetricsCsv::read(&csv).map_err(io_err(&csv))?;
    let mut driver = Driver::Pure {
        env: make_robot_env_with(&opts.env, &opts.env_settings)?,
        policy: Policy::load(&dir.join("checkpoint")).map_err(RlError::from)?,
    };
    let here = evaluate(&mut driver, opts.eval_episodes, 1_000_000 + opts.seed, None)?;
    let then = &summary.pure_rl;
    let figures = |s: &AgentStats| (s.return_mean.to_bits(), s.falls, s.episodes);
    if figures(&here) != figures(then) {
        return Err(ExperimentError::PureRunChanged {
            from: from.to_path_buf(),
            recorded: then.return_mean,
            here: here.return_mean,
        });
    }
    // The evaluations during training; the last entry is the final one, made again here.
    let mut budgets = summary.pure_budgets;
    budgets.pop();
    Ok(Trained {
        checkpoint: dir.join("checkpoint"),
        rows,
        wall: then.wall_seconds,
        steps: then.env_steps,
        budgets,
    })
}

/// Checks, reading only, that `centaur compare --resume` may run `opts` in its directory
/// (`opts.out`): nothing there, a run killed before it wrote its record, or a run of the
/// same options (finished: kept; killed: run again). A run of other options, a record that
/// does not read or one of an older Centaur is refused ([`ExperimentError::ResumeDiffers`],
/// [`ExperimentError::ResumeUnreadable`], [`ExperimentError::OlderRecord`]): resuming would
/// replace a run that is not this one's.
pub fn check_resumable(opts: &ExperimentOptions) -> Result<(), ExperimentError> {
    match recorded_identity(&opts.out)? {
        Some(record) if record.identity != opts.identity() => {
            let difference =
                crate::spec::first_difference(&record.options, &opts.options()).unwrap_or_else(|| {
                    format!("identity: recorded {}, given {}", record.identity, opts.identity())
                });
            Err(ExperimentError::ResumeDiffers { dir: opts.out.clone(), difference })
        }
        _ => Ok(()),
    }
}

/// The record in `dir`'s `experiment.json`, `None` where there is none (or no `dir`),
/// [`ExperimentError::ResumeUnreadable`] where it does not read,
/// [`ExperimentError::OlderRecord`] where an older Centaur wrote it.
fn recorded_identity(dir: &Path) -> Result<Option<CurrentRecord>, ExperimentError> {
    let path = dir.join("experiment.json");
    let text = match crate::rundir::read_text_bounded(&path, crate::spec::MAX_SPEC_BYTES) {
        Ok(text) => text,
        Err(crate::rundir::ReadError::Io(e))
            if matches!(e.kind(), std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory) =>
        {
            return Ok(None);
        }
        Err(e) => {
            return Err(ExperimentError::ResumeUnreadable { dir: dir.to_path_buf(), reason: e.to_string() });
        }
    };
    let record: ExperimentRecord = serde_json::from_str(&text)
        .map_err(|e| ExperimentError::ResumeUnreadable { dir: dir.to_path_buf(), reason: e.to_string() })?;
    Ok(Some(record.current(dir)?))
}

/// The result of a run already finished in `opts.out` with the same options (its
/// `experiment.json` identity, `summary.json` and both agents' `metrics.csv`), or `None`
/// if the directory holds no such finished run. `centaur compare --resume` keeps these.
pub fn finished_experiment(opts: &ExperimentOptions) -> Option<ExperimentResult> {
    if recorded_identity(&opts.out).ok()??.identity != opts.identity() {
        return None;
    }
    let read = |f: &str| std::fs::read_to_string(opts.out.join(f)).ok();
    let summary: ExperimentSummary = serde_json::from_str(&read("summary.json")?).ok()?;
    let curve = |agent: &str| -> Option<Curve> {
        let rows = MetricsCsv::read(&opts.out.join(agent).join("metrics.csv")).ok()?;
        Some(rows.iter().map(|m| (m.env_steps, m.episode_return_mean)).collect())
    };
    Some(ExperimentResult { summary, pure_curve: curve("pure_rl")?, hybrid_curve: curve("hybrid")? })
}

/// Runs the experiment (see the module docs) and writes the output directory.
pub fn run_experiment(
    opts: &ExperimentOptions,
    progress: &mut dyn FnMut(Phase, &UpdateMetrics),
) -> Result<ExperimentResult, ExperimentError> {
    // The hybrid needs a controller: refuse a robot without one before training anything.
    controller_config(&opts.env)?;
    // And a residual setup that does not fit the robot, before anything is written.
    make_residual_env_with(&opts.env, opts.residual.clone(), &opts.env_settings)?;
    // And a learner configuration out of range (reliability probe: no empty run directory).
    opts.algo.validate()?;
    if let Some(h) = &opts.hybrid_algo {
        h.validate()?;
        if h.kind() != opts.algo.kind() {
            return Err(ExperimentError::HybridLearnerKind {
                algo: opts.algo.kind().name(),
                hybrid: h.kind().name(),
            });
        }
    }
    if let Some(from) = &opts.pure_from {
        // Replacing this run would remove the files to be reused.
        if crate::rundir::same_path(from, &opts.out) {
            return Err(ExperimentError::PureFromItself { dir: opts.out.clone() });
        }
        // And a source that cannot be reused is refused before anything is written.
        check_pure_source(from, opts)?;
    }
    let _held = prepare_run_dir(opts)?;
    // Pure RL on the robot environment, the hybrid on the residual environment.
    // Set when one training fails, to stop the other one running side by side.
    let stop = AtomicBool::new(false);
    let failed = |r: Result<_, ExperimentError>| {
        if r.is_err() {
            stop.store(true, Ordering::Relaxed);
        }
        r
    };
    let train_pure = |progress: &mut dyn FnMut(Phase, &UpdateMetrics)| {
        if let Some(from) = &opts.pure_from {
            let reused = reuse_pure(from, opts)?;
            if let Some(last) = reused.rows.last() {
                progress(Phase::TrainPure, last);
            }
            return Ok(reused);
        }
        let mut env = vec_env_of(
            &mut || Ok(make_robot_env_with(&opts.env, &opts.env_settings)? as Box<dyn Env>),
            opts.n_envs,
            opts.threads,
        )?;
        train_one(opts, &opts.out.join("pure_rl"), &mut env, Phase::TrainPure, progress, &stop)
    };
    let train_hybrid = |progress: &mut dyn FnMut(Phase, &UpdateMetrics)| {
        let mut env = vec_env_of(
            &mut || {
                Ok(Box::new(make_residual_env_with(&opts.env, opts.residual.clone(), &opts.env_settings)?)
                    as Box<dyn Env>)
            },
            opts.n_envs,
            opts.threads,
        )?;
        train_one(opts, &opts.out.join("hybrid"), &mut env, Phase::TrainHybrid, progress, &stop)
    };
    // With several threads the two trainings run side by side: each depends only on its own
    // seed and environments (and not on the thread count, see `VecEnv`), so the results are
    // those of one after the other, and the cores one training leaves idle (its learner's
    // updates are single-threaded) do the other's work. The hybrid's progress reaches
    // `progress` on this thread through a channel. Each agent's wall time (summary, metrics)
    // is then measured while the other one trains too. A failure stops the other training.
    let (pure, hybrid) = if opts.threads > 1 {
        std::thread::scope(|s| {
            let (tx, rx) = std::sync::mpsc::channel::<(Phase, UpdateMetrics)>();
            let hybrid = s.spawn(move || {
                failed(train_hybrid(&mut |phase, m| {
                    let _ = tx.send((phase, *m));
                }))
            });
            let pure = failed(train_pure(&mut |phase, m| {
                progress(phase, m);
                while let Ok((phase, m)) = rx.try_recv() {
                    progress(phase, &m);
                }
            }));
            // Until the hybrid's thread ends and drops its sender.
            for (phase, m) in rx.iter() {
                progress(phase, &m);
            }
            let hybrid = hybrid.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
            (pure, hybrid)
        })
    } else {
        let pure = train_pure(progress)?;
        (Ok(pure), train_hybrid(progress))
    };
    // The first real error (not the other training's `Stopped`).
    let (
        Trained {
            checkpoint: pure_ckpt,
            rows: pure_rows,
            wall: pure_wall,
            steps: pure_steps,
            budgets: mut pure_budgets,
        },
        Trained {
            checkpoint: hybrid_ckpt,
            rows: hybrid_rows,
            wall: hybrid_wall,
            steps: hybrid_steps,
            budgets: mut hybrid_budgets,
        },
    ) = match (pure, hybrid) {
        (Ok(p), Ok(h)) => (p, h),
        (Err(ExperimentError::Stopped), Err(e)) | (Err(e), _) | (Ok(_), Err(e)) => return Err(e),
    };
    progress(Phase::Evaluate, &UpdateMetrics::default());

    // Evaluation: the policies as deployed (loaded back from their checkpoints). The three
    // agents are evaluated on their own envs and seeds, so running them side by side on
    // the worker threads gives the same figures as one after the other.
    let seed = 1_000_000 + opts.seed;
    let eval = |name: &str, driver: Result<Driver, ExperimentError>| {
        let record = opts.record.then(|| opts.out.join(format!("{name}.mcap")));
        evaluate(&mut driver?, opts.eval_episodes, seed, record.as_deref())
    };
    let pure = || -> Result<Driver, ExperimentError> {
        Ok(Driver::Pure {
            env: make_robot_env_with(&opts.env, &opts.env_settings)?,
            policy: Policy::load(&pure_ckpt).map_err(RlError::from)?,
        })
    };
    let hybrid = || -> Result<Driver, ExperimentError> {
        Ok(Driver::Hybrid {
            env: Box::new(make_residual_env_with(&opts.env, opts.residual.clone(), &opts.env_settings)?),
            policy: Policy::load(&hybrid_ckpt).map_err(RlError::from)?,
        })
    };
    let controller = || -> Result<Driver, ExperimentError> {
        let env = make_robot_env_with(&opts.env, &opts.env_settings)?;
        // The controller the hybrid runs (its rating included), commanded as at zero steering.
        let mut config = controller_config(&opts.env)?;
        opts.residual.rate_controller(&mut config)?;
        let controller = LocomotionController::new(env.model(), config).map_err(HybridError::from)?;
        let mapping = ActionMapping::new(env.as_ref(), &controller)?;
        Ok(Driver::Controller {
            env,
            controller: Box::new(controller),
            mapping,
            command: opts.residual.command,
        })
    };
    let (pure_stats, hybrid_stats, ctrl_stats) = if opts.threads > 1 {
        std::thread::scope(|s| {
            let p = s.spawn(|| eval("pure_rl", pure()));
            let h = s.spawn(|| eval("hybrid", hybrid()));
            let c = eval("controller", controller());
            let join = |h: std::thread::ScopedJoinHandle<'_, _>| {
                h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))
            };
            (join(p), join(h), c)
        })
    } else {
        (eval("pure_rl", pure()), eval("hybrid", hybrid()), eval("controller", controller()))
    };
    let (mut pure_stats, mut hybrid_stats, ctrl_stats) = (pure_stats?, hybrid_stats?, ctrl_stats?);
    (pure_stats.env_steps, pure_stats.wall_seconds) = (pure_steps, pure_wall);
    (hybrid_stats.env_steps, hybrid_stats.wall_seconds) = (hybrid_steps, hybrid_wall);

    let last = |s: &AgentStats| BudgetEval {
        env_steps: s.env_steps,
        wall_seconds: s.wall_seconds,
        return_mean: s.return_mean,
        falls: s.falls,
        episodes: s.episodes,
    };
    pure_budgets.push(last(&pure_stats));
    hybrid_budgets.push(last(&hybrid_stats));
    let summary = ExperimentSummary {
        hybrid: hybrid_stats,
        pure_rl: pure_stats,
        controller: ctrl_stats,
        hybrid_budgets,
        pure_budgets,
    };
    write_outputs(opts, &summary, &pure_rows, &hybrid_rows)?;
    let points = |rows: &[UpdateMetrics]| rows.iter().map(|m| (m.env_steps, m.episode_return_mean)).collect();
    Ok(ExperimentResult { summary, pure_curve: points(&pure_rows), hybrid_curve: points(&hybrid_rows) })
}

/// Writes `summary.json` and the learning curves of both agents into the run directory.
fn write_outputs(
    opts: &ExperimentOptions,
    summary: &ExperimentSummary,
    pure_rows: &[UpdateMetrics],
    hybrid_rows: &[UpdateMetrics],
) -> Result<(), ExperimentError> {
    let path = opts.out.join("summary.json");
    let text = serde_json::to_string_pretty(summary)
        .map_err(|e| ExperimentError::Io { path: path.clone(), source: e.into() })?;
    write_atomic(&path, &(text + "\n")).map_err(io_err(&path))?;
    let curve = |label: &str, rows: &[UpdateMetrics]| Series {
        label: label.to_string(),
        x: rows.iter().map(|m| m.env_steps as f64).collect(),
        y: rows.iter().map(|m| m.episode_return_mean).collect(),
        lower: Some(rows.iter().map(|m| m.episode_return_mean - m.episode_return_std).collect()),
        upper: Some(rows.iter().map(|m| m.episode_return_mean + m.episode_return_std).collect()),
    };
    let labels = PlotLabels {
        title: format!("{} on {}: pure RL vs hybrid (seed {})", opts.algo.kind().name(), opts.env, opts.seed),
        x: "environment steps".into(),
        y: "training episode return (mean ± std)".into(),
    };
    let series = [curve("pure RL", pure_rows), curve("hybrid (residual on the controller)", hybrid_rows)];
    for ext in ["png", "svg"] {
        match plot_curves(&opts.out.join(format!("learning_curves.{ext}")), &labels, &series) {
            Ok(()) | Err(PlotError::Empty { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registry::residual_config;

    fn record(residual: Option<&ResidualConfig>, identity: String) -> ExperimentRecord {
        ExperimentRecord {
            env: "minitaur".into(),
            algo: "ppo".into(),
            steps: 10,
            seed: 0,
            identity: Some(identity.clone()),
            pure_identity: Some(identity),
            options: Some(serde_json::json!({})),
            residual: residual.cloned(),
            env_settings: EnvSettings::default(),
            pure_from: None,
            controller_motor: Some(MotorInverse::Nominal),
            controller: None,
        }
    }

    fn write_record(dir: &Path, record: &ExperimentRecord) {
        std::fs::write(dir.join("experiment.json"), serde_json::to_string_pretty(record).unwrap()).unwrap();
    }

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("centaur-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// The hybrid's setup is checked against the one a run recorded as data: the same passes
    /// (also after a round trip through the file), another is refused naming both, the
    /// controller's own rating is no rating, a field missing from the record takes its
    /// default, and a missing or corrupt record is a typed error.
    #[test]
    fn a_run_is_evaluated_only_with_the_setup_it_was_trained_with() {
        let dir = temp_dir("trained-with");
        let trained = residual_config("minitaur").unwrap();
        assert_eq!(trained.rated_speed, Some(3.5));
        assert!(matches!(check_trained_with(&dir, &trained), Err(ExperimentError::NotAnExperiment { .. })));
        write_record(&dir, &record(Some(&trained), "(not read)".into()));
        check_trained_with(&dir, &trained).unwrap();
        let other = ResidualConfig { rated_speed: Some(2.5), ..trained.clone() };
        let err = check_trained_with(&dir, &other).unwrap_err();
        let ExperimentError::SetupMismatch { trained: ref t, ref given, .. } = err else { panic!("{err}") };
        assert_eq!(*t, format!("{trained:?}"));
        assert_eq!(*given, format!("{other:?}"));
        let slower = ResidualConfig {
            steering: crate::hybrid::Steering { speed: 0.5, ..crate::hybrid::Steering::OFF },
            ..trained.clone()
        };
        assert!(matches!(check_trained_with(&dir, &slower), Err(ExperimentError::SetupMismatch { .. })));

        // The trot's own rating (2.5 m/s) recorded explicitly is the unrated setup, both ways.
        let unrated = ResidualConfig { rated_speed: None, ..trained.clone() };
        write_record(&dir, &record(Some(&other), "(not read)".into()));
        check_trained_with(&dir, &unrated).unwrap();
        write_record(&dir, &record(Some(&unrated), "(not read)".into()));
        check_trained_with(&dir, &other).unwrap();
        assert!(matches!(check_trained_with(&dir, &trained), Err(ExperimentError::SetupMismatch { .. })));

        // A record whose setup lacks a field (as one written before the field existed would)
        // reads it at its default.
        let mut value = serde_json::to_value(record(Some(&trained), "(not read)".into())).unwrap();
        value["residual"].as_object_mut().unwrap().remove("warmup_with_policy");
        std::fs::write(dir.join("experiment.json"), value.to_string()).unwrap();
        check_trained_with(&dir, &trained).unwrap();
        let warm = ResidualConfig { warmup_with_policy: true, ..trained.clone() };
        assert!(matches!(check_trained_with(&dir, &warm), Err(ExperimentError::SetupMismatch { .. })));

        std::fs::write(dir.join("experiment.json"), "{ not json").unwrap();
        assert!(matches!(check_trained_with(&dir, &trained), Err(ExperimentError::Io { .. })));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A record holding the controller's preset is checked against today's: the same
    /// passes quietly, a changed gain is named for a warning.
    #[test]
    fn a_run_trained_on_another_controller_preset_is_named() {
        let dir = temp_dir("controller-changed");
        let trained = residual_config("minitaur").unwrap();
        let today = serde_json::to_value(controller_config("minitaur").unwrap()).unwrap();
        let with = |controller: Option<serde_json::Value>| ExperimentRecord {
            controller,
            ..record(Some(&trained), "(not read)".into())
        };
        write_record(&dir, &with(Some(today.clone())));
        assert_eq!(check_trained_with(&dir, &trained).unwrap().controller_changed, None);
        let mut older = today.clone();
        older["wbc"]["w_posture"] = serde_json::json!(0.05);
        write_record(&dir, &with(Some(older)));
        let changed = check_trained_with(&dir, &trained).unwrap().controller_changed;
        assert_eq!(changed.as_deref(), Some("wbc.w_posture: recorded 0.05, given 0.01"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A run trained with `[env]` settings that only perturbed its training (motor strength
    /// drawn at reset, pushes) is fit for the preset environment, one that observed the body
    /// state for that environment observing it; one whose settings change the task is
    /// refused, naming those keys only.
    #[test]
    fn training_only_settings_leave_a_run_fit_for_the_preset_env() {
        let dir = temp_dir("training-only");
        let preset = residual_config("minitaur").unwrap();
        let with = |toml: &str| {
            let (env_settings, _) = crate::settings::split_run_toml(toml).unwrap();
            ExperimentRecord { env_settings, ..record(Some(&preset), String::new()) }
        };
        write_record(
            &dir,
            &with(
                "[env]\nmotor_strength = [0.8, 1.2]\npushes = { force = 5.0, every = 2.0, duration = 0.1 }\n",
            ),
        );
        check_trained_with(&dir, &preset).unwrap();
        assert!(!check_trained_with(&dir, &preset).unwrap().observe_body_state);
        // The body state in the observation is no perturbation but no other task either: the
        // studies observe it too.
        write_record(&dir, &with("[env]\nobserve_body_state = true\n"));
        assert!(check_trained_with(&dir, &preset).unwrap().observe_body_state);
        write_record(&dir, &with("[env]\nobserve_body_state = true\nenergy_weight = 0.0\n"));
        let err = check_trained_with(&dir, &preset).unwrap_err();
        let ExperimentError::EnvSettingsNotCovered { ref keys, .. } = err else { panic!("{err}") };
        assert_eq!(keys, "energy_weight");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The motor the controller was told is read back for the studies as recorded.
    #[test]
    fn the_studies_learn_which_motor_the_controller_was_told() {
        let dir = temp_dir("controller-motor");
        let preset = residual_config("minitaur").unwrap();
        for motor in [MotorInverse::Nominal, MotorInverse::Drawn] {
            let told =
                ExperimentRecord { controller_motor: Some(motor), ..record(Some(&preset), String::new()) };
            write_record(&dir, &told);
            assert_eq!(check_trained_with(&dir, &preset).unwrap().controller_motor, Some(motor));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A record of an older Centaur (a `fingerprint` text, no identity, no setup as data)
    /// is refused as such by every consumer: the studies, the resume check and
    /// `--pure-from`.
    #[test]
    fn a_record_of_an_older_centaur_is_named_as_such() {
        let dir = temp_dir("older-record");
        let older = r#"{"env": "minitaur", "algo": "ppo", "steps": 10, "seed": 0, "fingerprint": "(\"minitaur\", Ppo(..))"}"#;
        std::fs::write(dir.join("experiment.json"), older).unwrap();
        let preset = residual_config("minitaur").unwrap();
        let older = |e: ExperimentError| matches!(e, ExperimentError::OlderRecord { .. });
        assert!(older(check_trained_with(&dir, &preset).unwrap_err()));
        assert!(older(recorded_hybrid(&dir).unwrap_err()));
        let opts = ExperimentOptions { out: dir.clone(), ..options() };
        assert!(older(check_resumable(&opts).unwrap_err()));
        assert!(finished_experiment(&opts).is_none());
        assert!(older(check_pure_source(&dir, &opts).unwrap_err()));
        let e = check_trained_with(&dir, &preset).unwrap_err().to_string();
        assert!(e.contains("recorded by an older Centaur"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A run writes its setup as data, and reads it back equal.
    #[test]
    fn the_record_holds_the_setup_as_data() {
        let preset = residual_config("minitaur").unwrap();
        let text = serde_json::to_string_pretty(&record(Some(&preset), String::new())).unwrap();
        assert!(text.contains("\"rated_speed\": 3.5") && text.contains("\"gait\": \"trot\""), "{text}");
        let back: ExperimentRecord = serde_json::from_str(&text).unwrap();
        assert_eq!(back.residual, Some(preset));
    }

    fn options() -> ExperimentOptions {
        ExperimentOptions {
            env: "minitaur".into(),
            algo: crate::experiment::tuned_config("minitaur", centaur_rl::AlgoKind::Ppo),
            steps: 1000,
            seed: 0,
            out: PathBuf::from("a"),
            n_envs: 4,
            threads: 1,
            eval_episodes: 10,
            residual: residual_config("minitaur").unwrap(),
            record: false,
            eval_every: None,
            overwrite: false,
            env_settings: EnvSettings::default(),
            pure_from: None,
            hybrid_algo: None,
        }
    }

    /// The identity changes with every option that decides results and with nothing else;
    /// the pure identity leaves out the hybrid's side only (its setup, its own learner
    /// settings, the motor its controller is told); a difference is named by its key.
    #[test]
    fn the_pure_identity_leaves_out_the_hybrids_side_only() {
        let opts = options();
        let not_results = ExperimentOptions {
            out: PathBuf::from("b"),
            threads: 2,
            record: true,
            overwrite: true,
            pure_from: Some(PathBuf::from("c")),
            ..opts.clone()
        };
        assert_eq!(opts.identity(), not_results.identity());
        let other_hybrid = ExperimentOptions {
            residual: ResidualConfig { rated_speed: Some(3.0), ..opts.residual.clone() },
            ..opts.clone()
        };
        let lr = centaur_rl::PpoConfig { learning_rate: 1e-3, ..Default::default() };
        let own_learner =
            ExperimentOptions { hybrid_algo: Some(centaur_rl::AlgoConfig::Ppo(lr.clone())), ..opts.clone() };
        let told = |toml: &str| {
            let (env_settings, _) = crate::settings::split_run_toml(toml).unwrap();
            ExperimentOptions { env_settings, ..opts.clone() }
        };
        let drawn = told("[env]\nmotor_inverse = \"drawn\"\n");
        // Today's default told explicitly is the default.
        assert_eq!(told("[env]\nmotor_inverse = \"nominal\"\n").identity(), opts.identity());
        for hybrid_side in [&other_hybrid, &own_learner, &drawn] {
            assert_ne!(opts.identity(), hybrid_side.identity());
            assert_eq!(opts.pure_identity(), hybrid_side.pure_identity());
        }
        let pure_sides = [
            ExperimentOptions { steps: 2000, ..opts.clone() },
            ExperimentOptions { seed: 1, ..opts.clone() },
            ExperimentOptions { n_envs: 8, ..opts.clone() },
            ExperimentOptions { eval_every: Some(500), ..opts.clone() },
            ExperimentOptions { eval_episodes: 11, ..opts.clone() },
            ExperimentOptions { env: "minitaur-fast".into(), ..opts.clone() },
            ExperimentOptions { algo: centaur_rl::AlgoConfig::Ppo(lr), ..opts.clone() },
            told("[env]\nenergy_weight = 0.0\n"),
        ];
        for other in &pure_sides {
            assert_ne!(opts.pure_identity(), other.pure_identity());
            assert_ne!(opts.identity(), other.identity());
        }
        assert_eq!(pure_sides.len(), 8);
        let difference = crate::spec::first_difference(&opts.options(), &other_hybrid.options()).unwrap();
        assert_eq!(difference, "residual.rated_speed: recorded 3.5, given 3.0");
        let difference = crate::spec::first_difference(&opts.options(), &drawn.options()).unwrap();
        assert_eq!(difference, "controller_motor: recorded \"nominal\", given \"drawn\"");
    }
}
