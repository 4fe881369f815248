//! Gymnasium's MuJoCo locomotion environments (v5) on Rapier: Ant, Walker2d, Hopper,
//! HalfCheetah and Humanoid.
//!
//! Read from `gymnasium/envs/mujoco/{ant,walker2d,hopper,half_cheetah,humanoid}_v5.py`
//! (gymnasium 1.4.0). Each preset ([`LocomotionConfig::ant`], …) holds the v5 constructor
//! defaults; each step applies `τ = gear · clip(action, ctrlrange)` for `frame_skip`
//! physics steps of MuJoCo's time step (HalfCheetah: of 25 ms, see below), then
//!
//! | | forward velocity | reward | healthy / termination | observation |
//! |---|---|---|---|---|
//! | Ant | torso xy, finite difference | `v_x + 1·healthy − 0.5 Σa² − 5e-4 Σ clip(cfrc_ext, ±1)²` | z ∈ [0.2, 1.0], state finite | `qpos[2:]` 13, qvel 14, clip(cfrc_ext) 78 (or the 27-d v4 variant) |
//! | Walker2d | `qpos[0]` | `v_x + 1·healthy − 1e-3 Σa²` | 0.8 < z < 2, −1 < angle < 1 | `qpos[1:]` 8, clip(qvel, ±10) 9 |
//! | Hopper | `qpos[0]` | `v_x + 1·healthy − 1e-3 Σa²` | z > 0.7, \|angle\| < 0.2, \|`state[2:]`\| < 100 | `qpos[1:]` 5, clip(qvel, ±10) 6 |
//! | HalfCheetah | `qpos[0]` | `v_x − 0.1 Σa²` | never | `qpos[1:]` 8, qvel 9 |
//! | Humanoid | centre of mass | `1.25 v_x + 5·healthy − 0.1 Σa² − min(5e-7 Σ cfrc_ext², 10)` | 1 < z < 2 | `qpos[2:]` 22, qvel 23, `qfrc_actuator[6:]` 17, cfrc_ext 78 |
//!
//! with 1000-step truncation and Gymnasium's reset noise. The control cost uses the action
//! as given (Gymnasium's behaviour); the actuators use it clipped to the control range
//! (MuJoCo's `ctrllimited`).
//!
//! Differences from MuJoCo (the README quantifies them): Rapier's rigid contacts and PGS
//! solver instead of MuJoCo's soft convex contacts, and semi-implicit Euler instead of RK4
//! (joint damping and springs implicit); robots collide with the ground only (MuJoCo also
//! lets some humanoid limbs collide with each other); joint limits are Rapier's hard limits
//! rather than MuJoCo's soft ones; `cfrc_ext` is the ground's contact wrench on each body
//! about the robot's centre of mass; Humanoid drops MuJoCo's `cinert` and `cvel` blocks
//! (140 instead of 348 entries); HalfCheetah takes two 25 ms physics steps per control
//! step instead of five of 10 ms ([`LocomotionConfig::half_cheetah`]). Inertias, masses, geometry, joint axes, ranges, gears,
//! armature, damping and springs are MuJoCo's compiled values (verified to 1e-14).
//!
//! Walker2d, Hopper and HalfCheetah move in the x–z plane through a fixed base and the
//! `rootx`, `rootz` (prismatic) and `rooty` (revolute) multibody joints, as in MuJoCo. Their
//! joint frames are built exactly for coordinate axes, without which Rapier 0.36.1 gave
//! their feet next to no ground friction (`Sim`'s `joint_axis_frame`;
//! `examples/planar_friction_probe.rs` and the planar slope test check it).

use centaur_dynamics::nalgebra::Vector3;
use centaur_dynamics::{BaseKind, Data, Model, RobotState};
use centaur_gym::{BoxSpace, Env, EnvError, Rng, Step, StepInfo};
use centaur_gym::{check_action, check_observation};

use crate::checks::{Fields, MAX_FRAME_SKIP};
use crate::error::RobotEnvError;
use crate::mujoco::MjRobot;
use crate::robot::{FootContact, JointHistory, ObsOptions, Push, PushSchedule, RobotEnv, Servo};
use crate::sim::{Sim, SimConfig};

/// Which robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum LocomotionRobot {
    /// Gymnasium Ant-v5.
    Ant,
    /// Gymnasium Walker2d-v5.
    Walker2d,
    /// Gymnasium Hopper-v5.
    Hopper,
    /// Gymnasium HalfCheetah-v5.
    HalfCheetah,
    /// Gymnasium Humanoid-v5.
    Humanoid,
}

