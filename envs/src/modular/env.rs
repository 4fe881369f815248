//! [`ModularEnv`]: a modular robot learning to move, with Revolve2's servos, control rate,
//! episode and fitness (see the module docs).

use centaur_dynamics::nalgebra::Vector3;
use centaur_dynamics::{Data, Model, RobotState, Shape};
use centaur_gym::{BoxSpace, Env, EnvError, Rng, Step, StepInfo};
use centaur_gym::{check_action, check_observation};

use super::body::{Body, ModuleSpecs};
use crate::checks::{Fields, MAX_FRAME_SKIP};
use crate::error::RobotEnvError;
use crate::robot::{FootContact, JointHistory, ObsOptions, Push, PushSchedule, RobotEnv};
use crate::sim::{ColliderSpec, Sim, SimConfig};

/// What the reward measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum ModularReward {
    /// The change of the core's horizontal distance from its start: the return of an
    /// episode is Revolve2's `xy_displacement` fitness (default).
    #[default]
    XyDisplacement,
    /// The core's displacement along the world x axis.
    ForwardX,
}

/// Which groups of entries the observation holds: the observation ablation of the PPO study
/// on modular robots (hinge positions only; plus the core's orientation; plus velocities).
/// Its third set, "the last 3 hinge positions + orientation", is
/// [`ModularObservation::HingesOrientation`] with `obs.joint_history = 3` (the history holds
/// the angles of the last three control steps, the newest of which repeats the current ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModularObservation {
    /// The core's height and orientation, the hinge angles, the core's velocities and the
    /// hinge velocities: `11 + 2n` entries (default).
    #[default]
    Full,
    /// The core's orientation quaternion and the hinge angles: `4 + n` entries.
    HingesOrientation,
    /// The hinge angles alone: `n` entries.
    Hinges,
}

impl ModularObservation {
    /// The number of entries for `n` hinges, before the shared options.
    pub fn dim(self, n: usize) -> usize {
        match self {
            ModularObservation::Full => 11 + 2 * n,
            ModularObservation::HingesOrientation => 4 + n,
            ModularObservation::Hinges => n,
        }
    }

    /// Whether the set holds the core's orientation.
    pub fn has_orientation(self) -> bool {
        !matches!(self, ModularObservation::Hinges)
    }
}

/// Configuration of a [`ModularEnv`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ModularConfig {
    /// The robot's body.
    pub body: Body,
    /// Name of the environment and robot (e.g. `"gecko"`).
    pub name: String,
    /// Physics steps per control step (default: 10 steps of 5 ms, Revolve2's 20 Hz).
    pub frame_skip: usize,
    /// Episode length in control steps (default: 600, Revolve2's standard 30 s).
    pub max_episode_steps: usize,
    /// What the reward measures (default: the xy displacement).
    pub reward: ModularReward,
    /// Weight of `Σ a²` subtracted from the reward (default: 0).
    pub ctrl_cost_weight: f64,
    /// Hinge angles at reset are uniform in ±this (rad) (default: 0.05).
    pub reset_noise_scale: f64,
    /// Physics settings (default: 5 ms steps, 8 PGS iterations).
    pub sim: SimConfig,
    /// Which entries the observation holds (default: all of them).
    pub observation: ModularObservation,
    /// Observation options.
    pub obs: ObsOptions,
    /// Periodic pushes on the base during every episode (default: none).
    pub pushes: Option<PushSchedule>,
}

impl ModularConfig {
    /// An environment for `body`, named `name`, with the defaults above.
    pub fn new(name: &str, body: Body) -> Self {
        ModularConfig {
            body,
            name: name.to_string(),
            frame_skip: 10,
            max_episode_steps: 600,
            reward: ModularReward::XyDisplacement,
            ctrl_cost_weight: 0.0,
            reset_noise_scale: 0.05,
            sim: SimConfig { dt: 0.005, ..SimConfig::default() },
            observation: ModularObservation::Full,
            obs: ObsOptions::default(),
            pushes: None,
        }
    }

    /// The gecko ([`Body::gecko`]).
    pub fn gecko() -> Self {
        Self::new("gecko", Body::gecko())
    }

