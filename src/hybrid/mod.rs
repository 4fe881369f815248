//! The hybrid's core, written once and used by training ([`crate::residual::ResidualEnv`])
//! and by deployment ([`crate::deploy::HybridStack`]), so that what a robot runs is what the
//! policy was trained on by construction:
//!
//! * [`Residual`]: the law `a = clip(a_ref + scale ⊙ clip(r, −1, 1), low, high)` that turns
//!   the controller's reference action `a_ref` and the policy's output `r` into the action
//!   applied, and the policy's observation layout;
//! * [`CommandTorques`], [`ContactMap`], [`ActionMapping`]: from a controller tick to the
//!   robot's actions (the controller's joint command as torques at the measured state, the
//!   robot's contact sensors matched to the controller's contact points).
//!
//! Nothing here knows the simulator: a robot is a [`RobotEnv`] (simulated) or a
//! [`crate::deploy::RobotInterface`] (anything that reports a state and takes actions).

mod error;
mod overrides;

pub use error::HybridError;
pub use overrides::{
    ControllerOverrides, MAX_COMMAND_ACCELERATION, MAX_RATED_SPEED, MPC_PERIOD_RANGE, PERIOD_SCALE_RANGE,
    SWING_HEIGHT_RANGE,
};

use centaur_dynamics::{Model, RobotState};
use centaur_envs::{RobotEnv, Servo};
use centaur_mpc::{Command, ControllerConfig, ControllerStatus, Gait, JointCommand, LocomotionController};

/// How the policy may steer the controller's command. Each non-zero span adds one entry
/// `c ∈ [−1, 1]` to the policy's action, after the joint residual, in this order (speed,
/// yaw rate, cadence, duty, swing, foothold), and the controller follows `base + span ·
/// clip(c, −1, 1)` (the gait's parts as their fields say); zero
/// switches that part off. The controller still clamps the result to its rating for the
/// gait and ramps towards it at its own acceleration limit, so a noisy steering output is
/// smoothed, not followed step by step; the cadence moves at the gait clock's slew
/// ([`centaur_mpc::GAIT_RATE_SLEW`]).
#[derive(Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Steering {
    /// Forward-speed span (m/s): `v = v₀ + speed · c`.
    pub speed: f64,
    /// Yaw-rate span (rad/s): `ω = ω₀ + yaw_rate · c`.
    pub yaw_rate: f64,
    /// Cadence span, a fraction in [0, 0.75]: the gait clock runs at `1 + cadence · c` times
    /// its rate, each cycle (swing and stance) taking `1 / (1 + cadence · c)` of the gait's
    /// period ([`centaur_mpc::LocomotionController::set_gait_rate`]). A robot whose gait
    /// has a fixed clock steps at one cadence whatever its speed; steering it lets the
    /// policy step faster to run (recorded only where set, so the records of runs without
    /// it read as before).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub cadence: f64,
    /// Duty-factor span, a fraction in [0, 0.3]: every leg's stance fraction is its gait's
    /// own plus `duty · c` ([`centaur_mpc::LocomotionController::set_gait_duty_shift`]), so
    /// below its own a trot's feet leave the ground sooner, with flight phases, as a
    /// running animal's do, and the stance sweeps a shorter stretch of ground at a given
    /// speed (recorded only where set).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub duty: f64,
    /// Swing-height span, a fraction in [0, 0.75]: each swing's apex is the controller's
    /// `swing_height` times `1 + swing · c`, taken at its lift-off
    /// ([`centaur_mpc::LocomotionController::set_swing_height_scale`]), so the policy can lift
    /// the feet less to step faster, or more over rough ground (recorded only where set).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub swing: f64,
    /// Foothold span (m), in [0, 0.1]: each swing lands `foothold · c` metres ahead of the
    /// controller's foothold (Raibert's neutral point and its capture-point term) along the
    /// heading, taken at its lift-off
    /// ([`centaur_mpc::LocomotionController::set_foothold_offset`]), so the policy can
    /// lengthen or shorten the stride the controller plans (recorded only where set).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub foothold: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// Every field as `derive(Debug)` writes it, but `cadence`, `duty`, `swing` and `foothold`
/// only where set: error messages name the setup as briefly as its data are recorded.
impl std::fmt::Debug for Steering {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Steering { speed, yaw_rate, cadence, duty, swing, foothold } = self;
        let mut s = f.debug_struct("Steering");
        s.field("speed", speed).field("yaw_rate", yaw_rate);
        if *cadence != 0.0 {
            s.field("cadence", cadence);
        }
        if *duty != 0.0 {
            s.field("duty", duty);
        }
        if *swing != 0.0 {
            s.field("swing", swing);
        }
        if *foothold != 0.0 {
            s.field("foothold", foothold);
        }
        s.finish()
    }
}

impl Steering {
    /// No steering: the command is fixed.
    pub const OFF: Steering =
        Steering { speed: 0.0, yaw_rate: 0.0, cadence: 0.0, duty: 0.0, swing: 0.0, foothold: 0.0 };

    /// Number of action entries the steering adds.
    pub fn dim(&self) -> usize {
        self.spans().iter().filter(|&&s| s != 0.0).count()
    }

    /// The speed's place in the order of the steering entries (speed, yaw rate, cadence,
    /// duty, swing, foothold): the first where it is on.
    pub const SPEED: usize = 0;
    /// The yaw rate's place in the order of the steering entries.
    pub const YAW_RATE: usize = 1;
    /// The cadence's place in the order of the steering entries.
    pub const CADENCE: usize = 2;
    /// The duty's place in the order of the steering entries.
    pub const DUTY: usize = 3;
    /// The swing height's place in the order of the steering entries.
    pub const SWING: usize = 4;
    /// The foothold offset's place in the order of the steering entries: the last.
    pub const FOOTHOLD: usize = 5;

    /// The spans in the order of their action entries: speed, yaw rate, cadence, duty,
    /// swing, foothold.
    fn spans(&self) -> [f64; 6] {
        [self.speed, self.yaw_rate, self.cadence, self.duty, self.swing, self.foothold]
    }

    /// The index among the steering entries of `part` (its place in [`Steering::spans`]),
    /// if it is switched on.
    fn entry(&self, part: usize) -> Option<usize> {
        let spans = self.spans();
        (spans[part] != 0.0).then(|| spans[..part].iter().filter(|&&s| s != 0.0).count())
    }
}

/// The initial exploration of a hybrid's learner, per action part: the standard deviation
/// of the Gaussian around the policy's (zero) mean, in the policy's [−1, 1] units. A
/// residual's noise of σ · scale on every joint knocks the controller over long before its
/// mean learns anything; a steering entry's noise is smoothed by the controller's ramp.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Exploration {
    /// σ of every joint-residual entry.
    pub residual: f64,
    /// σ of every steering entry.
    pub steering: f64,
}

/// A rising exploration for the joint residual: the learner's σ on every residual entry is
/// held at least at a floor that rises log-linearly from [`Exploration::residual`] (the
/// gentle start) to `residual` over the first `samples` training samples, then is released
/// to the learner ([`centaur_rl::ExplorationFloor`]; PPO and A2C).
///
/// Why: a gentle start keeps the first episodes on the controller's gait, but a residual
/// explored that gently never leaves it. Walker2d's hybrid with a residual bound of the
/// whole action range and σ 0.01 stayed at the walk's 1.0 m/s for 1M samples; explored at
/// σ 0.3 from the start it learnt to run (README, "Walker2d: a residual that learns to
/// run"), but its first episodes fell. The ramp does both; Walker2d's preset used it until a
/// rising bound ([`BoundRamp`]), which keeps σ 0.3 from the start, did better.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExplorationRamp {
    /// σ of every joint-residual entry at the end of the ramp, in the policy's [−1, 1] units.
    pub residual: f64,
    /// Training samples (all environments together) over which the floor rises.
    pub samples: u64,
}

/// A rising residual bound: the joint residual's bound starts at `from` times the scale and
/// rises log-linearly to the full scale over the first `samples` training samples (all
/// environments together), then stays there. A gentle start that leaves the learner's own
/// exploration alone: the residual's noise, and its mean, act at the small bound while the
/// learner's σ is already the one that finds a new gait (the rising exploration,
/// [`ExplorationRamp`], instead starts the learner at a tiny σ). The environment learns the
/// samples from the learner ([`centaur_gym::Env::set_training_samples`]; Centaur's learners
/// tell it, and a resumed run's learner goes on from its own count); one never told (an
/// evaluation, a deployed stack, another trainer) applies the full scale.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundRamp {
    /// The bound at the start, as a fraction of the scale, in (0, 1].
    pub from: f64,
    /// Training samples (all environments together) over which the bound rises.
    pub samples: u64,
}

impl BoundRamp {
    /// The fraction of the scale after `samples` training samples:
    /// `from^(1 − min(samples / self.samples, 1))`.
    pub fn factor(&self, samples: u64) -> f32 {
        let progress = (samples as f64 / self.samples as f64).min(1.0);
        self.from.powf(1.0 - progress) as f32
    }

    fn validate(&self, joint_residual: bool) -> Result<(), HybridError> {
        let refuse = |part, value, expected| Err(HybridError::BadSetting { part, value, expected });
        if !joint_residual {
            return refuse("bound_ramp.from", self.from, "a joint residual to bound (the hybrid has none)");
        }
        if !(self.from > 0.0 && self.from <= 1.0) {
            return refuse("bound_ramp.from", self.from, "a fraction of the scale in (0, 1]");
        }
        if self.samples == 0 {
            return refuse("bound_ramp.samples", 0.0, "at least one training sample");
        }
        Ok(())
    }
}

/// A safety fade: the policy's authority shrinks as the body sinks below the controller's
/// height reference, handing the robot back to the controller alone in two stages. The sag
/// is `(h_ref − z_com) / h_ref`, the CoM's drop below the height the controller holds it at
/// ([`LocomotionController::height_reference`]) as a fraction of that height. Up to a sag
/// of `start` the policy acts in full. Between `start` and the midpoint
/// `m = (start + end) / 2` its steering fades linearly to none (the command returns to the
/// unsteered one, at the controller's acceleration limit); between `m` and `end` its joint
/// residual fades linearly to none; from `end` on the controller acts alone. A state whose
/// CoM height is not finite gets no authority.
///
/// Why the height: a Minitaur hybrid trained near the actuators' limit falls on weak motors
/// by sinking (its body drops below the 0.13 m fall height with the motors saturated),
/// which the policy cannot observe coming. Why two stages: slowing down is the gentle
/// remedy; taking the residual away at once from a gait only the residual holds (a hybrid at
/// 3 m/s, above the controller's own 2.5 m/s trot) felled it more often than it saved it
/// (README, "Robustness": the measured alternatives). The fade is a filter on top of a
/// trained policy: a run may be evaluated with or without it
/// (`centaur_lab::experiment::check_trained_with` ignores it).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fade {
    /// Sag (fraction of the height reference) up to which the policy has full authority.
    pub start: f64,
    /// Sag from which it has none.
    pub end: f64,
}

/// The policy's authority over each part of its action, in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Authority {
    /// Over the joint residual.
    pub residual: f32,
    /// Over the steering.
    pub steering: f32,
}

impl Authority {
    /// Full authority (no fade, or a body that has not sunk).
    pub const FULL: Authority = Authority { residual: 1.0, steering: 1.0 };
}

