//! The command line of the examples and the `centaur` binary: arguments, progress bars and
//! the printed tables (clap, indicatif: the lab's, so that robot software linking the
//! `centaur` library compiles neither).

use std::path::{Path, PathBuf};
use std::time::Instant;

use centaur_rl::{AlgoKind, UpdateMetrics};

use crate::experiment::{
    EXPERIMENT_FILES, ExperimentError, ExperimentOptions, ExperimentResult, Phase, run_experiment,
};
use crate::hybrid::{Fade, ResidualConfig};
use crate::mpc::Gait;
use crate::spec::{
    ControllerTable, CountFlags, ExplorationTable, HybridTableFields, HybridTables, Parts, Purpose,
    RampTable, RunSpec, SteeringTable, Torques,
};

/// The progress-bar style of the examples and the command line.
pub fn progress_style() -> indicatif::ProgressStyle {
    indicatif::ProgressStyle::with_template("{msg:>22} [{bar:40}] {pos}/{len} steps ({per_sec}, eta {eta})")
        .expect("a valid template")
        .progress_chars("=> ")
}

/// Training progress of an experiment's two agents, which may train side by side (see
/// [`run_experiment`]): the steps both have done and the latest training return of each,
/// for a progress bar.
#[derive(Clone, Debug, Default)]
pub struct TrainingProgress {
    done: [u64; 2],
    returns: [Option<f64>; 2],
}

impl TrainingProgress {
    /// Records an update of a training phase (the evaluation phase is ignored) and returns
    /// the steps both agents have done, each counted up to `steps`.
    pub fn record(&mut self, phase: Phase, m: &UpdateMetrics, steps: u64) -> u64 {
        let k = match phase {
            Phase::TrainPure => 0,
            Phase::TrainHybrid => 1,
            Phase::Evaluate => return self.done.iter().sum(),
        };
        self.done[k] = m.env_steps.min(steps);
        self.returns[k] = Some(m.episode_return_mean);
        self.done.iter().sum()
    }

    /// "pure PPO 1.23, hybrid PPO 4.56" (the agents that have reported so far).
    pub fn message(&self, learner: &str) -> String {
        let parts: Vec<String> = ["pure", "hybrid"]
            .iter()
            .zip(self.returns)
            .filter_map(|(name, r)| r.map(|r| format!("{name} {learner} {r:.2}")))
            .collect();
        parts.join(", ")
    }
}

/// [`run_experiment`] with a progress bar over both agents' training and the evaluation;
/// `learner` names the algorithm in the bar (e.g. "PPO"). What the examples run.
pub fn run_experiment_with_progress(
    opts: &ExperimentOptions,
    learner: &str,
) -> Result<ExperimentResult, ExperimentError> {
    let steps = opts.steps;
    let bar = indicatif::ProgressBar::new(2 * steps);
    bar.set_style(progress_style());
    let mut training = TrainingProgress::default();
    let result = run_experiment(opts, &mut |phase, m| {
        if phase == Phase::Evaluate {
            bar.set_message("evaluating");
            bar.set_position(2 * steps);
            return;
        }
        bar.set_position(training.record(phase, m, steps));
        bar.set_message(training.message(learner));
    });
    bar.finish_and_clear();
    result
}

/// Which parts of the hybrid's action are on (`--parts`), for the ablation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum HybridParts {
    /// The joint residual and the command steering the robot's preset has.
    #[default]
    Both,
    /// The joint residual only (steering off).
    Residual,
    /// The command steering only (no joint residual).
    Command,
}

