//! Pure RL against the hybrid (residual RL on the controller) on the same benchmark, with
//! the controller alone as a third agent.
//!
//! [`run_experiment`] trains a pure-RL agent on the robot environment and a hybrid agent on
//! its [`ResidualEnv`] with the same algorithm, hyperparameters, seed and step budget,
//! evaluates the two policies and the controller alone over the same evaluation seeds with
//! deterministic actions, and writes what follows. With more than one thread
//! ([`ExperimentOptions::threads`]) the two agents train side by side and the three are
//! evaluated side by side; every figure is the same as with one thread, only the wall times
//! (which then overlap) differ.
//!
//! | file | content |
//! |---|---|
//! | `summary.json` | `{"hybrid": {...}, "pure_rl": {...}, "controller": {...}}` ([`AgentStats`] each) |
//! | `{pure_rl,hybrid}/metrics.csv` | training metrics per update |
//! | `{pure_rl,hybrid}/checkpoint` | the trained learner (`Policy::load` acts with it) |
//! | `learning_curves.png`, `.svg` | training return against environment steps, both agents |
//! | `{pure_rl,hybrid,controller}.mcap` | the first evaluation episode of each agent, for Foxglove |
//!
//! Evaluation metrics per episode: return; mean forward speed (base displacement along x over
//! the episode's duration); fall (the episode terminated); energy `Σ |τ·q̇| dt`; torque RMS
//! over steps and actuators. The cost of transport is `E / (m g d)` over all episodes
//! (total energy over weight times total forward distance), reported only when the agent
//! moved forward.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use centaur_dynamics::nalgebra::Vector3;
use centaur_envs::RobotEnv;
use centaur_mpc::LocomotionController;
use centaur_rl::{AlgoKind, Algorithm, Env, MetricsCsv, Policy, RlError, Step, UpdateMetrics, VecEnv};
use serde::Serialize;

use crate::control::{ActionMapping, ControlError, controller_config, make_robot_env};
use crate::plot::{PlotError, PlotLabels, Series, plot_curves};
use crate::recording::{Frame, RecordError, Recorder};
use crate::residual::{ResidualConfig, ResidualEnv};
use crate::train::{TrainError, build_algorithm};