impl Fade {
    /// The policy's authority at sag `sag` (none for a sag that is not finite).
    pub fn authority(&self, sag: f64) -> Authority {
        if !sag.is_finite() {
            return Authority { residual: 0.0, steering: 0.0 };
        }
        let mid = 0.5 * (self.start + self.end);
        let ramp = |from: f64, to: f64| ((to - sag) / (to - from)).clamp(0.0, 1.0) as f32;
        Authority { residual: ramp(mid, self.end), steering: ramp(self.start, mid) }
    }

    fn validate(&self) -> Result<(), HybridError> {
        for (part, value) in [("fade.start", self.start), ("fade.end", self.end)] {
            if !(value.is_finite() && (0.0..=1.0).contains(&value)) {
                return Err(HybridError::BadSetting {
                    part,
                    value,
                    expected: "a fraction of the height in [0, 1]",
                });
            }
        }
        if self.end <= self.start {
            return Err(HybridError::BadSetting {
                part: "fade.end",
                value: self.end,
                expected: "a sag above fade.start",
            });
        }
        Ok(())
    }
}

/// The residual setup of a hybrid: how large the correction may be, how the policy may
/// steer the command, what the policy sees, and what the controller is commanded.
///
/// Runs record it as data (`experiment.json`); a field missing from a record takes its
/// default here, so a record written before a field existed reads as the setup it ran.
#[derive(Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ResidualConfig {
    /// Residual scale per action entry (one value: the same for every entry), in the
    /// environment's action units (default: 0.3).
    pub scale: Vec<f64>,
    /// Whether the policy outputs a joint residual (default: true). Off, the policy only
    /// steers the command (`steering` must then be on).
    pub joint_residual: bool,
    /// How the policy steers the command (default: off).
    pub steering: Steering,
    /// The learner's initial exploration per action part (`None`, the default: the
    /// learner's own, e.g. PPO's `log_std_init`). Only learners with a per-entry Gaussian
    /// (PPO, A2C) take it.
    pub exploration: Option<Exploration>,
    /// A rising exploration floor for the joint residual (`None`, the default: none;
    /// recorded only where set, so the records of runs without it read as before). Needs
    /// [`ResidualConfig::exploration`] (its start) and the joint residual.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exploration_ramp: Option<ExplorationRamp>,
    /// Off-policy learners (SAC, SAC v1, TD3, DDPG) warm up with the policy's own
    /// exploration around its zero output, i.e. the controller plus noise, instead of
    /// uniformly random actions (default: false, Stable-Baselines3's uniform warm-up).
    pub warmup_with_policy: bool,
    /// Append the reference action to the observation (default: true).
    pub include_reference: bool,
    /// Append the controller's measured body state to the observation (default: false;
    /// recorded only where set, so the records of runs without it read as before): the
    /// CoM's velocity in the heading frame (forward, lateral, vertical, m/s) and its
    /// height (m), [`observed_state`] of the controller's last tick. The controller
    /// estimates these for itself every tick (in simulation: the simulator's base state,
    /// on a robot: its state estimator), so the hybrid's policy sees what its controller
    /// sees; the robot's own observation may lack them (the Minitaur's, PyBullet's, holds
    /// joint angles, velocities, torques and the base orientation, not the body's
    /// velocity, and pure RL on it does not see them either).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub include_state: bool,
    /// The command the controller follows (default: trot at 0.3 m/s); with steering, the
    /// command at zero steering output.
    pub command: Command,
    /// The controller's rated speed (m/s) for the command's gait, replacing the
    /// controller's own (`None`, the default: the controller's own; see
    /// [`ResidualConfig::rate_controller`]; the Minitaur hybrid preset sets 3.5 over the
    /// trot's own 2.5). The controller clamps every steered command to the rating, so the
    /// steering cannot take the gait faster than this; above the controller's own rating the
    /// controller alone is not measured to hold on every body, and the learner has to find
    /// where it does.
    pub rated_speed: Option<f64>,
    /// The safety fade (`None`, the default: the policy acts in full everywhere; recorded
    /// only where set, so the records of runs without it read as before).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fade: Option<Fade>,
    /// A rising residual bound (`None`, the default: the full scale from the start;
    /// recorded only where set, so the records of runs without it read as before).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bound_ramp: Option<BoundRamp>,
    /// Multiplies the period of the command's gait under the hybrid (and its controller-alone
    /// baseline), as [`ResidualConfig::rated_speed`] replaces its rating (`None`, the default:
    /// the controller's own period; recorded only where set). A controller's gait clock
    /// sets the hybrid's cadence: its residual changes how far each step reaches, not how
    /// often the feet step. Walker2d's hybrid on its walk's own 0.8 s cycle ran at ≈ 2.9 m/s
    /// with steps of ≈ 1.2 m, each foot touching down every 0.8 s, while pure PPO ran at
    /// 3.6–4.4 m/s with strides of 0.36–0.66 s; steering the cadence ([`Steering::cadence`])
    /// did not get it out (the policy kept the 0.8 s cycle), a faster clock did (README).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub period_scale: Option<f64>,
    /// The controller's command ramp under the hybrid (and its controller-alone baseline),
    /// m/s², replacing the controller's own `max_acceleration` (`None`, the default: the
    /// controller's own; recorded only where set). Every command, the steered ones too,
    /// reaches the controller through this ramp: at the Minitaur's 3 m/s² a start to
    /// 3.7 m/s takes 1.2 s of a 10 s episode, and a steered speed changes by at most
    /// 0.03 m/s per control step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_acceleration: Option<f64>,
    /// The swing feet's apex height above lift-off and touch-down under the hybrid (and its
    /// controller-alone baseline), m, replacing the controller's own `swing_height` (a
    /// preset's `turn_swing_height`, where set, still holds while it turns) (`None`, the
    /// default: the controller's own; recorded only where set); within
    /// [`SWING_HEIGHT_RANGE`]. The Minitaur's 7 cm were chosen for its 0.3 m/s trot; its
    /// hybrid at 4 m/s and 8 steps a second did better on 3 cm (README, "A lower swing").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub swing_height: Option<f64>,
    /// How often the controller solves its convex MPC under the hybrid (and its
    /// controller-alone baseline), s, replacing the controller's own `mpc_period` (`None`,
    /// the default: the controller's own, 0.02 s on every preset; recorded only where set);
    /// within [`MPC_PERIOD_RANGE`]. Between solves the controller follows the last plan's
    /// forces. A longer period makes every hybrid sample cheaper, and the hybrid learnt less
    /// per sample on it (README, "Where the hybrid's time goes, and a cheaper controller
    /// under it").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mpc_period: Option<f64>,
    /// The controller's cheap torque path under the hybrid (and its controller-alone
    /// baseline) instead of its whole-body QP ([`centaur_mpc::ControlMode::Cheap`]: stance
    /// legs `τ = −J_cᵀ f_MPC`, swing legs Cartesian PD; default: false, the whole-body QP;
    /// recorded only where set). The controller alone is much weaker on it (the Minitaur's
    /// trot at 3 m/s falls within about a second); each sample costs less, and the hybrid
    /// learnt less per sample on it (README, "Where the hybrid's time goes, and a cheaper
    /// controller under it").
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub cheap_torques: bool,
}

/// Every field as `derive(Debug)` writes it, but `fade`, `exploration_ramp`, `bound_ramp`,
/// `period_scale`, `max_acceleration`, `swing_height`, `mpc_period`, `cheap_torques` and
/// `include_state` only where set: error messages name the setup as briefly as its data
/// are recorded (runs record it as JSON, where these are left out at their defaults too).
impl std::fmt::Debug for ResidualConfig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let ResidualConfig {
            scale,
            joint_residual,
            steering,
            exploration,
            exploration_ramp,
            warmup_with_policy,
            include_reference,
            include_state,
            command,
            rated_speed,
            fade,
            bound_ramp,
            period_scale,
            max_acceleration,
            swing_height,
            mpc_period,
            cheap_torques,
        } = self;
        let mut s = f.debug_struct("ResidualConfig");
        s.field("scale", scale)
            .field("joint_residual", joint_residual)
            .field("steering", steering)
            .field("exploration", exploration);
        if let Some(ramp) = exploration_ramp {
            s.field("exploration_ramp", ramp);
        }
        s.field("warmup_with_policy", warmup_with_policy).field("include_reference", include_reference);
        if *include_state {
            s.field("include_state", include_state);
        }
        s.field("command", command).field("rated_speed", rated_speed);
        if let Some(fade) = fade {
            s.field("fade", fade);
        }
        if let Some(ramp) = bound_ramp {
            s.field("bound_ramp", ramp);
        }
        if let Some(scale) = period_scale {
            s.field("period_scale", scale);
        }
        if let Some(a) = max_acceleration {
            s.field("max_acceleration", a);
        }
        if let Some(h) = swing_height {
            s.field("swing_height", h);
        }
        if let Some(p) = mpc_period {
            s.field("mpc_period", p);
        }
        if *cheap_torques {
            s.field("cheap_torques", cheap_torques);
        }
        s.finish()
    }
}

impl Default for ResidualConfig {
    fn default() -> Self {
        ResidualConfig {
            scale: vec![0.3],
            joint_residual: true,
            steering: Steering::OFF,
            exploration: None,
            exploration_ramp: None,
            warmup_with_policy: false,
            include_reference: true,
            include_state: false,
            command: Command::forward(0.3, Gait::Trot),
            rated_speed: None,
            fade: None,
            bound_ramp: None,
            period_scale: None,
            max_acceleration: None,
            swing_height: None,
            mpc_period: None,
            cheap_torques: false,
        }
    }
}

impl ResidualConfig {
    /// The learner's initial exploration σ per entry of a policy of `policy_dim` actions
    /// (joint residual first, then steering), if [`ResidualConfig::exploration`] is set.
    pub fn initial_exploration(&self, policy_dim: usize) -> Option<Vec<f64>> {
        let e = self.exploration?;
        let joints = self.joint_entries(policy_dim);
        Some((0..policy_dim).map(|k| if k < joints { e.residual } else { e.steering }).collect())
    }

    /// How many of a policy's `policy_dim` actions are joint-residual entries (they come
    /// first; the steering entries follow).
    fn joint_entries(&self, policy_dim: usize) -> usize {
        policy_dim - self.steering.dim().min(policy_dim)
    }

    /// A residual of `scale` around the controller following `command`.
    pub fn new(scale: f64, command: Command) -> Self {
        ResidualConfig { scale: vec![scale], command, ..ResidualConfig::default() }
    }

