//! [`MinitaurEnv`]: the environment, its configuration and randomisation.

use centaur_dynamics::nalgebra::Vector3;
use centaur_dynamics::{Data, Inertia, Model, RobotState, center_of_mass_velocity};
use centaur_gym::{BoxSpace, Env, EnvError, Rng, Step, StepInfo};
use centaur_gym::{check_action, check_observation};

use super::legs::{leg_model_to_motor_angles, motor_angles_to_leg_model};
use super::model::{
    ENERGY_TERM_DT, KNEE_ANGLE, LEG_NAMES, MOTOR_DIRECTION, MOTOR_NAMES, TOE_LEFT, TOE_RIGHT, minitaur_model,
};
use super::motor::MotorModel;
use crate::checks::{Fields, MAX_FRAME_SKIP};
use crate::error::RobotEnvError;
use crate::robot::{
    BODY_STATE_DIM, FootContact, JointHistory, ObsOptions, Push, PushSchedule, RobotEnv, heading_body_state,
};
use crate::sim::{ColliderSpec, LoopClosure, Sim, SimConfig};

/// Observation bounds: angle, velocity (V / Kt), observed torque, quaternion.
const OBS_BOUNDS: [f32; 4] = [std::f32::consts::PI, 16.0 / 0.0954, 5.7, 1.0];
const OBSERVATION_EPS: f32 = 0.01;

/// How motor commands become torques.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub enum MotorControl {
    /// PyBullet's DC motor model (the v0 default).
    Accurate(MotorModel),
    /// PyBullet's `pd_control_enabled`: `τ = −kp (q − q*) − kd q̇`, clipped to ±`max_torque`.
    Pd {
        /// Position gain (N·m/rad) (PyBullet: 8).
        kp: f64,
        /// Velocity gain (N·m·s/rad) (PyBullet: 0.3).
        kd: f64,
        /// Torque limit (N·m) (PyBullet's `_max_force`: 3.5).
        max_torque: f64,
    },
}

/// What an action means.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum MinitaurAction {
    /// The leg model (v0 default), see [`leg_model_to_motor_angles`].
    LegModel,
    /// Desired motor angles directly, in the motor frame (rad, bounded by [0, π]... see the
    /// action space).
    MotorAngles,
    /// PWM duty cycles in [−1, 1] (PyBullet's `torque_control_enabled`, accurate model only).
    Pwm,
}

/// Physical randomisation at every reset (v0's `MinitaurEnvRandomizer`, plus motor strength
/// from Tan et al. 2018). Each range is `(low, high)` of a uniform draw.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MinitaurRandomization {
    /// Relative base mass error (default: (−0.2, 0.2)).
    pub base_mass_error: (f64, f64),
    /// Relative leg and motor mass error (default: (−0.2, 0.2)).
    pub leg_mass_error: (f64, f64),
    /// Battery voltage (V) (default: (14.8, 16.8)).
    pub battery_voltage: (f64, f64),
    /// Motor viscous damping (N·m·s/rad) (default: (0.0, 0.01)).
    pub motor_damping: (f64, f64),
    /// Lower-leg friction (default: (0.8, 1.5)).
    pub foot_friction: (f64, f64),
    /// Motor strength scale (default: (1.0, 1.0), i.e. off as in v0).
    pub motor_strength: (f64, f64),
}

impl Default for MinitaurRandomization {
    fn default() -> Self {
        MinitaurRandomization {
            base_mass_error: (-0.2, 0.2),
            leg_mass_error: (-0.2, 0.2),
            battery_voltage: (14.8, 16.8),
            motor_damping: (0.0, 0.01),
            foot_friction: (0.8, 1.5),
            motor_strength: (1.0, 1.0),
        }
    }
}

