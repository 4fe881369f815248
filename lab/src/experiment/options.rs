//! What an experiment takes, gives back and can fail with.

use std::path::{Path, PathBuf};

use centaur_gym::EnvError;
use centaur_rl::{AlgoConfig, RlError};

use super::summary::ExperimentSummary;
use crate::hybrid::{HybridError, ResidualConfig};
use crate::plot::PlotError;
use crate::recording::RecordError;
use crate::registry::{RegistryError, controller_motor};
use crate::settings::EnvSettings;

/// Why an experiment failed.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// Environment, controller or hybrid.
    #[error(transparent)]
    Registry(#[from] RegistryError),
    /// An environment refused a call.
    #[error("environment: {0}")]
    Env(#[from] EnvError),
    /// The controller does not fit the robot.
    #[error(transparent)]
    Hybrid(#[from] HybridError),
    /// Learning.
    #[error(transparent)]
    Rl(#[from] RlError),
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
    /// A robot environment a study does not cover.
    #[error("{study} is defined for {supported}, not for '{env}'")]
    NotCovered {
        /// The study.
        study: &'static str,
        /// The environments it covers.
        supported: &'static str,
        /// The one asked for.
        env: String,
    },
    /// An option that only a hybrid (`<robot>-residual`) takes, given for another environment.
    #[error("{option} applies to a hybrid (`<robot>-residual`), not to '{env}'")]
    NotAHybrid {
        /// The environment.
        env: String,
        /// What was asked for.
        option: &'static str,
    },
    /// A run spec refused.
    #[error(transparent)]
    Spec(#[from] crate::spec::SpecError),
    /// A comparison resumed or extended with another spec than it recorded.
    #[error(
        "{dir} records the spec {recorded} (spec.json), not the one given ({given}): its seeds were run with other options; choose another --out, or --overwrite"
    )]
    SpecChanged {
        /// The comparison directory.
        dir: PathBuf,
        /// The identity in its `spec.json`.
        recorded: String,
        /// The identity of the spec given.
        given: String,
    },
    /// A robot environment error (building a perturbed robot).
    #[error("robot: {0}")]
    Robot(#[from] centaur_envs::RobotEnvError),
    /// The output directory already holds a run.
    #[error("{dir} already holds a run ({file}); replace it with --overwrite or choose another --out")]
    RunExists {
        /// The directory.
        dir: PathBuf,
        /// The run file found there.
        file: &'static str,
    },
    /// A run evaluated with another hybrid setup than it was trained with (its
    /// `experiment.json` records the setup).
    #[error(
        "{run}: its hybrid was trained with {trained}, not with the options given ({given}); evaluate it with the setup it was trained with (`centaur robustness` takes --rated-speed, --steer-speed, --parts, …; a Minitaur run recorded without a rating was trained at the trot's own 2.5 m/s: --rated-speed 2.5)"
    )]
    SetupMismatch {
        /// The run directory.
        run: PathBuf,
        /// The setup it was trained with, as recorded.
        trained: String,
        /// The setup given.
        given: String,
    },
    /// A run directory whose `experiment.json` an older Centaur wrote (it holds no
    /// identity, or not the hybrid's setup as data): nothing can tell what it ran.
    #[error(
        "{dir}/experiment.json was recorded by an older Centaur (it holds no run identity): rerun that run, or use it with the Centaur that wrote it"
    )]
    OlderRecord {
        /// The run directory.
        dir: PathBuf,
    },
    /// Another process is writing an experiment in the directory.
    #[error(
        "another process is writing an experiment in {dir} (it holds {dir}/{lock}); wait for it to end or choose another --out",
        lock = crate::rundir::LOCK_FILE
    )]
    Busy {
        /// The directory.
        dir: PathBuf,
    },
    /// A run trained with `[env]` settings that change the task, given to a study that runs
    /// the preset env (settings that only perturbed training, `settings::TRAINING_ONLY`, are
    /// accepted, and `motor_inverse`, which the study follows).
    #[error(
        "{run}: its agents were trained with [env] settings that change the task ({keys}); this runs the robot's preset environment, on which they were not trained"
    )]
    EnvSettingsNotCovered {
        /// The run directory.
        run: PathBuf,
        /// The `[env]` keys it was trained with that change the task.
        keys: String,
    },
    /// A directory that holds no experiment (no `experiment.json`).
    #[error(
        "{dir} holds no experiment.json: give the directory of one run of `centaur compare` (e.g. runs/compare_…/seed_0) or of the main example (runs/residual_ppo_minitaur)"
    )]
    NotAnExperiment {
        /// The directory.
        dir: PathBuf,
    },
    /// `centaur compare --resume` found a seed's directory holding a run of other options
    /// than these: resuming would replace it.
    #[error(
        "{dir}: it holds a run of other options than these ({difference}); resuming would replace it: give the options it ran with, or choose another --out (--overwrite replaces the whole comparison)"
    )]
    ResumeDiffers {
        /// The seed's directory.
        dir: PathBuf,
        /// The first difference, `key: recorded …, given …`.
        difference: String,
    },
    /// `centaur compare --resume` found a seed's record (`experiment.json`) it cannot read:
    /// resuming would replace a run it cannot tell to be this one.
    #[error(
        "{dir}/experiment.json cannot be read as a run's record ({reason}); resuming would replace that run: move it away, or choose another --out (--overwrite replaces the whole comparison)"
    )]
    ResumeUnreadable {
        /// The seed's directory.
        dir: PathBuf,
        /// Why the record does not read.
        reason: String,
    },
    /// A run whose pure-RL agent was to be reused was trained with other options.
    #[error(
        "{from}: its pure-RL agent was trained with other options than this run's (only the hybrid's setup may differ): {difference}"
    )]
    PureRunDiffers {
        /// The run directory given to reuse.
        from: PathBuf,
        /// The first difference, `key: recorded …, given …`.
        difference: String,
    },
    /// A run whose pure-RL agent was to be reused has not finished (no `summary.json`, or
    /// its pure-RL files are missing).
    #[error("{from}: no finished run to reuse the pure-RL agent of ({missing} is missing)")]
    PureRunUnfinished {
        /// The run directory given to reuse.
        from: PathBuf,
        /// The first file missing.
        missing: &'static str,
    },
    /// A run directory to reuse the pure-RL agent of that holds no run.
    #[error(
        "{dir} holds no run to reuse the pure-RL agent of (no experiment.json): --pure-from takes the --out directory of a comparison run with at least as many seeds"
    )]
    NoPureRun {
        /// The directory.
        dir: PathBuf,
    },
    /// Another process is writing the run whose pure-RL agent was to be reused.
    #[error("another process is writing {from} (it holds {from}/{lock}); reuse its pure-RL agent when it has finished", lock = crate::rundir::LOCK_FILE)]
    PureRunBusy {
        /// The run directory given to reuse.
        from: PathBuf,
    },
    /// The pure-RL agent to reuse evaluates differently here than where it was trained:
    /// the environment or the code has changed since.
    #[error(
        "{from}: its pure-RL agent evaluates to {here} here against {recorded} when it was trained; the environment or the code changed since, so its training cannot stand for this run's — train it again (leave out --pure-from)"
    )]
    PureRunChanged {
        /// The run directory given to reuse.
        from: PathBuf,
        /// The recorded final mean return.
        recorded: f64,
        /// The mean return of the same evaluation here.
        here: f64,
    },
    /// A directory given as a comparison that holds none.
    #[error(
        "{dir} holds no comparison (no seed_0/experiment.json): give the --out directory of a `centaur compare`"
    )]
    NotAComparison {
        /// The directory.
        dir: PathBuf,
    },
    /// The run to reuse the pure-RL agent of is the run's own directory.
    #[error(
        "--pure-from names the output directory itself ({dir}); give the directory of another comparison"
    )]
    PureFromItself {
        /// The directory.
        dir: PathBuf,
    },
    /// A training stopped because the other agent's, running side by side, failed.
    #[error("stopped: the other agent's training failed")]
    Stopped,
    /// The hybrid's own hyperparameters are for another algorithm than the run's.
    #[error(
        "the hybrid's hyperparameters are {hybrid}'s, but the run compares {algo}: give the same algorithm's"
    )]
    HybridLearnerKind {
        /// The run's algorithm.
        algo: &'static str,
        /// The algorithm the hybrid's hyperparameters are for.
        hybrid: &'static str,
    },
}

pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ExperimentError + '_ {
    move |source| ExperimentError::Io { path: path.to_path_buf(), source }
}

/// What to run.
#[derive(Clone, Debug)]
pub struct ExperimentOptions {
    /// Robot environment with a controller (see [`crate::registry::ROBOTS`]).
    pub env: String,
    /// Algorithm and hyperparameters, the same for both agents unless
    /// [`ExperimentOptions::hybrid_algo`] sets the hybrid's (the seed is
    /// [`ExperimentOptions::seed`]; see [`crate::experiment::tuned_config`] for the presets).
    pub algo: AlgoConfig,
    /// The hybrid's own hyperparameters, the same algorithm as `algo` (`None`: `algo`'s): each
    /// agent may then be compared at its own tuning, as RL Zoo tunes each environment.
    pub hybrid_algo: Option<AlgoConfig>,
    /// Training steps per agent.
    pub steps: u64,
    /// Seed (learners; evaluation seeds are `1_000_000 + seed + k`).
    pub seed: u64,
    /// Output directory.
    pub out: PathBuf,
    /// Parallel environments per agent.
    pub n_envs: usize,
    /// Threads stepping each agent's environments; with more than one, the two agents also
    /// train side by side (results unchanged, see [`run_experiment`](super::run_experiment)).
    pub threads: usize,
    /// Evaluation episodes per agent (≥ 10 recommended).
    pub eval_episodes: usize,
    /// The residual setup of the hybrid.
    pub residual: ResidualConfig,
    /// Write an MCAP recording per agent.
    pub record: bool,
    /// Evaluate both learners deterministically (`eval_episodes` episodes) every this many
    /// training steps as well as at the end (`None`: at the end only). Training runs in
    /// chunks between the evaluations, with the learning-rate schedule of the whole budget.
    pub eval_every: Option<u64>,
    /// Replace a run already in `out` (its files only) instead of refusing.
    pub overwrite: bool,
    /// `[env]` settings over the robot's preset, for both agents and the controller alone
    /// (empty: the preset).
    pub env_settings: EnvSettings,
    /// A finished run (a directory like this one's) whose pure-RL agent is reused instead of
    /// trained again: its training (metrics, evaluations during training, checkpoint, wall
    /// times) is copied, its final checkpoint evaluated again here. It must have been run
    /// with the same options but for the hybrid's setup ([`ExperimentOptions::pure_identity`]);
    /// pure RL does not depend on the hybrid, so the figures are those of training it again
    /// with the code that wrote that run. `None`: train it.
    pub pure_from: Option<PathBuf>,
}

