//! The `centaur` command line: `centaur train --env pendulum --algo sac --steps 20000 --seed 0 --out runs/sac`;
//! `centaur control --env minitaur --gait trot --speed 0.3 --seconds 10 --out runs/ctrl`;
//! `centaur compare --env minitaur --algo ppo --seeds 5 --steps 150000 --out runs/cmp`.

use std::path::PathBuf;
use std::process::ExitCode;

use centaur_envs::minitaur::MotorInverse;
use centaur_lab::cli::{HybridArgs, TrainingProgress, positive_count, progress_style};
use centaur_lab::compare::{CompareOptions, run_compare};
use centaur_lab::control::{ControlOptions, Push, check_out_dir, run_control, write_summary};
use centaur_lab::experiment::Phase;
use centaur_lab::experiment::{
    Condition, RobustnessOptions, recorded_hybrid, robustness_table, run_robustness,
};
use centaur_lab::spec::{CountFlags, Purpose, RunSpec};
use centaur_lab::train::{TrainOptions, read_run_record, resume, train};
use centaur_mpc::{Gait, MpcSolver};
use centaur_rl::AlgoKind;
use clap::{Args, Parser, Subcommand};
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

// Parsed once per process: the size of the largest variant (compare's flags) costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// Train a learner on an environment; writes run.json, metrics.csv, checkpoint (also
    /// every --checkpoint-every steps), summary.json and learning_curve.{svg,png} into --out.
    /// `--resume DIR` continues a killed run to the same result.
    Train(TrainArgs),
    /// Train pure RL and the hybrid (residual RL on the controller) with the same budget over
    /// several seeds, evaluate both and the controller alone; writes compare.json,
    /// learning_curves.{png,svg} and one run directory per seed into --out.
    Compare(CompareArgs),
    /// Run the model-based controller (convex MPC + whole-body QP) alone on a robot
    /// environment; writes summary.json into --out.
    Control(ControlArgs),
    /// Evaluate a run's three agents (the hybrid, pure RL, the controller alone) under
    /// lateral pushes, base-mass, friction and motor-strength changes; prints the table and
    /// writes robustness.json into the run directory.
    Robustness(RobustnessArgs),
    /// Evaluate a trained policy deterministically on its environment or another
    /// configuration of it (`--config` with an `[env]` table); prints the table and writes
    /// eval.json (eval_FILE.json with --config FILE) beside the checkpoint.
    Eval(EvalArgs),
    /// Check a run spec and print it resolved: every value explicit (the learner's every
    /// hyperparameter, the hybrid's whole setup), as a run records it in spec.json, with its
    /// identity. Nothing runs; a bad spec is refused naming the key.
    Spec(SpecArgs),
    /// Train a grid (or list) of run settings × seeds in parallel, resumably; writes one run
    /// directory per point and seed, sweep.json (IQM with 95 % CIs per point) and
    /// sweep_curves.{png,svg}.
    Sweep(SweepArgs),
}

/// Arguments of `centaur sweep`.
#[derive(Args)]
struct SweepArgs {
    /// The grid file (see `centaur_lab::sweep` or the README); several (a study's files, e.g.
    /// `--grid studies/d_*.toml`) run one after another, each into `OUT/<file stem>`, all
    /// checked before the first runs.
    #[arg(long, num_args = 1.., required = true)]
    grid: Vec<PathBuf>,
    /// Seeds per point (0..seeds) [default: the spec's `seeds` over a spec, else 3]
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u64).range(1..=1000))]
    seeds: Option<u64>,
    /// A run spec every point starts from, for grid files that name none (their keys are
    /// then the spec's table keys, e.g. `"learner.learning_rate" = [3e-4, 1e-4]`)
    #[arg(long)]
    spec: Option<PathBuf>,
    /// Override one key of the spec, e.g. `--set hybrid.residual_scale=0.4` (repeatable)
    #[arg(long = "set", value_name = "KEY=VALUE", requires = "spec")]
    sets: Vec<String>,
    /// Output directory; rerunning the same grid keeps finished runs and resumes the rest.
    #[arg(long, required_unless_present = "check")]
    out: Option<PathBuf>,
    /// Check the grid file (every point's and judge's settings) and list its points; run
    /// nothing.
    #[arg(long)]
    check: bool,
    /// Runs at once, one thread each [default: the available cores].
    #[arg(long, allow_negative_numbers = true, value_parser = positive_count)]
    jobs: Option<usize>,
    /// Replace a sweep of another grid in --out.
    #[arg(long)]
    overwrite: bool,
}