/// Configuration of [`MinitaurEnv`]; `Default` is `MinitaurBulletEnv-v0`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MinitaurConfig {
    /// Weight of the forward distance per step (default: 1.0).
    pub distance_weight: f64,
    /// Weight of the energy term (default: 0.005).
    pub energy_weight: f64,
    /// Weight of the sideways drift penalty (default: 0.0).
    pub drift_weight: f64,
    /// Weight of the vertical shake penalty (default: 0.0).
    pub shake_weight: f64,
    /// Episode ends when the base is farther than this from the origin (m) (default: ∞).
    pub distance_limit: f64,
    /// Truncation (steps) (default: 1000).
    pub max_episode_steps: usize,
    /// Physics steps per env step (default: 5).
    pub action_repeat: usize,
    /// Physics settings (default: dt 2 ms, 1 substep, 16 PGS iterations — the loop gaps stay
    /// below 1 mm while trotting, 8 leave 1.3 mm — 120 Hz ground contact, gravity −10 m/s²).
    pub sim: SimConfig,
    /// Motor model (default: PyBullet's DC motor model, kp 1.0, kd 0.02).
    pub motor_control: MotorControl,
    /// Action meaning (default: leg model).
    pub action: MinitaurAction,
    /// Overheat protection (default: true).
    pub overheat_protection: bool,
    /// Randomisation at reset (default: on, as v0).
    pub randomization: Option<MinitaurRandomization>,
    /// Control latency: the observation is this old (s) (default: 0; at most [`MAX_LATENCY`]).
    pub latency: f64,
    /// Observation noise: N(0, σ·bound) per entry (default: 0).
    pub observation_noise_std: f64,
    /// Lower legs collide as capsules (default: true; ~30 % faster).
    pub capsule_feet: bool,
    /// Observation options (default: none).
    pub obs: ObsOptions,
    /// Periodic pushes on the base during every episode (default: none).
    pub pushes: Option<PushSchedule>,
    /// Which motor model [`RobotEnv::action_for_torques`] inverts (default:
    /// [`MotorInverse::Nominal`]; earlier [`MotorInverse::Drawn`]). Always
    /// recorded; a recorded configuration without it was written before it existed, with
    /// the drawn motor ([`MotorInverse::legacy`]).
    pub motor_inverse: MotorInverse,
    /// Append the body state to the observation (default: false; recorded only where set):
    /// the centre of mass's velocity in the heading frame (forward, lateral, vertical,
    /// m/s) and its height (m), of the nominal robot's mass distribution, undelayed and
    /// without noise — what a hybrid's controller measures every tick and its policy may
    /// observe (`include_state` of the root crate's residual setup), so pure RL can be
    /// given the same information. Not part of `MinitaurBulletEnv-v0`'s observation.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub observe_body_state: bool,
}

/// The motor model a controller's torques are turned into actions with
/// ([`RobotEnv::action_for_torques`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotorInverse {
    /// The motor drawn at reset — battery voltage, viscous damping and motor strength
    /// included: the controller is told the randomised motor, which a controller on the
    /// robot would not know (strength and damping at least). The earlier default: every
    /// controller and hybrid figure measured before the nominal motor became the default was
    /// measured so.
    Drawn,
    /// The nominal motor of [`MinitaurConfig::motor_control`], whatever was drawn: the
    /// controller knows only the data sheet, as it would on the robot. The default.
    #[default]
    Nominal,
}

impl MotorInverse {
    /// The motor inverse of a configuration recorded before the field existed: the drawn one.
    pub fn legacy() -> MotorInverse {
        MotorInverse::Drawn
    }
}

impl Default for MinitaurConfig {
    fn default() -> Self {
        MinitaurConfig {
            distance_weight: 1.0,
            energy_weight: 0.005,
            drift_weight: 0.0,
            shake_weight: 0.0,
            distance_limit: f64::INFINITY,
            max_episode_steps: 1000,
            action_repeat: 5,
            sim: SimConfig { gravity: [0.0, 0.0, -10.0], pgs_iterations: 16, ..SimConfig::default() },
            motor_control: MotorControl::Accurate(MotorModel::default()),
            action: MinitaurAction::LegModel,
            overheat_protection: true,
            randomization: Some(MinitaurRandomization::default()),
            latency: 0.0,
            observation_noise_std: 0.0,
            capsule_feet: true,
            obs: ObsOptions::default(),
            pushes: None,
            motor_inverse: MotorInverse::Nominal,
            observe_body_state: false,
        }
    }
}