    /// Checks the scale against the action dimension, the steering spans and the
    /// exploration.
    pub fn validate(&self, action_dim: usize) -> Result<(), HybridError> {
        if !(self.scale.len() == 1 || self.scale.len() == action_dim) {
            return Err(HybridError::ScaleLength { entries: self.scale.len(), action_dim });
        }
        if let Some(&value) = self.scale.iter().find(|s| !(s.is_finite() && **s >= 0.0)) {
            return Err(HybridError::BadScale { value });
        }
        for (part, value) in
            [("steering.speed", self.steering.speed), ("steering.yaw_rate", self.steering.yaw_rate)]
        {
            if !value.is_finite() || value < 0.0 {
                return Err(HybridError::BadSetting { part, value, expected: "a finite span ≥ 0" });
            }
        }
        if !(self.steering.cadence.is_finite() && (0.0..=MAX_CADENCE).contains(&self.steering.cadence)) {
            let value = self.steering.cadence;
            return Err(HybridError::BadSetting {
                part: "steering.cadence",
                value,
                expected: "a fraction in [0, 0.75] (the clock's rate 1 ± cadence within the controller's [0.25, 4])",
            });
        }
        if !(self.steering.duty >= 0.0 && centaur_mpc::duty_shift_in_range(self.steering.duty)) {
            let value = self.steering.duty;
            return Err(HybridError::BadSetting {
                part: "steering.duty",
                value,
                expected: "a fraction in [0, 0.3] (the controller's largest shift of the stance fractions)",
            });
        }
        if !(self.steering.swing.is_finite() && (0.0..=MAX_SWING).contains(&self.steering.swing)) {
            let value = self.steering.swing;
            return Err(HybridError::BadSetting {
                part: "steering.swing",
                value,
                expected: "a fraction in [0, 0.75] (the apex 1 ± swing times the controller's swing height)",
            });
        }
        if !(self.steering.foothold.is_finite() && (0.0..=MAX_FOOTHOLD).contains(&self.steering.foothold)) {
            let value = self.steering.foothold;
            return Err(HybridError::BadSetting {
                part: "steering.foothold",
                value,
                expected: "metres in [0, 0.1] (the controller's largest foothold offset)",
            });
        }
        if self.steering.yaw_rate > MAX_YAW_RATE {
            let value = self.steering.yaw_rate;
            return Err(HybridError::BadSetting {
                part: "steering.yaw_rate",
                value,
                expected: "a span ≤ 2π rad/s",
            });
        }
        if let Some(e) = self.exploration {
            for (part, value) in [("exploration.residual", e.residual), ("exploration.steering", e.steering)]
            {
                if !(value > 0.0 && value <= MAX_EXPLORATION) {
                    return Err(HybridError::BadSetting { part, value, expected: "a σ in (0, 10]" });
                }
            }
        }
        if let Some(ramp) = self.exploration_ramp {
            self.validate_ramp(ramp)?;
        }
        self.check_command_values()?;
        if !self.joint_residual && self.steering.dim() == 0 {
            return Err(HybridError::NothingToLearn);
        }
        self.controller_overrides().validate()?;
        if let Some(f) = &self.fade {
            f.validate()?;
        }
        if let Some(ramp) = &self.bound_ramp {
            ramp.validate(self.joint_residual)?;
        }
        Ok(())
    }

    /// `config` with [`ResidualConfig::rated_speed`], if set, as the rating of the
    /// command's gait, [`ResidualConfig::period_scale`], if set, multiplying its period,
    /// [`ResidualConfig::max_acceleration`], if set, as its command ramp and
    /// [`ResidualConfig::swing_height`], if set, as its swing apex,
    /// [`ResidualConfig::mpc_period`], if set, as its MPC period and, with
    /// [`ResidualConfig::cheap_torques`], its cheap torque path:
    /// the controller the hybrid (and the controller-alone baseline beside it) runs. The
    /// gait must be offered and not the stand, which has no speed rating and no period. The
    /// command (at zero steering) must then be within the rating, speed and turning, as
    /// `centaur control` requires: the controller would clamp one outside it, and the run
    /// would not be the one asked for. Steering may go beyond; the controller clamps it (see
    /// `rated_speed`).
    pub fn rate_controller(&self, config: &mut ControllerConfig) -> Result<(), HybridError> {
        self.apply_rating(config)?;
        self.check_command_values()?;
        let c = &self.command;
        config.check_command(c.gait, c.forward_velocity.hypot(c.lateral_velocity), c.yaw_rate)?;
        Ok(())
    }

    /// The ramp's end σ within (0, 10] and at least the start's, a positive sample count,
    /// and something to ramp: an initial exploration and a joint residual.
    fn validate_ramp(&self, ramp: ExplorationRamp) -> Result<(), HybridError> {
        let Some(start) = self.exploration else {
            return Err(HybridError::BadSetting {
                part: "exploration_ramp.residual",
                value: ramp.residual,
                expected: "an initial exploration to ramp from (set exploration)",
            });
        };
        if !self.joint_residual {
            return Err(HybridError::BadSetting {
                part: "exploration_ramp.residual",
                value: ramp.residual,
                expected: "a joint residual to explore (the hybrid has none)",
            });
        }
        if !(ramp.residual > 0.0 && ramp.residual <= MAX_EXPLORATION) {
            let value = ramp.residual;
            return Err(HybridError::BadSetting {
                part: "exploration_ramp.residual",
                value,
                expected: "a σ in (0, 10]",
            });
        }
        if ramp.residual < start.residual {
            return Err(HybridError::BadSetting {
                part: "exploration_ramp.residual",
                value: ramp.residual,
                expected: "a σ at least the initial exploration.residual (the floor rises)",
            });
        }
        if ramp.samples == 0 {
            return Err(HybridError::BadSetting {
                part: "exploration_ramp.samples",
                value: 0.0,
                expected: "at least one training sample",
            });
        }
        Ok(())
    }

    /// The learner's exploration floor for a policy of `policy_dim` actions (joint residual
    /// first, then steering: the steering entries have none), if
    /// [`ResidualConfig::exploration_ramp`] is set.
    pub fn exploration_floor(&self, policy_dim: usize) -> Option<centaur_rl::ExplorationFloor> {
        let (ramp, start) = (self.exploration_ramp?, self.exploration?);
        let joints = self.joint_entries(policy_dim);
        let entries =
            (0..policy_dim).map(|k| (k < joints).then_some([start.residual, ramp.residual])).collect();
        Some(centaur_rl::ExplorationFloor { entries, steps: ramp.samples })
    }

    /// The command's numbers ([`Command::check`]) and a yaw rate within [`MAX_YAW_RATE`].
    fn check_command_values(&self) -> Result<(), HybridError> {
        self.command.check()?;
        let value = self.command.yaw_rate;
        if value.abs() > MAX_YAW_RATE {
            return Err(HybridError::BadSetting {
                part: "command.yaw_rate",
                value,
                expected: "at most 2π rad/s",
            });
        }
        Ok(())
    }

    fn apply_rating(&self, config: &mut ControllerConfig) -> Result<(), HybridError> {
        self.controller_overrides().apply(config)
    }

    /// The part of the setup that overrides the robot's controller preset, for the
    /// command's gait.
    pub fn controller_overrides(&self) -> ControllerOverrides {
        ControllerOverrides {
            gait: self.command.gait,
            rated_speed: self.rated_speed,
            period_scale: self.period_scale,
            max_acceleration: self.max_acceleration,
            swing_height: self.swing_height,
            mpc_period: self.mpc_period,
            cheap_torques: self.cheap_torques,
        }
    }
}

/// The largest yaw rate (rad/s) a command or a yaw-rate steering span may ask for, here and
/// in `centaur control`: one turn a second, far beyond every robot here (the presets turn
/// at up to 0.5 rad/s). A larger one only ramps the yaw reference without end.
pub const MAX_YAW_RATE: f64 = 2.0 * std::f64::consts::PI;

/// The widest cadence span ([`Steering::cadence`]): the gait clock's rate stays within
/// [0.25, 1.75] times its own, inside the range the controller runs its clock at
/// ([`centaur_mpc::GAIT_RATE_RANGE`]), so no steered rate is clamped.
pub const MAX_CADENCE: f64 = 0.75;

/// The widest swing-height span ([`Steering::swing`]): the apex stays within [0.25, 1.75]
/// times the controller's swing height, the range the controller holds its scale in
/// ([`centaur_mpc::SWING_SCALE_RANGE`]), so no steered scale is clamped.
pub const MAX_SWING: f64 = 0.75;

/// The widest foothold span ([`Steering::foothold`], m): the controller's largest foothold
/// offset ([`centaur_mpc::MAX_FOOTHOLD_OFFSET`]), so no steered offset is clamped.
pub const MAX_FOOTHOLD: f64 = 0.1;

/// The largest initial exploration σ accepted ([`Exploration`]), in the policy's [−1, 1]
/// units: at σ 10 nearly every sample already lands outside [−1, 1] and is clipped, and far
/// larger ones (1e308) make the learner's first loss infinite.
pub const MAX_EXPLORATION: f64 = 10.0;

/// The residual law, the steering of the command and the policy's observation layout,
/// with the scale resolved per action entry. See the module docs.
///
/// The policy's action is `[r (the joint residual, one entry per robot action, if on) |
/// c (the steering entries: speed, then yaw rate, then cadence, then duty, those switched
/// on)]`.
#[derive(Clone, Debug)]
pub struct Residual {
    scale: Vec<f32>,
    joint: bool,
    steering: Steering,
    include_reference: bool,
    include_state: bool,
    fade: Option<Fade>,
}

/// Entries of [`observed_state`].
pub const OBSERVED_STATE_DIM: usize = centaur_envs::BODY_STATE_DIM;

/// The body state a hybrid's policy observes with [`ResidualConfig::include_state`], from
/// the controller's last tick: the CoM's velocity turned into the heading frame (the
/// body's yaw; forward, lateral, vertical, m/s) and the CoM's height (m), by
/// [`centaur_envs::heading_body_state`], the law pure RL's `observe_body_state` uses.
/// Non-finite values (a controller that never ticked on a valid state) read as 0.
pub fn observed_state(status: &ControllerStatus) -> [f32; OBSERVED_STATE_DIM] {
    centaur_envs::heading_body_state(status.com, status.com_velocity, status.rpy[2])
}

impl Residual {
    /// The law for a robot of `action_dim` actions.
    pub fn new(config: &ResidualConfig, action_dim: usize) -> Result<Residual, HybridError> {
        config.validate(action_dim)?;
        let scale =
            (0..action_dim).map(|k| *config.scale.get(k).unwrap_or(&config.scale[0]) as f32).collect();
        Ok(Residual {
            scale,
            joint: config.joint_residual,
            steering: config.steering,
            include_reference: config.include_reference,
            include_state: config.include_state,
            fade: config.fade,
        })
    }

    /// The policy's authority now ([`Fade`]): full without a fade, else from the CoM height
    /// the `controller` measured at its last tick against its height reference under
    /// `command`.
    pub fn authority(&self, controller: &LocomotionController, command: &Command) -> Authority {
        let Some(fade) = &self.fade else { return Authority::FULL };
        let h = controller.height_reference(command);
        fade.authority((h - controller.status().com[2]) / h)
    }

    /// Number of the robot's actions.
    pub fn robot_action_dim(&self) -> usize {
        self.scale.len()
    }

    /// Number of the policy's action entries (joint residual, if on, then steering).
    pub fn policy_action_dim(&self) -> usize {
        self.joint_dim() + self.steering.dim()
    }

    fn joint_dim(&self) -> usize {
        if self.joint { self.scale.len() } else { 0 }
    }

    /// Dimension of the policy's observation over a robot observation of `robot_obs_dim`.
    pub fn obs_dim(&self, robot_obs_dim: usize) -> usize {
        robot_obs_dim
            + 5
            + if self.include_reference { self.scale.len() } else { 0 }
            + if self.include_state { OBSERVED_STATE_DIM } else { 0 }
    }

    /// Whether the reference action is part of the observation.
    pub fn includes_reference(&self) -> bool {
        self.include_reference
    }

    /// Whether the controller's body state ([`observed_state`]) is part of the observation.
    pub fn includes_state(&self) -> bool {
        self.include_state
    }

    /// The body state [`Residual::observation`] takes: [`observed_state`] of `status` where
    /// the observation includes it, zeros (ignored, and not computed) where it does not.
    pub fn state_of(&self, status: &ControllerStatus) -> [f32; OBSERVED_STATE_DIM] {
        if self.include_state { observed_state(status) } else { [0.0; OBSERVED_STATE_DIM] }
    }

