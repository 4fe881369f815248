//! [`ResidualEnv`]: residual reinforcement learning on top of the model-based controller.
//!
//! The policy outputs a correction `r ∈ [−1, 1]ᵐ` in the environment's action units,
//! scaled per action entry, and the environment receives
//!
//! `a = clip(a_ref(s) + scale ⊙ r, low, high)`
//!
//! where `a_ref(s)` is the controller's command at the current state mapped to the
//! environment's action space (the same mapping as the controller alone uses, see
//! [`crate::hybrid::ActionMapping`]); the law and the observation layout are
//! [`crate::hybrid::Residual`]'s, the ones deployment uses. The policy observes the environment's observation,
//! the gait phase `(sin 2πφ, cos 2πφ)`, the command `(v_x, v_y, ω_z)` and, optionally, the
//! reference action itself and the controller's measured body state
//! ([`crate::hybrid::observed_state`]). The reward is the environment's, unchanged, so pure RL and the
//! hybrid are judged on the same benchmark.
//!
//! With a policy whose mean output is zero the hybrid acts exactly like the controller
//! (the experiment runner zeroes the policy head before training); the residual is bounded
//! by `scale`, so learning starts at the controller's gait and cannot leave its
//! neighbourhood faster than the scale allows. An optional safety fade
//! ([`crate::hybrid::Fade`]) takes the policy's steering, then its residual, away as the
//! body sinks below the controller's height reference.
//!
//! The step reports the residual's root-mean-square (in action units, after scaling) as the
//! last reward term ([`centaur_gym::StepInfo::reward_terms`]`[7]`, named `residual_rms`; it is not part
//! of the reward).

use centaur_envs::RobotEnv;
use centaur_gym::{BoxSpace, Env, EnvError, MAX_REWARD_TERMS, Step, check_action, check_observation};
use centaur_mpc::{Command, LocomotionController};
use centaur_rl::{AlgoKind, Algorithm, RlError};

use crate::hybrid::{ActionMapping, HybridError, OBSERVED_STATE_DIM, Residual, ResidualConfig};

/// Makes a freshly built learner of kind `kind` start a hybrid as its controller: its mean
/// output zero (the untrained hybrid acts exactly like the controller) and, for learners
/// that explore with a per-entry Gaussian (PPO, A2C), the initial exploration per action
/// part that `config` asks for (a gentle start) and its rising floor, if any
/// ([`ResidualConfig::exploration_ramp`]); for off-policy learners, a warm-up with the
/// policy's own exploration if `config.warmup_with_policy` (an on-policy learner asked for
/// it is refused). `policy_dim` is the hybrid env's action dimension. Used by the
/// experiment runner and `centaur train` on `<robot>-residual`.
pub fn start_as_controller(
    algo: &mut dyn Algorithm,
    kind: AlgoKind,
    config: &ResidualConfig,
    policy_dim: usize,
) -> Result<(), RlError> {
    algo.zero_policy_output();
    if let Some(std) = config.initial_exploration(policy_dim)
        && kind.takes_exploration_std()
    {
        algo.set_exploration_std(&std)?;
        if let Some(floor) = config.exploration_floor(policy_dim) {
            algo.set_exploration_floor(floor)?;
        }
    }
    if config.warmup_with_policy {
        algo.set_warmup_with_policy()?;
    }
    Ok(())
}

/// Index of the residual size in [`StepInfo::reward_terms`](centaur_gym::StepInfo).
pub const RESIDUAL_TERM: usize = MAX_REWARD_TERMS - 1;

/// An environment whose actions are residuals on top of a [`LocomotionController`].
pub struct ResidualEnv {
    env: Box<dyn RobotEnv>,
    controller: LocomotionController,
    mapping: ActionMapping,
    config: ResidualConfig,
    residual: Residual,
    obs_space: BoxSpace,
    act_space: BoxSpace,
    env_obs: Vec<f32>,
    reference: Vec<f32>,
    applied: Vec<f32>,
    /// The command the controller follows now (the base command steered by the policy's
    /// last action).
    command: Command,
    name: String,
    /// The rising residual bound's fraction of the scale at the samples the learner last
    /// told ([`Env::set_training_samples`], [`crate::hybrid::BoundRamp`]); 1 (the full
    /// scale) if it never told or there is no ramp.
    bound: f32,
}

impl ResidualEnv {
    /// Wraps `env` and a controller built for its model (see
    /// [`crate::registry::make_residual_env`] for a robot by name).
    pub fn new(
        env: Box<dyn RobotEnv>,
        controller: LocomotionController,
        config: ResidualConfig,
    ) -> Result<ResidualEnv, HybridError> {
        let mapping = ActionMapping::new(env.as_ref(), &controller)?;
        let m = env.action_space().dim();
        let residual = Residual::new(&config, m)?;
        // The command for this robot (a body height within its legs' reach).
        controller.check_command(&config.command)?;
        // A bound wider than the action range clips to the range: a typo such as 1e300 is
        // refused rather than carried as infinity.
        let space = env.action_space();
        for k in 0..m {
            let scale = config.scale[if config.scale.len() == 1 { 0 } else { k }];
            let width = f64::from(space.high[k]) - f64::from(space.low[k]);
            if width.is_finite() && scale > width {
                return Err(HybridError::BadSetting {
                    part: "residual scale",
                    value: scale,
                    expected: "at most the width of the joint's action range",
                });
            }
        }
        let policy_dim = residual.policy_action_dim();
        let base = env.observation_space();
        let mut low = base.low.clone();
        let mut high = base.high.clone();
        low.extend([-1.0f32, -1.0, f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY]);
        high.extend([1.0f32, 1.0, f32::INFINITY, f32::INFINITY, f32::INFINITY]);
        if residual.includes_reference() {
            low.extend(env.action_space().low.iter());
            high.extend(env.action_space().high.iter());
        }
        if residual.includes_state() {
            low.extend([f32::NEG_INFINITY; OBSERVED_STATE_DIM]);
            high.extend([f32::INFINITY; OBSERVED_STATE_DIM]);
        }
        debug_assert_eq!(low.len(), residual.obs_dim(base.dim()));
        let name = format!("{}-residual", env.name());
        Ok(ResidualEnv {
            env_obs: vec![0.0; base.dim()],
            obs_space: BoxSpace::new(low, high),
            act_space: BoxSpace::symmetric(policy_dim, 1.0),
            reference: vec![0.0; m],
            command: config.command,
            applied: vec![0.0; m],
            residual,
            env,
            controller,
            mapping,
            config,
            name,
            bound: 1.0,
        })
    }

