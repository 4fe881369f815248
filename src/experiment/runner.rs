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
use super::options::{
    Curve, ExperimentError, ExperimentOptions, ExperimentResult, Phase, io_err, pure_part, residual_part,
};
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
    /// [`ExperimentOptions::fingerprint`].
    fingerprint: String,
    /// The hybrid's setup, as data. Records written before it was stored lack it; their
    /// fingerprint's text is matched instead ([`legacy`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    residual: Option<ResidualConfig>,
    /// The `[env]` settings of both agents (absent: the preset).
    #[serde(default, skip_serializing_if = "EnvSettings::is_empty")]
    env_settings: EnvSettings,
    /// The run whose pure-RL agent this one reused ([`ExperimentOptions::pure_from`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pure_from: Option<PathBuf>,
    /// The motor the controller was told, on a Minitaur ([`controller_motor`]). Records
    /// written before the controller's motor was recorded lack it: theirs was the one in their
    /// `[env]` settings, or else the drawn motor ([`MotorInverse::legacy`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    controller_motor: Option<MotorInverse>,
    /// The robot's controller preset the hybrid ran on (`ControllerConfig`, every gain and
    /// weight), in newer records; older ones lack it and are not checked for it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    controller: Option<serde_json::Value>,
}

impl ExperimentRecord {
    /// The motor the run's controller was told (`None`: not a Minitaur).
    fn controller_motor(&self) -> Option<MotorInverse> {
        let recorded = || self.env_settings.motor_inverse.unwrap_or_else(MotorInverse::legacy);
        self.controller_motor.or_else(|| controller_motor(&self.env, &self.env_settings).map(|_| recorded()))
    }
}