/// `centaur sweep`.
fn sweep(args: SweepArgs) -> ExitCode {
    // Every grid is checked (and its output named) before anything runs.
    let spec = args.spec.clone().map(|path| centaur_lab::sweep::SpecSource { path, sets: args.sets.clone() });
    let mut grids = Vec::with_capacity(args.grid.len());
    for path in &args.grid {
        match centaur_lab::sweep::check_grid_with(path, spec.as_ref()) {
            Ok(g) => grids.push((path.clone(), g)),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let seeds_of = |g: &centaur_lab::sweep::CheckedGrid| args.seeds.or(g.spec_seeds).unwrap_or(3);
    if args.check {
        for (path, g) in &grids {
            let judges: Vec<&String> = g.grid.judges.keys().collect();
            println!(
                "{}: {} on {}, {} steps per run, {} points × {} seeds; judges: {}",
                path.display(),
                g.grid.algo,
                g.grid.env,
                g.grid.steps,
                g.points.len(),
                seeds_of(g),
                if judges.is_empty() { "none".to_string() } else { format!("{judges:?}") }
            );
            for p in &g.points {
                let values: Vec<String> = p.values.iter().map(|(k, v)| format!("{k} = {v}")).collect();
                println!("{}: {}", p.name, values.join(", "));
            }
        }
        return ExitCode::SUCCESS;
    }
    let out = args.out.expect("clap requires --out without --check");
    let outs = match centaur_lab::sweep::study_dirs(&grids, &out, args.overwrite) {
        Ok(outs) => outs,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let jobs = args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    for ((grid, checked), out) in grids.iter().zip(outs) {
        let seeds = seeds_of(checked);
        let opts = centaur_lab::sweep::SweepOptions {
            grid: grid.clone(),
            seeds,
            out,
            jobs,
            overwrite: args.overwrite,
            spec: spec.clone(),
        };
        if grids.len() > 1 {
            println!("== {} → {}", opts.grid.display(), opts.out.display());
        }
        // Said before the first run, which may take a while to end: what runs and where.
        println!(
            "{} points × {} seeds = {} runs of {} steps ({} on {}), {jobs} at a time → {}",
            checked.points.len(),
            seeds,
            checked.points.len() as u64 * seeds,
            checked.grid.steps,
            checked.grid.algo,
            checked.grid.env,
            opts.out.display()
        );
        let done = std::sync::atomic::AtomicUsize::new(0);
        let report = |point: &str, seed: u64, s: &centaur_lab::train::Summary| {
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            println!(
                "[{k}] {point} seed {seed}: final return {:.2} ({} steps, {:.0} s)",
                s.final_return_mean, s.steps, s.wall_seconds
            );
        };
        match centaur_lab::sweep::run_sweep(&opts, &report) {
            Ok(summary) => {
                if summary.kept_runs > 0 {
                    println!("kept {} runs finished before", summary.kept_runs);
                }
                println!();
                print!("{}", centaur_lab::sweep::markdown(&summary));
                println!("\nwrote {}\n", opts.out.join("sweep.json").display());
            }
            Err(e) => {
                eprintln!("error: {}: {e}", opts.grid.display());
                return ExitCode::FAILURE;
            }
        }
    }
    ExitCode::SUCCESS
}

/// Arguments of `centaur eval`.
#[derive(Args)]
struct EvalArgs {
    /// A run directory (its `checkpoint`) or a checkpoint file.
    #[arg(long)]
    checkpoint: PathBuf,
    /// A run file whose `[env]` table replaces the settings the policy was trained with.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Evaluate on another environment than the checkpoint's (its spaces must fit).
    #[arg(long)]
    env: Option<String>,
    /// Deterministic episodes.
    #[arg(long, allow_negative_numbers = true, default_value_t = 10, value_parser = positive_count)]
    episodes: usize,
    /// Episode k resets with seed + k.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1_000_000)]
    seed: u64,
    /// Record the first episode as an MCAP file for Foxglove (robot environments).
    #[arg(long)]
    record: Option<PathBuf>,
    /// Where to write the report [default: beside the checkpoint, eval.json; with --config
    /// FILE or --env NAME, eval_NAME_FILE.json, with _fade behind --fade, so that no
    /// judgement replaces another].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Evaluate even if the environment the checkpoint records is no longer what its name
    /// and settings build (a preset or default changed since training).
    #[arg(long)]
    allow_env_change: bool,
    /// A hybrid (`<robot>-residual`) behind a safety fade: its steering fades from a sag of
    /// START to none halfway to END, then its joint residual to none at END (as `centaur
    /// compare --fade`; a filter on the trained policy) [default: none]
    #[arg(long, num_args = 2, value_names = ["START", "END"], allow_negative_numbers = true)]
    fade: Option<Vec<f64>>,
}

/// `centaur eval`.
fn eval(args: EvalArgs) -> ExitCode {
    let opts = centaur_lab::eval::EvalOptions {
        checkpoint: args.checkpoint,
        config: args.config,
        env: args.env,
        episodes: args.episodes,
        seed: args.seed,
        record: args.record,
        out: args.out,
        allow_env_change: args.allow_env_change,
        fade: args.fade.as_deref().map(|f| centaur_lab::hybrid::Fade { start: f[0], end: f[1] }),
    };
    match centaur_lab::eval::run_eval(&opts) {
        Ok(report) => {
            print!("{}", centaur_lab::eval::markdown(&report));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Arguments of `centaur train`.
#[derive(Args)]
struct TrainArgs {
    /// A run spec (TOML; see `centaur_lab::spec`) giving the environment (`robot`; the hybrid is
    /// `<robot>-residual`, with its `[hybrid]`, `[controller]` and `[exploration]`), the learner
    /// and its `[learner]` settings, the budget and `[env]`; --steps, --envs, --eval-episodes and
    /// --eval-every override it, --env, --algo and --config go in it
    #[arg(long, value_name = "FILE", conflicts_with_all = ["env", "algo", "config", "resume"])]
    spec: Option<PathBuf>,
    /// Override one key of --spec, e.g. `--set learner.learning_rate=1e-4` (repeatable)
    #[arg(long = "set", value_name = "KEY=VALUE", requires = "spec")]
    sets: Vec<String>,
    /// Environment name (see `centaur train --env ?` for the list; `modular:FILE.json` for a
    /// modular robot described in a file).
    #[arg(long, required_unless_present_any = ["resume", "spec"])]
    env: Option<String>,
    /// Algorithm: ppo, a2c, sac, sac1, td3 or ddpg.
    #[arg(long, value_parser = parse_algo, required_unless_present_any = ["resume", "spec"])]
    algo: Option<AlgoKind>,
    /// Environment steps to train for [default: the spec's].
    #[arg(long, allow_negative_numbers = true, required_unless_present_any = ["resume", "spec"])]
    steps: Option<u64>,
    /// Seed [default: the config file's `seed`, else 0].
    #[arg(long, allow_negative_numbers = true)]
    seed: Option<u64>,
    /// Output directory (refused if it already holds a run, unless --overwrite).
    #[arg(long, required_unless_present = "resume")]
    out: Option<PathBuf>,
    /// TOML file setting any of the algorithm's hyperparameters and, in an `[env]` table, the
    /// environment's settings over its preset (read once, kept in run.json).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Threads stepping the environments (results do not depend on it).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1)]
    threads: usize,
    /// Number of parallel environments [default: the spec's, else 1].
    #[arg(long, allow_negative_numbers = true)]
    envs: Option<usize>,
    /// Deterministic evaluation episodes at the end (at least 10) [default: the spec's, else 10].
    #[arg(long, allow_negative_numbers = true)]
    eval_episodes: Option<usize>,
    /// Environment steps between checkpoints (0: only at the end); each checkpoint starts
    /// fresh episodes so that a resumed run continues exactly.
    #[arg(long, allow_negative_numbers = true, default_value_t = centaur_lab::train::DEFAULT_CHECKPOINT_EVERY)]
    checkpoint_every: u64,
    /// Environment steps between deterministic evaluations of the checkpoint, written to
    /// evaluations.csv (0: only the final one); a multiple of --checkpoint-every [default:
    /// the spec's, else 0].
    #[arg(long, allow_negative_numbers = true)]
    eval_every: Option<u64>,
    /// Replace the run already in --out (its run files only).
    #[arg(long, conflicts_with = "resume")]
    overwrite: bool,
    /// Continue the run in this directory from its last checkpoint (every setting comes from
    /// its run.json; only --threads may be given).
    #[arg(
        long,
        value_name = "DIR",
        conflicts_with_all = ["env", "algo", "steps", "seed", "out", "config", "envs", "eval_episodes", "checkpoint_every", "eval_every"]
    )]
    resume: Option<PathBuf>,
}

/// The options of `centaur train`: from the flags, or from `--spec` with the flags over it.
fn train_options(args: &TrainArgs, out: PathBuf) -> Result<TrainOptions, String> {
    let Some(path) = &args.spec else {
        return Ok(TrainOptions {
            env: args.env.clone().expect("clap requires --env"),
            algo: args.algo.expect("clap requires --algo"),
            steps: args.steps.expect("clap requires --steps"),
            seed: args.seed,
            out,
            config: args.config.clone(),
            threads: args.threads,
            n_envs: args.envs.unwrap_or(1),
            eval_episodes: args.eval_episodes.unwrap_or(10),
            checkpoint_every: args.checkpoint_every,
            eval_every: args.eval_every.unwrap_or(0),
            overwrite: args.overwrite,
            spec: None,
        });
    };
    let spec = RunSpec::read(path, &args.sets).map_err(|e| e.to_string())?.with_counts(CountFlags {
        seeds: None,
        steps: args.steps,
        envs: args.envs.map(|n| n as u64),
        eval_episodes: args.eval_episodes.map(|n| n as u64),
        eval_every: args.eval_every,
    });
    let resolved = spec.resolve(Purpose::Train).map_err(|e| e.to_string())?;
    Ok(TrainOptions {
        env: resolved.robot.clone(),
        algo: resolved.kind(),
        steps: resolved.steps,
        seed: args.seed,
        out,
        config: None,
        threads: args.threads,
        n_envs: resolved.envs,
        eval_episodes: resolved.eval_episodes,
        checkpoint_every: args.checkpoint_every,
        eval_every: resolved.eval_every,
        overwrite: args.overwrite,
        spec: Some(resolved),
    })
}

/// Arguments of `centaur robustness`.
#[derive(Args)]
struct RobustnessArgs {
    /// Robot environment the run trained on (the study covers minitaur) [default: the one
    /// the run records]
    #[arg(long)]
    env: Option<String>,
    /// Run directory (of `residual_ppo_minitaur` or one seed of `centaur compare`).
    #[arg(long)]
    run: PathBuf,
    /// Deterministic episodes per agent and condition.
    #[arg(long, allow_negative_numbers = true, default_value_t = 10, value_parser = positive_count)]
    episodes: usize,
    /// The controller (alone and in the hybrid) turns its torques into actions with the
    /// nominal motor model, whatever the run was trained with (by default: the one it was
    /// trained with, the nominal one in newer runs, in older ones the one drawn at reset,
    /// whose strength, damping and battery voltage a controller on the robot would not know);
    /// writes robustness_nominal_motor.json instead of robustness.json
    #[arg(long)]
    nominal_motor: bool,
    /// Overrides of the hybrid's setup, over the one the run records in experiment.json (a
    /// flag that changes what the policy was trained with is warned about; a record from
    /// before the setup was data takes the robot's preset with these flags and is checked
    /// against its text). `--fade START END` evaluates the hybrid behind a safety fade
    /// whatever it was trained with, writing robustness_fade.json
    /// (robustness_nominal_motor_fade.json with --nominal-motor).
    #[command(flatten)]
    hybrid: HybridArgs,
}

/// `centaur robustness`.
fn robustness(args: RobustnessArgs) -> ExitCode {
    let (env, residual) = match robustness_setup(&args) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let opts = RobustnessOptions {
        env,
        run: args.run.clone(),
        residual,
        episodes: args.episodes.max(1),
        seed: 2_000_000,
        conditions: Condition::standard(),
        motor_inverse: args.nominal_motor.then_some(MotorInverse::Nominal),
    };
    match run_robustness(&opts) {
        Ok(rows) => {
            print!("{}", robustness_table(&rows));
            let name = format!(
                "robustness{}{}.json",
                if args.nominal_motor { "_nominal_motor" } else { "" },
                if opts.residual.fade.is_some() { "_fade" } else { "" }
            );
            let path = args.run.join(name);
            let text = serde_json::to_string_pretty(&rows).expect("rows serialise");
            if let Err(e) = centaur_lab::rundir::write_atomic(&path, &(text + "\n")) {
                eprintln!("error: {}: {e}", path.display());
                return ExitCode::FAILURE;
            }
            println!("\nwrote {}", path.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Arguments of `centaur control`.
#[derive(Args)]
struct ControlArgs {
    /// Robot environment: minitaur, minitaur-deterministic, minitaur-fast, ant, walker2d or
    /// humanoid.
    #[arg(long)]
    env: String,
    /// Gait: stand, walk, trot, pace, bound, pronk or gallop; each robot offers some of them
    /// up to a rated speed (minitaur: stand, trot to 2.5 m/s, walk to 0.5, bound to 2.5,
    /// pronk to 2.0; ant: stand, trot to 1.2, walk to 0.3; walker2d: stand, walk to 1.0;
    /// humanoid: stand (by stepping in place), walk to 0.5) and refuses the others with an
    /// error naming what it offers.
    #[arg(long, value_parser = centaur_lab::cli::gait_name, default_value = "trot")]
    gait: Gait,
    /// Commanded forward speed (m/s).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    speed: f64,
    /// Simulated seconds.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Reset seed.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0)]
    seed: u64,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Push on the body (N): lateral, world +y (negative pushes to the right), or with
    /// `--push-axis x` along world +x, the robots' starting heading (negative pushes back;
    /// the planar Walker2d takes only these).
    #[arg(long, allow_negative_numbers = true)]
    push_force: Option<f64>,
    /// The push's axis: `y` (lateral, the default) or `x` (fore and aft).
    #[arg(long, default_value = "y", value_parser = ["x", "y"], requires = "push_force")]
    push_axis: String,
    /// Start of the push (s).
    #[arg(long, default_value_t = 3.0, requires = "push_force")]
    push_at: f64,
    /// Duration of the push (s).
    #[arg(long, default_value_t = 0.1, requires = "push_force")]
    push_duration: f64,
    /// Measure distance, speed and drifts from this time (s), e.g. after a landing.
    #[arg(long, default_value_t = 0.0)]
    measure_from: f64,
    /// Solve the MPC on a worker thread and simulate in real time (ticks then never wait
    /// for a solve; the run takes `--seconds` of wall time and is not bit-reproducible).
    #[arg(long)]
    background_mpc: bool,
    /// The MPC's solver: structured (the default) or clarabel.
    #[arg(long, value_parser = parse_mpc_solver, default_value = "structured")]
    mpc_solver: MpcSolver,
    /// Commanded yaw rate (rad/s, positive turns left); each gait is rated to turn up to a
    /// yaw rate and speed (minitaur: trot ±0.5 rad/s to 0.6 m/s, bound ±0.5 to 1.0 m/s and
    /// ±0.3 to 1.2 m/s, the walk and the pronk straight; ant: trot ±0.5 to 1.0 m/s, walk
    /// ±0.5; humanoid: walk ±0.5 to 0.4 m/s and ±0.3 to 0.5 m/s; walker2d: planar, straight)
    /// and refuses more with an error saying its rating.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    yaw_rate: f64,
    /// Speed steps within the run: `T:V,T:V,…` commands V m/s from T s on (`--speed`
    /// before the first), e.g. `0:0,1:1.5,6:0`; the summary gives each segment's mean speed.
    #[arg(long, value_parser = parse_speed_schedule)]
    speed_schedule: Option<SpeedSchedule>,
    /// Gaussian noise added to every action entry each control step, as a fraction of the
    /// entry's half-range (0.1: 10 %), as a learner's exploration perturbs the controller.
    #[arg(long, default_value_t = 0.0)]
    action_noise: f64,
    /// Run a gait the robot does not offer, or faster than its rating, to measure it (the
    /// controller's speed clamp is lifted too).
    #[arg(long)]
    unrated: bool,
    /// Minitaur: turn the controller's torques into actions with the motor model drawn at
    /// reset (which a controller on the robot would not know; the earlier default)
    /// instead of the nominal one
    #[arg(long)]
    drawn_motor: bool,
    /// Multiplies the gait's period, a factor in [0.25, 4]: below 1 the gait clock steps
    /// faster (as the hybrid's `--period-scale`).
    #[arg(long, default_value_t = 1.0)]
    period_scale: f64,
    /// Moves every leg's stance fraction by this much from its gait's own, in [-0.3, 0.3]:
    /// below 0 the feet lift off sooner, a trot with flight phases (as the hybrid's
    /// `--steer-duty` lets its policy do)
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    duty_shift: f64,
    /// The command ramp, m/s² in (0, 20], replacing the controller's own (as the hybrid's
    /// `--max-acceleration`) [default: the controller's own: minitaur 3, ant 1, walker2d 1,
    /// humanoid 0.3]
    #[arg(long, allow_negative_numbers = true)]
    max_acceleration: Option<f64>,
    /// The swing feet's apex height, m in [0.01, 0.3], replacing the controller's own (as
    /// the hybrid's `--swing-height`) [default: the controller's own: minitaur 0.07, ant,
    /// walker2d and humanoid 0.08]
    #[arg(long, allow_negative_numbers = true)]
    swing_height: Option<f64>,
}

/// `--speed-schedule`'s pairs (a newtype, so that clap takes the list as one value).
#[derive(Clone, Debug)]
struct SpeedSchedule(Vec<(f64, f64)>);

fn parse_speed_schedule(s: &str) -> Result<SpeedSchedule, String> {
    s.split(',')
        .map(|pair| {
            let (t, v) = pair.split_once(':').ok_or_else(|| format!("`{pair}`: expected TIME:SPEED"))?;
            let num = |x: &str| x.trim().parse::<f64>().map_err(|e| format!("`{x}`: {e}"));
            Ok((num(t)?, num(v)?))
        })
        .collect::<Result<_, String>>()
        .map(SpeedSchedule)
}

#[derive(Args)]
struct CompareArgs {
    /// A run spec (TOML; see `centaur_lab::spec`): robot, learner, seeds, budget, `[env]`,
    /// `[learner]`, `[hybrid_learner]`, `[hybrid]`, `[controller]`, `[exploration]`. The flags below
    /// that it also sets override it; --env, --algo, --config and --hybrid-config go in it
    #[arg(long, value_name = "FILE", conflicts_with_all = ["env", "algo", "config", "hybrid_config"])]
    spec: Option<PathBuf>,
    /// Override one key of --spec, e.g. `--set controller.rated_speed=4.0` (repeatable)
    #[arg(long = "set", value_name = "KEY=VALUE", requires = "spec")]
    sets: Vec<String>,
    /// Robot environment with a controller: minitaur, minitaur-fast, ant, walker2d, humanoid.
    #[arg(long, required_unless_present = "spec")]
    env: Option<String>,
    /// Algorithm: ppo, a2c, sac, sac1, td3 or ddpg.
    #[arg(long, value_parser = parse_algo, required_unless_present = "spec")]
    algo: Option<AlgoKind>,
    /// Number of seeds (0..seeds) [default: the spec's, else 5].
    #[arg(long, allow_negative_numbers = true)]
    seeds: Option<u64>,
    /// Training steps per agent and seed [default: the spec's].
    #[arg(long, allow_negative_numbers = true, required_unless_present = "spec")]
    steps: Option<u64>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// TOML file with hyperparameters for both agents (default: the examples' settings for
    /// this robot and algorithm, else the algorithm's defaults) and, in an `[env]` table, the
    /// robot's settings over its preset for all three agents (as `centaur train` takes).
    #[arg(long)]
    config: Option<PathBuf>,
    /// TOML file with the hybrid's own hyperparameters (no `[env]` table), replacing --config's
    /// for the hybrid only: each agent at its own tuning. Pure RL keeps --config's, so
    /// --pure-from may reuse the agents of a comparison run without it
    #[arg(long, value_name = "FILE")]
    hybrid_config: Option<PathBuf>,
    /// Parallel environments per agent [default: the spec's, else 4 for PPO and A2C, 1 otherwise].
    #[arg(long, allow_negative_numbers = true)]
    envs: Option<u64>,
    /// Threads stepping each agent's environments; with more than one, a seed's two agents
    /// also train side by side (results unchanged).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = positive_count)]
    threads: usize,
    /// Seeds run at once, each on its own --threads (results unchanged).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = positive_count)]
    jobs: usize,
    /// Evaluation episodes per agent and seed [default: the spec's, else 10].
    #[arg(long, allow_negative_numbers = true)]
    eval_episodes: Option<u64>,
    /// Evaluate both learners deterministically every this many training steps (and at
    /// the end); 0: at the end only [default: the spec's, else 100000].
    #[arg(long, allow_negative_numbers = true)]
    eval_every: Option<u64>,
    /// Keep the seeds already finished in --out with the same options and run the rest (a
    /// killed comparison loses at most the seeds it was running); a seed holding a run of
    /// other options is refused before anything trains.
    #[arg(long, conflicts_with = "overwrite")]
    resume: bool,
    /// Replace the comparison already in --out (its run files only).
    #[arg(long)]
    overwrite: bool,
    /// Reuse the pure-RL agents of a finished comparison (its seed_K directories) instead of
    /// training them again: for an ablation of the hybrid. That comparison must have been run
    /// with the same options but for the hybrid's (refused, naming the difference, otherwise)
    #[arg(long, value_name = "DIR")]
    pure_from: Option<PathBuf>,
    /// The hybrid's setup (each flag sets one key of the spec's `[hybrid]`, `[controller]` or
    /// `[exploration]`, over the spec's).
    #[command(flatten)]
    hybrid: HybridArgs,
}

/// The run spec a comparison's flags describe: `--spec FILE` with its `--set`s, or the
/// flags themselves (`--config` as a `[learner]` over the defaults and its `[env]`), with
/// `--seeds`, `--steps`, `--envs`, `--eval-episodes` and `--eval-every` over either.
fn compare_spec(args: &CompareArgs) -> Result<RunSpec, String> {
    let spec = match &args.spec {
        Some(path) => RunSpec::read(path, &args.sets).map_err(|e| e.to_string())?,
        None => RunSpec::from_flags(
            args.env.as_deref().expect("clap requires --env without --spec"),
            args.algo.expect("clap requires --algo without --spec"),
            args.steps.expect("clap requires --steps without --spec"),
            args.config.as_deref(),
            args.hybrid_config.as_deref(),
        )?,
    };
    Ok(spec.with_counts(CountFlags {
        seeds: args.seeds,
        steps: args.steps,
        envs: args.envs,
        eval_episodes: args.eval_episodes,
        eval_every: args.eval_every,
    }))
}

/// The robot and the hybrid's setup of `centaur robustness`: the run's recorded ones with
/// the flags over them (a change to what the policy was trained with is warned about).
fn robustness_setup(args: &RobustnessArgs) -> Result<(String, centaur_lab::hybrid::ResidualConfig), String> {
    let (recorded_env, recorded) = recorded_hybrid(&args.run).map_err(|e| e.to_string())?;
    let env = args.env.clone().unwrap_or(recorded_env);
    let residual = args.hybrid.tables().apply(recorded.clone()).map_err(|e| e.to_string())?;
    let without_fade = |r: &centaur_lab::hybrid::ResidualConfig| centaur_lab::hybrid::ResidualConfig {
        fade: None,
        ..r.clone()
    };
    if without_fade(&residual) != without_fade(&recorded) {
        eprintln!(
            "warning: {} trained its hybrid with {recorded:?}; evaluating it with {residual:?}, as the flags ask",
            args.run.display()
        );
    }
    Ok((env, residual))
}

/// Arguments of `centaur spec`.
#[derive(Args)]
struct SpecArgs {
    /// The run spec (TOML).
    file: PathBuf,
    /// Override one key, e.g. `--set controller.rated_speed=4.0` (repeatable)
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Resolve it as `centaur train` does (one agent on `robot`) even where the robot has a
    /// controller [default: a robot with a controller as `centaur compare` does, any other
    /// environment, `<robot>-residual` included, as `centaur train` does]
    #[arg(long)]
    train: bool,
}

/// `centaur spec`: a spec checked and printed resolved.
fn spec_command(args: SpecArgs) -> ExitCode {
    let resolved = RunSpec::read(&args.file, &args.sets).and_then(|s| {
        let purpose = if args.train { Purpose::Train } else { s.purpose() };
        s.resolve(purpose)
    });
    match resolved {
        Ok(resolved) => {
            print!("{}", resolved.record_json());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The command line as typed, each argument quoted where a shell would need it.
fn command_line() -> String {
    let quote = |a: String| {
        if !a.is_empty() && a.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+".contains(c)) {
            a
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    };
    let mut args = std::env::args();
    let program = args.next().map(|p| {
        std::path::Path::new(&p).file_name().map_or(p.clone(), |f| f.to_string_lossy().into_owned())
    });
    program.into_iter().chain(args.map(quote)).collect::<Vec<_>>().join(" ")
}

/// `centaur compare`: pure RL against the hybrid over several seeds.
fn compare(args: CompareArgs) -> ExitCode {
    let resolved = compare_spec(&args).and_then(|spec| {
        spec.resolve_with(Purpose::Compare, &args.hybrid.tables()).map_err(|e| e.to_string())
    });
    let base =
        resolved.and_then(|r| CompareOptions::from_spec(&r, args.out.clone()).map_err(|e| e.to_string()));
    let base = match base {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let opts = CompareOptions {
        threads: args.threads,
        jobs: args.jobs,
        resume: args.resume,
        overwrite: args.overwrite,
        pure_from: args.pure_from,
        command: Some(command_line()),
        ..base
    };
    let seeds = opts.seeds.max(1);
    let bar = ProgressBar::new(seeds * 2 * opts.steps);
    bar.set_style(progress_style());
    let steps = opts.steps;
    let learner = opts.algo.kind().name().to_uppercase();
    // One progress record per seed: with --jobs, several seeds report at once.
    let mut training = vec![TrainingProgress::default(); seeds as usize];
    let mut done = vec![0; seeds as usize];
    let result = run_compare(&opts, &mut |seed, phase, m| {
        let k = seed as usize;
        if phase == Phase::Evaluate {
            bar.set_message(format!("seed {seed} evaluating"));
            done[k] = 2 * steps;
        } else {
            done[k] = training[k].record(phase, m, steps);
            bar.set_message(format!("seed {seed} {}", training[k].message(&learner)));
        }
        bar.set_position(done.iter().sum());
    });
    bar.finish_and_clear();
    match result {
        Ok(summary) => {
            println!(
                "{} on {}: {} seeds × {} steps per agent, {} evaluation episodes each\n",
                summary.algo, summary.env, summary.seeds, summary.steps, opts.eval_episodes
            );
            print!("{}", summary.markdown_table());
            if summary.budgets.len() > 1 {
                println!("\nBy training budget (deterministic evaluation):\n");
                print!("{}", summary.budget_table());
            }
            println!("\nThe hybrid against pure RL (IQMs over seeds):\n");
            print!("{}", summary.head_to_head.text());
            println!(
                "\nwrote {}, {} and {}",
                opts.out.join("compare.json").display(),
                opts.out.join("results.md").display(),
                opts.out.join("spec.json").display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn parse_mpc_solver(s: &str) -> Result<MpcSolver, String> {
    match s {
        "structured" => Ok(MpcSolver::Structured),
        "clarabel" => Ok(MpcSolver::Clarabel),
        other => Err(format!("unknown MPC solver `{other}` (structured or clarabel)")),
    }
}

/// `centaur control`: one closed-loop run, its summary printed and written.
fn control(args: ControlArgs) -> ExitCode {
    let opts = ControlOptions {
        env: args.env,
        gait: args.gait,
        speed: args.speed,
        seconds: args.seconds,
        seed: args.seed,
        push: args.push_force.map(|f| Push {
            at: args.push_at,
            force: if args.push_axis == "x" { [f, 0.0, 0.0] } else { [0.0, f, 0.0] },
            duration: args.push_duration,
        }),
        measure_from: args.measure_from,
        background_mpc: args.background_mpc,
        mpc_solver: args.mpc_solver,
        yaw_rate: args.yaw_rate,
        speed_schedule: args.speed_schedule.map(|s| s.0).unwrap_or_default(),
        action_noise: args.action_noise,
        unrated: args.unrated,
        drawn_motor: args.drawn_motor,
        period_scale: args.period_scale,
        duty_shift: args.duty_shift,
        max_acceleration: args.max_acceleration,
        swing_height: args.swing_height,
    };
    let result = check_out_dir(&args.out)
        .and_then(|()| run_control(&opts))
        .and_then(|s| write_summary(&args.out, &s).map(|path| (s, path)));
    match result {
        Ok((s, path)) => {
            // A turning run's mean speed along its initial heading says little: report the
            // yaw rate and the speed along the heading instead.
            let motion = if s.commanded_yaw_rate != 0.0 {
                format!(
                    "mean yaw rate {:.3} rad/s (commanded {}), speed along the heading {:.3} m/s",
                    s.mean_yaw_rate, s.commanded_yaw_rate, s.mean_forward_speed
                )
            } else if s.segments.len() > 1 {
                // A speed schedule: each segment's command and mean speed.
                let segs: Vec<String> = s
                    .segments
                    .iter()
                    .map(|g| {
                        format!("{:.3} m/s from {} s (commanded {})", g.mean_speed, g.from, g.commanded_speed)
                    })
                    .collect();
                format!("mean speed {}", segs.join(", "))
            } else {
                format!("mean speed {:.3} m/s", s.mean_speed)
            };
            let command = if s.segments.len() > 1 {
                "on its speed schedule".to_string()
            } else {
                format!("at {} m/s", s.commanded_speed)
            };
            let command = if s.period_scale == 1.0 {
                command
            } else {
                format!("{command} (its period × {})", s.period_scale)
            };
            let command = if s.duty_shift == 0.0 {
                command
            } else {
                format!("{command} (its stance fractions {:+})", s.duty_shift)
            };
            let cot = s.cost_of_transport.map_or(String::new(), |c| format!(", cost of transport {c:.2}"));
            println!(
                "{} {} {command} for {:.1} s: {motion}, {}, yaw drift {:.3} rad{cot}, tick {:.0} µs mean / {:.0} µs p99 (MPC {:.0} µs, WBC {:.0} µs); wrote {}",
                s.env,
                s.gait,
                s.seconds,
                if s.fell { "fell" } else { "did not fall" },
                s.yaw_drift,
                s.mean_tick_us,
                s.p99_tick_us,
                s.mean_mpc_solve_us,
                s.mean_wbc_solve_us,
                path.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn parse_algo(s: &str) -> Result<AlgoKind, String> {
    AlgoKind::from_name(s).ok_or_else(|| {
        format!("unknown algorithm `{s}` (one of: {})", AlgoKind::ALL.map(|k| k.name()).join(", "))
    })
}

fn main() -> ExitCode {
    let args = match Cli::parse().command {
        Command::Train(args) => args,
        Command::Control(args) => return control(args),
        Command::Compare(args) => return compare(args),
        Command::Robustness(args) => return robustness(args),
        Command::Eval(args) => return eval(args),
        Command::Sweep(args) => return sweep(args),
        Command::Spec(args) => return spec_command(args),
    };
    train_command(args)
}

/// `centaur train`.
fn train_command(args: TrainArgs) -> ExitCode {
    let resolved = match &args.resume {
        Some(dir) => read_run_record(dir)
            .map(|r| (r.steps, r.eval_episodes, dir.clone(), None))
            .map_err(|e| e.to_string()),
        None => {
            let out = args.out.clone().expect("clap requires --out");
            train_options(&args, out.clone()).map(|o| (o.steps, o.eval_episodes, out, Some(o)))
        }
    };
    let (steps, eval_episodes, out, opts) = match resolved {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let bar = ProgressBar::new(steps);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} steps {per_sec} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let mut progress = |m: &centaur_rl::UpdateMetrics| {
        bar.set_position(m.env_steps.min(steps));
        if m.episode_return_mean.is_finite() {
            bar.set_message(format!("return {:.1}", m.episode_return_mean));
        }
    };
    // Without options the run is resumed, in its own directory.
    let result = match &opts {
        Some(opts) => train(opts, &mut progress),
        None => resume(&out, args.threads, &mut progress),
    };
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
                eval_episodes.max(10),
                out.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