    /// The wrapped environment.
    pub fn inner(&self) -> &dyn RobotEnv {
        self.env.as_ref()
    }

    /// The wrapped environment, mutable (e.g. to push the robot).
    pub fn inner_mut(&mut self) -> &mut dyn RobotEnv {
        self.env.as_mut()
    }

    /// The controller.
    pub fn controller(&self) -> &LocomotionController {
        &self.controller
    }

    /// The reference action for the next step.
    pub fn reference(&self) -> &[f32] {
        &self.reference
    }

    /// The action applied at the last step.
    pub fn applied(&self) -> &[f32] {
        &self.applied
    }

    /// The configuration.
    pub fn config(&self) -> &ResidualConfig {
        &self.config
    }

    /// The command the controller follows now: the configured one, steered by the
    /// policy's last action (see [`crate::hybrid::Steering`]).
    pub fn command(&self) -> &Command {
        &self.command
    }

    /// Ticks the controller on the current state and stores the next reference action.
    fn update_reference(&mut self) {
        let t = self.env.episode_time();
        let cmd = self.mapping.tick(&mut self.controller, self.env.as_ref(), &self.command, t);
        self.mapping.action(self.env.as_mut(), cmd, &mut self.reference);
    }

    fn write_obs(&self, obs: &mut [f32]) {
        self.residual.observe(&self.controller, &self.env_obs, &self.command, &self.reference, obs);
    }
}

impl Env for ResidualEnv {
    fn name(&self) -> &str {
        &self.name
    }

    fn observation_space(&self) -> &BoxSpace {
        &self.obs_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.act_space
    }

    fn max_episode_steps(&self) -> usize {
        self.env.max_episode_steps()
    }

    /// The robot's configuration, the residual setup and the controller's whole
    /// configuration (gains, weights, offers): a run resumed or a
    /// checkpoint evaluated on a controller whose preset changed since is refused, naming
    /// the first difference (older records hold no `controller` and are not checked
    /// for it). Runs of `centaur compare` also check the residual setup they were trained
    /// with (`centaur_lab::experiment::check_trained_with`).
    fn config_text(&self) -> Option<String> {
        let robot: serde_json::Value = serde_json::from_str(&self.env.config_text()?).ok()?;
        let controller = serde_json::to_value(self.controller.config()).ok()?;
        Some(
            serde_json::json!({ "robot": robot, "residual": self.config, "controller": controller })
                .to_string(),
        )
    }

    fn dt(&self) -> f64 {
        self.env.dt()
    }

    fn set_training_samples(&mut self, samples: u64) {
        if let Some(ramp) = self.config.bound_ramp {
            self.bound = ramp.factor(samples);
        }
    }

    fn reward_term_names(&self) -> &'static [&'static str] {
        // The wrapped env's terms, padded, with the residual size last.
        match self.env.reward_term_names() {
            ["forward", "energy", "drift", "shake"] => {
                &["forward", "energy", "drift", "shake", "", "", "", "residual_rms"]
            }
            ["forward", "healthy", "ctrl_cost", "contact_cost"] => {
                &["forward", "healthy", "ctrl_cost", "contact_cost", "", "", "", "residual_rms"]
            }
            _ => &["", "", "", "", "", "", "", "residual_rms"],
        }
    }

    fn reset(&mut self, seed: Option<u64>, obs: &mut [f32]) -> Result<(), EnvError> {
        check_observation(&self.obs_space, obs)?;
        self.env.reset(seed, &mut self.env_obs)?;
        self.controller.reset();
        self.command = self.config.command;
        self.update_reference();
        self.applied.copy_from_slice(&self.reference);
        self.write_obs(obs);
        Ok(())
    }

    /// Residuals and steering outputs outside [−1, 1] are clipped; NaN or a wrong length
    /// is refused. The joint residual acts on this step; the steered command on the
    /// controller's next tick (the policy observes it).
    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Step, EnvError> {
        check_action(&self.act_space, action)?;
        check_observation(&self.obs_space, obs)?;
        // The controller ticked on this state (`update_reference`): its CoM height is now's.
        // The step HybridStack::tick makes too; the robot's step does not touch the
        // controller, so the steering may come before it.
        let sq = self.residual.act(
            &mut self.controller,
            &self.config.command,
            &mut self.command,
            &self.reference,
            action,
            self.bound,
            self.env.action_space(),
            &mut self.applied,
        );
        let mut step = self.env.step(&self.applied, &mut self.env_obs)?;
        step.info.reward_terms[RESIDUAL_TERM] = (sq / self.applied.len().max(1) as f64).sqrt();
        if !step.done() {
            self.update_reference();
        }
        self.write_obs(obs);
        Ok(step)
    }
}