/// What a run's hybrid was trained with, as far as the studies that reuse it need to know
/// ([`check_trained_with`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TrainedWith {
    /// The motor the controller was told, on a Minitaur (`None`: another robot); the studies
    /// tell it the same unless asked otherwise.
    pub controller_motor: Option<MotorInverse>,
    /// Whether both agents observed the robot's body state (`[env] observe_body_state`,
    /// the Minitaur's); the studies build their environments with it.
    pub observe_body_state: bool,
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
        fingerprint: opts.fingerprint(),
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
/// studies that reuse the run build from, so that no flag has to be typed again. `None` for
/// the setup: a record written before the setup was stored as data (its robot's preset,
/// with the flags it was trained with, is then checked against its text by
/// [`check_trained_with`]).
pub fn recorded_hybrid(dir: &Path) -> Result<(String, Option<ResidualConfig>), ExperimentError> {
    let record = read_record(dir)?;
    Ok((record.env, record.residual))
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
/// (`the_trots_own_rating_reproduces_the_old_preset_bit_for_bit`), so the two match. Records
/// from before the setup was stored as data are matched by their text. A run trained with
/// `[env]` settings is refused unless they only perturbed training
/// ([`crate::settings::TRAINING_ONLY`]: motor strength drawn at reset, pushes), set the
/// motor the controller is told or put the body state in the observation, both returned
/// ([`TrainedWith`]), since the callers run the robot's preset environment with them. A run
/// whose record holds the controller's preset (newer records do) is refused when today's
/// differs, naming the first difference. The safety fade ([`crate::hybrid::Fade`]) is not
/// compared: a run may be evaluated with or without it. `centaur robustness` and
/// `examples/embed_controller` check with it.
pub fn check_trained_with(dir: &Path, residual: &ResidualConfig) -> Result<TrainedWith, ExperimentError> {
    let record = read_record(dir)?;
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
    let (same, trained) = match &record.residual {
        Some(trained) => (unrated_if_own(trained) == unrated_if_own(residual), format!("{trained:?}")),
        None => (
            legacy::matches(&record.fingerprint, &unrated_if_own(residual), own_rating),
            residual_part(&record.fingerprint),
        ),
    };
    if same {
        if let (Some(recorded), Ok(today)) = (&record.controller, controller_config(&record.env)) {
            let today = serde_json::to_string(&today).unwrap_or_default();
            if let Some(difference) = crate::train::config_difference(&recorded.to_string(), &today) {
                return Err(ExperimentError::ControllerChanged { run: dir.to_path_buf(), difference });
            }
        }
        return Ok(TrainedWith {
            controller_motor: record.controller_motor(),
            observe_body_state: record.env_settings.observe_body_state == Some(true),
        });
    }
    Err(ExperimentError::SetupMismatch { run: dir.to_path_buf(), trained, given: format!("{residual:?}") })
}

/// Records written before `experiment.json` stored the hybrid's setup as data hold it
/// only as `ResidualConfig`'s `Debug` text inside the fingerprint, in
/// one of three forms: with every field below; without `rated_speed` (written before it
/// existed); without it and `warmup_with_policy`. The forms are written out here field by
/// field, so that fields added to the setup later leave them as they were.
mod legacy {
    use std::fmt;

    use centaur_mpc::{Command, Gait};

    use crate::hybrid::{Exploration, ResidualConfig, Steering};

    /// Whether `fingerprint` holds `residual` (with no rating when it is the controller's
    /// own, which is `own_rating`) in one of the old forms.
    pub(super) fn matches(fingerprint: &str, residual: &ResidualConfig, own_rating: Option<f64>) -> bool {
        // The old forms predate these parts: a setup with any of them set is not one of them.
        let newer = residual.exploration_ramp.is_some()
            || residual.fade.is_some()
            || residual.bound_ramp.is_some()
            || residual.period_scale.is_some()
            || residual.max_acceleration.is_some()
            || residual.swing_height.is_some()
            || residual.mpc_period.is_some()
            || residual.cheap_torques
            || residual.include_state
            || residual.steering.cadence != 0.0
            || residual.steering.duty != 0.0
            || residual.steering.swing != 0.0
            || residual.steering.foothold != 0.0;
        if newer {
            return false;
        }
        let mut candidates = vec![residual.clone()];
        if residual.rated_speed.is_none() && own_rating.is_some() {
            // A run may also have recorded the controller's own rating explicitly.
            candidates.push(ResidualConfig { rated_speed: own_rating, ..residual.clone() });
        }
        candidates.iter().any(|r| {
            let unrated = r.rated_speed.is_none();
            let forms = [
                Some(Form { r, rating: true, warmup: true }),
                unrated.then_some(Form { r, rating: false, warmup: true }),
                (unrated && !r.warmup_with_policy).then_some(Form { r, rating: false, warmup: false }),
            ];
            forms.iter().flatten().any(|form| fingerprint.contains(&format!("{form:?}")))
        })
    }

    /// One old form of `ResidualConfig`'s text.
    struct Form<'a> {
        r: &'a ResidualConfig,
        rating: bool,
        warmup: bool,
    }

    impl fmt::Debug for Form<'_> {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            // Every field named: a field added to the setup must be decided on here (an old
            // record can only have run with it at its default).
            let ResidualConfig {
                scale,
                joint_residual,
                steering,
                exploration,
                // Records of this form predate the ramp: it can only be `None` here.
                exploration_ramp: _,
                warmup_with_policy,
                include_reference,
                command,
                rated_speed,
                // Records of this form predate the fade: it can only be `None` here.
                fade: _,
                // ... and the rising bound, the period scale and the command ramp.
                bound_ramp: _,
                period_scale: _,
                max_acceleration: _,
                // ... and the body state in the observation: it can only be off here.
                include_state: _,
                // ... and the swing height: it can only be the controller's own here.
                swing_height: _,
                // ... and the MPC period and the torque path: the controller's own here.
                mpc_period: _,
                cheap_torques: _,
            } = self.r;
            let mut s = f.debug_struct("ResidualConfig");
            s.field("scale", scale)
                .field("joint_residual", joint_residual)
                .field("steering", &SteeringForm(steering))
                .field("exploration", &exploration.as_ref().map(ExplorationForm));
            if self.warmup {
                s.field("warmup_with_policy", warmup_with_policy);
            }
            s.field("include_reference", include_reference).field("command", &CommandForm(command));
            if self.rating {
                s.field("rated_speed", rated_speed);
            }
            s.finish()
        }
    }

    struct SteeringForm<'a>(&'a Steering);

    impl fmt::Debug for SteeringForm<'_> {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            // Records of this form predate the cadence, the duty, the swing and the foothold:
            // they can only be 0 here.
            let Steering { speed, yaw_rate, cadence: _, duty: _, swing: _, foothold: _ } = self.0;
            f.debug_struct("Steering").field("speed", speed).field("yaw_rate", yaw_rate).finish()
        }
    }

    struct ExplorationForm<'a>(&'a Exploration);

    impl fmt::Debug for ExplorationForm<'_> {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            let Exploration { residual, steering } = self.0;
            f.debug_struct("Exploration").field("residual", residual).field("steering", steering).finish()
        }
    }

    struct CommandForm<'a>(&'a Command);

    impl fmt::Debug for CommandForm<'_> {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            let Command { forward_velocity, lateral_velocity, yaw_rate, body_height, gait } = self.0;
            f.debug_struct("Command")
                .field("forward_velocity", forward_velocity)
                .field("lateral_velocity", lateral_velocity)
                .field("yaw_rate", yaw_rate)
                .field("body_height", body_height)
                .field("gait", &GaitForm(*gait))
                .finish()
        }
    }

    /// A gait as the derived `Debug` of `Gait` wrote it when these records were made, spelt
    /// out here so that a change to `Gait`'s `Debug` cannot change the frozen form.
    struct GaitForm(Gait);

    impl fmt::Debug for GaitForm {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(match self.0 {
                Gait::Stand => "Stand",
                Gait::Walk => "Walk",
                Gait::Trot => "Trot",
                Gait::Pace => "Pace",
                Gait::Bound => "Bound",
                Gait::Pronk => "Pronk",
                Gait::Gallop => "Gallop",
            })
        }
    }
}