impl LocomotionRobot {
    /// Short name, e.g. `"walker2d"`.
    pub fn name(&self) -> &'static str {
        match self {
            LocomotionRobot::Ant => "ant",
            LocomotionRobot::Walker2d => "walker2d",
            LocomotionRobot::Hopper => "hopper",
            LocomotionRobot::HalfCheetah => "half_cheetah",
            LocomotionRobot::Humanoid => "humanoid",
        }
    }

    fn assets(&self) -> (&'static str, &'static str, BaseKind) {
        match self {
            LocomotionRobot::Ant => (
                include_str!("../../assets/mujoco/ant.urdf"),
                include_str!("../../assets/mujoco/ant.mujoco.json"),
                BaseKind::Floating,
            ),
            LocomotionRobot::Walker2d => (
                include_str!("../../assets/mujoco/walker2d.urdf"),
                include_str!("../../assets/mujoco/walker2d.mujoco.json"),
                BaseKind::Fixed,
            ),
            LocomotionRobot::Hopper => (
                include_str!("../../assets/mujoco/hopper.urdf"),
                include_str!("../../assets/mujoco/hopper.mujoco.json"),
                BaseKind::Fixed,
            ),
            LocomotionRobot::HalfCheetah => (
                include_str!("../../assets/mujoco/half_cheetah.urdf"),
                include_str!("../../assets/mujoco/half_cheetah.mujoco.json"),
                BaseKind::Fixed,
            ),
            LocomotionRobot::Humanoid => (
                include_str!("../../assets/mujoco/humanoid.urdf"),
                include_str!("../../assets/mujoco/humanoid.mujoco.json"),
                BaseKind::Floating,
            ),
        }
    }

    /// Links whose ground contact counts as a foot contact (for [`StepInfo::foot_contacts`]).
    fn feet(&self) -> &'static [&'static str] {
        match self {
            LocomotionRobot::Ant => &["ankle_1_body", "ankle_2_body", "ankle_3_body", "ankle_4_body"],
            LocomotionRobot::Walker2d => &["foot", "foot_left"],
            LocomotionRobot::Hopper => &["foot"],
            LocomotionRobot::HalfCheetah => &["bfoot", "ffoot"],
            LocomotionRobot::Humanoid => &["right_foot", "left_foot"],
        }
    }
}

/// Configuration of a [`LocomotionEnv`]; the presets hold Gymnasium v5's defaults.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LocomotionConfig {
    /// The robot.
    pub robot: LocomotionRobot,
    /// Weight of the forward velocity (Ant/Walker2d/Hopper/HalfCheetah: 1.0, Humanoid: 1.25).
    pub forward_reward_weight: f64,
    /// Weight of `Σ a²` (Ant 0.5, Walker2d/Hopper 1e-3, HalfCheetah/Humanoid 0.1).
    pub ctrl_cost_weight: f64,
    /// Weight of the contact cost (Ant 5e-4, Humanoid 5e-7, others 0).
    pub contact_cost_weight: f64,
    /// Reward per healthy step (Humanoid 5.0, HalfCheetah 0, others 1.0).
    pub healthy_reward: f64,
    /// End the episode when unhealthy (default: true; HalfCheetah never terminates).
    pub terminate_when_unhealthy: bool,
    /// Healthy range of the torso height (m).
    pub healthy_z_range: (f64, f64),
    /// Healthy range of the torso angle (rad) (Walker2d, Hopper).
    pub healthy_angle_range: (f64, f64),
    /// Healthy range of `state[2:]` (Hopper: (−100, 100)).
    pub healthy_state_range: (f64, f64),
    /// Clip range of the contact forces (Ant: (−1, 1)).
    pub contact_force_range: (f64, f64),
    /// Cap of the contact cost (Humanoid: 10).
    pub contact_cost_max: f64,
    /// Reset noise scale.
    pub reset_noise_scale: f64,
    /// Include the contact forces in the observation (Ant v5: true; v4's 27-d variant: false).
    pub include_cfrc_ext_in_observation: bool,
    /// Physics steps per env step (Ant 5, Walker2d 4, Hopper 4, HalfCheetah 2 — MuJoCo's 5 of
    /// 10 ms as 2 of 25 ms, see [`LocomotionConfig::half_cheetah`] — Humanoid 5).
    pub frame_skip: usize,
    /// Truncation (steps) (default: 1000).
    pub max_episode_steps: usize,
    /// Physics settings; `dt` defaults to MuJoCo's time step of the model (HalfCheetah: 25 ms).
    pub sim: SimConfig,
    /// Observation options (default: none).
    pub obs: ObsOptions,
    /// Periodic pushes on the base during every episode (default: none).
    pub pushes: Option<PushSchedule>,
}