impl MinitaurConfig {
    /// v0 without randomisation (a fixed robot, useful for controllers and tests).
    pub fn deterministic() -> Self {
        MinitaurConfig { randomization: None, ..Self::default() }
    }

    /// v0 with 3.3 ms physics steps (3 per control step instead of 5): 1.7× faster, with the
    /// motor model updated at 300 Hz instead of PyBullet's 500 Hz. Measured against the 2 ms
    /// default (30 random-action episodes; 10 s open-loop trot): return −1.40 vs −1.37,
    /// length 699 vs 793; the trot covers 2.55 m instead of 2.78 m (PyBullet: 3.05 m).
    pub fn fast() -> Self {
        let base = Self::default();
        MinitaurConfig { sim: SimConfig { dt: 0.01 / 3.0, ..base.sim.clone() }, action_repeat: 3, ..base }
    }

    /// Checks the numbers.
    pub fn validate(&self) -> Result<(), RobotEnvError> {
        let f = Fields("MinitaurConfig");
        let bad = |what: &str| Err(RobotEnvError::config("MinitaurConfig", what));
        f.count("action_repeat (frame_skip in [env])", self.action_repeat, MAX_FRAME_SKIP)?;
        f.count("max_episode_steps", self.max_episode_steps, usize::MAX)?;
        f.at_most("latency", self.latency, MAX_LATENCY, &format!("a latency of 0 to {MAX_LATENCY} s"))?;
        f.non_negative("observation_noise_std", self.observation_noise_std)?;
        f.finite("distance_weight", self.distance_weight)?;
        f.finite("energy_weight", self.energy_weight)?;
        f.finite("drift_weight", self.drift_weight)?;
        f.finite("shake_weight", self.shake_weight)?;
        f.joint_history(self.obs.joint_history)?;
        if let Some(p) = &self.pushes {
            p.validate("MinitaurConfig")?;
        }
        // Infinite is allowed (no limit, the default); zero or less would end every episode
        // at its first step.
        if self.distance_limit.is_nan() || self.distance_limit <= 0.0 {
            return bad(&format!(
                "distance_limit = {:?}: expected a positive distance (m; inf for no limit)",
                self.distance_limit
            ));
        }
        if let Some(r) = &self.randomization {
            let (low, high) = r.motor_strength;
            if !(low.is_finite() && high.is_finite() && low > 0.0 && low <= high) {
                return bad(&format!(
                    "randomization.motor_strength = ({low:?}, {high:?}): expected 0 < low ≤ high, finite"
                ));
            }
        }
        if self.action == MinitaurAction::Pwm && !matches!(self.motor_control, MotorControl::Accurate(_)) {
            return bad("PWM actions need the accurate motor model");
        }
        Ok(())
    }
}

/// Longest control latency (s) a Minitaur env takes: its observations are kept one per
/// physics step for as long.
pub const MAX_LATENCY: f64 = 1.0;

/// Leg-model action bounds are [−1, 1]; motor-angle actions are bounded by [0, π]... in the
/// motor frame PyBullet leaves them unbounded; we use [−π, 2π] to keep the box finite.
fn action_space(action: MinitaurAction) -> BoxSpace {
    match action {
        MinitaurAction::LegModel | MinitaurAction::Pwm => BoxSpace::symmetric(8, 1.0),
        MinitaurAction::MotorAngles => {
            BoxSpace::new(vec![-std::f32::consts::PI; 8], vec![2.0 * std::f32::consts::PI; 8])
        }
    }
}

