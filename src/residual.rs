//! [`ResidualEnv`]: residual reinforcement learning on top of the model-based controller.
//!
//! The policy outputs a correction `r ∈ [−1, 1]ᵐ` in the environment's action units,
//! scaled per action entry, and the environment receives
//!
//! `a = clip(a_ref(s) + scale ⊙ r, low, high)`
//!
//! where `a_ref(s)` is the controller's command at the current state mapped to the
//! environment's action space (the same mapping as the controller alone uses, see
//! [`crate::control::ActionMapping`]). The policy observes the environment's observation,
//! the gait phase `(sin 2πφ, cos 2πφ)`, the command `(v_x, v_y, ω_z)` and, optionally, the
//! reference action itself. The reward is the environment's, unchanged, so pure RL and the
//! hybrid are judged on the same benchmark.
//!
//! With a policy whose mean output is zero the hybrid acts exactly like the controller
//! ([`crate::experiment`] zeroes the policy head before training); the residual is bounded
//! by `scale`, so learning starts at the controller's gait and cannot leave its
//! neighbourhood faster than the scale allows.
//!
//! The step reports the residual's root-mean-square (in action units, after scaling) as the
//! last reward term ([`centaur_rl::StepInfo::reward_terms`]`[7]`, named `residual_rms`; it is not part
//! of the reward).

use centaur_envs::RobotEnv;
use centaur_mpc::{Command, LocomotionController};
use centaur_rl::env::{check_action, check_observation};
use centaur_rl::{BoxSpace, Env, EnvError, MAX_REWARD_TERMS, Step};

use crate::control::{ActionMapping, ControlError, controller_config, make_robot_env};

/// Index of the residual size in [`StepInfo::reward_terms`](centaur_rl::StepInfo).
pub const RESIDUAL_TERM: usize = MAX_REWARD_TERMS - 1;

/// Configuration of a [`ResidualEnv`].
#[derive(Clone, Debug, PartialEq)]
pub struct ResidualConfig {
    /// Residual scale per action entry (one value: the same for every entry), in the
    /// environment's action units (default: 0.3).
    pub scale: Vec<f64>,
    /// Append the reference action to the observation (default: true).
    pub include_reference: bool,
    /// The command the controller follows (default: trot at 0.3 m/s).
    pub command: Command,
}

impl Default for ResidualConfig {
    fn default() -> Self {
        ResidualConfig {
            scale: vec![0.3],
            include_reference: true,
            command: Command::forward(0.3, centaur_mpc::Gait::Trot),
        }
    }
}

impl ResidualConfig {
    /// The default residual setup for a robot environment: the controller's gait and a
    /// speed it follows reliably, and a residual scale in the env's action units (a quarter
    /// of the Minitaur's leg-model range; 30 % of the Gymnasium robots' control range, 10 %
    /// for Walker2d, whose walking controller PPO's exploration at 30 % knocks over: one
    /// seed of 60k PPO steps evaluated at 460 with 0.3, 1200 with 0.1).
    pub fn for_env(env_name: &str) -> Self {
        let robot = env_name.trim_end_matches("-fast").trim_end_matches("27");
        let (gait, speed, scale) = match robot {
            "minitaur" => (centaur_mpc::Gait::Trot, 0.3, 0.25),
            "ant" => (centaur_mpc::Gait::Trot, 0.3, 0.3),
            "walker2d" => (centaur_mpc::Gait::Walk, 0.5, 0.1),
            "humanoid" => (centaur_mpc::Gait::Stand, 0.0, 0.3),
            _ => (centaur_mpc::Gait::Trot, 0.3, 0.3),
        };
        ResidualConfig { scale: vec![scale], include_reference: true, command: Command::forward(speed, gait) }
    }

    /// Checks the scale.
    pub fn validate(&self, action_dim: usize) -> Result<(), EnvError> {
        if !(self.scale.len() == 1 || self.scale.len() == action_dim) {
            return Err(EnvError::Other(format!(
                "residual scale has {} entries; give 1 or the action dimension {action_dim}",
                self.scale.len()
            )));
        }
        if self.scale.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
            return Err(EnvError::Other("residual scales must be finite and non-negative".into()));
        }
        Ok(())
    }
}

/// An environment whose actions are residuals on top of a [`LocomotionController`].
pub struct ResidualEnv {
    env: Box<dyn RobotEnv>,
    controller: LocomotionController,
    mapping: ActionMapping,
    config: ResidualConfig,
    scale: Vec<f32>,
    obs_space: BoxSpace,
    act_space: BoxSpace,
    env_obs: Vec<f32>,
    reference: Vec<f32>,
    applied: Vec<f32>,
    name: String,
}