impl LocomotionConfig {
    fn base(robot: LocomotionRobot) -> Self {
        let dt = match robot {
            LocomotionRobot::Ant | LocomotionRobot::HalfCheetah => 0.01,
            LocomotionRobot::Walker2d | LocomotionRobot::Hopper => 0.002,
            LocomotionRobot::Humanoid => 0.003,
        };
        LocomotionConfig {
            robot,
            forward_reward_weight: 1.0,
            ctrl_cost_weight: 1e-3,
            contact_cost_weight: 0.0,
            healthy_reward: 1.0,
            terminate_when_unhealthy: true,
            healthy_z_range: (f64::NEG_INFINITY, f64::INFINITY),
            healthy_angle_range: (f64::NEG_INFINITY, f64::INFINITY),
            healthy_state_range: (f64::NEG_INFINITY, f64::INFINITY),
            contact_force_range: (f64::NEG_INFINITY, f64::INFINITY),
            contact_cost_max: f64::INFINITY,
            reset_noise_scale: 5e-3,
            include_cfrc_ext_in_observation: false,
            frame_skip: 4,
            max_episode_steps: 1000,
            sim: SimConfig { dt, ground_contact_frequency: 60.0, ..SimConfig::default() },
            obs: ObsOptions::default(),
            pushes: None,
        }
    }

    /// Ant-v5. Ground contacts at 20 Hz: softer contacts, like MuJoCo's default ones, give
    /// MuJoCo's random-action statistics (at 60 Hz episodes last 1.7× longer).
    pub fn ant() -> Self {
        let base = Self::base(LocomotionRobot::Ant);
        LocomotionConfig {
            sim: SimConfig { ground_contact_frequency: 20.0, ..base.sim.clone() },
            ctrl_cost_weight: 0.5,
            contact_cost_weight: 5e-4,
            healthy_z_range: (0.2, 1.0),
            contact_force_range: (-1.0, 1.0),
            reset_noise_scale: 0.1,
            include_cfrc_ext_in_observation: true,
            frame_skip: 5,
            ..base
        }
    }

    /// Ant with the 27-d observation (no contact forces) one seed paper uses (v4's default).
    pub fn ant_27d() -> Self {
        LocomotionConfig { include_cfrc_ext_in_observation: false, ..Self::ant() }
    }

    /// Walker2d-v5.
    pub fn walker2d() -> Self {
        LocomotionConfig {
            healthy_z_range: (0.8, 2.0),
            healthy_angle_range: (-1.0, 1.0),
            ..Self::base(LocomotionRobot::Walker2d)
        }
    }

    /// Hopper-v5.
    pub fn hopper() -> Self {
        LocomotionConfig {
            healthy_z_range: (0.7, f64::INFINITY),
            healthy_angle_range: (-0.2, 0.2),
            healthy_state_range: (-100.0, 100.0),
            ..Self::base(LocomotionRobot::Hopper)
        }
    }

    /// HalfCheetah-v5 with two 25 ms physics steps per 50 ms control step (MuJoCo: five of
    /// 10 ms). The control step, and so every reward, observation and episode length, is
    /// MuJoCo's; Rapier's step is larger because its cost per step, not the number of
    /// contacts, sets this env's speed (38 % of it in Rapier's multibody mass matrix). At
    /// 25 ms and 4 PGS iterations (8 in the other envs) the env runs about 2× faster than at
    /// 10 ms and 8 (6,229 → 13,027 steps/s in the README's tables); the resting height differs by 1.1 mm and random actions
    /// return −264 ± 45 over 10 episodes (10 ms: −308 ± 68; MuJoCo's two reference runs
    /// −234 and −278 ± 62). `sim.dt = 0.01`, `sim.pgs_iterations = 8` with
    /// `frame_skip = 5` give MuJoCo's step.
    ///
    /// Until the planar robots' ground friction was fixed it needed 1/300 s steps: at 10 ms
    /// random flailing slid it backwards at −0.6 m/s (MuJoCo: −0.08).
    pub fn half_cheetah() -> Self {
        LocomotionConfig {
            ctrl_cost_weight: 0.1,
            healthy_reward: 0.0,
            terminate_when_unhealthy: false,
            reset_noise_scale: 0.1,
            frame_skip: 2,
            sim: SimConfig { dt: 0.025, pgs_iterations: 4, ..Self::base(LocomotionRobot::HalfCheetah).sim },
            ..Self::base(LocomotionRobot::HalfCheetah)
        }
    }

