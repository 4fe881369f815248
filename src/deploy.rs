//! What robot software embeds: the controller plus a trained residual policy behind a small
//! robot interface, with no training code and no allocation per tick.
//!
//! ```text
//! state, sensors ──> LocomotionController ──> reference action ─┐
//!                 └─> Policy (loaded checkpoint) ──> residual ──┴─> clip(reference + scale·residual) ──> actuators
//! ```
//!
//! [`HybridStack::tick`] reproduces exactly what the hybrid saw and did during training
//! ([`crate::residual::ResidualEnv`]): the same controller tick, the same torque → command
//! mapping, the same observation layout ([`write_residual_observation`]) and the same clip.
//! Without a policy it runs the controller alone.

use centaur_dynamics::{Model, RobotState};
use centaur_envs::RobotEnv;
use centaur_mpc::{Command, ConfigError, ControllerConfig, JointCommand, LocomotionController};
use centaur_rl::{BoxSpace, Policy};

use crate::residual::{ResidualConfig, write_residual_observation};

/// What a robot (or its simulation) provides to the locomotion stack.
pub trait RobotInterface {
    /// The description the controller was built from.
    fn model(&self) -> &Model;
    /// Model joint indices of the actuators, in command order.
    fn actuated_joints(&self) -> &[usize];
    /// The actuators' command space.
    fn command_space(&self) -> &BoxSpace;
    /// The latest state estimate.
    fn state(&self) -> &RobotState;
    /// The sensor observation the policy was trained on.
    fn sensors(&self, out: &mut [f32]);
    /// Dimension of [`RobotInterface::sensors`].
    fn sensor_dim(&self) -> usize;
    /// The actuator command that applies joint torques `tau` (actuated order) now.
    fn command_for_torques(&self, tau: &[f64], out: &mut [f32]);
    /// Time since start (s).
    fn time(&self) -> f64;
    /// Links that carry a ground-contact sensor, in [`RobotInterface::contacts`] order. The
    /// controller uses the sensors when every one of its contact points has one (matched by
    /// link name once, at construction), else it follows its gait schedule alone. The
    /// default senses nothing.
    fn contact_frames(&self) -> &[String] {
        &[]
    }
    /// The contact sensors' flags, in [`RobotInterface::contact_frames`] order, into `out`.
    fn contacts(&self, out: &mut [bool]) {
        let _ = out;
    }
}

/// Every robot environment is a robot interface (its observation is the sensor vector).
pub struct Simulated<'a> {
    /// The environment.
    pub env: &'a dyn RobotEnv,
    /// The observation it returned last.
    pub obs: &'a [f32],
}

impl RobotInterface for Simulated<'_> {
    fn model(&self) -> &Model {
        self.env.model()
    }
    fn actuated_joints(&self) -> &[usize] {
        self.env.actuated_joints()
    }
    fn command_space(&self) -> &BoxSpace {
        self.env.action_space()
    }
    fn state(&self) -> &RobotState {
        self.env.robot_state()
    }
    fn sensors(&self, out: &mut [f32]) {
        out.copy_from_slice(self.obs);
    }
    fn sensor_dim(&self) -> usize {
        self.obs.len()
    }
    fn command_for_torques(&self, tau: &[f64], out: &mut [f32]) {
        self.env.action_for_torques(tau, out)
    }
    fn time(&self) -> f64 {
        self.env.episode_time()
    }
    fn contact_frames(&self) -> &[String] {
        self.env.foot_frames()
    }
    fn contacts(&self, out: &mut [bool]) {
        for (o, foot) in out.iter_mut().zip(self.env.foot_contacts()) {
            *o = foot.in_contact;
        }
    }
}

/// Joint torques of a controller command at a state, in the robot's actuator order:
/// `τ = τ_ff + k_p (q* − q) + k_d (q̇* − q̇)`.
#[derive(Clone, Debug)]
pub struct CommandTorques {
    /// Per actuator: index in the controller's command, and the joint's `q`, `v` indices.
    map: Vec<(usize, usize, usize)>,
    tau: Vec<f64>,
}

impl CommandTorques {
    /// Matches `actuated` (model joint indices) with the controller's joints by name.
    pub fn new(model: &Model, actuated: &[usize], controller: &LocomotionController) -> Result<Self, String> {
        let names = controller.joint_names();
        let mut map = Vec::with_capacity(actuated.len());
        for &j in actuated {
            let name = &model.joints[j].name;
            if model.joints[j].nq() != 1 || model.joints[j].nv() != 1 {
                return Err(format!("joint `{name}` is not a one-coordinate joint (a (cos θ, sin θ) pair?)"));
            }
            let k = names
                .iter()
                .position(|n| n == name)
                .ok_or_else(|| format!("the controller does not drive joint `{name}`"))?;
            map.push((k, model.joints[j].idx_q, model.joints[j].idx_v));
        }
        Ok(CommandTorques { tau: vec![0.0; map.len()], map })
    }

    /// The torques of `cmd` at `state`.
    pub fn torques(&mut self, state: &RobotState, cmd: &JointCommand) -> &[f64] {
        for (t, &(k, iq, iv)) in self.tau.iter_mut().zip(&self.map) {
            *t = cmd.tau[k]
                + cmd.kp[k] * (cmd.q_des[k] - state.q[iq])
                + cmd.kd[k] * (cmd.qd_des[k] - state.v[iv]);
        }
        &self.tau
    }
}