/// `MinitaurBulletEnv-v0` simulated with Rapier (see the module docs).
pub struct MinitaurEnv {
    config: MinitaurConfig,
    nominal: Model,
    sim: Sim,
    rng: Rng,
    obs_space: BoxSpace,
    act_space: BoxSpace,
    motor_joints: [usize; 8],
    motor_dofs: [usize; 8],
    foot_colliders: Vec<Vec<rapier3d::prelude::ColliderHandle>>,
    foot_frames: Vec<String>,
    motor: MotorModel,
    motor_enabled: [bool; 8],
    overheat_counter: [usize; 8],
    observed_torque: [f64; 8],
    /// Torque applied at the last physics step, joint frame.
    applied_torque: [f64; 8],
    state: RobotState,
    contacts: [FootContact; 4],
    last_position: Vector3<f64>,
    steps: usize,
    needs_reset: bool,
    history: JointHistory,
    /// Ring of past base observations (28 entries) for the latency option, one per physics step.
    delayed: Vec<f32>,
    delayed_head: usize,
    delay_steps: usize,
    base_obs: [f32; 28],
    push: Push,
    episode_time: f64,
    /// Buffers for the body state in the observation ([`MinitaurConfig::observe_body_state`]).
    com_data: Option<Data>,
}

impl MinitaurEnv {
    /// Builds the environment (the robot stands at its reset pose after [`Env::reset`]).
    pub fn new(config: MinitaurConfig) -> Result<MinitaurEnv, RobotEnvError> {
        config.validate()?;
        let nominal = minitaur_model()
            .map_err(|source| RobotEnvError::Urdf { robot: "minitaur".into(), source: Box::new(source) })?;
        let mut motor_joints = [0usize; 8];
        let mut motor_dofs = [0usize; 8];
        for (i, name) in MOTOR_NAMES.iter().enumerate() {
            let j = nominal.joint_index(name).ok_or_else(|| RobotEnvError::Missing {
                robot: "minitaur".into(),
                what: "joint",
                name: name.to_string(),
            })?;
            motor_joints[i] = j;
            motor_dofs[i] = nominal.joints[j].idx_v;
        }
        let sim = build_sim(&nominal, &config, 1.0)?;
        let obs_dim = observation_dim(&config);
        let mut high = Vec::with_capacity(obs_dim);
        for (k, b) in OBS_BOUNDS.iter().enumerate() {
            let n = if k == 3 { 4 } else { 8 };
            if k == 3 && config.obs.drop_base_orientation {
                continue;
            }
            high.extend(std::iter::repeat_n(b + OBSERVATION_EPS, n));
        }
        high.extend(std::iter::repeat_n(OBS_BOUNDS[0] + OBSERVATION_EPS, 8 * config.obs.joint_history));
        if config.observe_body_state {
            high.extend([f32::INFINITY; BODY_STATE_DIM]);
        }
        let low = high.iter().map(|h| -h).collect();
        let motor = match &config.motor_control {
            MotorControl::Accurate(m) => m.clone(),
            MotorControl::Pd { .. } => MotorModel::default(),
        };
        let delay_steps = (config.latency / config.sim.dt).round() as usize;
        let pushes = config.pushes;
        let foot_frames = LEG_NAMES.iter().map(|l| format!("lower_leg_{l}R_link")).collect();
        let mut env = MinitaurEnv {
            act_space: action_space(config.action),
            obs_space: BoxSpace::new(low, high),
            history: JointHistory::new(config.obs.joint_history, 8),
            delayed: vec![0.0; 28 * (delay_steps + 1)],
            delayed_head: 0,
            delay_steps,
            config,
            state: RobotState::new(&nominal),
            nominal,
            sim,
            rng: Rng::seed_from_u64(0),
            motor_joints,
            motor_dofs,
            foot_colliders: Vec::new(),
            foot_frames,
            motor,
            motor_enabled: [true; 8],
            overheat_counter: [0; 8],
            observed_torque: [0.0; 8],
            applied_torque: [0.0; 8],
            contacts: [FootContact::default(); 4],
            last_position: Vector3::zeros(),
            steps: 0,
            needs_reset: true,
            base_obs: [0.0; 28],
            push: Push::new(pushes, false),
            episode_time: 0.0,
            com_data: None,
        };
        if env.config.observe_body_state {
            env.com_data = Some(Data::new(&env.nominal));
        }
        env.index_feet();
        Ok(env)
    }

    /// The configuration.
    pub fn config(&self) -> &MinitaurConfig {
        &self.config
    }