/// The hybrid's setup on the command line, over the robot's preset
/// for the learner ([`crate::registry::residual_config_for`]); flattened into the examples' and `centaur`'s
/// parsers.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct HybridArgs {
    /// Bound of the joint residual (action units), one value for every action [default: the robot's]
    #[arg(long)]
    pub residual_scale: Option<f64>,
    /// Forward speed the controller is commanded at zero steering, m/s [default: the robot's]
    #[arg(long, allow_negative_numbers = true)]
    pub speed: Option<f64>,
    /// The controller's gait under the hybrid, one the robot offers (e.g. `bound` on the
    /// Minitaur) [default: the robot's: trot on the Minitaur and the Ant, walk on the bipeds]
    #[arg(long, value_parser = gait_name)]
    pub gait: Option<Gait>,
    /// Span of the policy's forward-speed steering, m/s (0: off) [default: the robot's]
    #[arg(long)]
    pub steer_speed: Option<f64>,
    /// Span of the policy's yaw-rate steering, rad/s (0: off) [default: the robot's]
    #[arg(long)]
    pub steer_yaw_rate: Option<f64>,
    /// Span of the policy's cadence steering, a fraction in [0, 0.75] (0: off): the gait
    /// clock runs at 1 ± this times its rate, so the gait may step faster or slower
    /// [default: the robot's]
    #[arg(long)]
    pub steer_cadence: Option<f64>,
    /// Span of the policy's duty-factor steering, a fraction in [0, 0.3] (0: off): every
    /// leg's stance fraction is its gait's own ± this, so the feet may leave the ground
    /// sooner (a trot with flight phases) or later [default: the robot's]
    #[arg(long)]
    pub steer_duty: Option<f64>,
    /// Span of the policy's swing-height steering, a fraction in [0, 0.75] (0: off): each
    /// swing's apex is the controller's swing height × (1 ± this), taken at lift-off
    /// [default: the robot's]
    #[arg(long)]
    pub steer_swing: Option<f64>,
    /// Span of the policy's foothold steering, metres in [0, 0.1] (0: off): each swing lands
    /// up to this far ahead of or behind the controller's foothold along the heading, taken
    /// at lift-off [default: the robot's]
    #[arg(long)]
    pub steer_foothold: Option<f64>,
    /// Which parts of the hybrid's action are on: both (the default), residual (no
    /// steering) or command (steering only)
    #[arg(long, value_enum, default_value = "both")]
    pub parts: HybridParts,
    /// Initial exploration σ of the joint residual, in policy units (PPO and A2C): each
    /// joint's noise is σ × the residual bound, so a wider --residual-scale explores wider
    /// unless σ is narrowed with it [default: the robot's]
    #[arg(long)]
    pub explore_residual: Option<f64>,
    /// Initial exploration σ of the steering, in policy units (PPO and A2C) [default: the robot's]
    #[arg(long)]
    pub explore_steering: Option<f64>,
    /// A rising exploration of the joint residual (PPO and A2C): the learner's σ is held at
    /// least at a floor rising log-linearly from the initial σ to SIGMA (policy units) over
    /// the first --explore-ramp-samples training samples, then released [default: the
    /// robot's: none (Walker2d's before its rising bound: 0.3)]
    #[arg(long, value_name = "SIGMA", conflicts_with = "no_explore_ramp")]
    pub explore_ramp: Option<f64>,
    /// Training samples over which --explore-ramp rises [default: the robot's ramp's, else
    /// 200,000]
    #[arg(long, value_name = "SAMPLES", requires = "explore_ramp")]
    pub explore_ramp_samples: Option<u64>,
    /// No rising exploration, whatever the robot's preset
    #[arg(long)]
    pub no_explore_ramp: bool,
    /// A rising residual bound: the joint residual's bound starts at FROM times the scale
    /// (a fraction in (0, 1]) and rises log-linearly to the full scale over the first
    /// --bound-ramp-samples training samples; a gentle start that leaves the learner's own
    /// exploration as it is (every learner) [default: the robot's: walker2d with PPO or A2C
    /// 0.0333 over 100,000 samples, none elsewhere]
    #[arg(long, value_name = "FROM", conflicts_with = "no_bound_ramp")]
    pub bound_ramp: Option<f64>,
    /// Training samples over which --bound-ramp rises [default: the robot's ramp's, else
    /// 200,000]
    #[arg(long, value_name = "SAMPLES", requires = "bound_ramp")]
    pub bound_ramp_samples: Option<u64>,
    /// No rising residual bound, whatever the robot's preset
    #[arg(long)]
    pub no_bound_ramp: bool,
    /// Off-policy learners (SAC, SAC v1, TD3, DDPG) warm up with the hybrid's own
    /// exploration around the controller instead of uniformly random actions
    #[arg(long)]
    pub warmup_with_policy: bool,
    /// The controller's rated speed for the hybrid's gait, m/s, replacing the controller's
    /// own (its steered commands are clamped to it); above the controller's own rating the
    /// controller alone is not measured to hold [default: the hybrid preset's: minitaur
    /// 3.5 (its trot's own is 2.5), walker2d 1.5 (its walk's own is 1.0), the controller's
    /// own elsewhere]
    #[arg(long)]
    pub rated_speed: Option<f64>,
    /// Multiplies the period of the hybrid's gait (and its controller-alone baseline's),
    /// a factor in [0.25, 4]: below 1 the gait clock steps faster, so the hybrid's feet do
    /// [default: the hybrid preset's: walker2d with PPO or A2C 0.6, 1 elsewhere]
    #[arg(long)]
    pub period_scale: Option<f64>,
    /// The controller's command ramp under the hybrid (and its controller-alone
    /// baseline's), m/s² in (0, 20], replacing the controller's own: how fast the start and
    /// every steered speed reach the controller [default: the controller's own: minitaur 3,
    /// ant 1, walker2d 1, humanoid 0.3]
    #[arg(long)]
    pub max_acceleration: Option<f64>,
    /// The controller's CoM height under the hybrid (and its controller-alone baseline's),
    /// m, replacing its gait's own; within 0.5–2 × the robot's standing CoM height
    /// (refused otherwise) [default: the gait's own: the robot's standing CoM height on the
    /// Minitaur's trot]
    #[arg(long)]
    pub body_height: Option<f64>,
    /// The swing feet's apex height under the hybrid (and its controller-alone baseline's),
    /// m in [0.01, 0.3], replacing the controller's own straight-line swing (a turning
    /// minitaur keeps its 0.05) [default: the controller's own: minitaur 0.07, ant, walker2d
    /// and humanoid 0.08]
    #[arg(long)]
    pub swing_height: Option<f64>,
    /// How often the hybrid's controller (and its controller-alone baseline) solves its
    /// convex MPC, s in [0.005, 0.2], replacing the controller's own; between solves it
    /// follows the last plan [default: the controller's own, 0.02]
    #[arg(long)]
    pub mpc_period: Option<f64>,
    /// The hybrid's controller (and its controller-alone baseline) computes its torques on
    /// the cheap path (stance legs τ = −J_cᵀ f from the MPC, swing legs Cartesian PD)
    /// instead of its whole-body QP: each sample costs less, and the controller alone is
    /// weaker
    #[arg(long)]
    pub cheap_torques: bool,
    /// The hybrid's policy also observes the controller's measured body state: the CoM's
    /// velocity in the heading frame and its height (4 entries after the reference
    /// action), which the robot's own observation may lack (the Minitaur's does)
    #[arg(long)]
    pub observe_state: bool,
    /// A safety fade as the body sinks: the policy's steering fades from full at a sag of
    /// START to none halfway to END, then its joint residual to none at END, the sag being
    /// the CoM's drop below the controller's height reference as a fraction of it (e.g.
    /// `--fade 0.12 0.24`); a filter on a trained policy, so a run may be evaluated with or
    /// without it [default: none]
    #[arg(long, num_args = 2, value_names = ["START", "END"], allow_negative_numbers = true)]
    pub fade: Option<Vec<f64>>,
}