    /// Humanoid-v5 (without the `cinert` and `cvel` observation blocks).
    pub fn humanoid() -> Self {
        LocomotionConfig {
            forward_reward_weight: 1.25,
            ctrl_cost_weight: 0.1,
            contact_cost_weight: 5e-7,
            contact_cost_max: 10.0,
            healthy_reward: 5.0,
            healthy_z_range: (1.0, 2.0),
            reset_noise_scale: 1e-2,
            include_cfrc_ext_in_observation: true,
            frame_skip: 5,
            ..Self::base(LocomotionRobot::Humanoid)
        }
    }

    /// The preset of a robot.
    pub fn preset(robot: LocomotionRobot) -> Self {
        match robot {
            LocomotionRobot::Ant => Self::ant(),
            LocomotionRobot::Walker2d => Self::walker2d(),
            LocomotionRobot::Hopper => Self::hopper(),
            LocomotionRobot::HalfCheetah => Self::half_cheetah(),
            LocomotionRobot::Humanoid => Self::humanoid(),
        }
    }

    /// Checks the numbers; an error names the field, its value and what it must be.
    pub fn validate(&self) -> Result<(), RobotEnvError> {
        let f = Fields("LocomotionConfig");
        f.count("frame_skip", self.frame_skip, MAX_FRAME_SKIP)?;
        f.count("max_episode_steps", self.max_episode_steps, usize::MAX)?;
        f.non_negative("reset_noise_scale", self.reset_noise_scale)?;
        f.finite("forward_reward_weight", self.forward_reward_weight)?;
        f.finite("ctrl_cost_weight", self.ctrl_cost_weight)?;
        f.finite("contact_cost_weight", self.contact_cost_weight)?;
        f.finite("healthy_reward", self.healthy_reward)?;
        f.cap("contact_cost_max", self.contact_cost_max)?;
        f.range("healthy_z_range", self.healthy_z_range)?;
        f.range("healthy_angle_range", self.healthy_angle_range)?;
        f.range("healthy_state_range", self.healthy_state_range)?;
        f.range("contact_force_range", self.contact_force_range)?;
        f.joint_history(self.obs.joint_history)?;
        if let Some(p) = &self.pushes {
            p.validate("LocomotionConfig")?;
        }
        Ok(())
    }
}

/// A Gymnasium MuJoCo locomotion environment simulated with Rapier (see the module docs).
pub struct LocomotionEnv {
    config: LocomotionConfig,
    robot: MjRobot,
    sim: Sim,
    data: Data,
    rng: Rng,
    obs_space: BoxSpace,
    act_space: BoxSpace,
    state: RobotState,
    qpos: Vec<f64>,
    qvel: Vec<f64>,
    tau: Vec<f64>,
    cfrc: Vec<f64>,
    feet: Vec<Vec<rapier3d::prelude::ColliderHandle>>,
    foot_frames: Vec<String>,
    contacts: Vec<FootContact>,
    actuated: Vec<usize>,
    /// Torques applied at the last step, per actuator.
    applied: Vec<f64>,
    /// The servo targets ([`RobotEnv::set_servo`]): `[q*, q̇*, kp, kd]` per actuator.
    servo: [Vec<f64>; 4],
    servo_on: bool,
    history: JointHistory,
    joint_scratch: Vec<f32>,
    base_obs: Vec<f32>,
    steps: usize,
    needs_reset: bool,
    push: Push,
    episode_time: f64,
}