    /// The simulator (read access, e.g. for loop-closure gaps or rendering).
    pub fn sim(&self) -> &Sim {
        &self.sim
    }

    /// Motor angles, velocities (motor frame) and the torques last applied (joint frame).
    pub fn motor_state(&self) -> ([f64; 8], [f64; 8]) {
        let mut q = [0.0; 8];
        let mut qd = [0.0; 8];
        for i in 0..8 {
            let (a, b) = self.sim.joint_state(self.motor_joints[i]);
            q[i] = MOTOR_DIRECTION[i] * a;
            qd[i] = MOTOR_DIRECTION[i] * b;
        }
        (q, qd)
    }

    fn index_feet(&mut self) {
        self.foot_colliders.clear();
        for leg in LEG_NAMES {
            let mut cs = Vec::new();
            for side in ["L", "R"] {
                let name = format!("lower_leg_{leg}{side}_link");
                for (k, g) in self.sim.model().geometries.iter().enumerate() {
                    if self.sim.model().frames[g.frame].name == name
                        && let Some(c) = self.sim.geometry_collider(k)
                    {
                        cs.push(c);
                    }
                }
            }
            self.foot_colliders.push(cs);
        }
    }

    /// One physics step with motor commands `cmd` (desired motor angles, or PWM).
    fn physics_step(&mut self, cmd: &[f64; 8]) -> f64 {
        let mut power = 0.0;
        for i in 0..8 {
            let (qj, qdj) = self.sim.joint_state(self.motor_joints[i]);
            let (q, qd) = (MOTOR_DIRECTION[i] * qj, MOTOR_DIRECTION[i] * qdj);
            let (actual, observed) = match (&self.config.motor_control, self.config.action) {
                (MotorControl::Accurate(_), MinitaurAction::Pwm) => {
                    self.motor.torque_from_pwm(cmd[i].clamp(-1.0, 1.0), qd)
                }
                (MotorControl::Accurate(_), _) => self.motor.torque(cmd[i], q, qd),
                (MotorControl::Pd { kp, kd, max_torque }, _) => {
                    let t = (-kp * (q - cmd[i]) - kd * qd).clamp(-max_torque, *max_torque);
                    (t, t)
                }
            };
            if self.config.overheat_protection {
                if actual.abs() > 2.45 {
                    self.overheat_counter[i] += 1;
                } else {
                    self.overheat_counter[i] = 0;
                }
                if self.overheat_counter[i] as f64 > 1.0 / self.config.sim.dt {
                    self.motor_enabled[i] = false;
                }
            }
            self.observed_torque[i] = observed;
            let applied = if self.motor_enabled[i] { actual } else { 0.0 };
            self.applied_torque[i] = MOTOR_DIRECTION[i] * applied;
            self.sim.set_joint_torque(self.motor_dofs[i], MOTOR_DIRECTION[i] * applied);
            power += applied * qd;
        }
        self.sim.step();
        self.episode_time += self.config.sim.dt;
        if self.delay_steps > 0 {
            self.write_base_observation();
            let slot = self.delayed_head;
            self.delayed[slot * 28..(slot + 1) * 28].copy_from_slice(&self.base_obs);
            self.delayed_head = (self.delayed_head + 1) % (self.delay_steps + 1);
        }
        power.abs() * self.config.sim.dt
    }

    /// The undelayed 28-entry observation from the simulator.
    fn write_base_observation(&mut self) {
        let (q, qd) = self.motor_state();
        for i in 0..8 {
            self.base_obs[i] = q[i] as f32;
            self.base_obs[8 + i] = qd[i] as f32;
            self.base_obs[16 + i] = self.observed_torque[i] as f32;
        }
        self.sim.read_state(&mut self.state);
        for k in 0..4 {
            self.base_obs[24 + k] = self.state.q[3 + k] as f32;
        }
    }

