//! Training the two agents (side by side when there are threads to spare) and evaluating
//! the three: [`run_experiment`].

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use centaur_gym::{Env, VecEnv};
use centaur_mpc::LocomotionController;
use centaur_rl::{Algorithm, MetricsCsv, Policy, RlError, UpdateMetrics};

use super::evaluation::{Driver, evaluate};
use super::options::{Curve, ExperimentError, ExperimentOptions, ExperimentResult, Phase, io_err};
use super::summary::{AgentStats, BudgetEval, ExperimentSummary};
use crate::hybrid::{ActionMapping, HybridError, ResidualConfig};
use crate::plot::{PlotError, PlotLabels, Series, plot_curves};
use crate::registry::{controller_config, make_residual_env, make_robot_env};
use crate::residual::start_as_controller;
use crate::rundir::{Claim, claim, write_atomic};

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
    let mut config = opts.algo.clone().with_seed(opts.seed);
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
                env: Box::new(make_residual_env(&opts.env, opts.residual.clone())?),
                policy: algo.policy(),
            },
            _ => Driver::Pure { env: make_robot_env(&opts.env, None)?, policy: algo.policy() },
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
    algo.save(&checkpoint)?;
    Ok(Trained { checkpoint, rows, wall, steps: algo.steps_done(), budgets: evals })
}

/// The files and folders an experiment writes into its directory.
pub const EXPERIMENT_FILES: [&str; 10] = [
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
}

/// Creates the run directory, refusing one that already holds a run unless `overwrite`
/// (which removes the run's files and folders, nothing else), and writes `experiment.json`.
fn prepare_run_dir(opts: &ExperimentOptions) -> Result<(), ExperimentError> {
    let dir = &opts.out;
    claim(dir, &EXPERIMENT_FILES, opts.overwrite).map_err(|c| match c {
        Claim::Taken(file) => ExperimentError::RunExists { dir: dir.clone(), file },
        Claim::Io(path, source) => ExperimentError::Io { path, source },
    })?;
    let record = ExperimentRecord {
        env: opts.env.clone(),
        algo: opts.algo.kind().name().to_string(),
        steps: opts.steps,
        seed: opts.seed,
        fingerprint: opts.fingerprint(),
    };
    let path = dir.join("experiment.json");
    let text = serde_json::to_string_pretty(&record).expect("the record serialises") + "\n";
    write_atomic(&path, &text).map_err(io_err(&path))
}

/// Checks that the run in `dir` trained its hybrid with `residual`: its `experiment.json`
/// fingerprint holds the setup it was run with. A run evaluated with another setup (a
/// different rating, steering span or parts) would be judged on a controller it never saw.
/// A rating equal to the controller's own for the gait is the same controller as none
/// (`the_trots_own_rating_reproduces_the_old_preset_bit_for_bit`), and records written
/// before `rated_speed` or `warmup_with_policy` existed lack those fields: both are matched.
/// `centaur robustness` and `examples/embed_controller` check with it.
pub fn check_trained_with(dir: &Path, residual: &ResidualConfig) -> Result<(), ExperimentError> {
    let path = dir.join("experiment.json");
    let text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
    let record: ExperimentRecord = serde_json::from_str(&text).map_err(|e| ExperimentError::Io {
        path: path.clone(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
    })?;
    let own_rating = controller_config(&record.env)
        .ok()
        .and_then(|c| c.offer(residual.command.gait).ok().map(|o| o.max_speed));
    if recorded_forms(residual, own_rating).iter().any(|form| record.fingerprint.contains(form.as_str())) {
        return Ok(());
    }
    Err(ExperimentError::SetupMismatch {
        run: dir.to_path_buf(),
        trained: residual_part(&record.fingerprint),
        given: format!("{residual:?}"),
    })
}

/// The texts a run's fingerprint may hold for `residual`: its own, and where its rating is
/// none or the controller's own (`own_rating`), the unrated one as recorded today and by the
/// versions before `rated_speed` and before `warmup_with_policy` (when off).
fn recorded_forms(residual: &ResidualConfig, own_rating: Option<f64>) -> Vec<String> {
    let mut forms = vec![format!("{residual:?}")];
    if residual.rated_speed.is_none() || residual.rated_speed == own_rating {
        let unrated = format!("{:?}", ResidualConfig { rated_speed: None, ..residual.clone() });
        let before_rating = unrated.replace(", rated_speed: None", "");
        if !residual.warmup_with_policy {
            forms.push(before_rating.replace(", warmup_with_policy: false", ""));
        }
        forms.extend([unrated, before_rating]);
    }
    forms
}

/// The `ResidualConfig { … }` part of a fingerprint (the whole fingerprint if it has none).
fn residual_part(fingerprint: &str) -> String {
    let Some(start) = fingerprint.find("ResidualConfig {") else { return fingerprint.to_string() };
    let mut depth = 0usize;
    for (i, c) in fingerprint[start..].char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return fingerprint[start..=start + i].to_string();
                }
            }
            _ => {}
        }
    }
    fingerprint[start..].to_string()
}