    /// The modular ant ([`Body::ant`]).
    pub fn ant() -> Self {
        Self::new("modular-ant", Body::ant())
    }

    /// The spider ([`Body::spider`]).
    pub fn spider() -> Self {
        Self::new("spider", Body::spider())
    }

    /// The preset of a name: `gecko`, `modular-ant` or `spider`.
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "gecko" => Some(Self::gecko()),
            "modular-ant" => Some(Self::ant()),
            "spider" => Some(Self::spider()),
            _ => None,
        }
    }

    /// Checks the numbers.
    pub fn validate(&self) -> Result<(), RobotEnvError> {
        let f = Fields("ModularConfig");
        f.count("frame_skip", self.frame_skip, MAX_FRAME_SKIP)?;
        f.count("max_episode_steps", self.max_episode_steps, usize::MAX)?;
        f.non_negative("reset_noise_scale", self.reset_noise_scale)?;
        f.finite("ctrl_cost_weight", self.ctrl_cost_weight)?;
        f.joint_history(self.obs.joint_history)?;
        if let Some(p) = &self.pushes {
            p.validate("ModularConfig")?;
        }
        if self.obs.drop_base_orientation && !self.observation.has_orientation() {
            return Err(RobotEnvError::config(
                "ModularConfig",
                "drop_base_orientation asks to remove an orientation the `hinges` observation does not hold",
            ));
        }
        if self.body.hinges().is_empty() {
            return Err(RobotEnvError::config("ModularConfig", "the body has no active hinge to drive"));
        }
        Ok(())
    }
}

/// A modular robot learning to move (see the module docs).
///
/// Observation (`11 + 2n` entries for `n` hinges, before the shared options): the core's
/// height, its orientation quaternion `(x, y, z, w)`, the hinge angles, the core's linear
/// and angular velocity (world axes), the hinge velocities; [`ModularObservation`] keeps
/// fewer groups. [`ObsOptions`] drops the quaternion or appends past hinge angles. Actions
/// outside `[−1, 1]` are clipped.
pub struct ModularEnv {
    config: ModularConfig,
    model: Model,
    data: Data,
    sim: Sim,
    rng: Rng,
    obs_space: BoxSpace,
    act_space: BoxSpace,
    state: RobotState,
    /// Model joint of each hinge, in action order.
    actuated: Vec<usize>,
    targets: Vec<f64>,
    applied: Vec<f64>,
    history: JointHistory,
    joint_scratch: Vec<f32>,
    start: Vector3<f64>,
    steps: usize,
    needs_reset: bool,
    push: Push,
    episode_time: f64,
}

