//! The model-based controller driving a simulated robot: robot environments by name, the
//! mapping from the controller's joint command to the environment's actions, and closed-loop
//! runs with the summary `centaur control` writes.
//!
//! Each environment step the controller ticks once on the robot state the simulator reports
//! (its only view of the robot); its command becomes joint torques at that state,
//! `τ = τ_ff + k_p (q* − q) + k_d (q̇* − q̇)`, and the environment turns torques into its own
//! actions ([`RobotEnv::action_for_torques`]: torque/gear for the Gymnasium robots, the
//! inverted DC motor model and leg model for the Minitaur). The residual environment uses
//! the same path, so an untrained hybrid acts exactly like the controller.

use std::time::Instant;

use centaur_dynamics::nalgebra::Vector3;
use centaur_envs::{LocomotionConfig, LocomotionEnv, MinitaurConfig, MinitaurEnv, RobotEnv};
use centaur_mpc::{Command, ConfigError, ControllerConfig, Gait, JointCommand, LocomotionController};
use centaur_rl::EnvError;

/// Robot environments by name (the controllable ones and the pure-RL ones).
pub const ROBOT_ENV_NAMES: &[&str] = &[
    "minitaur",
    "minitaur-fast",
    "minitaur-deterministic",
    "ant",
    "ant27",
    "walker2d",
    "hopper",
    "halfcheetah",
    "humanoid",
];

/// Why a control run could not happen.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    /// No robot environment has this name.
    #[error("unknown robot environment `{0}` (available: {names})", names = ROBOT_ENV_NAMES.join(", "))]
    UnknownEnv(String),
    /// No controller preset for this robot.
    #[error("no controller for `{0}` (controllers exist for minitaur, ant, walker2d and humanoid)")]
    NoController(String),
    /// Unknown gait name.
    #[error("unknown gait `{0}` (stand, walk, trot, pace, bound, pronk, gallop)")]
    UnknownGait(String),
    /// The environment failed.
    #[error("environment: {0}")]
    Env(#[from] EnvError),
    /// The controller configuration is invalid.
    #[error("controller: {0}")]
    Config(#[from] ConfigError),
    /// A bad option.
    #[error("{0}")]
    Invalid(String),
}

/// A robot environment by name; `max_episode_steps` overrides the default length.
pub fn make_robot_env(
    name: &str,
    max_episode_steps: Option<usize>,
) -> Result<Box<dyn RobotEnv>, ControlError> {
    let steps = |default: usize| max_episode_steps.unwrap_or(default);
    Ok(match name {
        "minitaur" => {
            let c = MinitaurConfig::default();
            Box::new(MinitaurEnv::new(MinitaurConfig { max_episode_steps: steps(c.max_episode_steps), ..c })?)
        }
        "minitaur-deterministic" => {
            // v0 without the per-reset mass, voltage, damping and friction randomisation.
            let c = MinitaurConfig::deterministic();
            Box::new(MinitaurEnv::new(MinitaurConfig { max_episode_steps: steps(c.max_episode_steps), ..c })?)
        }
        "minitaur-fast" => {
            let c = MinitaurConfig::fast();
            Box::new(MinitaurEnv::new(MinitaurConfig { max_episode_steps: steps(c.max_episode_steps), ..c })?)
        }
        other => {
            let config = match other {
                "ant" => LocomotionConfig::ant(),
                "ant27" => LocomotionConfig::ant_27d(),
                "walker2d" => LocomotionConfig::walker2d(),
                "hopper" => LocomotionConfig::hopper(),
                "halfcheetah" => LocomotionConfig::half_cheetah(),
                "humanoid" => LocomotionConfig::humanoid(),
                _ => return Err(ControlError::UnknownEnv(name.to_string())),
            };
            let max = steps(config.max_episode_steps);
            Box::new(LocomotionEnv::new(LocomotionConfig { max_episode_steps: max, ..config })?)
        }
    })
}

/// The controller preset for a robot environment.
pub fn controller_config(env_name: &str) -> Result<ControllerConfig, ControlError> {
    let robot = env_name.trim_end_matches("-fast").trim_end_matches("-deterministic").trim_end_matches("27");
    let preset = match robot {
        "minitaur" | "ant" | "walker2d" | "humanoid" => robot,
        _ => return Err(ControlError::NoController(env_name.to_string())),
    };
    ControllerConfig::preset(preset).ok_or_else(|| ControlError::NoController(env_name.to_string()))
}

/// Maps a controller's joint command to an environment's actions.
#[derive(Clone, Debug)]
pub struct ActionMapping {
    /// For each actuated joint of the env (action order): index in the command.
    cmd_index: Vec<usize>,
    /// For each actuated joint: its `q` and `v` indices in the model.
    qv: Vec<(usize, usize)>,
    tau: Vec<f64>,
    /// For each contact point of the controller: the env foot on the same link, if any.
    contact_foot: Vec<Option<usize>>,
    contacts: Vec<bool>,
}

impl ActionMapping {
    /// Matches the env's actuated joints with the controller's joints by name.
    pub fn new(env: &dyn RobotEnv, controller: &LocomotionController) -> Result<ActionMapping, ControlError> {
        let model = env.model();
        let names = controller.joint_names();
        let mut cmd_index = Vec::new();
        let mut qv = Vec::new();
        for &j in env.actuated_joints() {
            let name = &model.joints[j].name;
            let k = names.iter().position(|n| n == name).ok_or_else(|| {
                ControlError::Invalid(format!("the controller does not drive joint `{name}`"))
            })?;
            cmd_index.push(k);
            qv.push((model.joints[j].idx_q, model.joints[j].idx_v));
        }
        let n = cmd_index.len();
        let contact_foot: Vec<Option<usize>> = controller
            .contact_frames()
            .iter()
            .map(|f| env.foot_frames().iter().position(|g| g == f))
            .collect();
        let contacts = vec![false; contact_foot.len()];
        Ok(ActionMapping { cmd_index, qv, tau: vec![0.0; n], contact_foot, contacts })
    }

    /// The env's measured foot contacts for the controller's contact points (contact order,
    /// matched by link name; heel and toe of one foot share its flag), or `None` if a contact
    /// point has no foot in the env.
    pub fn contacts(&mut self, env: &dyn RobotEnv) -> Option<&[bool]> {
        let feet = env.foot_contacts();
        for (c, foot) in self.contacts.iter_mut().zip(&self.contact_foot) {
            *c = feet.get((*foot)?)?.in_contact;
        }
        Some(&self.contacts)
    }

    /// The joint torques of `cmd` at the env's current state (action order).
    pub fn torques(&mut self, env: &dyn RobotEnv, cmd: &JointCommand) -> &[f64] {
        let s = env.robot_state();
        for (k, (&c, &(iq, iv))) in self.cmd_index.iter().zip(&self.qv).enumerate() {
            self.tau[k] =
                cmd.tau[c] + cmd.kp[c] * (cmd.q_des[c] - s.q[iq]) + cmd.kd[c] * (cmd.qd_des[c] - s.v[iv]);
        }
        &self.tau
    }

    /// The env action realising `cmd` at the env's current state.
    pub fn action(&mut self, env: &dyn RobotEnv, cmd: &JointCommand, out: &mut [f32]) {
        self.torques(env, cmd);
        env.action_for_torques(&self.tau, out);
    }
}

/// A push during a control run: force (N, world frame) on the base from `at` for `duration` s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Push {
    /// Start time (s).
    pub at: f64,
    /// Force (N).
    pub force: [f64; 3],
    /// Duration (s).
    pub duration: f64,
}