pub use crate::spec::DEFAULT_RAMP_SAMPLES;

/// A gait by name (`--gait` here and on `centaur control`), for clap.
pub fn gait_name(name: &str) -> Result<Gait, String> {
    crate::control::parse_gait(name).map_err(|e| e.to_string())
}

impl HybridArgs {
    /// The run spec's hybrid tables these flags set: each flag is sugar for one key
    /// (`--steer-speed` is `hybrid.steering.speed`, `--rated-speed` is
    /// `controller.rated_speed`, `--explore-ramp` is `exploration.ramp.residual`, …).
    pub fn tables(&self) -> HybridTables {
        let ramp = |off: bool, value: Option<f64>, samples: Option<u64>, bound: bool| {
            if off {
                Some(RampTable { off: true, ..RampTable::default() })
            } else {
                value.map(|v| RampTable {
                    from: bound.then_some(v),
                    residual: (!bound).then_some(v),
                    samples,
                    off: false,
                })
            }
        };
        HybridTables {
            hybrid: HybridTableFields {
                residual_scale: self.residual_scale,
                parts: Some(match self.parts {
                    HybridParts::Both => Parts::Both,
                    HybridParts::Residual => Parts::Residual,
                    HybridParts::Command => Parts::Command,
                }),
                steering: SteeringTable {
                    speed: self.steer_speed,
                    yaw_rate: self.steer_yaw_rate,
                    cadence: self.steer_cadence,
                    duty: self.steer_duty,
                    swing: self.steer_swing,
                    foothold: self.steer_foothold,
                },
                include_reference: None,
                observe_state: self.observe_state.then_some(true),
                fade: self.fade.as_deref().map(|f| Fade { start: f[0], end: f[1] }),
                bound_ramp: ramp(self.no_bound_ramp, self.bound_ramp, self.bound_ramp_samples, true),
            },
            controller: ControllerTable {
                gait: self.gait,
                speed: self.speed,
                yaw_rate: None,
                body_height: self.body_height,
                rated_speed: self.rated_speed,
                period_scale: self.period_scale,
                max_acceleration: self.max_acceleration,
                swing_height: self.swing_height,
                mpc_period: self.mpc_period,
                torques: self.cheap_torques.then_some(Torques::Cheap),
            },
            exploration: ExplorationTable {
                residual: self.explore_residual,
                steering: self.explore_steering,
                ramp: ramp(self.no_explore_ramp, self.explore_ramp, self.explore_ramp_samples, false),
                warmup_with_policy: self.warmup_with_policy.then_some(true),
            },
        }
    }

    /// `preset` with what the command line changes ([`HybridArgs::tables`] over it, as a
    /// spec's tables are); checked against nothing yet (the environment checks it with the
    /// robot's action dimension). clap's `requires` rules out the one refusal of
    /// [`HybridTables::apply`] (ramp samples without a start).
    pub fn apply(&self, preset: ResidualConfig) -> ResidualConfig {
        self.tables().apply(preset).expect("clap requires a ramp's start with its samples")
    }
}

