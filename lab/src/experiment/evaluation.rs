//! Deterministic evaluation of an agent — the controller alone, a pure-RL policy or the
//! hybrid — over episodes with fixed seeds, with the first episode recorded for Foxglove.

use std::path::Path;

use centaur_dynamics::nalgebra::Vector3;
use centaur_envs::RobotEnv;
use centaur_gym::{Env, Step};
use centaur_mpc::LocomotionController;
use centaur_rl::Policy;

use super::options::ExperimentError;
use super::summary::AgentStats;
use crate::hybrid::{ActionMapping, Fade, HybridError, ResidualConfig};
use crate::recording::{CommandFrame, Frame, Recorder};
use crate::registry::{EnvSource, make_residual_env_with, make_robot_env_with, residual_config_for, robot};
use crate::residual::ResidualEnv;

/// A trained policy's deterministic episodes (episode `k` resets with `seed + k`) on a robot
/// environment, or on a hybrid `<robot>-residual` with the source's setup (a run's recorded
/// one, else the robot's residual preset for the source's learner; behind the safety `fade`
/// if given:
/// [`crate::hybrid::ResidualConfig::fade`]), with the source's `[env]` settings over the
/// preset; the first episode recorded to `record` if given. A policy of
/// other dimensions is refused with both shapes, a fade on an environment that is not a
/// hybrid with the environment's name.
pub fn evaluate_policy(
    source: &EnvSource,
    policy: Policy,
    episodes: usize,
    seed: u64,
    record: Option<&Path>,
    fade: Option<Fade>,
) -> Result<AgentStats, ExperimentError> {
    let (env, settings) = (source.name(), source.settings());
    let hybrid = env.strip_suffix("-residual").filter(|r| robot(r).is_some_and(|s| s.residual.is_some()));
    let shape = (policy.obs_dim(), policy.act_dim());
    let (mut driver, needed) = match hybrid {
        Some(r) => {
            // The source's setup: the one it was given (a run's record), else the preset.
            let residual = match source.residual() {
                Some(residual) => residual,
                None => residual_config_for(r, source.learner())?,
            };
            let fade = fade.or(residual.fade);
            let env = make_residual_env_with(r, ResidualConfig { fade, ..residual }, settings)?;
            let needed = (env.observation_space().dim(), env.action_space().dim());
            (Driver::Hybrid { env: Box::new(env), policy }, needed)
        }
        None if fade.is_some() => {
            return Err(ExperimentError::NotAHybrid { env: env.to_string(), option: "a safety fade" });
        }
        None => {
            let env = make_robot_env_with(env, settings)?;
            let needed = (env.observation_space().dim(), env.action_space().dim());
            (Driver::Pure { env, policy }, needed)
        }
    };
    if shape != needed {
        return Err(HybridError::PolicyShape { policy: shape, needed }.into());
    }
    evaluate(&mut driver, episodes, seed, record)
}

/// The agent an evaluation runs.
pub(crate) enum Driver {
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

    fn robot_mut(&mut self) -> &mut dyn RobotEnv {
        match self {
            Driver::Controller { env, .. } | Driver::Pure { env, .. } => env.as_mut(),
            Driver::Hybrid { env, .. } => env.inner_mut(),
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

    /// The robot's action dimension (the hybrid's policy may also steer the command).
    fn robot_act_dim(&self) -> usize {
        match self {
            Driver::Controller { env, .. } | Driver::Pure { env, .. } => env.action_space().dim(),
            Driver::Hybrid { env, .. } => env.inner().action_space().dim(),
        }
    }

    fn reset(&mut self, seed: u64, obs: &mut [f32]) -> Result<(), ExperimentError> {
        match self {
            Driver::Controller { env, controller, .. } => {
                env.reset(Some(seed), obs)?;
                controller.reset();
            }
            Driver::Pure { env, .. } => env.reset(Some(seed), obs)?,
            Driver::Hybrid { env, .. } => env.reset(Some(seed), obs)?,
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
                mapping.action(env.as_mut(), cmd, action);
                rec.reference.clone_from_slice(action);
                rec.applied.clone_from_slice(action);
                rec.planned_com.clear();
                rec.planned_com.extend_from_slice(&controller.status().planned_com);
                rec.foot_targets.clear();
                rec.foot_targets.extend_from_slice(&controller.status().foot_targets);
                rec.command = Some(CommandFrame::of(command, controller));
                env.step(action, obs)?
            }
            Driver::Pure { env, policy } => {
                policy.act(obs, action);
                rec.applied.clone_from_slice(action);
                env.step(action, obs)?
            }
            Driver::Hybrid { env, policy } => {
                policy.act(obs, action);
                rec.reference.clone_from_slice(env.reference());
                rec.planned_com.clear();
                rec.planned_com.extend_from_slice(&env.controller().status().planned_com);
                rec.foot_targets.clear();
                rec.foot_targets.extend_from_slice(&env.controller().status().foot_targets);
                let s = env.step(action, obs)?;
                // The command as the policy steered it at this step (for the next tick).
                rec.command = Some(CommandFrame::of(env.command(), env.controller()));
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
    command: Option<CommandFrame>,
}

/// Base x position of a floating or planar robot.
fn base_x(env: &dyn RobotEnv) -> f64 {
    env.robot_state().q[0]
}

/// Evaluates an agent over `episodes` deterministic episodes (seeds `seed..seed+episodes`),
/// recording the first one to `record` if given.
pub(crate) fn evaluate(
    driver: &mut Driver,
    episodes: usize,
    seed: u64,
    record: Option<&Path>,
) -> Result<AgentStats, ExperimentError> {
    evaluate_pushed(driver, episodes, seed, record, None)
}

/// A lateral push during every evaluation episode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct EpisodePush {
    /// Episode time at which it starts (s).
    pub at: f64,
    /// Force (N) along world y; episodes alternate its sign (even episodes +y, odd −y).
    pub force: f64,
    /// Duration (s).
    pub duration: f64,
}

/// [`evaluate`], with `push` applied in every episode.
pub(crate) fn evaluate_pushed(
    driver: &mut Driver,
    episodes: usize,
    seed: u64,
    record: Option<&Path>,
    push: Option<EpisodePush>,
) -> Result<AgentStats, ExperimentError> {
    let mut obs = vec![0.0f32; driver.obs_dim()];
    let mut action = vec![0.0f32; driver.act_dim()];
    let m = driver.robot_act_dim();
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
    for ep in 0..episodes {
        driver.reset(seed + ep as u64, &mut obs)?;
        let x0 = base_x(driver.robot());
        let (mut ret, mut n) = (0.0, 0usize);
        let mut pushed = false;
        loop {
            if let Some(p) = push
                && !pushed
                && driver.robot().episode_time() >= p.at - 1e-9
            {
                let sign = if ep % 2 == 0 { 1.0 } else { -1.0 };
                driver.robot_mut().push(Vector3::new(0.0, sign * p.force, 0.0), p.duration);
                pushed = true;
            }
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
                    command: rec.command,
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
        cost_of_transport: super::summary::cost_of_transport(energy, driver.robot().model(), distance),
        energy_mean: energy / k,
        torque_rms: (torque_sq / torque_n.max(1) as f64).sqrt(),
        length_mean: lengths.iter().sum::<f64>() / k,
        env_steps: 0,
        wall_seconds: 0.0,
    })
}