impl LocomotionEnv {
    /// Builds the environment.
    pub fn new(config: LocomotionConfig) -> Result<LocomotionEnv, RobotEnvError> {
        config.validate()?;
        let (urdf, sidecar, base) = config.robot.assets();
        let robot = MjRobot::new(urdf, sidecar, config.robot.name(), base)?;
        let sim = robot.build_sim(&config.sim)?;
        let model = &robot.model;
        let nb = robot.num_bodies();
        let base_dim = base_obs_dim(&config, &robot);
        let n_joints_obs = robot.nq - if base == BaseKind::Floating { 7 } else { 3 };
        let orientation_dim =
            if config.obs.drop_base_orientation { orientation_entries(config.robot) } else { 0 };
        let obs_dim = base_dim - orientation_dim + n_joints_obs * config.obs.joint_history;
        let actuated = robot.actuators.iter().map(|(iv, _)| model.joint_of_dof(*iv)).collect::<Vec<usize>>();
        let act_space = BoxSpace::new(robot.ctrl_low.clone(), robot.ctrl_high.clone());
        let feet_names: Vec<String> = config.robot.feet().iter().map(|s| s.to_string()).collect();
        // Planar robots (no free base) cannot move sideways: pushed along ±x.
        let planar = !robot.model.has_floating_base();
        let mut env = LocomotionEnv {
            obs_space: BoxSpace::unbounded(obs_dim),
            act_space,
            state: RobotState::new(model),
            qpos: vec![0.0; robot.nq],
            qvel: vec![0.0; robot.nv],
            tau: vec![0.0; model.nv],
            cfrc: vec![0.0; 6 * nb],
            data: Data::new(model),
            feet: Vec::new(),
            foot_frames: feet_names,
            contacts: vec![FootContact::default(); config.robot.feet().len()],
            applied: vec![0.0; actuated.len()],
            servo: std::array::from_fn(|_| vec![0.0; actuated.len()]),
            servo_on: false,
            actuated,
            history: JointHistory::new(config.obs.joint_history, n_joints_obs),
            joint_scratch: vec![0.0; n_joints_obs],
            base_obs: vec![0.0; base_dim],
            steps: 0,
            needs_reset: true,
            push: Push::new(config.pushes, planar),
            episode_time: 0.0,
            rng: Rng::seed_from_u64(0),
            config,
            robot,
            sim,
        };
        env.index_feet();
        Ok(env)
    }

    /// The configuration.
    pub fn config(&self) -> &LocomotionConfig {
        &self.config
    }

    /// The simulator.
    pub fn sim(&self) -> &Sim {
        &self.sim
    }

    /// The robot's MuJoCo facts (sidecar): time step, total mass, joints, actuators, bodies.
    pub fn sidecar(&self) -> &crate::mujoco::Sidecar {
        &self.robot.sidecar
    }

    /// MuJoCo `qpos` of the current state.
    pub fn qpos(&self) -> &[f64] {
        &self.qpos
    }

    /// MuJoCo `qvel` of the current state.
    pub fn qvel(&self) -> &[f64] {
        &self.qvel
    }

    /// Sets the state from MuJoCo `qpos`/`qvel` (e.g. to replay a reference trajectory).
    #[track_caller]
    pub fn set_mujoco_state(&mut self, qpos: &[f64], qvel: &[f64]) {
        assert!(qpos.len() == self.robot.nq && qvel.len() == self.robot.nv, "qpos/qvel sizes");
        self.qpos.copy_from_slice(qpos);
        self.qvel.copy_from_slice(qvel);
        self.robot.state_from_mujoco(qpos, qvel, &mut self.state);
        self.sim.set_state(&self.state);
        self.needs_reset = false;
    }

    fn index_feet(&mut self) {
        let model = &self.robot.model;
        self.feet = self
            .foot_frames
            .iter()
            .map(|name| {
                model
                    .geometries
                    .iter()
                    .enumerate()
                    .filter(|(_, g)| &model.frames[g.frame].name == name)
                    .filter_map(|(k, _)| self.sim.geometry_collider(k))
                    .collect()
            })
            .collect();
    }

    /// Forward position used for the velocity: torso x (Ant: torso xy), Humanoid: CoM.
    fn forward_position(&mut self) -> Vector3<f64> {
        match self.config.robot {
            LocomotionRobot::Humanoid => self.robot.center_of_mass(&mut self.data, self.state.q.as_slice()),
            LocomotionRobot::Ant => Vector3::new(self.state.q[0], self.state.q[1], 0.0),
            _ => Vector3::new(self.qpos[0], 0.0, 0.0),
        }
    }

    fn is_healthy(&self) -> bool {
        let c = &self.config;
        let finite = self.qpos.iter().chain(&self.qvel).all(|x| x.is_finite());
        let in_range = |x: f64, r: (f64, f64), strict: bool| {
            if strict { r.0 < x && x < r.1 } else { r.0 <= x && x <= r.1 }
        };
        match c.robot {
            LocomotionRobot::Ant => finite && in_range(self.qpos[2], c.healthy_z_range, false),
            LocomotionRobot::Walker2d => {
                in_range(self.qpos[1], c.healthy_z_range, true)
                    && in_range(self.qpos[2], c.healthy_angle_range, true)
            }
            LocomotionRobot::Hopper => {
                let state_ok = self.qpos[2..]
                    .iter()
                    .chain(&self.qvel)
                    .all(|&x| in_range(x, c.healthy_state_range, true));
                state_ok
                    && in_range(self.qpos[1], c.healthy_z_range, true)
                    && in_range(self.qpos[2], c.healthy_angle_range, true)
            }
            LocomotionRobot::HalfCheetah => true,
            LocomotionRobot::Humanoid => in_range(self.qpos[2], c.healthy_z_range, true),
        }
    }