/// The command line shared by the experiment examples (`residual_ppo_minitaur`,
/// `residual_sac_walker2d`, `residual_td3_ant`); flatten it into an example's own parser.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct ExampleArgs {
    /// Environment steps per agent [default: the example's budget]
    #[arg(long, allow_negative_numbers = true)]
    pub steps: Option<u64>,
    /// Seed of both agents' training (the evaluation seeds follow from it)
    #[arg(long, allow_negative_numbers = true, default_value_t = 0)]
    pub seed: u64,
    /// Run directory, refused if it already holds a run unless --overwrite [default:
    /// runs/EXAMPLE, the example's name, or runs/EXAMPLE-2, -3, … if that holds a run]
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the run already in --out (its run files only)
    #[arg(long)]
    pub overwrite: bool,
    /// Parallel environments per agent [default: the example's]
    #[arg(long, allow_negative_numbers = true, value_parser = positive_count)]
    pub envs: Option<usize>,
    /// Threads stepping each agent's environments, at most one per environment; with more
    /// than one the two agents train side by side [default: the available cores]
    #[arg(long, allow_negative_numbers = true, value_parser = positive_count)]
    pub threads: Option<usize>,
    /// Deterministic evaluation episodes per agent
    #[arg(long, allow_negative_numbers = true, default_value_t = 10, value_parser = positive_count)]
    pub eval_episodes: usize,
    /// TOML file of hyperparameters for both agents [default: the tuned set for the robot and
    /// algorithm, see `tuned_config`], with the robot's settings in an `[env]` table
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Do not write the MCAP recordings
    #[arg(long)]
    pub no_record: bool,
    /// A run spec (TOML; see `centaur::spec`) for the example's robot and learner: its
    /// `[env]`, `[learner]`, `[hybrid_learner]`, `[hybrid]`, `[controller]` and `[exploration]`, its
    /// budget and evaluations; the flags here override it (its seeds are compare's: the
    /// example trains one, --seed)
    #[arg(long, value_name = "FILE", conflicts_with = "config")]
    pub spec: Option<PathBuf>,
    /// Override one key of --spec, e.g. `--set controller.rated_speed=4.0` (repeatable)
    #[arg(long = "set", value_name = "KEY=VALUE", requires = "spec")]
    pub sets: Vec<String>,
    /// The hybrid's setup (each flag sets one key of the spec's `[hybrid]`, `[controller]` or
    /// `[exploration]`).
    #[command(flatten)]
    pub hybrid: HybridArgs,
}

/// `base` if it holds no run, else the first of `base-2`, `base-3`, … that holds none: an
/// example run again never replaces the previous run. A directory another process is
/// writing (its [`crate::rundir::LOCK_FILE`] held) counts as holding a run, so an example
/// started while another is still setting up its directory moves on too (two started at the
/// same instant may still pick one directory; the second is then refused as busy, and
/// nothing is overwritten). Probing an existing directory leaves an empty lock file in it.
pub fn free_run_dir(base: &Path) -> PathBuf {
    let holds_run = |d: &Path| {
        EXPERIMENT_FILES.iter().any(|f| d.join(f).exists())
            || (d.is_dir() && matches!(crate::rundir::lock_dir(d), Err(crate::rundir::Claim::Busy)))
    };
    if !holds_run(base) {
        return base.to_path_buf();
    }
    let mut name = base.as_os_str().to_owned();
    name.push("-");
    (2u64..)
        .map(|k| {
            let mut n = name.clone();
            n.push(k.to_string());
            PathBuf::from(n)
        })
        .find(|d| !holds_run(d))
        .expect("some numbered directory is free")
}

/// A count of at least 1 (`--envs`, `--threads`, `--eval-episodes`): clap's value parser
/// for options where 0 would otherwise silently mean 1 or print a table of nothing.
pub fn positive_count(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("expected a whole number of at least 1, got {text:?}")),
    }
}

/// What an example runs when its command line does not say otherwise.
#[derive(Clone, Copy, Debug)]
pub struct ExampleDefaults<'a> {
    /// The example's name: error prefix and default run directory `runs/<name>`.
    pub name: &'a str,
    /// Robot environment.
    pub env: &'a str,
    /// Algorithm of both agents.
    pub algo: AlgoKind,
    /// Training steps per agent.
    pub steps: u64,
    /// Parallel environments per agent.
    pub envs: usize,
}

