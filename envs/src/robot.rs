//! What every robot environment offers besides the RL interface: robot-level access for
//! controllers, and the observation options one seed paper ablates.

use centaur_dynamics::nalgebra::Vector3;
use centaur_dynamics::{Model, RobotState};
use centaur_gym::Env;

use crate::sim::Sim;

/// One foot's contact during the last control step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FootContact {
    /// Whether the foot touched the ground at the end of the step.
    pub in_contact: bool,
    /// Ground reaction force on the foot (N, world frame) at the end of the step.
    pub force: Vector3<f64>,
    /// Where it acts: the impulse-weighted mean contact point (world frame).
    pub point: Vector3<f64>,
}

/// Joint servo targets for the actuated joints, in [`RobotEnv::actuated_joints`] order:
/// the PD part `kp (q* − q) + kd (q̇* − q̇)` of a controller's joint command
/// ([`RobotEnv::set_servo`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Servo<'a> {
    /// Target positions.
    pub q: &'a [f64],
    /// Target velocities.
    pub qd: &'a [f64],
    /// Position gains (N·m/rad).
    pub kp: &'a [f64],
    /// Velocity gains (N·m·s/rad).
    pub kd: &'a [f64],
}

/// Robot-level access for controllers: the model the simulator was built from, the state in
/// the dynamics conventions, foot contacts, and external pushes.
pub trait RobotEnv: Env {
    /// The model the simulation was built from (with the environment's inertias).
    fn model(&self) -> &Model;
    /// The robot's state at the end of the last step (or reset).
    fn robot_state(&self) -> &RobotState;
    /// Foot contacts at the end of the last step, one per foot.
    fn foot_contacts(&self) -> &[FootContact];
    /// Names of the foot frames, in [`RobotEnv::foot_contacts`] order.
    fn foot_frames(&self) -> &[String];
    /// Model joint indices of the actuated joints, in action order.
    fn actuated_joints(&self) -> &[usize];
    /// Simulated time since the episode started (s).
    fn episode_time(&self) -> f64;
    /// Applies a force (N, world frame) to the base for the next `duration` seconds.
    fn push(&mut self, force: Vector3<f64>, duration: f64);
    /// The action that applies the joint torques `tau` (N·m or N, joint frame, one per
    /// actuated joint in [`RobotEnv::actuated_joints`] order) as closely as the action space
    /// allows at the current state (clipped to the action bounds). This is how a
    /// controller's torques become actions, for the controller alone and for the residual
    /// (hybrid) policy alike.
    fn action_for_torques(&self, tau: &[f64], out: &mut [f32]);
    /// Torques the actuators applied during the last physics step (N·m or N, joint frame,
    /// [`RobotEnv::actuated_joints`] order).
    fn last_torques(&self) -> &[f64];
    /// Holds joint servo targets for the following steps (until replaced, removed with
    /// `None`, or the next reset): at every physics step the env adds their PD torque at the
    /// joints' current state to the action's torque, within the actuators' range. This is a
    /// robot's motor drivers under a controller that ticks at the control rate; the action
    /// then carries the feed-forward torque (and a learner's residual). Returns whether the
    /// env has such a servo: the torque-actuated robots do; the Minitaur's actions are
    /// already motor positions servoed at the physics rate, so it has none.
    fn set_servo(&mut self, servo: Option<Servo<'_>>) -> bool {
        let _ = servo;
        false
    }
}

/// Observation options shared by every environment (one seed paper ablates them).
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ObsOptions {
    /// Append the joint positions of the last `k` control steps (oldest first), after the
    /// environment's own observation (default: 0).
    pub joint_history: usize,
    /// Remove the base orientation from the observation (default: false).
    pub drop_base_orientation: bool,
}

/// Pushes on the robot's base during every episode, as a setting of the environment (the
/// `[env]` key `pushes = { force, every, duration }`): every `every` seconds of an
/// episode a horizontal force of `force` newtons in a random direction (along ±x on the
/// planar robots, which cannot move sideways) acts on the base for `duration` seconds.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PushSchedule {
    /// Force (N).
    pub force: f64,
    /// Period (s): the first push comes at this time into the episode.
    pub every: f64,
    /// Duration of each push (s), at most `every`.
    pub duration: f64,
}

impl PushSchedule {
    /// Checks the numbers (for the config named `config`).
    pub(crate) fn validate(&self, config: &'static str) -> Result<(), crate::RobotEnvError> {
        let f = crate::checks::Fields(config);
        f.non_negative("pushes.force", self.force)?;
        f.positive("pushes.every", self.every, f64::MAX, "a period > 0 (s)")?;
        f.positive(
            "pushes.duration",
            self.duration,
            self.every,
            "a duration > 0 and at most pushes.every (s)",
        )
    }
}