    /// `applied = clip(reference + g · scale ⊙ clip(r, −1, 1), low, high)`, per entry, with
    /// `r` the joint-residual part of the policy's `output` and `g` the policy's
    /// `authority` over it ([`Residual::authority`]; 1 without a fade); without a joint
    /// residual, `applied = reference`. Returns `Σ (g · scale ⊙ clip(r))²`, the squared
    /// size of the correction.
    #[track_caller]
    pub fn apply(
        &self,
        reference: &[f32],
        output: &[f32],
        authority: f32,
        low: &[f32],
        high: &[f32],
        applied: &mut [f32],
    ) -> f64 {
        let m = self.scale.len();
        assert!(
            reference.len() == m && output.len() == self.policy_action_dim() && applied.len() == m,
            "Residual::apply: {} actions and {} policy outputs, got reference {}, output {}, applied {}",
            m,
            self.policy_action_dim(),
            reference.len(),
            output.len(),
            applied.len()
        );
        if !self.joint {
            applied.copy_from_slice(reference);
            return 0.0;
        }
        let mut sq = 0.0f64;
        for k in 0..m {
            let r = self.scale[k] * (authority * output[k].clamp(-1.0, 1.0));
            sq += (r as f64) * (r as f64);
            applied[k] = (reference[k] + r).clamp(low[k], high[k]);
        }
        sq
    }

    /// One step of the hybrid on the controller's `reference` action, the sequence training
    /// ([`crate::residual::ResidualEnv`]) and deployment ([`crate::deploy::HybridStack`])
    /// share: the policy's authority now ([`Residual::authority`], at the command it
    /// steered last, `steered`), the law applied to its `output` within `bound` of the
    /// scale (the rising bound's fraction in training, 1 deployed) into `applied`
    /// ([`Residual::apply`]), then the command steered from `base` into `steered` and the
    /// gait clock's rate steered, for the controller's next tick. Returns
    /// [`Residual::apply`]'s squared correction.
    #[allow(clippy::too_many_arguments)]
    pub fn act(
        &self,
        controller: &mut LocomotionController,
        base: &Command,
        steered: &mut Command,
        reference: &[f32],
        output: &[f32],
        bound: f32,
        space: &centaur_gym::BoxSpace,
        applied: &mut [f32],
    ) -> f64 {
        let g = self.authority(controller, steered);
        let sq = self.apply(reference, output, g.residual * bound, &space.low, &space.high, applied);
        *steered = self.steer(base, output, g.steering);
        self.steer_gait(controller, output, g.steering);
        sq
    }

    /// The policy's observation ([`Residual::observation`]) from the robot's `sensors`, the
    /// controller's status (its phase and, where observed, its state), the command it
    /// follows and its `reference` action.
    pub fn observe(
        &self,
        controller: &LocomotionController,
        sensors: &[f32],
        command: &Command,
        reference: &[f32],
        obs: &mut [f32],
    ) {
        let status = controller.status();
        let state = self.state_of(status);
        self.observation(sensors, status.phase, command, reference, &state, obs);
    }

    /// The command the policy's `output` steers `base` to, each steering entry scaled by
    /// the policy's `authority` over the steering ([`Residual::authority`]; 1 without a
    /// fade), `base` itself without steering, for a zero output or at no authority.
    pub fn steer(&self, base: &Command, output: &[f32], authority: f32) -> Command {
        let mut cmd = *base;
        if let Some(c) = self.steering_entry(output, authority, Steering::SPEED) {
            cmd.forward_velocity = base.forward_velocity + self.steering.speed * c;
        }
        if let Some(c) = self.steering_entry(output, authority, Steering::YAW_RATE) {
            cmd.yaw_rate = base.yaw_rate + self.steering.yaw_rate * c;
        }
        cmd
    }

    /// The steering entry of `part` ([`Steering::SPEED`], [`Steering::YAW_RATE`],
    /// [`Steering::CADENCE`] or [`Steering::DUTY`]) as the policy's `output` gives it, `g · clip(c, −1, 1)` with `g` the
    /// `authority` over the steering; `None` where that part is off.
    fn steering_entry(&self, output: &[f32], authority: f32, part: usize) -> Option<f64> {
        let k = self.joint_dim() + self.steering.entry(part)?;
        Some((authority * output.get(k).copied().unwrap_or(0.0).clamp(-1.0, 1.0)) as f64)
    }

    /// The gait clock's rate the policy's `output` steers to, `1 + cadence · g · clip(c, −1,
    /// 1)` with `c` its cadence entry and `g` the `authority` over the steering; `None`
    /// without cadence steering (the clock keeps its own rate).
    pub fn gait_rate(&self, output: &[f32], authority: f32) -> Option<f64> {
        self.steering_entry(output, authority, Steering::CADENCE).map(|c| 1.0 + self.steering.cadence * c)
    }

    /// The shift of the stance fractions the policy's `output` steers to, `duty · g ·
    /// clip(c, −1, 1)` with `c` its duty entry (after the cadence) and `g` the
    /// `authority` over the steering; `None` without duty steering (the gaits keep their
    /// own).
    pub fn duty_shift(&self, output: &[f32], authority: f32) -> Option<f64> {
        self.steering_entry(output, authority, Steering::DUTY).map(|c| self.steering.duty * c)
    }

    /// The scale of the swing apex the policy's `output` steers to, `1 + swing · g ·
    /// clip(c, −1, 1)` with `c` its swing entry (after the duty) and `g` the
    /// `authority` over the steering; `None` without swing steering (the controller's own
    /// height).
    pub fn swing_scale(&self, output: &[f32], authority: f32) -> Option<f64> {
        self.steering_entry(output, authority, Steering::SWING).map(|c| 1.0 + self.steering.swing * c)
    }

    /// The foothold offset (m, forward along the heading) the policy's `output` steers to,
    /// `foothold · g · clip(c, −1, 1)` with `c` its foothold entry (the last steering entry)
    /// and `g` the `authority` over the steering; `None` without foothold steering (the
    /// controller's own footholds).
    pub fn foothold_offset(&self, output: &[f32], authority: f32) -> Option<f64> {
        self.steering_entry(output, authority, Steering::FOOTHOLD).map(|c| self.steering.foothold * c)
    }

    /// Steers `controller`'s gait as the policy's `output` says: its clock's rate
    /// ([`Residual::gait_rate`]), its stance fractions ([`Residual::duty_shift`]), its
    /// swing apex ([`Residual::swing_scale`]) and its footholds
    /// ([`Residual::foothold_offset`]), each only where the policy steers it.
    pub fn steer_gait(&self, controller: &mut LocomotionController, output: &[f32], authority: f32) {
        if let Some(rate) = self.gait_rate(output, authority) {
            controller.set_gait_rate(rate);
        }
        if let Some(shift) = self.duty_shift(output, authority) {
            controller.set_gait_duty_shift(shift);
        }
        if let Some(scale) = self.swing_scale(output, authority) {
            controller.set_swing_height_scale(scale);
        }
        if let Some(offset) = self.foothold_offset(output, authority) {
            controller.set_foothold_offset(offset);
        }
    }