    /// Gymnasium's observation (before the shared options).
    fn write_base_obs(&mut self) {
        let robot = self.config.robot;
        let mut k = 0;
        let mut put = |o: &mut Vec<f32>, x: f64| {
            o[k] = x as f32;
            k += 1;
        };
        let skip = match robot {
            LocomotionRobot::Ant | LocomotionRobot::Humanoid => 2,
            _ => 1,
        };
        let clip_v = matches!(robot, LocomotionRobot::Walker2d | LocomotionRobot::Hopper);
        for &x in &self.qpos[skip..] {
            put(&mut self.base_obs, x);
        }
        for &x in &self.qvel {
            put(&mut self.base_obs, if clip_v { x.clamp(-10.0, 10.0) } else { x });
        }
        if robot == LocomotionRobot::Humanoid {
            // qfrc_actuator[6:]: gear × clipped control on each joint, in qvel order.
            for iv in 6..self.robot.model.nv {
                put(&mut self.base_obs, self.tau[iv]);
            }
        }
        if self.config.include_cfrc_ext_in_observation {
            let (lo, hi) = self.config.contact_force_range;
            for &w in &self.cfrc {
                put(&mut self.base_obs, w.clamp(lo, hi));
            }
        }
    }

    fn write_obs(&mut self, obs: &mut [f32]) {
        self.write_base_obs();
        let joints_start = match self.config.robot {
            LocomotionRobot::Ant | LocomotionRobot::Humanoid => 5,
            _ => 2,
        };
        let drop =
            if self.config.obs.drop_base_orientation { orientation_entries(self.config.robot) } else { 0 };
        // The orientation entries sit right before the joint positions.
        let o_start = joints_start - drop;
        obs[..o_start].copy_from_slice(&self.base_obs[..o_start]);
        let rest = &self.base_obs[joints_start..];
        obs[o_start..o_start + rest.len()].copy_from_slice(rest);
        let n = o_start + rest.len();
        let nj = self.history.len() / self.config.obs.joint_history.max(1);
        let first_joint = if self.robot.model.has_floating_base() { 7 } else { 3 };
        if self.config.obs.joint_history > 0 {
            for (h, &x) in self.joint_scratch.iter_mut().zip(&self.qpos[first_joint..first_joint + nj]) {
                *h = x as f32;
            }
            self.history.push(&self.joint_scratch);
        }
        self.history.write(&mut obs[n..n + self.history.len()]);
    }

    fn update_contacts(&mut self) {
        for (c, cs) in self.contacts.iter_mut().zip(&self.feet) {
            *c = FootContact::default();
            for &h in cs {
                if let Some((f, p)) = self.sim.contact_force(h) {
                    c.in_contact = true;
                    c.force += f;
                    c.point = p;
                }
            }
        }
    }
}

/// Orientation entries of `qpos` in the observation: the quaternion (4) for free robots,
/// the torso pitch `rooty` (1) for planar ones.
fn orientation_entries(robot: LocomotionRobot) -> usize {
    match robot {
        LocomotionRobot::Ant | LocomotionRobot::Humanoid => 4,
        _ => 1,
    }
}

fn base_obs_dim(config: &LocomotionConfig, robot: &MjRobot) -> usize {
    let skip = match config.robot {
        LocomotionRobot::Ant | LocomotionRobot::Humanoid => 2,
        _ => 1,
    };
    let mut n = robot.nq - skip + robot.nv;
    if config.robot == LocomotionRobot::Humanoid {
        n += robot.model.nv - 6;
    }
    if config.include_cfrc_ext_in_observation {
        n += 6 * robot.num_bodies();
    }
    n
}

impl Env for LocomotionEnv {
    fn name(&self) -> &str {
        self.config.robot.name()
    }

    fn observation_space(&self) -> &BoxSpace {
        &self.obs_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.act_space
    }

    fn max_episode_steps(&self) -> usize {
        self.config.max_episode_steps
    }