/// Why an experiment failed.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// Environment or controller.
    #[error(transparent)]
    Control(#[from] ControlError),
    /// Learning.
    #[error(transparent)]
    Rl(#[from] RlError),
    /// Building the learner.
    #[error(transparent)]
    Train(#[from] TrainError),
    /// Recording.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// Plotting.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// Writing outputs.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// A training stopped because the other agent's, running side by side, failed.
    #[error("stopped: the other agent's training failed")]
    Stopped,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ExperimentError + '_ {
    move |source| ExperimentError::Io { path: path.to_path_buf(), source }
}

/// How an agent did over the evaluation episodes (and its training cost).
#[derive(Clone, Debug, Default, Serialize)]
pub struct AgentStats {
    /// Mean episode return.
    pub return_mean: f64,
    /// Standard deviation of the episode return.
    pub return_std: f64,
    /// Mean forward speed (m/s).
    pub mean_speed: f64,
    /// Episodes that ended by a fall.
    pub falls: usize,
    /// Evaluation episodes.
    pub episodes: usize,
    /// Cost of transport `E / (m g d)` (None if the agent did not move forward).
    pub cost_of_transport: Option<f64>,
    /// Mean energy per episode (J).
    pub energy_mean: f64,
    /// Torque RMS over steps and actuators (N·m).
    pub torque_rms: f64,
    /// Mean episode length (steps).
    pub length_mean: f64,
    /// Training environment steps (0 for the controller).
    pub env_steps: u64,
    /// Training wall-clock seconds (0 for the controller).
    pub wall_seconds: f64,
}

/// The agent an evaluation runs.
enum Driver {
    Controller {
        env: Box<dyn RobotEnv>,
        controller: Box<LocomotionController>,
        mapping: ActionMapping,
        command: centaur_mpc::Command,
    },
    Pure {
        env: Box<dyn RobotEnv>,
        policy: Policy,
    },
    Hybrid {
        env: Box<ResidualEnv>,
        policy: Policy,
    },
}

impl Driver {
    fn robot(&self) -> &dyn RobotEnv {
        match self {
            Driver::Controller { env, .. } | Driver::Pure { env, .. } => env.as_ref(),
            Driver::Hybrid { env, .. } => env.inner(),
        }
    }

    fn obs_dim(&self) -> usize {
        match self {
            Driver::Controller { env, .. } | Driver::Pure { env, .. } => env.observation_space().dim(),
            Driver::Hybrid { env, .. } => env.observation_space().dim(),
        }
    }

    fn act_dim(&self) -> usize {
        match self {
            Driver::Controller { env, .. } | Driver::Pure { env, .. } => env.action_space().dim(),
            Driver::Hybrid { env, .. } => env.action_space().dim(),
        }
    }

    fn reset(&mut self, seed: u64, obs: &mut [f32]) -> Result<(), ExperimentError> {
        match self {
            Driver::Controller { env, controller, .. } => {
                env.reset(Some(seed), obs).map_err(ControlError::from)?;
                controller.reset();
            }
            Driver::Pure { env, .. } => env.reset(Some(seed), obs).map_err(ControlError::from)?,
            Driver::Hybrid { env, .. } => env.reset(Some(seed), obs).map_err(ControlError::from)?,
        }
        Ok(())
    }

    /// One step; returns the step and fills `reference`, `residual`, `applied` for recording.
    fn step(
        &mut self,
        obs: &mut [f32],
        action: &mut [f32],
        rec: &mut StepRecord,
    ) -> Result<Step, ExperimentError> {
        let step = match self {
            Driver::Controller { env, controller, mapping, command } => {
                let t = env.episode_time();
                let cmd = mapping.tick(controller, env.as_ref(), command, t);
                mapping.action(env.as_ref(), cmd, action);
                rec.reference.clone_from_slice(action);
                rec.applied.clone_from_slice(action);
                rec.planned_com.clear();
                rec.planned_com.extend_from_slice(&controller.status().planned_com);
                rec.foot_targets.clear();
                rec.foot_targets.extend_from_slice(&controller.status().foot_targets);
                env.step(action, obs).map_err(ControlError::from)?
            }
            Driver::Pure { env, policy } => {
                policy.act(obs, action);
                rec.applied.clone_from_slice(action);
                env.step(action, obs).map_err(ControlError::from)?
            }
            Driver::Hybrid { env, policy } => {
                policy.act(obs, action);
                rec.reference.clone_from_slice(env.reference());
                rec.planned_com.clear();
                rec.planned_com.extend_from_slice(&env.controller().status().planned_com);
                rec.foot_targets.clear();
                rec.foot_targets.extend_from_slice(&env.controller().status().foot_targets);
                let s = env.step(action, obs).map_err(ControlError::from)?;
                rec.applied.clone_from_slice(env.applied());
                for k in 0..rec.residual.len() {
                    rec.residual[k] = rec.applied[k] - rec.reference[k];
                }
                s
            }
        };
        Ok(step)
    }
}

#[derive(Default)]
struct StepRecord {
    reference: Vec<f32>,
    residual: Vec<f32>,
    applied: Vec<f32>,
    planned_com: Vec<[f64; 3]>,
    foot_targets: Vec<[f64; 3]>,
}

/// Base x position of a floating or planar robot.
fn base_x(env: &dyn RobotEnv) -> f64 {
    env.robot_state().q[0]
}

/// Evaluates an agent over `episodes` deterministic episodes (seeds `seed..seed+episodes`),
/// recording the first one to `record` if given.
fn evaluate(
    driver: &mut Driver,
    episodes: usize,
    seed: u64,
    record: Option<&Path>,
) -> Result<AgentStats, ExperimentError> {
    let mut obs = vec![0.0f32; driver.obs_dim()];
    let mut action = vec![0.0f32; driver.act_dim()];
    let m = driver.act_dim();
    let mut rec = StepRecord {
        reference: vec![0.0; m],
        residual: vec![0.0; m],
        applied: vec![0.0; m],
        ..Default::default()
    };
    let mut recorder = match record {
        Some(p) => Some(Recorder::create(p, driver.robot().model())?),
        None => None,
    };
    let (mut returns, mut speeds, mut lengths) = (Vec::new(), Vec::new(), Vec::new());
    let (mut falls, mut energy, mut distance) = (0usize, 0.0, 0.0);
    let (mut torque_sq, mut torque_n) = (0.0, 0usize);
    let mut contacts: Vec<(Vector3<f64>, Vector3<f64>)> = Vec::new();
    let mass = driver.robot().model().total_mass();
    let g = driver.robot().model().gravity.norm().max(1e-9);
    for ep in 0..episodes {
        driver.reset(seed + ep as u64, &mut obs)?;
        let x0 = base_x(driver.robot());
        let (mut ret, mut n) = (0.0, 0usize);
        loop {
            let s = driver.step(&mut obs, &mut action, &mut rec)?;
            ret += s.reward;
            n += 1;
            energy += s.info.energy;
            for t in driver.robot().last_torques() {
                torque_sq += t * t;
                torque_n += 1;
            }
            if ep == 0
                && let Some(r) = recorder.as_mut()
            {
                let robot = driver.robot();
                contacts.clear();
                contacts.extend(
                    robot.foot_contacts().iter().filter(|c| c.in_contact).map(|c| (c.point, c.force)),
                );
                r.record(&Frame {
                    time: robot.episode_time(),
                    state: Some(robot.robot_state()),
                    contacts: &contacts,
                    planned_com: &rec.planned_com,
                    foot_targets: &rec.foot_targets,
                    reference: &rec.reference,
                    residual: if matches!(driver, Driver::Hybrid { .. }) { &rec.residual } else { &[] },
                    applied: &rec.applied,
                    reward: s.reward,
                    forward_velocity: s.info.forward_velocity,
                    energy: s.info.energy,
                })?;
            }
            if s.done() {
                if s.terminated {
                    falls += 1;
                }
                break;
            }
        }
        let dx = base_x(driver.robot()) - x0;
        let seconds = n as f64 * driver.robot().dt();
        distance += dx;
        returns.push(ret);
        speeds.push(dx / seconds.max(1e-9));
        lengths.push(n as f64);
    }
    if let Some(r) = recorder {
        r.finish()?;
    }
    let k = episodes.max(1) as f64;
    let mean = returns.iter().sum::<f64>() / k;
    let std = (returns.iter().map(|r| (r - mean) * (r - mean)).sum::<f64>() / k).sqrt();
    Ok(AgentStats {
        return_mean: mean,
        return_std: std,
        mean_speed: speeds.iter().sum::<f64>() / k,
        falls,
        episodes,
        cost_of_transport: (distance > 0.01).then(|| energy / (mass * g * distance)),
        energy_mean: energy / k,
        torque_rms: (torque_sq / torque_n.max(1) as f64).sqrt(),
        length_mean: lengths.iter().sum::<f64>() / k,
        env_steps: 0,
        wall_seconds: 0.0,
    })
}

/// What to run.
#[derive(Clone, Debug)]
pub struct ExperimentOptions {
    /// Robot environment (see [`crate::control::ROBOT_ENV_NAMES`]).
    pub env: String,
    /// Algorithm (the same for both agents).
    pub algo: AlgoKind,
    /// Training steps per agent.
    pub steps: u64,
    /// Seed (learners; evaluation seeds are `1_000_000 + seed + k`).
    pub seed: u64,
    /// Output directory.
    pub out: PathBuf,
    /// TOML hyperparameters shared by both agents (None: the algorithm's defaults).
    pub algo_config: Option<String>,
    /// Parallel environments per agent.
    pub n_envs: usize,
    /// Threads stepping each agent's environments; with more than one, the two agents also
    /// train side by side (results unchanged, see [`run_experiment`]).
    pub threads: usize,
    /// Evaluation episodes per agent (≥ 10 recommended).
    pub eval_episodes: usize,
    /// The residual setup of the hybrid.
    pub residual: ResidualConfig,
    /// Write an MCAP recording per agent.
    pub record: bool,
}

/// The three agents of an experiment.
#[derive(Clone, Debug, Serialize)]
pub struct ExperimentSummary {
    /// Residual RL on the controller.
    pub hybrid: AgentStats,
    /// RL alone.
    pub pure_rl: AgentStats,
    /// The controller alone.
    pub controller: AgentStats,
}

impl ExperimentSummary {
    /// The evaluation table in Markdown: return, forward speed, falls, energy, cost of
    /// transport and torque RMS of the three agents.
    pub fn markdown_table(&self) -> String {
        let row = |name: &str, s: &AgentStats| {
            let cot = s.cost_of_transport.map_or("—".to_string(), |c| format!("{c:.2}"));
            format!(
                "| {name} | {:.2} ± {:.2} | {:.3} | {}/{} | {:.1} | {cot} | {:.2} |\n",
                s.return_mean, s.return_std, s.mean_speed, s.falls, s.episodes, s.energy_mean, s.torque_rms
            )
        };
        let mut t = String::from(
            "| agent | return | mean forward speed (m/s) | falls | energy / episode (J) | cost of transport | torque RMS (N·m) |\n|---|---:|---:|---:|---:|---:|---:|\n",
        );
        t += &row("hybrid (residual RL on the controller)", &self.hybrid);
        t += &row("pure RL", &self.pure_rl);
        t += &row("controller alone", &self.controller);
        t
    }
}

/// PPO for the Minitaur: RL Zoo's `MinitaurBulletEnv-v0` settings (normalised observations
/// and rewards, n_steps 2048 per env, 10 epochs, learning rate 2.5e-4, clip 0.2, λ 0.95),
/// with minibatches of 512 and γ 0.995 instead of 0.99. The Minitaur's reward has no
/// survival bonus, so at γ 0.99 (a horizon of about 1 s) a fall costs little and residual
/// PPO learned a 1.24 m/s gait that fell in 9 of 10 evaluation episodes (return 6.6); at
/// γ 0.995 it keeps the speed and falls once (return 11.6, seed 0, 300k steps).
pub const MINITAUR_PPO_CONFIG: &str = "n_steps = 2048
batch_size = 512
n_epochs = 10
learning_rate = 2.5e-4
clip_coef = 0.2
gae_lambda = 0.95
gamma = 0.995
ent_coef = 0.0
";

/// Off-policy learners on the locomotion robots start learning after 5,000 steps.
pub const OFF_POLICY_LOCOMOTION_CONFIG: &str = "learning_starts = 5000\n";

/// The hyperparameters the examples and `centaur compare` use for `algo` on `env` when the
/// user gives none: [`MINITAUR_PPO_CONFIG`] for PPO on the Minitaur,
/// [`OFF_POLICY_LOCOMOTION_CONFIG`] for SAC, TD3 and DDPG on the other robots, else the
/// algorithm's defaults (`None`).
pub fn tuned_config(env: &str, algo: AlgoKind) -> Option<&'static str> {
    let minitaur = env.starts_with("minitaur");
    match algo {
        AlgoKind::Ppo if minitaur => Some(MINITAUR_PPO_CONFIG),
        AlgoKind::Sac | AlgoKind::SacV1 | AlgoKind::Td3 | AlgoKind::Ddpg if !minitaur => {
            Some(OFF_POLICY_LOCOMOTION_CONFIG)
        }
        _ => None,
    }
}

/// Training curve of one agent: `(env steps, mean training episode return)` per update.
pub type Curve = Vec<(u64, f64)>;

/// An experiment's summary and the two training curves.
#[derive(Clone, Debug)]
pub struct ExperimentResult {
    /// Evaluation of the three agents.
    pub summary: ExperimentSummary,
    /// Pure RL's training curve.
    pub pure_curve: Curve,
    /// The hybrid's training curve.
    pub hybrid_curve: Curve,
}

/// Which agent a progress report is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Training the pure-RL agent.
    TrainPure,
    /// Training the hybrid agent.
    TrainHybrid,
    /// Evaluating all three agents: reported once, with default metrics, as it starts.
    Evaluate,
}