impl ExampleArgs {
    /// The experiment these arguments describe, with `defaults` filling in what they leave
    /// out. Fails (with a message) only when the `--config` file cannot be read.
    pub fn options(&self, defaults: &ExampleDefaults<'_>) -> Result<ExperimentOptions, String> {
        let spec = match &self.spec {
            Some(path) => {
                let spec = RunSpec::read(path, &self.sets).map_err(|e| e.to_string())?;
                if spec.robot != defaults.env || spec.algo != defaults.algo.name() {
                    return Err(format!(
                        "{}: a spec of {} on {}; this example runs {} on {} (`centaur compare --spec` runs any)",
                        path.display(),
                        spec.algo,
                        spec.robot,
                        defaults.algo.name(),
                        defaults.env
                    ));
                }
                spec
            }
            None => RunSpec {
                envs: Some(defaults.envs as u64),
                // An example evaluates at the end only.
                eval_every: Some(0),
                ..RunSpec::from_flags(
                    defaults.env,
                    defaults.algo,
                    defaults.steps,
                    self.config.as_deref(),
                    None,
                )?
            },
        };
        let spec = spec.with_counts(CountFlags {
            steps: self.steps,
            envs: self.envs.map(|n| n as u64),
            eval_episodes: Some(self.eval_episodes as u64),
            ..CountFlags::default()
        });
        let resolved =
            spec.resolve_with(Purpose::Compare, &self.hybrid.tables()).map_err(|e| e.to_string())?;
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        Ok(ExperimentOptions {
            env: resolved.robot.clone(),
            algo: resolved.learner_config(),
            steps: resolved.steps,
            seed: self.seed,
            out: self.out.clone().unwrap_or_else(|| free_run_dir(&Path::new("runs").join(defaults.name))),
            n_envs: resolved.envs,
            threads: self.threads.unwrap_or(cores).clamp(1, resolved.envs),
            eval_episodes: resolved.eval_episodes,
            residual: resolved.hybrid.clone().ok_or("the example's robot has a hybrid")?,
            record: !self.no_record,
            eval_every: (resolved.eval_every > 0).then_some(resolved.eval_every),
            overwrite: self.overwrite,
            hybrid_algo: resolved.hybrid_learner_config(),
            env_settings: resolved.env.clone(),
            pure_from: None,
        })
    }
}