    fn config_text(&self) -> Option<String> {
        serde_json::to_string(&self.config).ok()
    }

    fn dt(&self) -> f64 {
        self.config.sim.dt * self.config.frame_skip as f64
    }

    fn reward_term_names(&self) -> &'static [&'static str] {
        &["forward", "healthy", "ctrl_cost", "contact_cost"]
    }

    fn reset(&mut self, seed: Option<u64>, obs: &mut [f32]) -> Result<(), EnvError> {
        check_observation(&self.obs_space, obs)?;
        if let Some(s) = seed {
            self.rng = Rng::seed_from_u64(s);
        }
        self.sim = self.robot.build_sim(&self.config.sim)?;
        self.servo_on = false;
        self.index_feet();
        let a = self.config.reset_noise_scale;
        let normal_velocity =
            matches!(self.config.robot, LocomotionRobot::Ant | LocomotionRobot::HalfCheetah);
        self.robot.reset_state(
            &mut self.rng,
            a,
            a,
            normal_velocity,
            &mut self.state,
            &mut self.qpos,
            &mut self.qvel,
        );
        self.sim.set_state(&self.state);
        self.cfrc.iter_mut().for_each(|x| *x = 0.0);
        self.steps = 0;
        self.episode_time = 0.0;
        let base = self.base_joint();
        self.push.clear(&mut self.sim, base, &mut self.rng);
        let first_joint = if self.robot.model.has_floating_base() { 7 } else { 3 };
        let nj = self.history.len() / self.config.obs.joint_history.max(1);
        for (h, &x) in self.joint_scratch.iter_mut().zip(&self.qpos[first_joint..first_joint + nj]) {
            *h = x as f32;
        }
        self.history.fill(&self.joint_scratch);
        self.tau.iter_mut().for_each(|t| *t = 0.0);
        self.write_obs(obs);
        self.update_contacts();
        self.needs_reset = false;
        Ok(())
    }

    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Step, EnvError> {
        check_action(&self.act_space, action)?;
        check_observation(&self.obs_space, obs)?;
        if self.needs_reset {
            return Err(EnvError::NeedsReset);
        }
        let before = self.forward_position();
        self.tau.iter_mut().for_each(|t| *t = 0.0);
        for (k, ((iv, gear), a)) in self.robot.actuators.iter().zip(action).enumerate() {
            let a = (*a).clamp(self.act_space.low[k], self.act_space.high[k]) as f64;
            self.tau[*iv] = gear * a;
        }
        self.sim.set_joint_torques(&self.tau);
        for (k, (iv, _)) in self.robot.actuators.iter().enumerate() {
            self.applied[k] = self.tau[*iv];
        }
        let mut energy = 0.0;
        // Under the servo the control cost is charged on what the actuators applied, the
        // mean over the physics steps of Σ (τ/gear)², not on the feed-forward action alone.
        let mut servo_ctrl_sq = 0.0;
        let base = self.base_joint();
        for _ in 0..self.config.frame_skip {
            if self.servo_on {
                servo_ctrl_sq += self.apply_servo(action);
            }
            self.push.apply(&mut self.sim, base, self.episode_time);
            self.sim.step();
            self.episode_time += self.config.sim.dt;
            let mut p = 0.0;
            for (iv, _) in &self.robot.actuators {
                let j = self.robot.model.joint_of_dof(*iv);
                p += self.tau[*iv] * self.sim.joint_state(j).1;
            }
            energy += p.abs() * self.config.sim.dt;
        }
        self.steps += 1;
        self.sim.read_state(&mut self.state);
        self.robot.to_mujoco(&self.state, &mut self.qpos, &mut self.qvel);
        let mut info = StepInfo { energy, ..StepInfo::default() };
        if !self.state.is_finite() || self.state.v.amax() > 1e4 {
            self.needs_reset = true;
            info.unstable = true;
            return Ok(Step { reward: 0.0, terminated: true, truncated: false, info });
        }
        let after = self.forward_position();
        let velocity = (after - before) / self.dt();
        if self.config.contact_cost_weight > 0.0 || self.config.include_cfrc_ext_in_observation {
            self.robot.contact_wrenches(&self.sim, &mut self.data, self.state.q.as_slice(), &mut self.cfrc);
        }
        let c = &self.config;
        let healthy = self.is_healthy();
        let forward = c.forward_reward_weight * velocity.x;
        let healthy_reward = if healthy { c.healthy_reward } else { 0.0 };
        let ctrl_sq = if self.servo_on {
            servo_ctrl_sq / c.frame_skip as f64
        } else {
            action.iter().map(|a| (*a as f64) * (*a as f64)).sum::<f64>()
        };
        let ctrl_cost = c.ctrl_cost_weight * ctrl_sq;
        let contact_cost = if c.contact_cost_weight > 0.0 {
            let (lo, hi) = c.contact_force_range;
            (c.contact_cost_weight * self.cfrc.iter().map(|w| w.clamp(lo, hi).powi(2)).sum::<f64>())
                .min(c.contact_cost_max)
        } else {
            0.0
        };
        let reward = forward + healthy_reward - ctrl_cost - contact_cost;
        info.reward_terms[..4].copy_from_slice(&[forward, healthy_reward, -ctrl_cost, -contact_cost]);
        info.forward_velocity = velocity.x;
        self.write_obs(obs);
        self.update_contacts();
        info.foot_contacts =
            self.contacts.iter().enumerate().fold(0u32, |m, (k, c)| m | ((c.in_contact as u32) << k));
        let terminated = self.config.terminate_when_unhealthy && !healthy;
        let truncated = !terminated && self.steps >= self.config.max_episode_steps;
        if terminated || truncated {
            self.needs_reset = true;
        }
        Ok(Step { reward, terminated, truncated, info })
    }
}