/// The result of a run already finished in `opts.out` with the same options (its
/// `experiment.json` fingerprint, `summary.json` and both agents' `metrics.csv`), or `None`
/// if the directory holds no such finished run. `centaur compare --resume` keeps these.
pub fn finished_experiment(opts: &ExperimentOptions) -> Option<ExperimentResult> {
    let read = |f: &str| std::fs::read_to_string(opts.out.join(f)).ok();
    let record: ExperimentRecord = serde_json::from_str(&read("experiment.json")?).ok()?;
    if record.fingerprint != opts.fingerprint() {
        return None;
    }
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
    make_residual_env(&opts.env, opts.residual.clone())?;
    // And a learner configuration out of range (reliability probe: no empty run directory).
    opts.algo.validate()?;
    prepare_run_dir(opts)?;
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
        let mut env = vec_env_of(
            &mut || Ok(make_robot_env(&opts.env, None)? as Box<dyn Env>),
            opts.n_envs,
            opts.threads,
        )?;
        train_one(opts, &opts.out.join("pure_rl"), &mut env, Phase::TrainPure, progress, &stop)
    };
    let train_hybrid = |progress: &mut dyn FnMut(Phase, &UpdateMetrics)| {
        let mut env = vec_env_of(
            &mut || Ok(Box::new(make_residual_env(&opts.env, opts.residual.clone())?) as Box<dyn Env>),
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
            env: make_robot_env(&opts.env, None)?,
            policy: Policy::load(&pure_ckpt).map_err(RlError::from)?,
        })
    };
    let hybrid = || -> Result<Driver, ExperimentError> {
        Ok(Driver::Hybrid {
            env: Box::new(make_residual_env(&opts.env, opts.residual.clone())?),
            policy: Policy::load(&hybrid_ckpt).map_err(RlError::from)?,
        })
    };
    let controller = || -> Result<Driver, ExperimentError> {
        let env = make_robot_env(&opts.env, None)?;
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

    /// The hybrid's setup is checked against the one a run recorded: the same passes, a
    /// different rating is refused naming both, a missing or corrupt record is an error.
    #[test]
    fn a_run_is_evaluated_only_with_the_setup_it_was_trained_with() {
        let dir = std::env::temp_dir().join(format!("centaur-trained-with-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let trained = residual_config("minitaur").unwrap();
        assert!(matches!(check_trained_with(&dir, &trained), Err(ExperimentError::Io { .. })));
        let record = |residual: &ResidualConfig| ExperimentRecord {
            env: "minitaur".into(),
            algo: "ppo".into(),
            steps: 10,
            seed: 0,
            fingerprint: format!("{:?}", ("minitaur", 10, residual, Some(5))),
        };
        let text = serde_json::to_string(&record(&trained)).unwrap();
        std::fs::write(dir.join("experiment.json"), text).unwrap();
        check_trained_with(&dir, &trained).unwrap();
        let other = ResidualConfig { rated_speed: Some(2.5), ..trained.clone() };
        let err = check_trained_with(&dir, &other).unwrap_err();
        let ExperimentError::SetupMismatch { trained: ref t, ref given, .. } = err else { panic!("{err}") };
        assert_eq!(*t, format!("{trained:?}"));
        assert_eq!(*given, format!("{other:?}"));
        // A record from before `rated_speed` and `warmup_with_policy` (a run trained at the
        // trot's own 2.5 m/s rating): matched by `--rated-speed 2.5` or no rating, not by the
        // preset's 3.0.
        let legacy = format!("{:?}", ResidualConfig { rated_speed: None, ..trained.clone() })
            .replace(", rated_speed: None", "")
            .replace(", warmup_with_policy: false", "");
        assert!(!legacy.contains("rated_speed") && !legacy.contains("warmup_with_policy"), "{legacy}");
        let legacy_record =
            ExperimentRecord { fingerprint: format!("(\"minitaur\", {legacy}, None)"), ..record(&trained) };
        std::fs::write(dir.join("experiment.json"), serde_json::to_string(&legacy_record).unwrap()).unwrap();
        check_trained_with(&dir, &other).unwrap();
        check_trained_with(&dir, &ResidualConfig { rated_speed: None, ..trained.clone() }).unwrap();
        assert!(matches!(check_trained_with(&dir, &trained), Err(ExperimentError::SetupMismatch { .. })));
        let faster = ResidualConfig {
            rated_speed: Some(2.5),
            steering: crate::hybrid::Steering { speed: 0.5, yaw_rate: 0.0 },
            ..trained.clone()
        };
        assert!(matches!(check_trained_with(&dir, &faster), Err(ExperimentError::SetupMismatch { .. })));
        std::fs::write(dir.join("experiment.json"), "{ not json").unwrap();
        assert!(matches!(check_trained_with(&dir, &trained), Err(ExperimentError::Io { .. })));
        std::fs::remove_dir_all(&dir).unwrap();
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