/// The controller's contact points matched by link name with a robot's contact sensors,
/// once; then each tick reads the sensors without searching or allocating.
#[derive(Clone, Debug)]
pub struct ContactMap {
    /// For each contact point of the controller: its sensor, or `None` if one has none.
    sensor_of: Option<Vec<usize>>,
    sensed: Vec<bool>,
    flags: Vec<bool>,
}

impl ContactMap {
    /// Matches `controller`'s contact frames with `sensor_frames`.
    pub fn new(controller: &LocomotionController, sensor_frames: &[String]) -> Self {
        let frames = controller.contact_frames();
        let sensor_of = frames.iter().map(|f| sensor_frames.iter().position(|s| s == f)).collect();
        ContactMap { sensor_of, sensed: vec![false; sensor_frames.len()], flags: vec![false; frames.len()] }
    }

    /// Whether every contact point has a sensor (the controller then uses them).
    pub fn complete(&self) -> bool {
        self.sensor_of.is_some()
    }

    /// One controller tick: with the sensed contacts (`read` fills them, in sensor order)
    /// when the map is complete, else on the gait schedule alone.
    pub fn tick<'c>(
        &mut self,
        controller: &'c mut LocomotionController,
        state: &RobotState,
        command: &Command,
        t: f64,
        read: impl FnOnce(&mut [bool]),
    ) -> &'c JointCommand {
        match &self.sensor_of {
            Some(sensor_of) => {
                read(&mut self.sensed);
                for (flag, &k) in self.flags.iter_mut().zip(sensor_of) {
                    *flag = self.sensed[k];
                }
                controller.tick_with_contacts(state, command, t, &self.flags)
            }
            None => controller.tick(state, command, t),
        }
    }
}

/// Controller + residual policy, with every buffer allocated at construction.
pub struct HybridStack {
    controller: LocomotionController,
    torques: CommandTorques,
    policy: Option<Policy>,
    config: ResidualConfig,
    scale: Vec<f32>,
    sensors: Vec<f32>,
    obs: Vec<f32>,
    reference: Vec<f32>,
    residual: Vec<f32>,
    command: Vec<f32>,
    contacts: ContactMap,
}

impl HybridStack {
    /// A stack for `robot`; `policy = None` runs the controller alone.
    pub fn new(
        robot: &dyn RobotInterface,
        controller: ControllerConfig,
        policy: Option<Policy>,
        config: ResidualConfig,
    ) -> Result<HybridStack, String> {
        let controller =
            LocomotionController::new(robot.model(), controller).map_err(|e: ConfigError| e.to_string())?;
        let torques = CommandTorques::new(robot.model(), robot.actuated_joints(), &controller)?;
        let m = robot.command_space().dim();
        config.validate(m).map_err(|e| e.to_string())?;
        let obs_dim = robot.sensor_dim() + 5 + if config.include_reference { m } else { 0 };
        if let Some(p) = &policy
            && (p.obs_dim() != obs_dim || p.act_dim() != m)
        {
            return Err(format!(
                "the policy maps {} observations to {} actions; this robot and residual setup need {obs_dim} → {m}",
                p.obs_dim(),
                p.act_dim()
            ));
        }
        let scale = (0..m).map(|k| *config.scale.get(k).unwrap_or(&config.scale[0]) as f32).collect();
        Ok(HybridStack {
            torques,
            policy,
            config,
            scale,
            sensors: vec![0.0; robot.sensor_dim()],
            obs: vec![0.0; obs_dim],
            reference: vec![0.0; m],
            residual: vec![0.0; m],
            command: vec![0.0; m],
            contacts: ContactMap::new(&controller, robot.contact_frames()),
            controller,
        })
    }

    /// The controller (for its status: QP timings, contact schedule, plan).
    pub fn controller(&self) -> &LocomotionController {
        &self.controller
    }

    /// Restarts the gait clock (call when the robot starts walking).
    pub fn reset(&mut self) {
        self.controller.reset();
    }

    /// Sets the velocity command.
    pub fn set_command(&mut self, command: Command) {
        self.config.command = command;
    }

    /// One control period: reads the robot, returns the actuator command.
    pub fn tick(&mut self, robot: &dyn RobotInterface) -> &[f32] {
        let cmd = self.contacts.tick(
            &mut self.controller,
            robot.state(),
            &self.config.command,
            robot.time(),
            |out| robot.contacts(out),
        );
        let tau = self.torques.torques(robot.state(), cmd);
        robot.command_for_torques(tau, &mut self.reference);
        match self.policy.as_mut() {
            None => self.command.copy_from_slice(&self.reference),
            Some(policy) => {
                robot.sensors(&mut self.sensors);
                let reference = if self.config.include_reference { Some(&self.reference[..]) } else { None };
                let phase = self.controller.status().phase;
                write_residual_observation(
                    &self.sensors,
                    phase,
                    &self.config.command,
                    reference,
                    &mut self.obs,
                );
                policy.act(&self.obs, &mut self.residual);
                let space = robot.command_space();
                for k in 0..self.command.len() {
                    let r = self.scale[k] * self.residual[k].clamp(-1.0, 1.0);
                    self.command[k] = (self.reference[k] + r).clamp(space.low[k], space.high[k]);
                }
            }
        }
        &self.command
    }
}