/// The body of an experiment example: prints what runs, trains and evaluates with a
/// progress bar ([`run_experiment_with_progress`]), prints the table, the training times and
/// the run directory. Errors go to stderr prefixed with `name`; the exit code says whether
/// it worked.
pub fn run_example(name: &str, opts: &ExperimentOptions) -> std::process::ExitCode {
    let label = opts.algo.kind().name().to_uppercase();
    println!(
        "Residual {label} vs pure {label} on {} — {} steps each, seed {}, {} envs on {} threads → {}",
        opts.env,
        opts.steps,
        opts.seed,
        opts.n_envs,
        opts.threads,
        opts.out.display()
    );
    let t0 = Instant::now();
    let summary = match run_experiment_with_progress(opts, &label) {
        Ok(r) => r.summary,
        Err(e) => {
            eprintln!("{name}: {e}");
            return std::process::ExitCode::FAILURE;
        }
    };
    println!(
        "\nEvaluation over {} episodes (deterministic actions, same seeds for every agent):\n",
        opts.eval_episodes
    );
    print!("{}", summary.markdown_table());
    println!(
        "\nTraining: hybrid {} steps in {:.0} s, pure {} steps in {:.0} s; total wall time {:.0} s.",
        summary.hybrid.env_steps,
        summary.hybrid.wall_seconds,
        summary.pure_rl.env_steps,
        summary.pure_rl.wall_seconds,
        t0.elapsed().as_secs_f64()
    );
    println!(
        "Run directory: {} (summary.json, learning_curves.png, */metrics.csv, */checkpoint, *.mcap)",
        opts.out.display()
    );
    std::process::ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::tuned_config;
    use crate::hybrid::{BoundRamp, Exploration, ExplorationRamp, Steering};
    use crate::registry::residual_config;
    use crate::train::parse_run_config;

    #[test]
    fn an_example_moves_past_a_directory_with_a_run_or_held_by_another_process() {
        let root = std::env::temp_dir().join(format!("centaur-free-dir-{}", std::process::id()));
        let base = root.join("example");
        assert_eq!(free_run_dir(&base), base, "a directory that does not exist is free");
        std::fs::create_dir_all(&base).unwrap();
        assert_eq!(free_run_dir(&base), base, "an empty directory is free");
        let held = crate::rundir::lock_dir(&base).unwrap();
        let second = root.join("example-2");
        assert_eq!(free_run_dir(&base), second, "a directory being written is not free");
        drop(held);
        assert_eq!(free_run_dir(&base), base, "released, it is free again");
        std::fs::write(base.join(EXPERIMENT_FILES[0]), "{}").unwrap();
        assert_eq!(free_run_dir(&base), second, "a directory holding a run is not free");
        std::fs::remove_dir_all(&root).unwrap();
    }

    /// `preset` with the hybrid options `args` applied, as a command line parses them.
    /// The configuration that meets every Minitaur bar, once as the sixteen flags it was
    /// run with and once as its spec: the same learner, hybrid and budget, so the same run.
    #[test]
    fn the_bars_spec_resolves_to_what_its_flags_gave() {
        use crate::spec::{Purpose, RunSpec};
        let flags = [
            "--explore-steering",
            "1.0",
            "--residual-scale",
            "0.5",
            "--explore-residual",
            "0.15",
            "--explore-ramp",
            "0.3",
            "--steer-cadence",
            "0.75",
            "--steer-speed",
            "2.5",
            "--rated-speed",
            "4.5",
            "--speed",
            "3.0",
            "--max-acceleration",
            "15",
        ];
        let preset = crate::registry::residual_config_for("minitaur", AlgoKind::Ppo).unwrap();
        let by_flags = parse_hybrid(preset, &flags).unwrap();
        let path =
            Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("configs/minitaur_hybrid_bars.toml");
        let spec = RunSpec::read(&path, &[]).unwrap().resolve(Purpose::Compare).unwrap();
        assert_eq!(spec.hybrid.as_ref(), Some(&by_flags));
        assert_eq!(spec.learner_config(), tuned_config("minitaur", AlgoKind::Ppo));
        assert_eq!(
            (spec.seeds, spec.steps, spec.envs, spec.eval_episodes, spec.eval_every),
            (5, 1_000_000, 4, 10, 100_000)
        );
        assert_eq!(spec.hybrid_learner, None);
        // The same flags over an empty spec give the same spec.
        let bare = RunSpec {
            schema: 1,
            robot: "minitaur".into(),
            algo: "ppo".into(),
            steps: 1_000_000,
            ..RunSpec::default()
        };
        let tables = {
            use clap::Parser;
            #[derive(clap::Parser)]
            struct Line {
                #[command(flatten)]
                hybrid: HybridArgs,
            }
            Line::try_parse_from([&["x"][..], &flags].concat()).unwrap().hybrid.tables()
        };
        assert_eq!(bare.resolve_with(Purpose::Compare, &tables).unwrap(), spec);
    }

    /// The main example with its named spec is the main example: the same options, so the
    /// same identity and the same run; a spec of another robot is refused.
    #[test]
    fn the_main_examples_spec_is_the_main_example() {
        use clap::Parser;
        #[derive(clap::Parser)]
        struct Line {
            #[command(flatten)]
            run: ExampleArgs,
        }
        let defaults = ExampleDefaults {
            name: "residual_ppo_minitaur",
            env: "minitaur",
            algo: AlgoKind::Ppo,
            steps: 300_000,
            envs: 4,
        };
        let options = |args: &[&str]| {
            Line::try_parse_from([&["x", "--out", "/nonexistent/run"][..], args].concat())
                .unwrap()
                .run
                .options(&defaults)
        };
        let spec =
            Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("configs/residual_ppo_minitaur.toml");
        let plain = options(&[]).unwrap();
        let by_spec = options(&["--spec", spec.to_str().unwrap()]).unwrap();
        assert_eq!(by_spec.identity(), plain.identity());
        assert_eq!(
            (by_spec.residual.clone(), by_spec.eval_every, by_spec.n_envs),
            (plain.residual.clone(), None, 4)
        );
        let ant = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("configs/ant_ppo_hybrid.toml");
        let e = options(&["--spec", ant.to_str().unwrap()]).unwrap_err();
        assert!(e.contains("this example runs ppo on minitaur"), "{e}");
    }

    /// `--config FILE` and `--hybrid-config FILE` become a spec's `[learner]` and
    /// `[hybrid_learner]` over the defaults: the learners they parsed to before.
    #[test]
    fn run_files_resolve_as_the_learners_they_parsed_to() {
        use crate::spec::{Purpose, RunSpec, run_file_tables};
        let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("configs");
        let mut compared = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            if text.contains("schema =") {
                continue;
            }
            let (algo, settings) = parse_run_config(AlgoKind::Ppo, &text, &path).unwrap();
            let (env, learner) = run_file_tables(&text, "x").unwrap();
            let spec = RunSpec {
                schema: 1,
                robot: "minitaur".into(),
                algo: "ppo".into(),
                steps: 1_000_000,
                env,
                learner: Some(learner.clone()),
                hybrid_learner: Some(learner),
                ..RunSpec::default()
            };
            let resolved = spec.resolve(Purpose::Compare).unwrap();
            assert_eq!(resolved.learner_config(), algo, "{}", path.display());
            assert_eq!(resolved.hybrid_learner_config(), Some(algo), "{}", path.display());
            assert_eq!(resolved.env, settings, "{}", path.display());
            compared += 1;
        }
        assert!(compared >= 5, "the run files in configs/ were compared ({compared})");
    }

    fn parse_hybrid(preset: ResidualConfig, args: &[&str]) -> Result<ResidualConfig, clap::Error> {
        use clap::Parser;
        #[derive(clap::Parser)]
        struct Line {
            #[command(flatten)]
            hybrid: HybridArgs,
        }
        Line::try_parse_from([&["x"][..], args].concat()).map(|l| l.hybrid.apply(preset))
    }

    #[test]
    fn the_hybrids_gait_is_the_presets_unless_given() {
        let preset = residual_config("minitaur").unwrap();
        let parse = |args: &[&str]| parse_hybrid(preset.clone(), args);
        assert_eq!(parse(&[]).unwrap(), preset);
        let bound = parse(&["--gait", "bound", "--speed", "1.5"]).unwrap();
        assert_eq!((bound.command.gait, bound.command.forward_velocity), (Gait::Bound, 1.5));
        assert_eq!(
            ResidualConfig { command: preset.command, ..bound.clone() },
            preset,
            "nothing else changes"
        );
        let e = parse(&["--gait", "moonwalk"]).err().unwrap().to_string();
        assert!(e.contains("moonwalk"), "{e}");
    }

    #[test]
    fn the_bound_ramp_is_the_presets_unless_given_or_switched_off() {
        let ant = residual_config("ant").unwrap();
        let ramp =
            |preset: &ResidualConfig, args: &[&str]| parse_hybrid(preset.clone(), args).unwrap().bound_ramp;
        assert_eq!(ramp(&ant, &[]), None);
        assert_eq!(
            ramp(&ant, &["--bound-ramp", "0.05"]),
            Some(BoundRamp { from: 0.05, samples: DEFAULT_RAMP_SAMPLES })
        );
        let with =
            ResidualConfig { bound_ramp: Some(BoundRamp { from: 0.1, samples: 50_000 }), ..ant.clone() };
        assert_eq!(ramp(&with, &[]), with.bound_ramp);
        assert_eq!(ramp(&with, &["--no-bound-ramp"]), None);
        // A new start keeps the preset's samples.
        assert_eq!(ramp(&with, &["--bound-ramp", "0.2"]), Some(BoundRamp { from: 0.2, samples: 50_000 }));
        assert_eq!(
            ramp(&ant, &["--bound-ramp", "0.2", "--bound-ramp-samples", "300000"]),
            Some(BoundRamp { from: 0.2, samples: 300_000 })
        );
        for args in [
            &["--bound-ramp-samples", "300000"][..],
            &["--bound-ramp", "0.5", "--no-bound-ramp"],
            &["--bound-ramp", "0.5", "--bound-ramp-samples", "1.5"],
        ] {
            assert!(parse_hybrid(ant.clone(), args).is_err(), "{args:?}");
        }
    }

    #[test]
    fn the_cadence_and_duty_steering_are_the_presets_unless_given_and_off_with_the_steering() {
        let walker = residual_config("walker2d").unwrap();
        let steering = |args: &[&str]| parse_hybrid(walker.clone(), args).unwrap().steering;
        assert_eq!(steering(&[]), walker.steering);
        assert_eq!(steering(&["--steer-cadence", "0.5"]), Steering { cadence: 0.5, ..walker.steering });
        assert_eq!(steering(&["--steer-cadence", "0.5", "--parts", "residual"]), Steering::OFF);
        assert!(parse_hybrid(walker.clone(), &["--steer-cadence", "x"]).is_err());
        assert_eq!(steering(&["--steer-duty", "0.15"]), Steering { duty: 0.15, ..walker.steering });
        assert_eq!(steering(&["--steer-duty", "0.15", "--parts", "residual"]), Steering::OFF);
        assert_eq!(steering(&["--steer-swing", "0.5"]), Steering { swing: 0.5, ..walker.steering });
        assert_eq!(steering(&["--steer-swing", "0.5", "--parts", "residual"]), Steering::OFF);
        assert!(parse_hybrid(walker.clone(), &["--steer-swing", "x"]).is_err());
        assert_eq!(steering(&["--steer-foothold", "0.05"]), Steering { foothold: 0.05, ..walker.steering });
        assert_eq!(steering(&["--steer-foothold", "0.05", "--parts", "residual"]), Steering::OFF);
        assert!(parse_hybrid(walker.clone(), &["--steer-foothold", "x"]).is_err());
    }

    #[test]
    fn the_period_scale_is_the_presets_unless_given() {
        let ant = residual_config("ant").unwrap();
        let scale = |args: &[&str]| parse_hybrid(ant.clone(), args).unwrap().period_scale;
        assert_eq!(scale(&[]), None);
        assert_eq!(scale(&["--period-scale", "0.8"]), Some(0.8));
        let with = ResidualConfig { period_scale: Some(0.7), ..ant.clone() };
        assert_eq!(parse_hybrid(with.clone(), &[]).unwrap().period_scale, Some(0.7));
        assert_eq!(parse_hybrid(with, &["--period-scale", "1"]).unwrap().period_scale, Some(1.0));
    }

    #[test]
    fn the_command_ramp_is_the_controllers_unless_given() {
        let minitaur = residual_config("minitaur").unwrap();
        let ramp = |args: &[&str]| parse_hybrid(minitaur.clone(), args).unwrap().max_acceleration;
        assert_eq!(ramp(&[]), None);
        assert_eq!(ramp(&["--max-acceleration", "6"]), Some(6.0));
        assert!(parse_hybrid(minitaur.clone(), &["--max-acceleration", "x"]).is_err());
    }

    #[test]
    fn the_body_height_is_the_gaits_unless_given() {
        let minitaur = residual_config("minitaur").unwrap();
        let height = |args: &[&str]| parse_hybrid(minitaur.clone(), args).unwrap().command.body_height;
        assert_eq!(height(&[]), None);
        assert_eq!(height(&["--body-height", "0.21"]), Some(0.21));
        assert!(parse_hybrid(minitaur.clone(), &["--body-height", "x"]).is_err());
    }

    #[test]
    fn the_swing_height_is_the_controllers_unless_given() {
        let minitaur = residual_config("minitaur").unwrap();
        let height = |args: &[&str]| parse_hybrid(minitaur.clone(), args).unwrap().swing_height;
        assert_eq!(height(&[]), None);
        assert_eq!(height(&["--swing-height", "0.045"]), Some(0.045));
        assert!(parse_hybrid(minitaur.clone(), &["--swing-height", "x"]).is_err());
    }

    #[test]
    fn the_mpc_period_and_the_torque_path_are_the_controllers_unless_given() {
        let minitaur = residual_config("minitaur").unwrap();
        let parsed = |args: &[&str]| parse_hybrid(minitaur.clone(), args).unwrap();
        assert_eq!((parsed(&[]).mpc_period, parsed(&[]).cheap_torques), (None, false));
        assert_eq!(parsed(&["--mpc-period", "0.06"]).mpc_period, Some(0.06));
        assert!(parsed(&["--cheap-torques"]).cheap_torques);
        assert!(parse_hybrid(minitaur.clone(), &["--mpc-period", "x"]).is_err());
    }

    #[test]
    fn the_body_state_is_observed_only_when_asked() {
        let minitaur = residual_config("minitaur").unwrap();
        assert!(!minitaur.include_state);
        assert!(!parse_hybrid(minitaur.clone(), &[]).unwrap().include_state);
        assert!(parse_hybrid(minitaur, &["--observe-state"]).unwrap().include_state);
    }

    #[test]
    fn the_exploration_ramp_is_the_presets_unless_given_or_switched_off() {
        // A preset with a ramp (Walker2d's had one before the rising bound).
        let walker = ExplorationRamp { residual: 0.3, samples: 100_000 };
        let with = ResidualConfig {
            exploration: Some(Exploration { residual: 0.01, steering: 0.5 }),
            exploration_ramp: Some(walker),
            ..residual_config("walker2d").unwrap()
        };
        let parse = |robot: &str, args: &[&str]| {
            parse_hybrid(
                if robot == "walker2d" { with.clone() } else { residual_config(robot).unwrap() },
                args,
            )
        };
        assert_eq!(parse("walker2d", &[]).unwrap().exploration_ramp, Some(walker));
        assert_eq!(parse("walker2d", &["--no-explore-ramp"]).unwrap().exploration_ramp, None);
        // A new σ keeps the preset's samples; elsewhere the default count.
        let ramp = |robot, args: &[&str]| parse(robot, args).unwrap().exploration_ramp.unwrap();
        assert_eq!(ramp("walker2d", &["--explore-ramp", "0.5"]), ExplorationRamp { residual: 0.5, ..walker });
        assert_eq!(
            ramp("ant", &["--explore-ramp", "0.5"]),
            ExplorationRamp { residual: 0.5, samples: DEFAULT_RAMP_SAMPLES }
        );
        assert_eq!(
            ramp("ant", &["--explore-ramp", "0.5", "--explore-ramp-samples", "300000"]),
            ExplorationRamp { residual: 0.5, samples: 300_000 }
        );
        // Samples without a σ, a ramp with its opposite, and a count that is not whole: refused.
        for args in [
            &["--explore-ramp-samples", "300000"][..],
            &["--explore-ramp", "0.5", "--no-explore-ramp"],
            &["--explore-ramp", "0.5", "--explore-ramp-samples", "1.5"],
        ] {
            assert!(parse("walker2d", args).is_err(), "{args:?} accepted");
        }
    }
}