impl ResidualEnv {
    /// Wraps `env` and a controller built for its model.
    pub fn new(
        env: Box<dyn RobotEnv>,
        controller: LocomotionController,
        config: ResidualConfig,
    ) -> Result<ResidualEnv, ControlError> {
        let mapping = ActionMapping::new(env.as_ref(), &controller)?;
        let m = env.action_space().dim();
        config.validate(m)?;
        let scale = (0..m).map(|k| *config.scale.get(k).unwrap_or(&config.scale[0]) as f32).collect();
        let base = env.observation_space();
        let extra = 2 + 3 + if config.include_reference { m } else { 0 };
        let mut low = base.low.clone();
        let mut high = base.high.clone();
        low.extend([-1.0f32, -1.0, f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY]);
        high.extend([1.0f32, 1.0, f32::INFINITY, f32::INFINITY, f32::INFINITY]);
        if config.include_reference {
            low.extend(env.action_space().low.iter());
            high.extend(env.action_space().high.iter());
        }
        debug_assert_eq!(low.len(), base.dim() + extra);
        let name = format!("{}-residual", env.name());
        Ok(ResidualEnv {
            env_obs: vec![0.0; base.dim()],
            obs_space: BoxSpace::new(low, high),
            act_space: BoxSpace::symmetric(m, 1.0),
            reference: vec![0.0; m],
            applied: vec![0.0; m],
            scale,
            env,
            controller,
            mapping,
            config,
            name,
        })
    }

    /// The residual environment for a robot environment by name, with its controller preset.
    pub fn for_env(env_name: &str, config: ResidualConfig) -> Result<ResidualEnv, ControlError> {
        let env = make_robot_env(env_name, None)?;
        let controller = LocomotionController::new(env.model(), controller_config(env_name)?)?;
        ResidualEnv::new(env, controller, config)
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

    /// Ticks the controller on the current state and stores the next reference action.
    fn update_reference(&mut self) {
        let t = self.env.episode_time();
        let cmd = self.mapping.tick(&mut self.controller, self.env.as_ref(), &self.config.command, t);
        self.mapping.action(self.env.as_ref(), cmd, &mut self.reference);
    }

    fn write_obs(&self, obs: &mut [f32]) {
        let reference = if self.config.include_reference { Some(&self.reference[..]) } else { None };
        write_residual_observation(
            &self.env_obs,
            self.controller.status().phase,
            &self.config.command,
            reference,
            obs,
        );
    }
}

/// The residual policy's observation: the robot's observation, the gait phase
/// `(sin 2πφ, cos 2πφ)`, the command `(v_x, v_y, ω_z)` and optionally the reference action.
/// The one place this layout is defined: [`ResidualEnv`] (training) and
/// [`crate::deploy::HybridStack`] (deployment) both call it.
#[track_caller]
pub fn write_residual_observation(
    robot_obs: &[f32],
    phase: f64,
    command: &Command,
    reference: Option<&[f32]>,
    out: &mut [f32],
) {
    let n = robot_obs.len();
    let m = reference.map_or(0, |r| r.len());
    assert!(out.len() == n + 5 + m, "residual observation: {} entries, expected {}", out.len(), n + 5 + m);
    out[..n].copy_from_slice(robot_obs);
    let (s, c) = (2.0 * std::f64::consts::PI * phase).sin_cos();
    out[n..n + 5].copy_from_slice(&[
        s as f32,
        c as f32,
        command.forward_velocity as f32,
        command.lateral_velocity as f32,
        command.yaw_rate as f32,
    ]);
    if let Some(r) = reference {
        out[n + 5..].copy_from_slice(r);
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

    fn dt(&self) -> f64 {
        self.env.dt()
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
        self.update_reference();
        self.applied.copy_from_slice(&self.reference);
        self.write_obs(obs);
        Ok(())
    }

    /// Residuals outside [−1, 1] are clipped; NaN or a wrong length is refused.
    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Step, EnvError> {
        check_action(&self.act_space, action)?;
        check_observation(&self.obs_space, obs)?;
        let space = self.env.action_space();
        let mut sq = 0.0f64;
        for k in 0..action.len() {
            let r = self.scale[k] * action[k].clamp(-1.0, 1.0);
            sq += (r as f64) * (r as f64);
            self.applied[k] = (self.reference[k] + r).clamp(space.low[k], space.high[k]);
        }
        let mut step = self.env.step(&self.applied, &mut self.env_obs)?;
        step.info.reward_terms[RESIDUAL_TERM] = (sq / action.len().max(1) as f64).sqrt();
        if !step.done() {
            self.update_reference();
        }
        self.write_obs(obs);
        Ok(step)
    }
}
