//! What robot software embeds: the controller plus a trained residual policy behind a small
//! robot interface, with no training code and no allocation per tick.
//!
//! ```text
//! state, sensors ──> LocomotionController ──> reference action ─┐
//!                 └─> Policy (loaded checkpoint) ──> residual ──┴─> clip(reference + scale·residual) ──> actuators
//! ```
//!
//! [`HybridStack::tick`] reproduces exactly what the hybrid saw and did during training
//! ([`crate::residual::ResidualEnv`]): both hold the one [`Residual`] (the law and the
//! observation layout), make the one step it defines ([`Residual::observe`], the policy,
//! then [`Residual::act`]) and tick the controller through [`ContactMap`] and
//! [`CommandTorques`]. Without a policy it runs the controller alone.

use centaur_dynamics::{Model, RobotState};
use centaur_envs::RobotEnv;
use centaur_gym::BoxSpace;
use centaur_mpc::{Command, ControllerConfig, LocomotionController};
use centaur_rl::Policy;

use crate::hybrid::{CommandTorques, ContactMap, HybridError, Residual, ResidualConfig};

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
    fn contacts(&self, _out: &mut [bool]) {}
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

/// Controller + residual policy, with every buffer allocated at construction.
pub struct HybridStack {
    controller: LocomotionController,
    torques: CommandTorques,
    policy: Option<Policy>,
    config: ResidualConfig,
    residual: Residual,
    sensors: Vec<f32>,
    obs: Vec<f32>,
    reference: Vec<f32>,
    residual_out: Vec<f32>,
    command: Vec<f32>,
    /// The command the controller follows: the configured one, steered by the policy.
    steered: Command,
    contacts: ContactMap,
}

impl HybridStack {
    /// A stack for `robot`; `policy = None` runs the controller alone.
    pub fn new(
        robot: &dyn RobotInterface,
        controller: ControllerConfig,
        policy: Option<Policy>,
        config: ResidualConfig,
    ) -> Result<HybridStack, HybridError> {
        // The rating the hybrid was trained with (`ResidualConfig::rated_speed`), if any.
        let mut controller = controller;
        config.rate_controller(&mut controller)?;
        let controller = LocomotionController::new(robot.model(), controller)?;
        // The command for this robot (a body height within its legs' reach).
        controller.check_command(&config.command)?;
        let torques = CommandTorques::new(robot.model(), robot.actuated_joints(), &controller)?;
        let m = robot.command_space().dim();
        let residual = Residual::new(&config, m)?;
        let obs_dim = residual.obs_dim(robot.sensor_dim());
        let act_dim = residual.policy_action_dim();
        let command0 = config.command;
        if let Some(p) = &policy
            && (p.obs_dim() != obs_dim || p.act_dim() != act_dim)
        {
            return Err(HybridError::PolicyShape {
                policy: (p.obs_dim(), p.act_dim()),
                needed: (obs_dim, act_dim),
            });
        }
        Ok(HybridStack {
            torques,
            policy,
            residual,
            config,
            sensors: vec![0.0; robot.sensor_dim()],
            obs: vec![0.0; obs_dim],
            reference: vec![0.0; m],
            residual_out: vec![0.0; act_dim],
            command: vec![0.0; m],
            steered: command0,
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
        self.steered = self.config.command;
    }

    /// Sets the velocity command (with steering: the command at zero steering output).
    pub fn set_command(&mut self, command: Command) {
        self.config.command = command;
        self.steered = command;
    }

    /// The command the controller follows now (the set one, steered by the policy).
    pub fn command(&self) -> &Command {
        &self.steered
    }

    /// One control period: reads the robot, returns the actuator command.
    pub fn tick(&mut self, robot: &dyn RobotInterface) -> &[f32] {
        let cmd =
            self.contacts.tick(&mut self.controller, robot.state(), &self.steered, robot.time(), |out| {
                robot.contacts(out)
            });
        let tau = self.torques.torques(robot.state(), cmd);
        robot.command_for_torques(tau, &mut self.reference);
        match self.policy.as_mut() {
            None => self.command.copy_from_slice(&self.reference),
            Some(policy) => {
                robot.sensors(&mut self.sensors);
                let r = &self.residual;
                r.observe(&self.controller, &self.sensors, &self.steered, &self.reference, &mut self.obs);
                policy.act(&self.obs, &mut self.residual_out);
                // The step ResidualEnv::step makes in training, at the full bound.
                r.act(
                    &mut self.controller,
                    &self.config.command,
                    &mut self.steered,
                    &self.reference,
                    &self.residual_out,
                    1.0,
                    robot.command_space(),
                    &mut self.command,
                );
            }
        }
        &self.command
    }
}