/// What to run.
#[derive(Clone, Debug)]
pub struct ControlOptions {
    /// Environment name (see [`ROBOT_ENV_NAMES`]).
    pub env: String,
    /// Gait.
    pub gait: Gait,
    /// Commanded forward speed (m/s).
    pub speed: f64,
    /// Duration (s).
    pub seconds: f64,
    /// Reset seed.
    pub seed: u64,
    /// Optional push.
    pub push: Option<Push>,
}

/// The summary of a control run (`summary.json` of `centaur control`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ControlSummary {
    /// Environment.
    pub env: String,
    /// Gait name.
    pub gait: String,
    /// Commanded forward speed (m/s).
    pub commanded_speed: f64,
    /// Mean forward speed over the run (m/s): base displacement along the initial heading / time.
    pub mean_speed: f64,
    /// Base displacement along the initial heading (m).
    pub distance: f64,
    /// Whether the episode ended by a fall (the env's termination).
    pub fell: bool,
    /// |final yaw − initial yaw| (rad).
    pub yaw_drift: f64,
    /// Lateral displacement (m).
    pub lateral_drift: f64,
    /// Mean controller tick time (µs).
    pub mean_tick_us: f64,
    /// 99th-percentile controller tick time (µs).
    pub p99_tick_us: f64,
    /// Mean MPC solve time over the ticks that solved (µs).
    pub mean_mpc_solve_us: f64,
    /// Mean whole-body QP solve time (µs).
    pub mean_wbc_solve_us: f64,
    /// MPC and whole-body QP failures (fallbacks taken).
    pub qp_failures: u64,
    /// Simulated seconds actually run.
    pub seconds: f64,
    /// Environment return accumulated over the run.
    pub env_return: f64,
}