    fn write_observation(&mut self, obs: &mut [f32]) {
        self.write_base_observation();
        let mut base = self.base_obs;
        if self.delay_steps > 0 {
            // The oldest slot of the ring is `delay_steps` physics steps old.
            let slot = self.delayed_head;
            base.copy_from_slice(&self.delayed[slot * 28..(slot + 1) * 28]);
        }
        if self.config.observation_noise_std > 0.0 {
            for (k, b) in base.iter_mut().enumerate() {
                let bound = OBS_BOUNDS[(k / 8).min(3)] as f64;
                *b += (self.rng.normal() * self.config.observation_noise_std * bound) as f32;
            }
        }
        let n = if self.config.obs.drop_base_orientation { 24 } else { 28 };
        obs[..n].copy_from_slice(&base[..n]);
        self.history.push(&base[..8]);
        self.history.write(&mut obs[n..n + self.history.len()]);
        if let Some(data) = self.com_data.as_mut() {
            let k = n + self.history.len();
            obs[k..k + BODY_STATE_DIM].copy_from_slice(&body_state(&self.nominal, data, &self.state));
        }
    }

    fn update_contacts(&mut self) {
        for (leg, cs) in self.foot_colliders.iter().enumerate() {
            let mut c = FootContact::default();
            for &h in cs {
                if let Some((f, p)) = self.sim.contact_force(h) {
                    c.in_contact = true;
                    c.force += f;
                    c.point = p;
                }
            }
            self.contacts[leg] = c;
        }
    }

    fn is_fallen(&self) -> bool {
        let q = &self.state.q;
        let (x, y) = (q[3], q[4]);
        // R[2,2] = 1 − 2(x² + y²) for a unit quaternion.
        let up_z = 1.0 - 2.0 * (x * x + y * y);
        up_z < 0.85 || q[2] < 0.13
    }

    /// Initial pose: base at (0, 0, 0.2), motors at ±π/2 and knees at ∓2.1834 (joint frame).
    fn initial_state(&self) -> RobotState {
        let model = self.sim.model();
        let mut s = RobotState::new(model);
        s.q[2] = 0.2;
        for (l, leg) in LEG_NAMES.iter().enumerate() {
            for (k, side) in ["L", "R"].iter().enumerate() {
                let dir = MOTOR_DIRECTION[2 * l + k];
                let m = model.joint_index(&format!("motor_{leg}{side}_joint")).expect("motor joint");
                let kn = model.joint_index(&format!("knee_{leg}{side}_link")).expect("knee joint");
                s.q[model.joints[m].idx_q] = dir * std::f64::consts::FRAC_PI_2;
                s.q[model.joints[kn].idx_q] = dir * KNEE_ANGLE;
            }
        }
        s
    }
}

fn observation_dim(config: &MinitaurConfig) -> usize {
    (if config.obs.drop_base_orientation { 24 } else { 28 })
        + 8 * config.obs.joint_history
        + if config.observe_body_state { BODY_STATE_DIM } else { 0 }
}

/// [`heading_body_state`] of the CoM at `state` of a robot of `model`'s masses, under the
/// base's yaw.
fn body_state(model: &Model, data: &mut Data, state: &RobotState) -> [f32; BODY_STATE_DIM] {
    let v = center_of_mass_velocity(model, data, state.q.as_slice(), state.v.as_slice());
    let com = data.com[0];
    let (_, _, yaw) = state.base_orientation().euler_angles();
    heading_body_state([com.x, com.y, com.z], [v.x, v.y, v.z], yaw)
}

fn build_sim(model: &Model, config: &MinitaurConfig, foot_friction: f64) -> Result<Sim, RobotEnvError> {
    let closures: Vec<LoopClosure> = LEG_NAMES
        .iter()
        .map(|leg| LoopClosure {
            frame_a: format!("lower_leg_{leg}R_link"),
            point_a: TOE_RIGHT,
            frame_b: format!("lower_leg_{leg}L_link"),
            point_b: TOE_LEFT,
            free_axis: Some([0.0, 1.0, 0.0]),
        })
        .collect();
    let lower_legs: Vec<String> =
        LEG_NAMES.iter().flat_map(|l| ["L", "R"].map(|s| format!("lower_leg_{l}{s}_link"))).collect();
    let colliders = ColliderSpec {
        links: Vec::new(),
        friction: lower_legs.iter().map(|l| (l.clone(), foot_friction)).collect(),
        default_friction: 1.0,
        capsule_boxes: if config.capsule_feet { lower_legs } else { Vec::new() },
    };
    Sim::new(model, &config.sim, &colliders, &closures)
        .map_err(|source| RobotEnvError::Sim { robot: "minitaur".into(), source })
}