impl ExperimentOptions {
    /// Everything that decides the pure-RL agent's results, as canonical JSON: the robot,
    /// the learner (kind and every setting), budget, seed, environments, evaluation and the
    /// `[env]` settings but for the motor the controller is told (pure RL has no
    /// controller). Not `out`, `threads`, `record`, `overwrite` or `pure_from`.
    pub fn pure_options(&self) -> serde_json::Value {
        let settings = EnvSettings { motor_inverse: None, ..self.env_settings.clone() };
        serde_json::json!({
            "env": self.env,
            "algo": self.algo.kind().name(),
            "learner": crate::spec::learner_value(&self.algo),
            "steps": self.steps,
            "seed": self.seed,
            "envs": self.n_envs,
            "eval_episodes": self.eval_episodes,
            "eval_every": self.eval_every,
            "env_settings": serde_json::to_value(&settings).expect("[env] settings serialise"),
        })
    }

    /// Everything that decides the run's results: [`ExperimentOptions::pure_options`] and
    /// the hybrid's side (its setup, its own learner settings where set, the motor its
    /// controller is told).
    pub fn options(&self) -> serde_json::Value {
        let mut options = self.pure_options();
        let object = options.as_object_mut().expect("the options are an object");
        object.insert("residual".into(), serde_json::to_value(&self.residual).expect("a setup serialises"));
        object.insert(
            "hybrid_learner".into(),
            self.hybrid_algo.as_ref().map_or(serde_json::Value::Null, crate::spec::learner_value),
        );
        object.insert(
            "controller_motor".into(),
            serde_json::to_value(controller_motor(&self.env, &self.env_settings))
                .expect("a motor serialises"),
        );
        options
    }

    /// The run's identity ([`crate::spec::identity_of`] of [`ExperimentOptions::options`]):
    /// a finished run whose `experiment.json` holds the same can be kept instead of run again.
    pub fn identity(&self) -> String {
        crate::spec::identity_of(&self.options())
    }

    /// Pure RL's identity: that of [`ExperimentOptions::pure_options`]; a run of another
    /// hybrid with the same identity trained the same pure-RL agent (`--pure-from`).
    pub fn pure_identity(&self) -> String {
        crate::spec::identity_of(&self.pure_options())
    }

    /// The hyperparameters the hybrid trains with: [`ExperimentOptions::hybrid_algo`], else
    /// [`ExperimentOptions::algo`].
    pub fn hybrid_learner(&self) -> &AlgoConfig {
        self.hybrid_algo.as_ref().unwrap_or(&self.algo)
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