impl LocomotionEnv {
    /// The action's torque plus the servo's PD torque at the joints' current state, each
    /// within its actuator's range `gear · ctrlrange`, set on the simulator; returns
    /// `Σ (τ/gear)²`, the control those torques amount to.
    fn apply_servo(&mut self, action: &[f32]) -> f64 {
        let mut ctrl_sq = 0.0;
        let [q_des, qd_des, kp, kd] = &self.servo;
        for (k, ((iv, gear), a)) in self.robot.actuators.iter().zip(action).enumerate() {
            let (lo, hi) = (self.act_space.low[k] as f64, self.act_space.high[k] as f64);
            let (q, qd) = self.sim.joint_state(self.robot.model.joint_of_dof(*iv));
            let pd = kp[k] * (q_des[k] - q) + kd[k] * (qd_des[k] - qd);
            let t = gear * (*a as f64).clamp(lo, hi) + pd;
            self.tau[*iv] = t.clamp(gear * lo, gear * hi);
            self.applied[k] = self.tau[*iv];
            ctrl_sq += (self.tau[*iv] / gear).powi(2);
        }
        self.sim.set_joint_torques(&self.tau);
        ctrl_sq
    }

    /// Model joint of the body pushes act on: the free base, or the torso of planar robots.
    fn base_joint(&self) -> usize {
        if self.robot.model.has_floating_base() {
            1
        } else {
            self.robot.model.joint_index("rooty").unwrap_or(1)
        }
    }
}

impl RobotEnv for LocomotionEnv {
    fn model(&self) -> &Model {
        &self.robot.model
    }

    fn robot_state(&self) -> &RobotState {
        &self.state
    }

    fn foot_contacts(&self) -> &[FootContact] {
        &self.contacts
    }

    fn foot_frames(&self) -> &[String] {
        &self.foot_frames
    }

    fn actuated_joints(&self) -> &[usize] {
        &self.actuated
    }

    fn episode_time(&self) -> f64 {
        self.episode_time
    }

    fn push(&mut self, force: Vector3<f64>, duration: f64) {
        self.push.start(force, self.episode_time, duration);
    }

    fn last_torques(&self) -> &[f64] {
        &self.applied
    }

    /// `action = τ / gear`, clipped to the control range.
    fn action_for_torques(&self, tau: &[f64], out: &mut [f32]) {
        for (k, ((_, gear), o)) in self.robot.actuators.iter().zip(out.iter_mut()).enumerate() {
            *o = ((tau[k] / gear) as f32).clamp(self.act_space.low[k], self.act_space.high[k]);
        }
    }

    fn set_servo(&mut self, servo: Option<Servo<'_>>) -> bool {
        match servo {
            Some(Servo { q, qd, kp, kd }) => {
                let n = self.applied.len();
                assert!(
                    q.len() == n && qd.len() == n && kp.len() == n && kd.len() == n,
                    "servo targets for {n} actuators expected"
                );
                for (dst, src) in self.servo.iter_mut().zip([q, qd, kp, kd]) {
                    dst.copy_from_slice(src);
                }
                self.servo_on = true;
            }
            None => self.servo_on = false,
        }
        true
    }
}