impl ModularEnv {
    /// Builds the environment.
    pub fn new(config: ModularConfig) -> Result<ModularEnv, RobotEnvError> {
        config.validate()?;
        let model = config
            .body
            .to_model(&config.name)
            .map_err(|source| RobotEnvError::Modular { robot: config.name.clone(), source })?;
        // Actions follow the order in which the hinges were attached.
        let actuated = config
            .body
            .hinges()
            .iter()
            .map(|h| {
                model.joint_index(&format!("hinge{}", h.0)).ok_or_else(|| RobotEnvError::Missing {
                    robot: config.name.clone(),
                    what: "joint",
                    name: format!("hinge{}", h.0),
                })
            })
            .collect::<Result<Vec<usize>, RobotEnvError>>()?;
        let n = actuated.len();
        let obs_dim = config.observation.dim(n) - if config.obs.drop_base_orientation { 4 } else { 0 }
            + n * config.obs.joint_history;
        let sim = build_sim(&model, &config)?;
        Ok(ModularEnv {
            obs_space: BoxSpace::unbounded(obs_dim),
            act_space: BoxSpace::new(vec![-1.0; n], vec![1.0; n]),
            state: RobotState::new(&model),
            data: Data::new(&model),
            targets: vec![0.0; n],
            applied: vec![0.0; n],
            history: JointHistory::new(config.obs.joint_history, n),
            joint_scratch: vec![0.0; n],
            actuated,
            start: Vector3::zeros(),
            steps: 0,
            needs_reset: true,
            push: Push::new(config.pushes, false),
            episode_time: 0.0,
            rng: Rng::seed_from_u64(0),
            sim,
            model,
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ModularConfig {
        &self.config
    }

    /// The simulator.
    pub fn sim(&self) -> &Sim {
        &self.sim
    }

    /// Height of the core's centre that puts the lowest box corner 1 mm above the ground at
    /// configuration `q` (base at height 0).
    fn resting_height(&mut self, q: &[f64]) -> f64 {
        centaur_dynamics::forward_kinematics(&self.model, &mut self.data, q);
        let mut lowest = f64::INFINITY;
        for g in &self.model.geometries {
            let Shape::Box { size } = g.shape else { continue };
            let pose = self.data.o_m_i[g.parent_joint].mul(&g.placement);
            for corner in 0..8 {
                let sign = |bit: usize| if corner & (1 << bit) != 0 { 0.5 } else { -0.5 };
                let p = Vector3::new(sign(0) * size.x, sign(1) * size.y, sign(2) * size.z);
                lowest = lowest.min(pose.act_point(&p).z);
            }
        }
        0.001 - lowest
    }

    fn write_obs(&mut self, obs: &mut [f32]) {
        let s = &self.state;
        let mut k = 0;
        let mut put = |x: f64| {
            obs[k] = x as f32;
            k += 1;
        };
        let set = self.config.observation;
        if set == ModularObservation::Full {
            put(s.q[2]);
        }
        if set.has_orientation() && !self.config.obs.drop_base_orientation {
            for i in 3..7 {
                put(s.q[i]);
            }
        }
        for &j in &self.actuated {
            put(s.q[self.model.joints[j].idx_q]);
        }
        if set == ModularObservation::Full {
            let (lin, ang) = (s.base_linear_velocity_world(), s.base_angular_velocity_world());
            for x in lin.iter().chain(ang.iter()) {
                put(*x);
            }
            for &j in &self.actuated {
                put(s.v[self.model.joints[j].idx_v]);
            }
        }
        if self.config.obs.joint_history > 0 {
            for (h, &j) in self.joint_scratch.iter_mut().zip(&self.actuated) {
                *h = s.q[self.model.joints[j].idx_q] as f32;
            }
            self.history.push(&self.joint_scratch);
        }
        self.history.write(&mut obs[k..k + self.history.len()]);
    }

    fn progress(&self) -> f64 {
        let d = self.state.base_position() - self.start;
        match self.config.reward {
            ModularReward::XyDisplacement => d.x.hypot(d.y),
            ModularReward::ForwardX => d.x,
        }
    }
}

/// The servo's torque: the PD law `kp (q* − q) − kd q̇`, within the torque–speed envelope
/// of a DC servo — the full `effort` at rest, falling linearly to zero at the rated
/// `velocity` in the direction of motion (braking torque stays available).
/// A state that is not finite gets no torque (the step then reports the blow-up).
pub fn servo_torque(specs: &ModuleSpecs, target: f64, q: f64, qd: f64) -> f64 {
    let pd = specs.kp * (target - q) - specs.kd * qd;
    if !pd.is_finite() {
        return 0.0;
    }
    let fraction = |x: f64| x.clamp(0.0, 1.0);
    let upper = specs.effort * fraction(1.0 - qd / specs.velocity);
    let lower = -specs.effort * fraction(1.0 + qd / specs.velocity);
    pd.max(lower).min(upper)
}

fn build_sim(model: &Model, config: &ModularConfig) -> Result<Sim, RobotEnvError> {
    let specs = config.body.specs();
    let colliders = ColliderSpec { default_friction: specs.friction, ..ColliderSpec::default() };
    let mut sim = Sim::new(model, &config.sim, &colliders, &[])
        .map_err(|source| RobotEnvError::Sim { robot: config.name.clone(), source })?;
    for j in 1..model.njoints() {
        if model.joints[j].nv() == 1 {
            sim.set_armature(model.joints[j].idx_v, specs.armature);
            sim.set_damping(model.joints[j].idx_v, 0.0);
        }
    }
    Ok(sim)
}

impl Env for ModularEnv {
    fn name(&self) -> &str {
        &self.config.name
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
        &["progress", "ctrl_cost"]
    }

    fn reset(&mut self, seed: Option<u64>, obs: &mut [f32]) -> Result<(), EnvError> {
        check_observation(&self.obs_space, obs)?;
        if let Some(s) = seed {
            self.rng = Rng::seed_from_u64(s);
        }
        self.sim = build_sim(&self.model, &self.config)?;
        let mut q = self.model.neutral_configuration();
        let a = self.config.reset_noise_scale;
        for &j in &self.actuated {
            q[self.model.joints[j].idx_q] = self.rng.range(-a, a);
        }
        q[2] = self.resting_height(q.as_slice());
        self.state.q.copy_from(&q);
        self.state.v.fill(0.0);
        self.sim.set_state(&self.state);
        self.start = self.state.base_position();
        for (t, &j) in self.targets.iter_mut().zip(&self.actuated) {
            *t = q[self.model.joints[j].idx_q];
        }
        self.applied.fill(0.0);
        for (h, &j) in self.joint_scratch.iter_mut().zip(&self.actuated) {
            *h = q[self.model.joints[j].idx_q] as f32;
        }
        self.history.fill(&self.joint_scratch);
        self.steps = 0;
        self.episode_time = 0.0;
        self.push.clear(&mut self.sim, 1, &mut self.rng);
        self.write_obs(obs);
        self.needs_reset = false;
        Ok(())
    }

    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Step, EnvError> {
        check_action(&self.act_space, action)?;
        check_observation(&self.obs_space, obs)?;
        if self.needs_reset {
            return Err(EnvError::NeedsReset);
        }
        let specs = self.config.body.specs();
        for (t, a) in self.targets.iter_mut().zip(action) {
            *t = (*a).clamp(-1.0, 1.0) as f64 * specs.range;
        }
        let before = self.progress();
        let mut energy = 0.0;
        for _ in 0..self.config.frame_skip {
            self.push.apply(&mut self.sim, 1, self.episode_time);
            for (k, &j) in self.actuated.iter().enumerate() {
                let (q, qd) = self.sim.joint_state(j);
                let tau = servo_torque(specs, self.targets[k], q, qd);
                self.applied[k] = tau;
                self.sim.set_joint_torque(self.model.joints[j].idx_v, tau);
                energy += (tau * qd).abs() * self.config.sim.dt;
            }
            self.sim.step();
            self.episode_time += self.config.sim.dt;
        }
        self.steps += 1;
        self.sim.read_state(&mut self.state);
        let mut info = StepInfo { energy, ..StepInfo::default() };
        if !self.state.is_finite() || self.state.v.amax() > 1e4 {
            self.needs_reset = true;
            info.unstable = true;
            return Ok(Step { reward: 0.0, terminated: true, truncated: false, info });
        }
        let progress = self.progress() - before;
        let ctrl_cost =
            self.config.ctrl_cost_weight * action.iter().map(|a| (*a as f64).powi(2)).sum::<f64>();
        info.reward_terms[..2].copy_from_slice(&[progress, -ctrl_cost]);
        info.forward_velocity = progress / self.dt();
        self.write_obs(obs);
        let truncated = self.steps >= self.config.max_episode_steps;
        self.needs_reset = truncated;
        Ok(Step { reward: progress - ctrl_cost, terminated: false, truncated, info })
    }
}

impl RobotEnv for ModularEnv {
    fn model(&self) -> &Model {
        &self.model
    }

    fn robot_state(&self) -> &RobotState {
        &self.state
    }

    /// Modular robots have no designated feet: empty.
    fn foot_contacts(&self) -> &[FootContact] {
        &[]
    }

    fn foot_frames(&self) -> &[String] {
        &[]
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

    /// The servo target whose PD torque at the current state is `τ`:
    /// `a = (q + (τ + kd q̇) / kp) / range`, clipped to `[−1, 1]`.
    fn action_for_torques(&self, tau: &[f64], out: &mut [f32]) {
        let s = self.config.body.specs();
        for ((o, &j), t) in out.iter_mut().zip(&self.actuated).zip(tau) {
            let joint = &self.model.joints[j];
            let (q, qd) = (self.state.q[joint.idx_q], self.state.v[joint.idx_v]);
            *o = (((q + (t + s.kd * qd) / s.kp) / s.range) as f32).clamp(-1.0, 1.0);
        }
    }
}