/// Scales the masses of links (and their inertias, as PyBullet's `changeDynamics` does).
fn scale_links(model: &mut Model, names: &[&str], factor: f64) {
    for f in model.frames.iter_mut() {
        if f.is_link && names.iter().any(|n| f.name.starts_with(n)) {
            f.link_inertia = Inertia::new(
                f.link_inertia.mass * factor,
                f.link_inertia.lever,
                f.link_inertia.rotational * factor,
            );
        }
    }
}

impl Env for MinitaurEnv {
    fn name(&self) -> &str {
        "minitaur"
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
        self.config.sim.dt * self.config.action_repeat as f64
    }

    fn reward_term_names(&self) -> &'static [&'static str] {
        &["forward", "energy", "drift", "shake"]
    }

    fn reset(&mut self, seed: Option<u64>, obs: &mut [f32]) -> Result<(), EnvError> {
        check_observation(&self.obs_space, obs)?;
        if let Some(s) = seed {
            self.rng = Rng::seed_from_u64(s);
        }
        // A fresh world every episode: resets are then deterministic by construction.
        let mut model = self.nominal.clone();
        let mut friction = 1.0;
        self.motor = match &self.config.motor_control {
            MotorControl::Accurate(m) => m.clone(),
            MotorControl::Pd { .. } => MotorModel::default(),
        };
        if let Some(r) = self.config.randomization.clone() {
            let base = 1.0 + self.rng.range(r.base_mass_error.0, r.base_mass_error.1);
            scale_links(&mut model, &["base_chassis_link"], base);
            let leg = 1.0 + self.rng.range(r.leg_mass_error.0, r.leg_mass_error.1);
            scale_links(&mut model, &["upper_leg_", "lower_leg_"], leg);
            let motor = 1.0 + self.rng.range(r.leg_mass_error.0, r.leg_mass_error.1);
            scale_links(&mut model, &["motor_"], motor);
            model.recompute_body_inertias();
            self.motor.voltage = self.rng.range(r.battery_voltage.0, r.battery_voltage.1);
            self.motor.viscous_damping = self.rng.range(r.motor_damping.0, r.motor_damping.1);
            friction = self.rng.range(r.foot_friction.0, r.foot_friction.1);
            self.motor.strength *= self.rng.range(r.motor_strength.0, r.motor_strength.1);
        }
        self.sim = build_sim(&model, &self.config, friction)?;
        self.index_feet();
        let s0 = self.initial_state();
        self.sim.set_state(&s0);
        self.motor_enabled = [true; 8];
        self.overheat_counter = [0; 8];
        self.observed_torque = [0.0; 8];
        self.push.clear(&mut self.sim, 1, &mut self.rng);
        // PyBullet settles the robot for 100 physics steps with every motor at π/2.
        if self.config.action != MinitaurAction::Pwm {
            let settle = [std::f64::consts::FRAC_PI_2; 8];
            for _ in 0..100 {
                self.physics_step(&settle);
            }
        }
        self.episode_time = 0.0;
        self.steps = 0;
        self.last_position = Vector3::zeros();
        self.sim.read_state(&mut self.state);
        if self.delay_steps > 0 {
            self.write_base_observation();
            for s in 0..=self.delay_steps {
                self.delayed[s * 28..(s + 1) * 28].copy_from_slice(&self.base_obs);
            }
        }
        self.write_base_observation();
        self.history.fill(&self.base_obs[..8]);
        self.write_observation(obs);
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
        let mut a = [0.0f64; 8];
        for (ai, (x, (lo, hi))) in
            a.iter_mut().zip(action.iter().zip(self.act_space.low.iter().zip(&self.act_space.high)))
        {
            *ai = x.clamp(*lo, *hi) as f64;
        }
        let cmd = match self.config.action {
            MinitaurAction::LegModel => leg_model_to_motor_angles(&a),
            MinitaurAction::MotorAngles | MinitaurAction::Pwm => a,
        };
        let mut energy = 0.0;
        for _ in 0..self.config.action_repeat {
            self.push.apply(&mut self.sim, 1, self.episode_time);
            energy += self.physics_step(&cmd);
        }
        self.steps += 1;
        self.sim.read_state(&mut self.state);
        let mut info = StepInfo { energy, ..StepInfo::default() };
        if !self.state.is_finite() || self.state.v.amax() > 1e3 {
            // The simulation blew up: end the episode, keep the last finite observation.
            self.needs_reset = true;
            info.unstable = true;
            return Ok(Step { reward: 0.0, terminated: true, truncated: false, info });
        }
        self.write_observation(obs);
        self.update_contacts();
        let p = Vector3::new(self.state.q[0], self.state.q[1], self.state.q[2]);
        let forward = p.x - self.last_position.x;
        let drift = -(p.y - self.last_position.y).abs();
        let shake = -(p.z - self.last_position.z).abs();
        self.last_position = p;
        // PyBullet: |observed torque · motor velocity| of the last physics step × 0.002.
        let (_, qd) = self.motor_state();
        let power: f64 = (0..8).map(|i| self.observed_torque[i] * qd[i]).sum();
        let energy_term = power.abs() * ENERGY_TERM_DT;
        let c = &self.config;
        let reward = c.distance_weight * forward - c.energy_weight * energy_term
            + c.drift_weight * drift
            + c.shake_weight * shake;
        info.reward_terms[..4].copy_from_slice(&[forward, energy_term, drift, shake]);
        info.forward_velocity = forward / self.dt();
        info.foot_contacts =
            self.contacts.iter().enumerate().fold(0u32, |m, (k, c)| m | ((c.in_contact as u32) << k));
        let terminated = self.is_fallen() || (p.x * p.x + p.y * p.y).sqrt() > c.distance_limit;
        let truncated = !terminated && self.steps >= c.max_episode_steps;
        if terminated || truncated {
            self.needs_reset = true;
        }
        Ok(Step { reward, terminated, truncated, info })
    }
}