fn vec_env_of(
    make: &mut dyn FnMut() -> Result<Box<dyn Env>, ExperimentError>,
    n: usize,
    threads: usize,
) -> Result<VecEnv, ExperimentError> {
    let envs = (0..n.max(1)).map(|_| make()).collect::<Result<Vec<_>, _>>()?;
    Ok(VecEnv::new(envs, threads).map_err(ControlError::from)?)
}

/// Trains one agent; returns its checkpoint path, metrics and wall time.
fn train_one(
    opts: &ExperimentOptions,
    dir: &Path,
    env: &mut VecEnv,
    phase: Phase,
    progress: &mut dyn FnMut(Phase, &UpdateMetrics),
    stop: &AtomicBool,
) -> Result<(PathBuf, Vec<UpdateMetrics>, f64, u64), ExperimentError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let cfg_path = dir.join("config.toml");
    let mut algo: Box<dyn Algorithm> =
        build_algorithm(opts.algo, opts.algo_config.as_deref(), &cfg_path, opts.seed, env)?;
    if phase == Phase::TrainHybrid {
        // Zero mean residual at the start: the untrained hybrid is the controller.
        algo.zero_policy_output();
    }
    let csv_path = dir.join("metrics.csv");
    let mut csv = MetricsCsv::create(&csv_path).map_err(io_err(&csv_path))?;
    let mut rows = Vec::new();
    let mut csv_error = None;
    let t0 = Instant::now();
    algo.learn(env, opts.steps, &mut |m| {
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
    let wall = t0.elapsed().as_secs_f64();
    if stop.load(Ordering::Relaxed) {
        return Err(ExperimentError::Stopped);
    }
    if let Some(e) = csv_error {
        return Err(ExperimentError::Io { path: csv_path, source: e });
    }
    csv.flush().map_err(io_err(&csv_path))?;
    let ckpt = dir.join("checkpoint");
    algo.save(&ckpt)?;
    Ok((ckpt, rows, wall, algo.steps_done()))
}

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

/// The command line shared by the experiment examples (`residual_ppo_minitaur`,
/// `residual_sac_walker2d`, `residual_td3_ant`); flatten it into an example's own parser.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct ExampleArgs {
    /// Environment steps per agent [default: the example's budget]
    #[arg(long)]
    pub steps: Option<u64>,
    /// Seed of both agents' training (the evaluation seeds follow from it)
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Run directory [default: runs/EXAMPLE, the example's name]
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Parallel environments per agent [default: the example's]
    #[arg(long, value_parser = positive_count)]
    pub envs: Option<usize>,
    /// Threads stepping each agent's environments, at most one per environment; with more
    /// than one the two agents train side by side [default: the available cores]
    #[arg(long, value_parser = positive_count)]
    pub threads: Option<usize>,
    /// Deterministic evaluation episodes per agent
    #[arg(long, default_value_t = 10)]
    pub eval_episodes: usize,
    /// TOML file of hyperparameters for both agents [default: the tuned set for the robot and
    /// algorithm, see `tuned_config`]
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Do not write the MCAP recordings
    #[arg(long)]
    pub no_record: bool,
}

/// A count of at least 1 (`--envs`, `--threads`).
fn positive_count(text: &str) -> Result<usize, String> {
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
        let algo_config = match &self.config {
            Some(path) => Some(
                std::fs::read_to_string(path)
                    .map_err(|e| format!("cannot read --config {}: {e}", path.display()))?,
            ),
            None => tuned_config(defaults.env, defaults.algo).map(str::to_string),
        };
        let n_envs = self.envs.unwrap_or(defaults.envs).max(1);
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        Ok(ExperimentOptions {
            env: defaults.env.to_string(),
            algo: defaults.algo,
            steps: self.steps.unwrap_or(defaults.steps),
            seed: self.seed,
            out: self.out.clone().unwrap_or_else(|| Path::new("runs").join(defaults.name)),
            algo_config,
            n_envs,
            threads: self.threads.unwrap_or(cores).clamp(1, n_envs),
            eval_episodes: self.eval_episodes,
            residual: ResidualConfig::for_env(defaults.env),
            record: !self.no_record,
        })
    }
}

/// The body of an experiment example: prints what runs, trains and evaluates with a
/// progress bar ([`run_experiment_with_progress`]), prints the table, the training times and
/// the run directory. Errors go to stderr prefixed with `name`; the exit code says whether
/// it worked.
pub fn run_example(name: &str, opts: &ExperimentOptions) -> std::process::ExitCode {
    let label = opts.algo.name().to_uppercase();
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

/// Runs the experiment (see the module docs) and writes the output directory.
pub fn run_experiment(
    opts: &ExperimentOptions,
    progress: &mut dyn FnMut(Phase, &UpdateMetrics),
) -> Result<ExperimentResult, ExperimentError> {
    // The hybrid needs a controller: refuse a robot without one before training anything.
    crate::control::controller_config(&opts.env)?;
    std::fs::create_dir_all(&opts.out).map_err(io_err(&opts.out))?;
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
            &mut || Ok(Box::new(ResidualEnv::for_env(&opts.env, opts.residual.clone())?) as Box<dyn Env>),
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
        (pure_ckpt, pure_rows, pure_wall, pure_steps),
        (hybrid_ckpt, hybrid_rows, hybrid_wall, hybrid_steps),
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
            env: Box::new(ResidualEnv::for_env(&opts.env, opts.residual.clone())?),
            policy: Policy::load(&hybrid_ckpt).map_err(RlError::from)?,
        })
    };
    let controller = || -> Result<Driver, ExperimentError> {
        let env = make_robot_env(&opts.env, None)?;
        let controller = LocomotionController::new(env.model(), controller_config(&opts.env)?)
            .map_err(ControlError::from)?;
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

    let summary = ExperimentSummary { hybrid: hybrid_stats, pure_rl: pure_stats, controller: ctrl_stats };
    let path = opts.out.join("summary.json");
    let text = serde_json::to_string_pretty(&summary)
        .map_err(|e| ExperimentError::Io { path: path.clone(), source: e.into() })?;
    std::fs::write(&path, text + "\n").map_err(io_err(&path))?;
    let curve = |label: &str, rows: &[UpdateMetrics]| Series {
        label: label.to_string(),
        x: rows.iter().map(|m| m.env_steps as f64).collect(),
        y: rows.iter().map(|m| m.episode_return_mean).collect(),
        lower: Some(rows.iter().map(|m| m.episode_return_mean - m.episode_return_std).collect()),
        upper: Some(rows.iter().map(|m| m.episode_return_mean + m.episode_return_std).collect()),
    };
    let labels = PlotLabels {
        title: format!("{} on {}: pure RL vs hybrid (seed {})", opts.algo.name(), opts.env, opts.seed),
        x: "environment steps".into(),
        y: "training episode return (mean ± std)".into(),
    };
    let series = [curve("pure RL", &pure_rows), curve("hybrid (residual on the controller)", &hybrid_rows)];
    for ext in ["png", "svg"] {
        match plot_curves(&opts.out.join(format!("learning_curves.{ext}")), &labels, &series) {
            Ok(()) | Err(PlotError::Empty { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    let points = |rows: &[UpdateMetrics]| rows.iter().map(|m| (m.env_steps, m.episode_return_mean)).collect();
    Ok(ExperimentResult { summary, pure_curve: points(&pure_rows), hybrid_curve: points(&hybrid_rows) })
}