/// A force on the robot's base for a while ([`RobotEnv::push`]), and the periodic pushes of
/// a [`PushSchedule`], shared by the envs.
#[derive(Clone, Debug)]
pub(crate) struct Push {
    /// The force (N, world frame) and the episode time at which it stops.
    active: Option<(Vector3<f64>, f64)>,
    /// Periodic pushes, whether the robot is planar (pushed along ±x), and the time of the
    /// next one.
    schedule: Option<(PushSchedule, bool)>,
    next: f64,
    /// Directions of the periodic pushes (seeded at each reset from the env's generator,
    /// which is drawn from only when there is a schedule).
    rng: centaur_gym::Rng,
}

impl Default for Push {
    fn default() -> Self {
        Push::new(None, false)
    }
}

impl Push {
    /// No push yet; `schedule`: periodic pushes (along ±x if `planar`).
    pub(crate) fn new(schedule: Option<PushSchedule>, planar: bool) -> Self {
        Push {
            active: None,
            schedule: schedule.map(|s| (s, planar)),
            next: 0.0,
            rng: centaur_gym::Rng::seed_from_u64(0),
        }
    }

    /// Pushes with `force` from `now` for `duration` seconds.
    pub(crate) fn start(&mut self, force: Vector3<f64>, now: f64, duration: f64) {
        self.active = Some((force, now + duration));
    }

    /// Cancels the push and removes its force from `sim` (at reset); with a schedule, the
    /// first periodic push is due `every` seconds in, its directions drawn from a generator
    /// seeded from `env_rng`.
    pub(crate) fn clear(&mut self, sim: &mut Sim, joint: usize, env_rng: &mut centaur_gym::Rng) {
        self.active = None;
        sim.set_external_force(joint, Vector3::zeros());
        if let Some((s, _)) = self.schedule {
            self.next = s.every;
            self.rng = centaur_gym::Rng::seed_from_u64(env_rng.next_u64());
        }
    }

    /// Before the physics step that starts at episode time `now`: applies the force to the
    /// body moved by `joint`, or removes it once the push is over. Without a push it leaves
    /// `sim` alone.
    pub(crate) fn apply(&mut self, sim: &mut Sim, joint: usize, now: f64) {
        if let Some((s, planar)) = self.schedule
            && now >= self.next
        {
            self.next += s.every;
            let force = if planar {
                Vector3::new(if self.rng.uniform() < 0.5 { -s.force } else { s.force }, 0.0, 0.0)
            } else {
                let a = self.rng.range(0.0, std::f64::consts::TAU);
                Vector3::new(s.force * a.cos(), s.force * a.sin(), 0.0)
            };
            self.start(force, now, s.duration);
        }
        if let Some((force, until)) = self.active {
            let on = now < until;
            sim.set_external_force(joint, if on { force } else { Vector3::zeros() });
            if !on {
                self.active = None;
            }
        }
    }
}

/// A ring of the last `k` joint-position vectors.
#[derive(Clone, Debug)]
pub(crate) struct JointHistory {
    k: usize,
    n: usize,
    data: Vec<f32>,
    head: usize,
}

impl JointHistory {
    pub(crate) fn new(k: usize, n: usize) -> Self {
        JointHistory { k, n, data: vec![0.0; k * n], head: 0 }
    }

    /// Fills every slot with `q` (at reset).
    pub(crate) fn fill(&mut self, q: &[f32]) {
        for s in 0..self.k {
            self.data[s * self.n..(s + 1) * self.n].copy_from_slice(q);
        }
        self.head = 0;
    }

    /// Records `q` as the newest entry.
    pub(crate) fn push(&mut self, q: &[f32]) {
        if self.k == 0 {
            return;
        }
        self.data[self.head * self.n..(self.head + 1) * self.n].copy_from_slice(q);
        self.head = (self.head + 1) % self.k;
    }

    /// Writes the history, oldest first, into `out` (`k·n` entries).
    pub(crate) fn write(&self, out: &mut [f32]) {
        for s in 0..self.k {
            let slot = (self.head + s) % self.k;
            out[s * self.n..(s + 1) * self.n].copy_from_slice(&self.data[slot * self.n..(slot + 1) * self.n]);
        }
    }

    pub(crate) fn len(&self) -> usize {
        self.k * self.n
    }
}

/// Entries of [`heading_body_state`].
pub const BODY_STATE_DIM: usize = 4;

/// The body state a policy may observe: the CoM's `velocity` (world) turned into the
/// heading frame of `yaw` (forward, lateral, vertical, m/s) and the height of the CoM at
/// `com` (m); non-finite values read as 0. The hybrid's policy observes it from its
/// controller's last tick (the root crate's `hybrid::observed_state`), pure RL on the
/// Minitaur from the simulator ([`crate::MinitaurConfig::observe_body_state`]): one law for
/// both, so the two see the same numbers.
pub fn heading_body_state(com: [f64; 3], velocity: [f64; 3], yaw: f64) -> [f32; BODY_STATE_DIM] {
    let [vx, vy, vz] = velocity;
    let (s, c) = yaw.sin_cos();
    let finite = |x: f64| if x.is_finite() { x as f32 } else { 0.0 };
    [finite(c * vx + s * vy), finite(-s * vx + c * vy), finite(vz), finite(com[2])]
}