impl RobotEnv for MinitaurEnv {
    fn model(&self) -> &Model {
        &self.nominal
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
        &self.motor_joints
    }

    fn episode_time(&self) -> f64 {
        self.episode_time
    }

    fn push(&mut self, force: Vector3<f64>, duration: f64) {
        self.push.start(force, self.episode_time, duration);
    }

    fn last_torques(&self) -> &[f64] {
        &self.applied_torque
    }

    /// Inverts the motor model at the current motor state: joint torque → motor-frame
    /// torque → PWM → desired motor angle (position modes) → leg model (clipped to ±1).
    fn action_for_torques(&self, tau: &[f64], out: &mut [f32]) {
        let (q, qd) = self.motor_state();
        let motor = match (&self.config.motor_control, self.config.motor_inverse) {
            (MotorControl::Accurate(nominal), MotorInverse::Nominal) => nominal,
            _ => &self.motor,
        };
        let mut cmd = [0.0f64; 8];
        for i in 0..8 {
            let t = MOTOR_DIRECTION[i] * tau[i];
            cmd[i] = match (&self.config.motor_control, self.config.action) {
                (MotorControl::Accurate(_), MinitaurAction::Pwm) => motor.pwm_for_torque(t, qd[i]),
                (MotorControl::Accurate(_), _) => motor.angle_for_torque(t, q[i], qd[i]),
                (MotorControl::Pd { kp, kd, .. }, _) => q[i] + (t + kd * qd[i]) / kp,
            };
        }
        let a = match self.config.action {
            MinitaurAction::LegModel => motor_angles_to_leg_model(&cmd),
            MinitaurAction::MotorAngles | MinitaurAction::Pwm => cmd,
        };
        for (k, o) in out.iter_mut().enumerate() {
            *o = (a[k] as f32).clamp(self.act_space.low[k], self.act_space.high[k]);
        }
    }
}
