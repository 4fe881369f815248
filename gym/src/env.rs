//! [`Env`]: one continuous-control environment with Gymnasium's semantics, what a step
//! reports ([`Step`], [`StepInfo`]) and why a call is refused ([`EnvError`]).
//!
//! Observations and actions are `f32` (the networks' type); rewards are `f64` so that
//! returns summed over long episodes keep their precision. Nothing here allocates per step:
//! callers pass output buffers.

use crate::space::BoxSpace;

/// Most reward terms an environment reports in [`StepInfo::reward_terms`].
pub const MAX_REWARD_TERMS: usize = 8;

/// What a step reports besides the reward (Gymnasium's `info`), fixed-size so that stepping
/// allocates nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepInfo {
    /// The terms whose (weighted) sum is the reward, named by [`Env::reward_term_names`].
    pub reward_terms: [f64; MAX_REWARD_TERMS],
    /// Forward velocity of the robot over the step (m/s), as the env's reward defines it.
    pub forward_velocity: f64,
    /// Mechanical energy spent by the actuators during the step, `Σ |τ·q̇| dt` (J).
    pub energy: f64,
    /// Foot contacts as a bit mask (bit k: foot k touches the ground).
    pub foot_contacts: u32,
    /// The simulation became non-finite or exploded; the episode was ended (`terminated`)
    /// and the observation is the last finite one.
    pub unstable: bool,
}

/// The outcome of [`Env::step`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Step {
    /// Reward for the transition.
    pub reward: f64,
    /// The episode ended in a terminal state (fall, unhealthy, blow-up): do not bootstrap.
    pub terminated: bool,
    /// The episode was cut by the time limit: the observation is not terminal, bootstrap.
    pub truncated: bool,
    /// Extra information.
    pub info: StepInfo,
}

impl Step {
    /// Whether the episode is over (terminated or truncated).
    pub fn done(&self) -> bool {
        self.terminated || self.truncated
    }
}

/// Why an environment refused a call.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The action vector has the wrong length.
    #[error("action has {got} entries, the action space has {expected}")]
    ActionLength {
        /// Action-space dimension.
        expected: usize,
        /// Length received.
        got: usize,
    },
    /// An action entry is NaN or infinite.
    #[error("action[{index}] is {value}, expected a finite number")]
    NonFiniteAction {
        /// Entry index.
        index: usize,
        /// The value received.
        value: f32,
    },
    /// The observation buffer has the wrong length.
    #[error("observation buffer has {got} entries, the observation space has {expected}")]
    ObservationLength {
        /// Observation-space dimension.
        expected: usize,
        /// Length received.
        got: usize,
    },
    /// `step` was called before `reset`, or after the episode ended without a reset.
    #[error("step called on an environment that needs reset (call reset first)")]
    NeedsReset,
    /// Environments given to a [`crate::VecEnv`] disagree on their spaces.
    #[error("environment {index} has different spaces from environment 0")]
    MismatchedSpaces {
        /// Index of the first mismatching environment.
        index: usize,
    },
    /// A [`crate::VecEnv`] needs at least one environment.
    #[error("a VecEnv needs at least one environment")]
    Empty,
    /// The worker threads of a [`crate::VecEnv`] could not start.
    #[error("cannot start {threads} threads: {source}")]
    Threads {
        /// Threads asked for.
        threads: usize,
        /// Why not.
        source: rayon::ThreadPoolBuildError,
    },
    /// An environment's own failure, with its type: the environment crate's error is the
    /// source (`centaur_envs::RobotEnvError` for the robots; downcast it to match on it).
    #[error(transparent)]
    Env(Box<dyn std::error::Error + Send + Sync + 'static>),
}

impl EnvError {
    /// Wraps an environment crate's own error.
    pub fn env(error: impl std::error::Error + Send + Sync + 'static) -> EnvError {
        EnvError::Env(Box::new(error))
    }
}

/// Checks an action's length and finiteness (what every env does first).
pub fn check_action(space: &BoxSpace, action: &[f32]) -> Result<(), EnvError> {
    if action.len() != space.dim() {
        return Err(EnvError::ActionLength { expected: space.dim(), got: action.len() });
    }
    if let Some((index, &value)) = action.iter().enumerate().find(|(_, a)| !a.is_finite()) {
        return Err(EnvError::NonFiniteAction { index, value });
    }
    Ok(())
}

/// Checks an observation buffer's length.
pub fn check_observation(space: &BoxSpace, obs: &[f32]) -> Result<(), EnvError> {
    if obs.len() != space.dim() {
        return Err(EnvError::ObservationLength { expected: space.dim(), got: obs.len() });
    }
    Ok(())
}

/// A continuous-control environment with Gymnasium semantics.
///
/// * [`Env::reset`] starts an episode and writes its first observation; `seed = Some(s)`
///   reseeds the environment's generator (like `reset(seed=s)`), `None` continues its stream.
/// * [`Env::step`] applies an action for one control period and writes the next
///   observation. When the episode ends the observation written is the final one: for a
///   truncated episode it is the state to bootstrap from.
/// * Actions outside [`Env::action_space`] are clipped (each env documents it); actions of
///   the wrong length or with NaN/∞ are refused with an [`EnvError`] and change nothing.
pub trait Env: Send {
    /// A short name, e.g. `"minitaur"`.
    fn name(&self) -> &str;
    /// The observation space.
    fn observation_space(&self) -> &BoxSpace;
    /// The action space.
    fn action_space(&self) -> &BoxSpace;
    /// Episode length limit (steps), after which `truncated` is set.
    fn max_episode_steps(&self) -> usize;
    /// Control period (s) of one step.
    fn dt(&self) -> f64;
    /// Names of the entries of [`StepInfo::reward_terms`], in order.
    fn reward_term_names(&self) -> &'static [&'static str] {
        &[]
    }
    /// Everything the environment was built with, as a JSON object (its configuration,
    /// defaults and presets resolved), for a run to record and compare later: a value that
    /// differs means another environment; a field missing from an older record (added to
    /// the configuration since) is not a difference. `None` (the default): the environment
    /// does not say.
    fn config_text(&self) -> Option<String> {
        None
    }
    /// Training progress: the learner's environment samples so far, told by Centaur's
    /// learners before every rollout (PPO, A2C) or step (the off-policy learners). An
    /// environment whose behaviour follows training (a hybrid's rising residual bound) reads
    /// it; one never told (an evaluation, another trainer) behaves as fully trained. The
    /// default ignores it.
    fn set_training_samples(&mut self, _samples: u64) {}
    /// Starts an episode; writes the first observation into `obs`.
    fn reset(&mut self, seed: Option<u64>, obs: &mut [f32]) -> Result<(), EnvError>;
    /// Advances one control period with `action`; writes the next observation into `obs`.
    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Step, EnvError>;
}