/// The text of `a` and `b` around their first difference (up to 60 characters before it and
/// 60 after), for an error message about two long fingerprints.
fn around_difference(a: &str, b: &str) -> (String, String) {
    let at = a
        .char_indices()
        .zip(b.chars())
        .find(|((_, x), y)| x != y)
        .map_or(a.len().min(b.len()), |((i, _), _)| i);
    let window = |s: &str| {
        let start = s[..at.min(s.len())].char_indices().rev().nth(59).map_or(0, |(i, _)| i);
        s[start..].chars().take(120).collect::<String>()
    };
    (window(a), window(b))
}

/// Checks, reading only, that `from` holds a finished run whose pure-RL agent was trained as
/// `opts` would train it: the same options but for the hybrid's setup
/// ([`ExperimentOptions::pure_fingerprint`]), a `summary.json`, and the agent's metrics and
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
    let (recorded, given) = (pure_part(&record.fingerprint), opts.pure_fingerprint());
    if recorded != given {
        let (recorded, given) = around_difference(&recorded, &given);
        return Err(ExperimentError::PureRunDiffers { from: from.to_path_buf(), recorded, given });
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
/// same options (finished: kept; killed: run again). A run of other options, or a record
/// that does not read, is refused ([`ExperimentError::ResumeDiffers`],
/// [`ExperimentError::ResumeUnreadable`]): resuming would replace a run that is not this
/// one's.
pub fn check_resumable(opts: &ExperimentOptions) -> Result<(), ExperimentError> {
    let given = opts.fingerprint();
    match recorded_fingerprint(&opts.out)? {
        Some(recorded) if recorded != given => {
            let (recorded, given) = around_difference(&recorded, &given);
            Err(ExperimentError::ResumeDiffers { dir: opts.out.clone(), recorded, given })
        }
        _ => Ok(()),
    }
}

/// The fingerprint recorded in `dir`'s `experiment.json`, `None` where there is none (or no
/// `dir`), [`ExperimentError::ResumeUnreadable`] where the record does not read.
fn recorded_fingerprint(dir: &Path) -> Result<Option<String>, ExperimentError> {
    let path = dir.join("experiment.json");
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if matches!(e.kind(), std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory) => {
            return Ok(None);
        }
        Err(source) => return Err(ExperimentError::Io { path, source }),
    };
    let record: ExperimentRecord = serde_json::from_str(&text)
        .map_err(|e| ExperimentError::ResumeUnreadable { dir: dir.to_path_buf(), reason: e.to_string() })?;
    Ok(Some(record.fingerprint))
}