    /// The policy's observation: the robot's observation, the gait phase
    /// `(sin 2πφ, cos 2πφ)`, the command `(v_x, v_y, ω_z)`, (if included) the reference
    /// action and (if included) the controller's body `state` ([`observed_state`]; ignored
    /// where not included).
    #[track_caller]
    pub fn observation(
        &self,
        robot_obs: &[f32],
        phase: f64,
        command: &Command,
        reference: &[f32],
        state: &[f32; OBSERVED_STATE_DIM],
        out: &mut [f32],
    ) {
        let n = robot_obs.len();
        assert!(
            out.len() == self.obs_dim(n),
            "residual observation: {} entries, expected {}",
            out.len(),
            self.obs_dim(n)
        );
        out[..n].copy_from_slice(robot_obs);
        let (s, c) = (2.0 * std::f64::consts::PI * phase).sin_cos();
        out[n..n + 5].copy_from_slice(&[
            s as f32,
            c as f32,
            command.forward_velocity as f32,
            command.lateral_velocity as f32,
            command.yaw_rate as f32,
        ]);
        let mut k = n + 5;
        if self.include_reference {
            out[k..k + self.scale.len()].copy_from_slice(reference);
            k += self.scale.len();
        }
        if self.include_state {
            out[k..].copy_from_slice(state);
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
    pub fn new(
        model: &Model,
        actuated: &[usize],
        controller: &LocomotionController,
    ) -> Result<Self, HybridError> {
        let names = controller.joint_names();
        let mut map = Vec::with_capacity(actuated.len());
        for &j in actuated {
            let joint = &model.joints[j];
            if joint.nq() != 1 || joint.nv() != 1 {
                return Err(HybridError::NotOneCoordinate { joint: joint.name.clone() });
            }
            let k = names
                .iter()
                .position(|n| *n == joint.name)
                .ok_or_else(|| HybridError::NotDriven { joint: joint.name.clone() })?;
            map.push((k, joint.idx_q, joint.idx_v));
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

    /// The feed-forward torques `τ_ff` of `cmd` alone.
    pub fn feed_forward(&mut self, cmd: &JointCommand) -> &[f64] {
        for (t, &(k, _, _)) in self.tau.iter_mut().zip(&self.map) {
            *t = cmd.tau[k];
        }
        &self.tau
    }

    /// The servo targets `[q*, q̇*, kp, kd]` of `cmd`, in actuator order, into `out`.
    pub fn servo_targets(&self, cmd: &JointCommand, out: &mut [Vec<f64>; 4]) {
        for (i, &(k, _, _)) in self.map.iter().enumerate() {
            out[0][i] = cmd.q_des[k];
            out[1][i] = cmd.qd_des[k];
            out[2][i] = cmd.kp[k];
            out[3][i] = cmd.kd[k];
        }
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

/// Maps a controller's joint command to a simulated robot's actions, and ticks the
/// controller with the robot's measured foot contacts.
///
/// Each environment step the controller ticks once on the robot state the simulator
/// reports (its only view of the robot). Where the robot has a joint servo
/// ([`RobotEnv::set_servo`]: the torque-actuated Gymnasium robots) the command's PD part
/// goes to it, evaluated at every physics step as motor drivers would, and the action
/// carries the feed-forward torque; otherwise the command becomes joint torques at that
/// state ([`CommandTorques`]). The environment turns torques into its own actions
/// ([`RobotEnv::action_for_torques`]: torque/gear for the Gymnasium robots, the inverted DC
/// motor model and leg model for the Minitaur). Every runner — `centaur control`, the hybrid
/// env, the experiment's controller baseline and the deployed stack — ticks the controller
/// this way, so they all run the same controller, and an untrained hybrid acts exactly
/// like the controller.
#[derive(Clone, Debug)]
pub struct ActionMapping {
    torques: CommandTorques,
    contacts: ContactMap,
    servo: [Vec<f64>; 4],
    /// Whether the env took servo targets (known after the first action; an env without a
    /// servo is not asked again, so the Minitaur's ticks do no servo work).
    has_servo: Option<bool>,
}

impl ActionMapping {
    /// Matches the env's actuated joints and feet with the controller's joints and contact
    /// points by name.
    pub fn new(env: &dyn RobotEnv, controller: &LocomotionController) -> Result<ActionMapping, HybridError> {
        let torques = CommandTorques::new(env.model(), env.actuated_joints(), controller)?;
        let n = env.actuated_joints().len();
        Ok(ActionMapping {
            torques,
            contacts: ContactMap::new(controller, env.foot_frames()),
            servo: std::array::from_fn(|_| vec![0.0; n]),
            has_servo: None,
        })
    }

    /// One controller tick at the env's state and time `t`: with the env's measured foot
    /// contacts when every contact point of the controller has a foot in the env, else on
    /// the gait schedule alone ([`ContactMap`]).
    pub fn tick<'c>(
        &mut self,
        controller: &'c mut LocomotionController,
        env: &dyn RobotEnv,
        command: &Command,
        t: f64,
    ) -> &'c JointCommand {
        self.contacts.tick(controller, env.robot_state(), command, t, |out| {
            for (o, foot) in out.iter_mut().zip(env.foot_contacts()) {
                *o = foot.in_contact;
            }
        })
    }

    /// The joint torques of `cmd` at the env's current state (action order).
    pub fn torques(&mut self, env: &dyn RobotEnv, cmd: &JointCommand) -> &[f64] {
        self.torques.torques(env.robot_state(), cmd)
    }

    /// The env action realising `cmd` at the env's current state, after handing the
    /// command's PD part to the env's servo where it has one.
    pub fn action(&mut self, env: &mut dyn RobotEnv, cmd: &JointCommand, out: &mut [f32]) {
        if self.has_servo != Some(false) {
            self.torques.servo_targets(cmd, &mut self.servo);
            let [q, qd, kp, kd] = &self.servo;
            let taken = env.set_servo(Some(Servo { q, qd, kp, kd }));
            self.has_servo = Some(taken);
            if taken {
                let tau = self.torques.feed_forward(cmd);
                env.action_for_torques(tau, out);
                return;
            }
        }
        let tau = self.torques.torques(env.robot_state(), cmd);
        env.action_for_torques(tau, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use centaur_mpc::{ConfigError, ControlMode};

    #[test]
    fn the_residual_law_clips_the_output_then_the_sum() {
        // scale 0.25: an output of 2 counts as 1 (a correction of 0.25); 0.9 + 0.25 clips to 1.
        let config = ResidualConfig::new(0.25, Command::stand());
        let r = Residual::new(&config, 3).unwrap();
        let mut applied = [0.0f32; 3];
        let sq = r.apply(&[0.9, 0.0, -0.5], &[2.0, -0.4, 0.0], 1.0, &[-1.0; 3], &[1.0; 3], &mut applied);
        assert_eq!(applied, [1.0, -0.1, -0.5]);
        // (0.25)² + (0.1)² in f32 products summed in f64.
        let want = (0.25f32 as f64).powi(2) + ((0.25f32 * -0.4) as f64).powi(2);
        assert_eq!(sq, want);
    }

    #[test]
    fn scales_are_checked() {
        let bad = ResidualConfig { scale: vec![0.1, 0.2], ..ResidualConfig::default() };
        assert!(matches!(
            Residual::new(&bad, 3),
            Err(HybridError::ScaleLength { entries: 2, action_dim: 3 })
        ));
        let nan = ResidualConfig { scale: vec![f64::NAN], ..ResidualConfig::default() };
        assert!(matches!(Residual::new(&nan, 3), Err(HybridError::BadScale { .. })));
        let per_entry = ResidualConfig { scale: vec![0.1, 0.2, 0.3], ..ResidualConfig::default() };
        assert_eq!(Residual::new(&per_entry, 3).unwrap().robot_action_dim(), 3);
    }

    /// `r`'s observation of a 3-entry robot observation `[1, 2, 3]` at `phase` under a 0.5 m/s
    /// trot, with the reference `[0.7, −0.7]` and the body `state`.
    fn observe(r: &Residual, phase: f64, state: &[f32; OBSERVED_STATE_DIM]) -> Vec<f32> {
        let mut out = vec![0.0f32; r.obs_dim(3)];
        r.observation(
            &[1.0, 2.0, 3.0],
            phase,
            &Command::forward(0.5, Gait::Trot),
            &[0.7, -0.7],
            state,
            &mut out,
        );
        out
    }

    #[test]
    fn the_observation_appends_phase_command_and_reference() {
        let r = Residual::new(&ResidualConfig::new(0.3, Command::forward(0.5, Gait::Trot)), 2).unwrap();
        let out = observe(&r, 0.25, &[9.0; OBSERVED_STATE_DIM]);
        // φ = 1/4: (sin π/2, cos π/2) = (1, 0).
        assert_eq!(out.len(), 3 + 5 + 2);
        assert_eq!(&out[..3], &[1.0, 2.0, 3.0]);
        assert!((out[3] - 1.0).abs() < 1e-7 && out[4].abs() < 1e-7);
        assert_eq!(&out[5..8], &[0.5, 0.0, 0.0]);
        assert_eq!(&out[8..], &[0.7, -0.7]);
    }

    #[test]
    fn the_observation_appends_the_body_state_last_and_only_where_asked() {
        let config = ResidualConfig {
            include_state: true,
            ..ResidualConfig::new(0.3, Command::forward(0.5, Gait::Trot))
        };
        let r = Residual::new(&config, 2).unwrap();
        assert!(r.includes_state());
        let state = [1.5, -0.25, 0.125, 0.2];
        let out = observe(&r, 0.0, &state);
        assert_eq!(out.len(), 3 + 5 + 2 + OBSERVED_STATE_DIM);
        assert_eq!(&out[8..10], &[0.7, -0.7]);
        assert_eq!(&out[10..], &state);
        // Without the reference, the state follows the command.
        let bare = Residual::new(&ResidualConfig { include_reference: false, ..config.clone() }, 2).unwrap();
        assert_eq!(&observe(&bare, 0.0, &state)[8..], &state);
        // Off (the default), nothing is appended and the records read as before.
        let off = ResidualConfig::default();
        assert!(!Residual::new(&off, 2).unwrap().includes_state());
        assert!(!format!("{off:?}").contains("include_state"));
        assert!(!serde_json::to_string(&off).unwrap().contains("include_state"));
        assert!(format!("{config:?}").contains("include_state: true"));
        let text = serde_json::to_string(&config).unwrap();
        assert!(text.contains("\"include_state\":true"), "{text}");
        assert_eq!(serde_json::from_str::<ResidualConfig>(&text).unwrap(), config);
    }

    #[test]
    fn the_observed_state_turns_the_velocity_into_the_heading_frame() {
        // Heading along +y: the world's +y is forward, the world's +x is to the right.
        let yaw = std::f64::consts::FRAC_PI_2;
        let com = [4.0, 5.0, 0.19];
        let [f, l, v, h] = centaur_envs::heading_body_state(com, [0.0, 2.0, -0.1], yaw);
        assert!((f - 2.0).abs() < 1e-6 && l.abs() < 1e-6, "({f}, {l})");
        assert_eq!((v, h), (-0.1, 0.19));
        let [f, l, ..] = centaur_envs::heading_body_state(com, [1.0, 0.0, 0.0], yaw);
        assert!(f.abs() < 1e-6 && (l + 1.0).abs() < 1e-6, "({f}, {l})");
        assert_eq!(centaur_envs::heading_body_state(com, [f64::NAN, 0.0, 0.0], yaw)[0], 0.0);
    }

    #[test]
    fn steering_maps_the_policy_output_onto_the_command() {
        let base = Command::forward(2.0, Gait::Trot);
        let config = ResidualConfig {
            steering: Steering { speed: 0.5, yaw_rate: 0.2, ..Steering::OFF },
            ..ResidualConfig::new(0.25, base)
        };
        let r = Residual::new(&config, 3).unwrap();
        assert_eq!(r.policy_action_dim(), 5);
        // [r₀ r₁ r₂ | c_speed c_yaw]
        assert_eq!(r.steer(&base, &[0.0; 5], 1.0), base);
        let c = r.steer(&base, &[9.0, 9.0, 9.0, 1.0, -0.5], 1.0);
        assert_eq!((c.forward_velocity, c.yaw_rate, c.gait), (2.5, -0.1, Gait::Trot));
        // Outputs beyond ±1 are clipped like the residual's.
        assert_eq!(r.steer(&base, &[0.0, 0.0, 0.0, -3.0, 0.0], 1.0).forward_velocity, 1.5);
        // The joint residual reads only its own entries.
        let mut applied = [0.0f32; 3];
        r.apply(&[0.1, 0.2, 0.3], &[0.0, 0.0, 0.0, 1.0, 1.0], 1.0, &[-1.0; 3], &[1.0; 3], &mut applied);
        assert_eq!(applied, [0.1, 0.2, 0.3]);
    }

    #[test]
    fn the_cadence_steers_the_gait_clock_last_and_is_checked_and_recorded_only_where_set() {
        let base = Command::forward(1.0, Gait::Walk);
        let config = ResidualConfig {
            steering: Steering { speed: 0.5, yaw_rate: 0.0, cadence: 0.4, ..Steering::OFF },
            ..ResidualConfig::new(0.25, base)
        };
        let r = Residual::new(&config, 3).unwrap();
        // [r₀ r₁ r₂ | c_speed c_cadence]
        assert_eq!(r.policy_action_dim(), 5);
        assert_eq!(r.gait_rate(&[0.0; 5], 1.0), Some(1.0));
        let out = [0.0, 0.0, 0.0, 0.2, 1.0];
        assert!((r.gait_rate(&out, 1.0).unwrap() - 1.4).abs() < 1e-12);
        assert!((r.steer(&base, &out, 1.0).forward_velocity - 1.1).abs() < 1e-6);
        // Clipped like every entry, scaled by the authority.
        assert!((r.gait_rate(&[0.0, 0.0, 0.0, 0.0, -5.0], 0.5).unwrap() - 0.8).abs() < 1e-6);
        // Cadence alone: its own entry; without it, no rate.
        let alone = ResidualConfig { steering: Steering { cadence: 0.5, ..Steering::OFF }, ..config.clone() };
        let r = Residual::new(&alone, 3).unwrap();
        assert_eq!(r.policy_action_dim(), 4);
        assert_eq!(r.gait_rate(&[1.0, 1.0, 1.0, -1.0], 1.0), Some(0.5));
        let without = ResidualConfig { steering: Steering { speed: 0.5, ..Steering::OFF }, ..config.clone() };
        assert_eq!(Residual::new(&without, 3).unwrap().gait_rate(&[1.0; 4], 1.0), None);
        // A span outside [0, 0.75] or not finite is refused.
        for bad in [-0.1, 0.8, 0.95, f64::NAN, f64::INFINITY] {
            let c = ResidualConfig { steering: Steering { cadence: bad, ..Steering::OFF }, ..config.clone() };
            assert!(
                matches!(Residual::new(&c, 3), Err(HybridError::BadSetting { part: "steering.cadence", .. })),
                "{bad}"
            );
        }
        // Written (text and data) only where set.
        assert_eq!(format!("{:?}", without.steering), "Steering { speed: 0.5, yaw_rate: 0.0 }");
        assert_eq!(format!("{:?}", config.steering), "Steering { speed: 0.5, yaw_rate: 0.0, cadence: 0.4 }");
        let json = serde_json::to_string(&without.steering).unwrap();
        assert_eq!(json, r#"{"speed":0.5,"yaw_rate":0.0}"#);
        let back: Steering = serde_json::from_str(&json).unwrap();
        assert_eq!(back, without.steering);
        let json = serde_json::to_string(&config.steering).unwrap();
        assert_eq!(serde_json::from_str::<Steering>(&json).unwrap(), config.steering);
    }

    #[test]
    fn the_duty_steers_the_stance_fractions_last_and_is_checked_and_recorded_only_where_set() {
        let base = Command::forward(1.0, Gait::Trot);
        let config = ResidualConfig {
            steering: Steering { speed: 0.5, yaw_rate: 0.0, cadence: 0.4, duty: 0.2, ..Steering::OFF },
            ..ResidualConfig::new(0.25, base)
        };
        let r = Residual::new(&config, 3).unwrap();
        assert_eq!(r.policy_action_dim(), 6);
        // [r₀ r₁ r₂ | c_speed c_cadence c_duty]
        assert_eq!(r.duty_shift(&[0.0; 6], 1.0), Some(0.0));
        let out = [0.0, 0.0, 0.0, 0.2, 0.5, -0.5];
        assert!((r.duty_shift(&out, 1.0).unwrap() + 0.1).abs() < 1e-12);
        assert!((r.gait_rate(&out, 1.0).unwrap() - 1.2).abs() < 1e-12);
        assert!((r.steer(&base, &out, 1.0).forward_velocity - 1.1).abs() < 1e-6);
        // Clipped to [−1, 1] and scaled by the authority.
        assert!((r.duty_shift(&[0.0, 0.0, 0.0, 0.0, 0.0, 5.0], 0.5).unwrap() - 0.1).abs() < 1e-12);
        // Alone, it is the only steering entry; off, there is none.
        let alone = ResidualConfig { steering: Steering { duty: 0.3, ..Steering::OFF }, ..config.clone() };
        let r = Residual::new(&alone, 3).unwrap();
        assert_eq!((r.policy_action_dim(), r.gait_rate(&[1.0; 4], 1.0)), (4, None));
        assert!((r.duty_shift(&[1.0, 1.0, 1.0, -1.0], 1.0).unwrap() + 0.3).abs() < 1e-12);
        let without =
            ResidualConfig { steering: Steering { duty: 0.0, ..config.steering }, ..config.clone() };
        assert_eq!(Residual::new(&without, 3).unwrap().duty_shift(&[1.0; 5], 1.0), None);
        for bad in [-0.1, 0.31, f64::NAN, f64::INFINITY] {
            let c = ResidualConfig { steering: Steering { duty: bad, ..Steering::OFF }, ..config.clone() };
            assert!(
                matches!(Residual::new(&c, 3), Err(HybridError::BadSetting { part: "steering.duty", .. })),
                "{bad}"
            );
        }
        // Recorded (text and data) only where set.
        assert_eq!(format!("{:?}", without.steering), "Steering { speed: 0.5, yaw_rate: 0.0, cadence: 0.4 }");
        assert_eq!(
            format!("{:?}", config.steering),
            "Steering { speed: 0.5, yaw_rate: 0.0, cadence: 0.4, duty: 0.2 }"
        );
        let json = serde_json::to_string(&config.steering).unwrap();
        assert_eq!(json, r#"{"speed":0.5,"yaw_rate":0.0,"cadence":0.4,"duty":0.2}"#);
        assert_eq!(serde_json::from_str::<Steering>(&json).unwrap(), config.steering);
        assert!(!serde_json::to_string(&without.steering).unwrap().contains("duty"));
    }

    #[test]
    fn the_swing_steers_the_apex_last_and_is_checked_and_recorded_only_where_set() {
        let base = Command::forward(1.0, Gait::Trot);
        let config = ResidualConfig {
            steering: Steering { speed: 0.5, cadence: 0.4, duty: 0.2, swing: 0.5, ..Steering::OFF },
            ..ResidualConfig::new(0.25, base)
        };
        let r = Residual::new(&config, 3).unwrap();
        // [r₀ r₁ r₂ | c_speed c_cadence c_duty c_swing]
        assert_eq!(r.policy_action_dim(), 7);
        assert_eq!(r.swing_scale(&[0.0; 7], 1.0), Some(1.0));
        let out = [0.0, 0.0, 0.0, 0.2, 0.5, -0.5, -0.6];
        assert!((r.swing_scale(&out, 1.0).unwrap() - 0.7).abs() < 1e-6);
        assert!((r.duty_shift(&out, 1.0).unwrap() + 0.1).abs() < 1e-12);
        assert!((r.gait_rate(&out, 1.0).unwrap() - 1.2).abs() < 1e-12);
        // Clipped to [−1, 1] and scaled by the authority.
        assert!((r.swing_scale(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0], 0.5).unwrap() - 1.25).abs() < 1e-12);
        // Alone, it is the only steering entry; off, there is none.
        let alone = ResidualConfig { steering: Steering { swing: 0.75, ..Steering::OFF }, ..config.clone() };
        let r = Residual::new(&alone, 3).unwrap();
        assert_eq!((r.policy_action_dim(), r.duty_shift(&[1.0; 4], 1.0)), (4, None));
        assert_eq!(r.swing_scale(&[1.0, 1.0, 1.0, -1.0], 1.0), Some(0.25));
        let without =
            ResidualConfig { steering: Steering { swing: 0.0, ..config.steering }, ..config.clone() };
        assert_eq!(Residual::new(&without, 3).unwrap().swing_scale(&[1.0; 6], 1.0), None);
        // The span's range is the controller's: no steered scale is clamped; the error's text
        // names it.
        assert_eq!((1.0 - MAX_SWING, 1.0 + MAX_SWING), centaur_mpc::SWING_SCALE_RANGE);
        let c = ResidualConfig { steering: Steering { swing: 0.8, ..Steering::OFF }, ..config.clone() };
        let err = Residual::new(&c, 3).unwrap_err().to_string();
        assert!(err.contains(&format!("[0, {MAX_SWING}]")), "{err}");
        let swing = |s: &mut Steering, x| s.swing = x;
        let (debug, json) = (", duty: 0.2, swing: 0.5 }", r#","swing":0.5}"#);
        span_refused_and_recorded_only_where_set(
            &config,
            swing,
            "swing",
            &[-0.1, 0.8, f64::NAN, f64::INFINITY],
            debug,
            json,
        );
    }

    /// What every gait-steering span shares: each `bad` span (alone) is refused naming
    /// `steering.{name}`, and the span is recorded, as text and as data, only where set —
    /// `config`'s steering (Debug text ending in `debug_tail`, JSON in `json_tail`) with it,
    /// the same with `set` to 0 without it.
    fn span_refused_and_recorded_only_where_set(
        config: &ResidualConfig,
        set: fn(&mut Steering, f64),
        name: &str,
        bad: &[f64],
        debug_tail: &str,
        json_tail: &str,
    ) {
        let part = format!("steering.{name}");
        for &b in bad {
            let mut steering = Steering::OFF;
            set(&mut steering, b);
            let got = Residual::new(&ResidualConfig { steering, ..config.clone() }, 3).err();
            assert!(
                matches!(&got, Some(HybridError::BadSetting { part: p, .. }) if *p == part),
                "{name} = {b}: {got:?}"
            );
        }
        let mut without = config.steering;
        set(&mut without, 0.0);
        assert!(!format!("{without:?}").contains(name));
        assert!(format!("{:?}", config.steering).ends_with(debug_tail));
        let json = serde_json::to_string(&config.steering).unwrap();
        assert!(json.ends_with(json_tail), "{json}");
        assert_eq!(serde_json::from_str::<Steering>(&json).unwrap(), config.steering);
        assert!(!serde_json::to_string(&without).unwrap().contains(name));
    }

    #[test]
    fn the_foothold_steers_the_offset_last_and_is_checked_and_recorded_only_where_set() {
        let base = Command::forward(1.0, Gait::Trot);
        let config = ResidualConfig {
            steering: Steering { speed: 0.5, cadence: 0.4, swing: 0.5, foothold: 0.08, ..Steering::OFF },
            ..ResidualConfig::new(0.25, base)
        };
        let r = Residual::new(&config, 3).unwrap();
        // [r₀ r₁ r₂ | c_speed c_cadence c_swing c_foothold]
        assert_eq!(r.policy_action_dim(), 7);
        assert_eq!(r.foothold_offset(&[0.0; 7], 1.0), Some(0.0));
        let out = [0.0, 0.0, 0.0, 0.2, 0.5, -0.6, 0.5];
        assert!((r.foothold_offset(&out, 1.0).unwrap() - 0.04).abs() < 1e-9);
        assert!((r.swing_scale(&out, 1.0).unwrap() - 0.7).abs() < 1e-6);
        assert!((r.gait_rate(&out, 1.0).unwrap() - 1.2).abs() < 1e-12);
        // Clipped to [−1, 1] and scaled by the authority.
        let far = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -5.0];
        assert!((r.foothold_offset(&far, 0.5).unwrap() + 0.04).abs() < 1e-9);
        // Alone, it is the only steering entry; off, there is none.
        let alone =
            ResidualConfig { steering: Steering { foothold: 0.1, ..Steering::OFF }, ..config.clone() };
        let r = Residual::new(&alone, 3).unwrap();
        assert_eq!((r.policy_action_dim(), r.swing_scale(&[1.0; 4], 1.0)), (4, None));
        assert!((r.foothold_offset(&[1.0, 1.0, 1.0, -1.0], 1.0).unwrap() + 0.1).abs() < 1e-9);
        let without =
            ResidualConfig { steering: Steering { foothold: 0.0, ..config.steering }, ..config.clone() };
        assert_eq!(Residual::new(&without, 3).unwrap().foothold_offset(&[1.0; 6], 1.0), None);
        // The span's range is the controller's: no steered offset is clamped.
        assert_eq!(MAX_FOOTHOLD, centaur_mpc::MAX_FOOTHOLD_OFFSET);
        let foothold = |s: &mut Steering, x| s.foothold = x;
        let (debug, json) = (", swing: 0.5, foothold: 0.08 }", r#","foothold":0.08}"#);
        span_refused_and_recorded_only_where_set(
            &config,
            foothold,
            "foothold",
            &[-0.01, 0.11, f64::NAN, f64::INFINITY],
            debug,
            json,
        );
    }

    #[test]
    fn the_fade_hands_the_robot_back_to_the_controller_as_the_body_sinks() {
        // Steering fades over [0.1, 0.15], then the residual over [0.15, 0.2].
        let fade = Fade { start: 0.1, end: 0.2 };
        let a = |sag: f64| {
            let a = fade.authority(sag);
            (a.steering, a.residual)
        };
        assert_eq!(a(-0.5), (1.0, 1.0));
        assert_eq!(a(0.1), (1.0, 1.0));
        let (steer, residual) = a(0.125);
        assert!((steer - 0.5).abs() < 1e-6 && residual == 1.0, "{steer} {residual}");
        let (steer, residual) = a(0.16);
        assert!(steer == 0.0 && (residual - 0.8).abs() < 1e-6, "{steer} {residual}");
        let (steer, residual) = a(0.175);
        assert!(steer == 0.0 && (residual - 0.5).abs() < 1e-6, "{steer} {residual}");
        assert_eq!(a(0.2), (0.0, 0.0));
        assert_eq!(a(3.0), (0.0, 0.0));
        assert_eq!(a(f64::NAN), (0.0, 0.0));
        // At authority g the residual and the steering are g times the policy's.
        let base = Command::forward(2.0, Gait::Trot);
        let config = ResidualConfig {
            steering: Steering { speed: 1.0, ..Steering::OFF },
            fade: Some(fade),
            ..ResidualConfig::new(0.25, base)
        };
        let r = Residual::new(&config, 2).unwrap();
        let mut applied = [0.0f32; 2];
        let out = [1.0, -1.0, 1.0];
        r.apply(&[0.1, 0.2], &out, 0.5, &[-1.0; 2], &[1.0; 2], &mut applied);
        assert_eq!(applied, [0.1 + 0.125, 0.2 - 0.125]);
        assert_eq!(r.steer(&base, &out, 0.5).forward_velocity, 2.5);
        assert_eq!(r.apply(&[0.1, 0.2], &out, 0.0, &[-1.0; 2], &[1.0; 2], &mut applied), 0.0);
        assert_eq!((applied, r.steer(&base, &out, 0.0)), ([0.1, 0.2], base));
        // Settings outside [0, 1] or with end ≤ start are refused, naming the field.
        for (start, end, part) in [
            (0.2, 0.1, "fade.end"),
            (0.1, 0.1, "fade.end"),
            (-0.1, 0.2, "fade.start"),
            (0.1, f64::NAN, "fade.end"),
        ] {
            let bad = ResidualConfig { fade: Some(Fade { start, end }), ..config.clone() };
            match Residual::new(&bad, 2) {
                Err(HybridError::BadSetting { part: p, .. }) => assert_eq!(p, part),
                other => panic!("{start}, {end}: {other:?}"),
            }
        }
        // Without a fade the record holds no `fade` key and the text none either.
        let text = serde_json::to_string(&ResidualConfig::default()).unwrap();
        assert!(!text.contains("fade"), "{text}");
        assert_eq!(
            format!("{:?}", ResidualConfig::default()),
            "ResidualConfig { scale: [0.3], joint_residual: true, steering: Steering { speed: 0.0, \
             yaw_rate: 0.0 }, exploration: None, warmup_with_policy: false, include_reference: true, \
             command: Command { forward_velocity: 0.3, lateral_velocity: 0.0, yaw_rate: 0.0, \
             body_height: None, gait: Trot }, rated_speed: None }"
        );
        assert!(format!("{config:?}").ends_with("fade: Fade { start: 0.1, end: 0.2 } }"));
        let with: ResidualConfig = serde_json::from_str(&serde_json::to_string(&config).unwrap()).unwrap();
        assert_eq!(with.fade, Some(fade));
    }

    #[test]
    fn command_only_hybrids_apply_the_reference_and_steer() {
        let base = Command::forward(1.0, Gait::Trot);
        let config = ResidualConfig {
            joint_residual: false,
            steering: Steering { speed: 0.5, ..Steering::OFF },
            ..ResidualConfig::new(0.25, base)
        };
        let r = Residual::new(&config, 3).unwrap();
        assert_eq!(r.policy_action_dim(), 1);
        let mut applied = [0.0f32; 3];
        assert_eq!(r.apply(&[0.1, 0.2, 0.3], &[1.0], 1.0, &[-1.0; 3], &[1.0; 3], &mut applied), 0.0);
        assert_eq!(applied, [0.1, 0.2, 0.3]);
        assert_eq!(r.steer(&base, &[-1.0], 1.0).forward_velocity, 0.5);
    }

    #[test]
    fn steering_and_exploration_settings_are_checked() {
        let nothing = ResidualConfig { joint_residual: false, ..ResidualConfig::default() };
        assert!(matches!(Residual::new(&nothing, 3), Err(HybridError::NothingToLearn)));
        let negative = ResidualConfig {
            steering: Steering { speed: -0.5, ..Steering::OFF },
            ..ResidualConfig::default()
        };
        assert!(matches!(
            Residual::new(&negative, 3),
            Err(HybridError::BadSetting { part: "steering.speed", .. })
        ));
        let nan = ResidualConfig {
            steering: Steering { speed: 0.0, yaw_rate: f64::NAN, ..Steering::OFF },
            ..ResidualConfig::default()
        };
        assert!(matches!(
            Residual::new(&nan, 3),
            Err(HybridError::BadSetting { part: "steering.yaw_rate", .. })
        ));
        let zero_sigma = ResidualConfig {
            exploration: Some(Exploration { residual: 0.0, steering: 1.0 }),
            ..ResidualConfig::default()
        };
        assert!(matches!(
            Residual::new(&zero_sigma, 3),
            Err(HybridError::BadSetting { part: "exploration.residual", .. })
        ));
    }

    #[test]
    fn the_initial_exploration_follows_the_action_layout() {
        let mut config = ResidualConfig {
            steering: Steering { speed: 0.5, ..Steering::OFF },
            exploration: Some(Exploration { residual: 0.2, steering: 0.7 }),
            ..ResidualConfig::default()
        };
        assert_eq!(config.initial_exploration(3), Some(vec![0.2, 0.2, 0.7]));
        config.joint_residual = false;
        assert_eq!(config.initial_exploration(1), Some(vec![0.7]));
        config.exploration = None;
        assert_eq!(config.initial_exploration(1), None);
    }

    #[test]
    fn the_exploration_ramp_floors_the_residual_only_and_is_checked() {
        let config = ResidualConfig {
            steering: Steering { speed: 0.5, ..Steering::OFF },
            exploration: Some(Exploration { residual: 0.01, steering: 0.5 }),
            exploration_ramp: Some(ExplorationRamp { residual: 0.3, samples: 100_000 }),
            ..ResidualConfig::default()
        };
        assert!(config.validate(2).is_ok());
        let floor = config.exploration_floor(3).unwrap();
        assert_eq!(floor.entries, vec![Some([0.01, 0.3]), Some([0.01, 0.3]), None]);
        assert_eq!(floor.steps, 100_000);
        assert_eq!(ResidualConfig { exploration_ramp: None, ..config.clone() }.exploration_floor(3), None);
        // Refused by name: nothing to ramp from, no residual, a falling or absurd σ, no samples.
        let bad = |c: ResidualConfig, part: &str| match c.validate(2) {
            Err(HybridError::BadSetting { part: p, .. }) => assert_eq!(p, part),
            other => panic!("{c:?}: {other:?}"),
        };
        bad(ResidualConfig { exploration: None, ..config.clone() }, "exploration_ramp.residual");
        bad(ResidualConfig { joint_residual: false, ..config.clone() }, "exploration_ramp.residual");
        for sigma in [0.005, 0.0, -1.0, f64::NAN, f64::INFINITY, 11.0] {
            let ramp = Some(ExplorationRamp { residual: sigma, samples: 100_000 });
            bad(ResidualConfig { exploration_ramp: ramp, ..config.clone() }, "exploration_ramp.residual");
        }
        let none = Some(ExplorationRamp { residual: 0.3, samples: 0 });
        bad(ResidualConfig { exploration_ramp: none, ..config.clone() }, "exploration_ramp.samples");
        // Recorded only where set: a setup without it keeps its text and its JSON.
        let without = ResidualConfig { exploration_ramp: None, ..config.clone() };
        assert!(
            !format!("{without:?}").contains("ramp")
                && !serde_json::to_string(&without).unwrap().contains("ramp")
        );
        let text = format!("{config:?}");
        assert!(
            text.contains("exploration_ramp: ExplorationRamp { residual: 0.3, samples: 100000 }"),
            "{text}"
        );
        let back: ResidualConfig = serde_json::from_str(&serde_json::to_string(&config).unwrap()).unwrap();
        assert_eq!(back, config);
    }

    #[test]
    fn the_bound_ramp_rises_log_linearly_and_is_checked() {
        let ramp = BoundRamp { from: 0.01, samples: 100_000 };
        assert_eq!(ramp.factor(0), 0.01);
        assert!((ramp.factor(50_000) - 0.1).abs() < 1e-6);
        assert_eq!(ramp.factor(100_000), 1.0);
        assert_eq!(ramp.factor(u64::MAX), 1.0);
        let config = ResidualConfig { bound_ramp: Some(ramp), ..ResidualConfig::default() };
        assert!(config.validate(2).is_ok());
        let bad = |c: ResidualConfig, part: &str| match c.validate(2) {
            Err(HybridError::BadSetting { part: p, .. }) => assert_eq!(p, part),
            other => panic!("{c:?}: {other:?}"),
        };
        let steering_only = ResidualConfig {
            joint_residual: false,
            steering: Steering { speed: 0.5, ..Steering::OFF },
            ..config.clone()
        };
        bad(steering_only, "bound_ramp.from");
        for from in [0.0, -0.1, 1.5, f64::NAN, f64::INFINITY] {
            let r = Some(BoundRamp { from, samples: 100_000 });
            bad(ResidualConfig { bound_ramp: r, ..config.clone() }, "bound_ramp.from");
        }
        let none = Some(BoundRamp { from: 0.01, samples: 0 });
        bad(ResidualConfig { bound_ramp: none, ..config.clone() }, "bound_ramp.samples");
        // Recorded only where set.
        let without = ResidualConfig::default();
        assert!(
            !format!("{without:?}").contains("bound_ramp")
                && !serde_json::to_string(&without).unwrap().contains("bound_ramp")
        );
        let text = format!("{config:?}");
        assert!(text.contains("bound_ramp: BoundRamp { from: 0.01, samples: 100000 }"), "{text}");
        let back: ResidualConfig = serde_json::from_str(&serde_json::to_string(&config).unwrap()).unwrap();
        assert_eq!(back, config);
    }

    #[test]
    fn a_period_scale_multiplies_the_gaits_period_and_bad_ones_are_refused() {
        let preset = ControllerConfig::walker2d();
        let walk = |c: &ControllerConfig| c.period_scales()[Gait::Walk.index()];
        let scaled = |v: Option<f64>, gait: Gait| ResidualConfig {
            period_scale: v,
            command: Command::forward(0.5, gait),
            ..ResidualConfig::default()
        };
        // None: the preset, untouched; a scale: the command's gait's period only.
        let mut c = preset.clone();
        scaled(None, Gait::Walk).rate_controller(&mut c).unwrap();
        assert_eq!(c, preset);
        scaled(Some(0.7), Gait::Walk).rate_controller(&mut c).unwrap();
        assert_eq!(walk(&c), 0.7 * walk(&preset));
        assert_eq!(c.period_scales()[Gait::Stand.index()], preset.period_scales()[Gait::Stand.index()]);
        for bad in [0.0, 0.1, 5.0, f64::NAN, f64::INFINITY] {
            let err = scaled(Some(bad), Gait::Walk).rate_controller(&mut preset.clone()).unwrap_err();
            assert!(matches!(err, HybridError::BadSetting { part: "period_scale", .. }), "{bad}: {err}");
            assert!(Residual::new(&scaled(Some(bad), Gait::Walk), 6).is_err(), "{bad}");
        }
        let err =
            scaled(Some(0.7), Gait::Stand).rate_controller(&mut preset.clone()).unwrap_err().to_string();
        assert!(err.contains("the stand has no period"), "{err}");
        assert!(scaled(Some(0.7), Gait::Trot).rate_controller(&mut preset.clone()).is_err(), "not offered");
        // Recorded only where set.
        assert!(!format!("{:?}", scaled(None, Gait::Walk)).contains("period_scale"));
        assert!(format!("{:?}", scaled(Some(0.7), Gait::Walk)).ends_with(", period_scale: 0.7 }"));
        assert!(!serde_json::to_string(&scaled(None, Gait::Walk)).unwrap().contains("period_scale"));
    }

    #[test]
    fn a_max_acceleration_replaces_the_controllers_ramp_and_bad_ones_are_refused() {
        let preset = ControllerConfig::minitaur();
        let ramped = |v: Option<f64>| ResidualConfig {
            max_acceleration: v,
            command: Command::forward(2.0, Gait::Trot),
            ..ResidualConfig::default()
        };
        let mut c = preset.clone();
        ramped(None).rate_controller(&mut c).unwrap();
        assert_eq!(c, preset);
        ramped(Some(6.0)).rate_controller(&mut c).unwrap();
        assert_eq!(c.max_acceleration, 6.0);
        assert_eq!(ControllerConfig { max_acceleration: preset.max_acceleration, ..c }, preset);
        refused_and_recorded_only_where_set("max_acceleration", ramped, 6.0, &[0.0, -1.0, 20.5]);
    }

    /// A controller setting `part` of the hybrid (`with(Some(v))` sets it to `v`): each of
    /// `bad` (and NaN and ∞) refused by the controller's rating and by the law, naming the
    /// part; recorded (text and data) only where set, and `good` read back.
    fn refused_and_recorded_only_where_set(
        part: &str,
        with: impl Fn(Option<f64>) -> ResidualConfig,
        good: f64,
        bad: &[f64],
    ) {
        let preset = ControllerConfig::minitaur();
        for &v in bad.iter().chain(&[f64::NAN, f64::INFINITY]) {
            let err = with(Some(v)).rate_controller(&mut preset.clone()).unwrap_err();
            assert!(matches!(err, HybridError::BadSetting { part: p, .. } if p == part), "{v}: {err}");
            assert!(Residual::new(&with(Some(v)), 8).is_err(), "{v}");
        }
        assert!(!format!("{:?}", with(None)).contains(part));
        assert!(format!("{:?}", with(Some(good))).ends_with(&format!(", {part}: {good:?} }}")));
        assert!(!serde_json::to_string(&with(None)).unwrap().contains(part));
        let text = serde_json::to_string(&with(Some(good))).unwrap();
        assert_eq!(serde_json::from_str::<ResidualConfig>(&text).unwrap(), with(Some(good)));
    }

    #[test]
    fn a_swing_height_replaces_the_controllers_and_bad_ones_are_refused() {
        let preset = ControllerConfig::minitaur();
        let swung = |v: Option<f64>| ResidualConfig {
            swing_height: v,
            command: Command::forward(2.0, Gait::Trot),
            ..ResidualConfig::default()
        };
        let mut c = preset.clone();
        swung(None).rate_controller(&mut c).unwrap();
        assert_eq!(c, preset);
        swung(Some(0.045)).rate_controller(&mut c).unwrap();
        assert_eq!(c.swing_height, 0.045);
        assert_eq!(ControllerConfig { swing_height: preset.swing_height, ..c }, preset);
        // 7 (centimetres for metres), none, too low or negative: refused, the text naming the
        // range the check uses.
        refused_and_recorded_only_where_set("swing_height", swung, 0.045, &[7.0, 0.0, 0.005, -0.05]);
        let (low, high) = SWING_HEIGHT_RANGE;
        let err = swung(Some(7.0)).rate_controller(&mut preset.clone()).unwrap_err().to_string();
        assert!(err.contains(&format!("[{low}, {high}] m")), "{err}");
    }

    #[test]
    fn an_mpc_period_and_the_cheap_torques_replace_the_controllers_and_bad_periods_are_refused() {
        let preset = ControllerConfig::minitaur();
        let with = |period: Option<f64>, cheap: bool| ResidualConfig {
            mpc_period: period,
            cheap_torques: cheap,
            command: Command::forward(2.0, Gait::Trot),
            ..ResidualConfig::default()
        };
        let mut c = preset.clone();
        with(None, false).rate_controller(&mut c).unwrap();
        assert_eq!(c, preset);
        with(Some(0.06), false).rate_controller(&mut c).unwrap();
        assert_eq!(c.mpc_period, 0.06);
        assert_eq!(ControllerConfig { mpc_period: preset.mpc_period, ..c.clone() }, preset);
        with(Some(0.06), true).rate_controller(&mut c).unwrap();
        assert_eq!((c.mpc_period, c.mode), (0.06, ControlMode::Cheap));
        assert_eq!(ControllerConfig { mpc_period: preset.mpc_period, mode: preset.mode, ..c }, preset);
        assert_eq!(preset.mode, ControlMode::WholeBody);
        // 60 (milliseconds for seconds), none, too short or negative: refused, the text
        // naming the range the check uses.
        refused_and_recorded_only_where_set(
            "mpc_period",
            |p| with(p, false),
            0.06,
            &[60.0, 0.0, 0.001, -0.02],
        );
        let (low, high) = MPC_PERIOD_RANGE;
        let err = with(Some(60.0), false).rate_controller(&mut preset.clone()).unwrap_err().to_string();
        assert!(err.contains(&format!("[{low}, {high}] s")), "{err}");
        // The cheap path is recorded only where set, and read back.
        assert!(!format!("{:?}", with(None, false)).contains("cheap_torques"));
        assert!(format!("{:?}", with(None, true)).ends_with(", cheap_torques: true }"));
        assert!(!serde_json::to_string(&with(None, false)).unwrap().contains("cheap_torques"));
        let text = serde_json::to_string(&with(Some(0.06), true)).unwrap();
        assert_eq!(serde_json::from_str::<ResidualConfig>(&text).unwrap(), with(Some(0.06), true));
    }

    #[test]
    fn a_rated_speed_replaces_the_gaits_rating_and_bad_ones_are_refused() {
        let preset = ControllerConfig::minitaur();
        let trot = |c: &ControllerConfig| c.offer(Gait::Trot).unwrap().max_speed;
        let rated = |v: Option<f64>, gait: Gait| ResidualConfig {
            rated_speed: v,
            command: Command::forward(2.0, gait),
            ..ResidualConfig::default()
        };
        // None: the preset, untouched.
        let mut c = preset.clone();
        rated(None, Gait::Trot).rate_controller(&mut c).unwrap();
        assert_eq!(c, preset);
        // A rating: the command's gait only.
        rated(Some(3.0), Gait::Trot).rate_controller(&mut c).unwrap();
        assert_eq!(trot(&c), 3.0);
        assert_eq!(c.offer(Gait::Walk).unwrap().max_speed, preset.offer(Gait::Walk).unwrap().max_speed);
        assert!(
            c.check_command(Gait::Trot, 2.9, 0.0).is_ok()
                && preset.check_command(Gait::Trot, 2.9, 0.0).is_err()
        );
        // Refused by name, and the config left as it was.
        for v in [f64::NAN, f64::INFINITY, 0.0, -1.0, 25.0] {
            let r = rated(Some(v), Gait::Trot);
            let mut c = preset.clone();
            assert!(matches!(r.validate(8), Err(HybridError::BadSetting { part: "rated_speed", .. })), "{v}");
            let err = r.rate_controller(&mut c).unwrap_err().to_string();
            assert!(err.contains("rated_speed"), "{v}: {err}");
            assert_eq!(c, preset);
        }
        let err = rated(Some(1.0), Gait::Stand).rate_controller(&mut preset.clone()).unwrap_err().to_string();
        assert!(err.contains("stand"), "{err}");
        // A gait the robot does not offer: the controller's error, naming those it does.
        let err =
            rated(Some(1.0), Gait::Gallop).rate_controller(&mut preset.clone()).unwrap_err().to_string();
        assert!(err.contains("gallop") && err.contains("trot (0–2.5 m/s;"), "{err}");
        // An offered gait other than the preset's: its own rating is replaced.
        let mut bound = preset.clone();
        rated(Some(3.0), Gait::Bound).rate_controller(&mut bound).unwrap();
        assert_eq!(bound.offer(Gait::Bound).unwrap().max_speed, 3.0);
        assert_eq!(bound.offer(Gait::Trot).unwrap().max_speed, 2.5);
    }

    /// The command the controller follows is checked like `centaur control`'s: finite, and
    /// (at zero steering) within the gait's rating, the hybrid's own if it sets one. A
    /// faster one used to run silently at the rating (`centaur compare --speed 100`), a NaN
    /// one stopped the first step with the env's "action[0] is NaN".
    #[test]
    fn the_command_and_the_exploration_are_checked() {
        let preset = ControllerConfig::minitaur();
        let with = |v: f64, rated: Option<f64>| ResidualConfig {
            rated_speed: rated,
            ..ResidualConfig::new(0.25, Command::forward(v, Gait::Trot))
        };
        assert!(with(2.5, None).rate_controller(&mut preset.clone()).is_ok());
        assert!(with(-3.5, Some(3.5)).rate_controller(&mut preset.clone()).is_ok());
        for (v, rated, needle) in [(2.6, None, "2.5"), (100.0, Some(3.5), "3.5"), (2.0, Some(1.0), "1")] {
            let err = with(v, rated).rate_controller(&mut preset.clone()).unwrap_err();
            let text = err.to_string();
            assert!(
                matches!(err, HybridError::Controller(ConfigError::SpeedAboveRating { .. }))
                    && text.contains(needle),
                "{v} {rated:?}: {text}"
            );
        }
        let err = with(f64::NAN, None).rate_controller(&mut preset.clone()).unwrap_err().to_string();
        assert!(err.contains("command.forward_velocity = NaN is out of range (finite)"), "{err}");
        let bad = |c: Command| ResidualConfig { command: c, ..ResidualConfig::default() }.validate(8);
        let fwd = Command::forward(1.0, Gait::Trot);
        for (c, part) in [
            (Command::forward(f64::NAN, Gait::Trot), "command.forward_velocity"),
            (Command { lateral_velocity: f64::INFINITY, ..fwd }, "command.lateral_velocity"),
            (Command { yaw_rate: f64::NAN, ..fwd }, "command.yaw_rate"),
            (Command { body_height: Some(0.0), ..fwd }, "command.body_height"),
            (Command { body_height: Some(f64::NAN), ..fwd }, "command.body_height"),
        ] {
            let refused = matches!(
                bad(c),
                Err(HybridError::Controller(ConfigError::OutOfRange { field, .. })) if field == part
            );
            assert!(refused, "{part}");
        }
        let too_fast = bad(Command { yaw_rate: -7.0, ..fwd });
        assert!(matches!(too_fast, Err(HybridError::BadSetting { part: "command.yaw_rate", .. })));
        assert!(bad(Command { body_height: Some(0.2), yaw_rate: -6.0, ..fwd }).is_ok());
        let steer_yaw = |yaw_rate: f64| ResidualConfig {
            steering: Steering { speed: 0.0, yaw_rate, ..Steering::OFF },
            ..ResidualConfig::default()
        };
        assert!(steer_yaw(6.0).validate(8).is_ok());
        let err = steer_yaw(1e9).validate(8).unwrap_err().to_string();
        assert!(err.contains("steering.yaw_rate = 1000000000.0") && err.contains("2π"), "{err}");
        let explore = |residual: f64| ResidualConfig {
            exploration: Some(Exploration { residual, steering: 0.5 }),
            ..ResidualConfig::default()
        };
        assert!(explore(10.0).validate(8).is_ok());
        for sigma in [0.0, -1.0, 10.5, 1e308, f64::NAN, f64::INFINITY] {
            let err = explore(sigma).validate(8).unwrap_err().to_string();
            assert!(err.contains("exploration.residual") && err.contains("(0, 10]"), "{sigma}: {err}");
        }
    }
}