fn yaw_of(q: &[f64]) -> f64 {
    let (x, y, z, w) = (q[3], q[4], q[5], q[6]);
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// Base pose (x, y, yaw) of a floating or planar robot.
fn planar_pose(env: &dyn RobotEnv) -> (f64, f64, f64) {
    let s = env.robot_state();
    if s.has_floating_base() {
        (s.q[0], s.q[1], yaw_of(s.q.as_slice()))
    } else {
        // Planar robots: rootx is the first coordinate, no lateral motion, no yaw.
        (s.q[0], 0.0, 0.0)
    }
}

/// Runs the controller alone on a robot environment and summarises the run.
pub fn run_control(opts: &ControlOptions) -> Result<ControlSummary, ControlError> {
    if !(opts.seconds > 0.0 && opts.seconds.is_finite() && opts.speed.is_finite()) {
        return Err(ControlError::Invalid("seconds must be positive and speed finite".into()));
    }
    let probe = make_robot_env(&opts.env, None)?;
    let steps = (opts.seconds / probe.dt()).round() as usize;
    drop(probe);
    let mut env = make_robot_env(&opts.env, Some(steps + 1))?;
    let mut ctrl = LocomotionController::new(env.model(), controller_config(&opts.env)?)?;
    let mut mapping = ActionMapping::new(env.as_ref(), &ctrl)?;
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let mut action = vec![0.0f32; env.action_space().dim()];
    env.reset(Some(opts.seed), &mut obs)?;
    let (x0, y0, yaw0) = planar_pose(env.as_ref());
    let command = Command::forward(opts.speed, opts.gait);
    let mut ticks = Vec::with_capacity(steps);
    let (mut mpc_us, mut mpc_n, mut wbc_us, mut wbc_n) = (0.0, 0usize, 0.0, 0usize);
    let mut fell = false;
    let mut ret = 0.0;
    let mut t = 0.0;
    for k in 0..steps {
        if let Some(p) = opts.push
            && (t - p.at).abs() < 0.5 * env.dt()
        {
            env.push(Vector3::from(p.force), p.duration);
        }
        let start = Instant::now();
        let cmd = match mapping.contacts(env.as_ref()) {
            Some(contacts) => ctrl.tick_with_contacts(env.robot_state(), &command, t, contacts),
            None => ctrl.tick(env.robot_state(), &command, t),
        };
        ticks.push(start.elapsed().as_secs_f64() * 1e6);
        mapping.action(env.as_ref(), cmd, &mut action);
        let status = ctrl.status();
        if status.mpc_ran {
            mpc_us += status.mpc_solve_us;
            mpc_n += 1;
        }
        wbc_us += status.wbc_solve_us;
        wbc_n += 1;
        let step = env.step(&action, &mut obs)?;
        ret += step.reward;
        t = (k + 1) as f64 * env.dt();
        if step.terminated {
            fell = true;
            break;
        }
        if step.truncated {
            break;
        }
    }
    let (x1, y1, yaw1) = planar_pose(env.as_ref());
    let (dx, dy) = (x1 - x0, y1 - y0);
    let distance = dx * yaw0.cos() + dy * yaw0.sin();
    let lateral = -dx * yaw0.sin() + dy * yaw0.cos();
    ticks.sort_by(|a, b| a.total_cmp(b));
    let p99 = ticks.get(((ticks.len() as f64) * 0.99) as usize).or(ticks.last()).copied().unwrap_or(0.0);
    let status = ctrl.status();
    Ok(ControlSummary {
        env: opts.env.clone(),
        gait: opts.gait.name().to_string(),
        commanded_speed: opts.speed,
        mean_speed: if t > 0.0 { distance / t } else { 0.0 },
        distance,
        fell,
        yaw_drift: centaur_mpc::controller::wrap_pi(yaw1 - yaw0).abs(),
        lateral_drift: lateral,
        mean_tick_us: ticks.iter().sum::<f64>() / ticks.len().max(1) as f64,
        p99_tick_us: p99,
        mean_mpc_solve_us: mpc_us / mpc_n.max(1) as f64,
        mean_wbc_solve_us: wbc_us / wbc_n.max(1) as f64,
        qp_failures: status.mpc_failures + status.wbc_failures,
        seconds: t,
        env_return: ret,
    })
}

/// Parses a gait name.
pub fn parse_gait(name: &str) -> Result<Gait, ControlError> {
    Gait::from_name(name).ok_or_else(|| ControlError::UnknownGait(name.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_robot_env_name_builds() {
        for name in ROBOT_ENV_NAMES {
            let env = make_robot_env(name, Some(10)).unwrap();
            assert_eq!(env.max_episode_steps(), 10, "{name}");
        }
        assert!(matches!(make_robot_env("cartpole", None), Err(ControlError::UnknownEnv(_))));
        assert!(matches!(controller_config("hopper"), Err(ControlError::NoController(_))));
    }
}