/// The result of a run already finished in `opts.out` with the same options (its
/// `experiment.json` fingerprint, `summary.json` and both agents' `metrics.csv`), or `None`
/// if the directory holds no such finished run. `centaur compare --resume` keeps these.
pub fn finished_experiment(opts: &ExperimentOptions) -> Option<ExperimentResult> {
    if recorded_fingerprint(&opts.out).ok()?? != opts.fingerprint() {
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

    fn record(residual: Option<&ResidualConfig>, fingerprint: String) -> ExperimentRecord {
        ExperimentRecord {
            env: "minitaur".into(),
            algo: "ppo".into(),
            steps: 10,
            seed: 0,
            fingerprint,
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
    /// passes, a changed gain is refused naming it, and a record without one (an older
    /// record) is not checked for it.
    #[test]
    fn a_run_trained_on_another_controller_preset_is_refused() {
        let dir = temp_dir("controller-changed");
        let trained = residual_config("minitaur").unwrap();
        let today = serde_json::to_value(controller_config("minitaur").unwrap()).unwrap();
        let with = |controller: Option<serde_json::Value>| ExperimentRecord {
            controller,
            ..record(Some(&trained), "(not read)".into())
        };
        write_record(&dir, &with(Some(today.clone())));
        check_trained_with(&dir, &trained).unwrap();
        let mut older = today.clone();
        older["wbc"]["w_posture"] = serde_json::json!(0.05);
        write_record(&dir, &with(Some(older)));
        let err = check_trained_with(&dir, &trained).unwrap_err();
        let ExperimentError::ControllerChanged { ref difference, .. } = err else { panic!("{err}") };
        assert_eq!(difference, "wbc.w_posture: recorded 0.05, today 0.01");
        write_record(&dir, &with(None));
        check_trained_with(&dir, &trained).unwrap();
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

    /// The motor the controller was told is read back for the studies: as recorded; in a
    /// record from before it was, the one its `[env]` settings name, or else the
    /// drawn motor, the default then. Setting it is no task change.
    #[test]
    fn the_studies_learn_which_motor_the_controller_was_told() {
        let dir = temp_dir("controller-motor");
        let preset = residual_config("minitaur").unwrap();
        let told = |record: ExperimentRecord| {
            write_record(&dir, &record);
            check_trained_with(&dir, &preset).unwrap().controller_motor
        };
        let now = record(Some(&preset), String::new());
        assert_eq!(
            told(ExperimentRecord { controller_motor: Some(MotorInverse::Nominal), ..now }),
            Some(MotorInverse::Nominal)
        );
        let legacy = || ExperimentRecord { controller_motor: None, ..record(Some(&preset), String::new()) };
        assert_eq!(told(legacy()), Some(MotorInverse::Drawn));
        let (env_settings, _) =
            crate::settings::split_run_toml("[env]\nmotor_inverse = \"nominal\"\n").unwrap();
        assert_eq!(told(ExperimentRecord { env_settings, ..legacy() }), Some(MotorInverse::Nominal));
        // A robot whose actions are torques has none.
        let ant = ExperimentRecord { env: "ant".into(), residual: None, ..legacy() };
        assert_eq!(ant.controller_motor(), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Records from before the setup was stored as data, in the exact text of two real runs:
    /// the main example's (before `warmup_with_policy` and `rated_speed`, trained
    /// at the trot's own 2.5 m/s) and a `centaur compare` seed's on an earlier preset (rated 3.0).
    #[test]
    fn records_from_before_the_setup_was_data_are_matched_by_their_text() {
        const OLDEST: &str = "ResidualConfig { scale: [0.25], joint_residual: true, steering: Steering { speed: 1.0, yaw_rate: 0.0 }, exploration: Some(Exploration { residual: 0.3, steering: 0.5 }), include_reference: true, command: Command { forward_velocity: 2.0, lateral_velocity: 0.0, yaw_rate: 0.0, body_height: None, gait: Trot } }";
        const RATED: &str = "ResidualConfig { scale: [0.25], joint_residual: true, steering: Steering { speed: 1.0, yaw_rate: 0.0 }, exploration: Some(Exploration { residual: 0.3, steering: 0.5 }), warmup_with_policy: false, include_reference: true, command: Command { forward_velocity: 2.0, lateral_velocity: 0.0, yaw_rate: 0.0, body_height: None, gait: Trot }, rated_speed: Some(3.0) }";
        let dir = temp_dir("legacy-record");
        // An earlier preset: steered ±1 m/s, rated 3.0.
        let preset = ResidualConfig {
            steering: crate::hybrid::Steering { speed: 1.0, ..crate::hybrid::Steering::OFF },
            rated_speed: Some(3.0),
            ..residual_config("minitaur").unwrap()
        };
        let at = |rated_speed| ResidualConfig { rated_speed, ..preset.clone() };
        let legacy =
            |residual: &str| record(None, format!("(\"minitaur\", Ppo(..), 4, 10, {residual}, None)"));

        write_record(&dir, &legacy(OLDEST));
        check_trained_with(&dir, &at(Some(2.5))).unwrap();
        check_trained_with(&dir, &at(None)).unwrap();
        let err = check_trained_with(&dir, &preset).unwrap_err();
        let ExperimentError::SetupMismatch { trained, .. } = err else { panic!("{err}") };
        assert_eq!(trained, OLDEST);
        let warm = ResidualConfig { warmup_with_policy: true, ..at(None) };
        assert!(matches!(check_trained_with(&dir, &warm), Err(ExperimentError::SetupMismatch { .. })));

        write_record(&dir, &legacy(RATED));
        check_trained_with(&dir, &preset).unwrap();
        assert!(matches!(
            check_trained_with(&dir, &at(Some(2.5))),
            Err(ExperimentError::SetupMismatch { .. })
        ));
        let slower = ResidualConfig {
            steering: crate::hybrid::Steering { speed: 0.5, ..crate::hybrid::Steering::OFF },
            ..preset.clone()
        };
        assert!(matches!(check_trained_with(&dir, &slower), Err(ExperimentError::SetupMismatch { .. })));
        // Parts newer than the old forms: a setup with one set was not trained there.
        let newer = [
            ResidualConfig { max_acceleration: Some(6.0), ..preset.clone() },
            ResidualConfig { period_scale: Some(0.7), ..preset.clone() },
            ResidualConfig {
                steering: crate::hybrid::Steering { cadence: 0.5, ..preset.steering },
                ..preset.clone()
            },
            ResidualConfig {
                steering: crate::hybrid::Steering { swing: 0.5, ..preset.steering },
                ..preset.clone()
            },
            ResidualConfig { swing_height: Some(0.03), ..preset.clone() },
            ResidualConfig { mpc_period: Some(0.06), ..preset.clone() },
            ResidualConfig { cheap_torques: true, ..preset.clone() },
        ];
        for r in &newer {
            assert!(
                matches!(check_trained_with(&dir, r), Err(ExperimentError::SetupMismatch { .. })),
                "{r:?}"
            );
        }
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

    #[test]
    fn the_pure_fingerprint_leaves_out_the_hybrids_setup_only() {
        assert_eq!(
            pure_part("(1, ResidualConfig { a: B { c: 1 }, d: 2 }, 3) with S"),
            "(1, ResidualConfig { .. }, 3) with S"
        );
        assert_eq!(pure_part("(no setup)"), "(no setup)");
        let preset = residual_config("minitaur").unwrap();
        let opts = ExperimentOptions {
            env: "minitaur".into(),
            algo: crate::experiment::tuned_config("minitaur", centaur_rl::AlgoKind::Ppo),
            steps: 1000,
            seed: 0,
            out: PathBuf::from("a"),
            n_envs: 4,
            threads: 1,
            eval_episodes: 10,
            residual: preset.clone(),
            record: false,
            eval_every: None,
            overwrite: false,
            env_settings: EnvSettings::default(),
            pure_from: None,
            hybrid_algo: None,
        };
        let other_hybrid = ExperimentOptions {
            residual: ResidualConfig { rated_speed: Some(3.0), ..preset },
            out: PathBuf::from("b"),
            ..opts.clone()
        };
        assert_ne!(opts.fingerprint(), other_hybrid.fingerprint());
        assert_eq!(opts.pure_fingerprint(), other_hybrid.pure_fingerprint());
        // The hybrid's own hyperparameters are the hybrid's: the pure part leaves them out.
        let lr = centaur_rl::PpoConfig { learning_rate: 1e-3, ..Default::default() };
        let own_learner =
            ExperimentOptions { hybrid_algo: Some(centaur_rl::AlgoConfig::Ppo(lr)), ..opts.clone() };
        assert_ne!(opts.fingerprint(), own_learner.fingerprint());
        assert_eq!(opts.pure_fingerprint(), own_learner.pure_fingerprint());
        assert!(own_learner.fingerprint().ends_with(super::super::options::NOMINAL_MOTOR_MARK));
        assert_eq!(own_learner.hybrid_learner().kind(), centaur_rl::AlgoKind::Ppo);
        // PPO's critic burn-in is left out at its default, so runs made
        // before it keep their fingerprint; set, it is the hybrid's and marks it.
        assert!(!own_learner.fingerprint().contains("actor_burn_in_steps"));
        assert!(own_learner.fingerprint().contains("critic_learning_rate: None, anneal_lr"));
        let burn_in = centaur_rl::PpoConfig { actor_burn_in_steps: 2048, ..Default::default() };
        let burnt =
            ExperimentOptions { hybrid_algo: Some(centaur_rl::AlgoConfig::Ppo(burn_in)), ..opts.clone() };
        assert!(
            burnt.fingerprint().contains("critic_learning_rate: None, actor_burn_in_steps: 2048, anneal_lr")
        );
        assert_eq!(opts.pure_fingerprint(), burnt.pure_fingerprint());
        for other_pure in [
            ExperimentOptions { steps: 2000, ..opts.clone() },
            ExperimentOptions { seed: 1, ..opts.clone() },
            ExperimentOptions { n_envs: 8, ..opts.clone() },
            ExperimentOptions { eval_every: Some(500), ..opts.clone() },
        ] {
            assert_ne!(opts.pure_fingerprint(), other_pure.pure_fingerprint());
        }
        // The Minitaur's default motor inverse (now the nominal one) marks the
        // fingerprint: a run on the old default (no mark) is not kept as this one, but its
        // pure-RL agent, which never uses the inverse, can be reused.
        assert!(opts.fingerprint().ends_with(super::super::options::NOMINAL_MOTOR_MARK));
        let before =
            opts.fingerprint().strip_suffix(super::super::options::NOMINAL_MOTOR_MARK).unwrap().to_string();
        assert_eq!(pure_part(&before), opts.pure_fingerprint());
        // Told the drawn motor explicitly, a run has the fingerprint of a run before the
        // switch (it is one); told the nominal motor explicitly, that of today's default.
        let told = |toml: &str| {
            let (env_settings, _) = crate::settings::split_run_toml(toml).unwrap();
            ExperimentOptions { env_settings, ..opts.clone() }.fingerprint()
        };
        assert_eq!(told("[env]\nmotor_inverse = \"drawn\"\n"), before);
        assert_eq!(told("[env]\nmotor_inverse = \"nominal\"\n"), opts.fingerprint());
        let other = told("[env]\nmotor_inverse = \"drawn\"\nenergy_weight = 0.0\n");
        assert!(
            other.contains("energy_weight: Some(0.0)") && other.contains("motor_inverse: None"),
            "{other}"
        );
        assert!(!other.contains("Drawn") && !other.contains("nominal motor"), "{other}");
        let ant = ExperimentOptions { env: "ant".into(), ..opts.clone() };
        assert!(!ant.fingerprint().contains("nominal motor"));
    }

    #[test]
    fn a_difference_is_quoted_with_its_surroundings() {
        let (a, b) = around_difference("(1, 2, 3)", "(1, 5, 3)");
        assert_eq!((a.as_str(), b.as_str()), ("(1, 2, 3)", "(1, 5, 3)"));
        // Long texts: from 60 characters before the difference, 120 in all, on character
        // boundaries (the fingerprints hold "·" and "±").
        let long = |c: char| format!("{}{c}{}", "±".repeat(100), "x".repeat(200));
        let (a, b) = around_difference(&long('a'), &long('b'));
        assert_eq!((a.chars().count(), b.chars().count()), (120, 120));
        assert!(a.starts_with(&"±".repeat(60)) && a[("±".len() * 60)..].starts_with('a'), "{a}");
        assert!(b.contains('b') && !b.contains('a'));
        // One text a prefix of the other: the difference is where the shorter ends.
        let (a, b) = around_difference("abc", "abcdef");
        assert_eq!((a.as_str(), b.as_str()), ("abc", "abcdef"));
    }

    #[test]
    fn the_residual_part_of_a_fingerprint_is_cut_at_its_closing_brace() {
        assert_eq!(
            residual_part("(1, ResidualConfig { a: B { c: 1 }, d: 2 }, 3)"),
            "ResidualConfig { a: B { c: 1 }, d: 2 }"
        );
        assert_eq!(residual_part("(no setup)"), "(no setup)");
    }
}
