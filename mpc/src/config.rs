//! Controller configuration: typed structs with documented defaults, presets as named
//! constructors, and `validate()` returning a typed [`ConfigError`](crate::ConfigError).

use crate::convex_mpc::MpcConfig;
use crate::error::ConfigError;
use crate::gait::Gait;
use crate::robot::{BaseSpec, ContactSpec, LoopClosureSpec, RobotSpec};
use crate::wbc::WbcConfig;

/// Where the convex MPC runs ([`crate::ControllerConfig::mpc_execution`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum MpcExecution {
    /// Inside [`crate::LocomotionController::tick`], every `mpc_period`: deterministic (the
    /// same states give the same commands bit for bit), as simulation and training need.
    /// A tick that solves takes the solve's time (≈ 0.3 ms), the others the whole-body QP's.
    #[default]
    Inline,
    /// On a worker thread the controller starts in `new` and joins when dropped. A tick
    /// that is due for a plan only copies the MPC's inputs to the worker; every tick adopts
    /// the newest finished plan and follows it from the time its state was measured, so a
    /// plan arrives one solve late. A tick waits for the worker only while the controller
    /// has never had a feasible plan (its first ticks, and the first after a reset — which
    /// may also wait out a solve for the old state that was already running); failed
    /// solves later do not block: the last feasible plan is followed, decayed, as inline.
    /// [`crate::ControllerStatus::mpc_blocked`] flags the ticks that waited.
    ///
    /// In the status, `mpc_ran`, the MPC status, time, iterations and failure count describe
    /// plans as they are adopted (a result replaced before any tick took it is not
    /// counted), while `contact_schedule` is that of the problem last submitted. A plan
    /// whose state is later than the tick's time (time went back without a reset) is
    /// dropped. If a solve panics the worker is gone: from then on every tick due for an MPC
    /// reports [`crate::QpStatus::SolverGone`] and counts an MPC failure, and the controller falls
    /// back as for failed solves.
    /// Timing-dependent, so not reproducible bit for bit: meant for robots, not training.
    Background,
}

/// How joint torques are computed from the MPC forces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum ControlMode {
    /// The whole-body QP ([`crate::WholeBodyQp`]).
    #[default]
    WholeBody,
    /// The cheap path: stance legs `τ = −J_cᵀ f_MPC`, swing legs Cartesian PD
    /// `τ = J_cᵀ (K_p e + K_d ė)` (passive joints handled through the loop closures).
    Cheap,
}

/// A gait a configuration offers ([`ControllerConfig::gaits`]): the controller runs it at
/// its own period, up to its rated speed, and where the offer says so at its own CoM height,
/// stance fraction and task weights.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GaitOffer {
    /// The gait.
    pub gait: Gait,
    /// Multiplies the gait's table period, on top of [`ControllerConfig::gait_period_scale`]
    /// (default: 1).
    pub period_scale: f64,
    /// Largest commanded planar speed (m/s) the gait is rated for: the speed it was measured
    /// to hold over seeds, or `f64::INFINITY` where a preset's gait is not rated (no
    /// closed-loop simulation of that robot). The controller clamps faster commands to it
    /// and counts them in [`crate::ControllerStatus::clamped_commands`]; `centaur control`
    /// refuses them. Ignored for [`Gait::Stand`], whose speed command only shifts the body
    /// over its planted feet (within `position_leash`).
    pub max_speed: f64,
    /// Largest commanded yaw rate (rad/s, either way) the gait is rated to turn at, up to
    /// [`GaitOffer::max_turning_speed`]; 0: the gait runs straight only; `f64::INFINITY`:
    /// not rated (default). The controller clamps larger yaw-rate commands to it (to 0 above
    /// `max_turning_speed`) and counts them in [`crate::ControllerStatus::clamped_commands`];
    /// `centaur control` refuses them. Ignored for [`Gait::Stand`] (it twists the body over
    /// its planted feet within the yaw reference's 0.3 rad reach).
    pub max_yaw_rate: f64,
    /// Largest commanded planar speed (m/s) at which [`GaitOffer::max_yaw_rate`] holds;
    /// faster, the gait is rated straight only (default: `f64::INFINITY`), or as
    /// [`GaitOffer::faster_turning`] says.
    pub max_turning_speed: f64,
    /// A second turning rating above [`GaitOffer::max_turning_speed`]: a smaller yaw rate up
    /// to a higher speed, for a gait whose turning degrades with speed (default: none,
    /// straight only above `max_turning_speed`). Set with [`GaitOffer::then_turning`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub faster_turning: Option<TurnRating>,
    /// The CoM height (m above the ground) the gait runs at when the command sets none
    /// ([`Command::body_height`]); default: none, the robot's nominal standing CoM height.
    /// Set with [`GaitOffer::com_height`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub com_height: Option<f64>,
    /// A CoM height that rises with speed above [`GaitOffer::com_height`] (default: none, the
    /// same height at every speed). Set with [`GaitOffer::rising_to`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height_rise: Option<HeightRise>,
    /// Every leg's stance fraction of the cycle while this gait runs, replacing the gait
    /// table's ([`crate::GaitPattern::with_duty`]; default: none, the table's; a trot
    /// staggered for turning takes the stagger's instead, [`crate::GaitPattern::staggered`]).
    /// Set with [`GaitOffer::duty`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duty_factor: Option<f64>,
    /// The MPC's state weights while this gait runs, replacing
    /// [`MpcConfig::state_weights`] (default: none, the configuration's). Set with
    /// [`GaitOffer::mpc_weights`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mpc_state_weights: Option<[f64; 12]>,
    /// The whole-body QP's body-orientation weight while this gait runs, replacing
    /// [`WbcConfig::w_body_angular`] (default: none, the configuration's). Set with
    /// [`GaitOffer::body_angular_weight`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body_angular_weight: Option<f64>,
}

/// The CoM height of a gait rising linearly with the commanded (ramped) planar speed, from
/// its [`GaitOffer::com_height`] at `from_speed` to `height` at `to_speed`, and held there
/// above ([`GaitOffer::height_rise`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct HeightRise {
    /// The speed (m/s) up to which the gait runs at its `com_height`.
    pub from_speed: f64,
    /// The speed (m/s) from which it runs at `height`.
    pub to_speed: f64,
    /// The CoM height (m above the ground) at `to_speed` and above.
    pub height: f64,
}

/// A turning rating: up to `max_yaw_rate` (rad/s, either way) while commanded at most
/// `max_speed` (m/s) ([`GaitOffer::faster_turning`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TurnRating {
    /// Largest rated yaw rate (rad/s).
    pub max_yaw_rate: f64,
    /// Largest commanded planar speed (m/s) at which it holds.
    pub max_speed: f64,
}

impl GaitOffer {
    /// `gait` at its table period, rated to `max_speed`, turning not rated.
    pub fn new(gait: Gait, max_speed: f64) -> Self {
        GaitOffer {
            gait,
            period_scale: 1.0,
            max_speed,
            max_yaw_rate: f64::INFINITY,
            max_turning_speed: f64::INFINITY,
            faster_turning: None,
            com_height: None,
            height_rise: None,
            duty_factor: None,
            mpc_state_weights: None,
            body_angular_weight: None,
        }
    }

    /// The same offer with every leg in stance for `duty` of the cycle
    /// ([`GaitOffer::duty_factor`]).
    pub fn duty(self, duty: f64) -> Self {
        GaitOffer { duty_factor: Some(duty), ..self }
    }

    /// The same offer with its own MPC state weights ([`GaitOffer::mpc_state_weights`]).
    pub fn mpc_weights(self, weights: [f64; 12]) -> Self {
        GaitOffer { mpc_state_weights: Some(weights), ..self }
    }

    /// The same offer with its own body-orientation weight in the whole-body QP
    /// ([`GaitOffer::body_angular_weight`]).
    pub fn body_angular_weight(self, weight: f64) -> Self {
        GaitOffer { body_angular_weight: Some(weight), ..self }
    }

    /// The same offer at `scale` times its table period.
    pub fn period(self, scale: f64) -> Self {
        GaitOffer { period_scale: scale, ..self }
    }

    /// The same offer run at a CoM height of `height` (m above the ground) unless the
    /// command sets one ([`GaitOffer::com_height`]).
    pub fn com_height(self, height: f64) -> Self {
        GaitOffer { com_height: Some(height), ..self }
    }

    /// The same offer with its CoM height rising from its [`GaitOffer::com_height`] at
    /// `from_speed` to `height` at `to_speed` (m/s, the commanded planar speed after the
    /// ramp), and held above ([`GaitOffer::height_rise`]).
    pub fn rising_to(self, height: f64, from_speed: f64, to_speed: f64) -> Self {
        GaitOffer { height_rise: Some(HeightRise { from_speed, to_speed, height }), ..self }
    }

    /// The gait's own CoM height (m) at the commanded planar `speed` (m/s), if it has one.
    pub fn height_at(&self, speed: f64) -> Option<f64> {
        let base = self.com_height?;
        Some(match self.height_rise {
            Some(r) => {
                let s = ((speed.abs() - r.from_speed) / (r.to_speed - r.from_speed)).clamp(0.0, 1.0);
                base + s * (r.height - base)
            }
            None => base,
        })
    }

    /// The same offer rated to turn at up to `max_yaw_rate` (rad/s) while commanded at most
    /// `max_speed` (m/s), and straight only above it.
    pub fn turning(self, max_yaw_rate: f64, max_speed: f64) -> Self {
        GaitOffer { max_yaw_rate, max_turning_speed: max_speed, ..self }
    }

    /// The same offer rated, above its [`GaitOffer::turning`] speed, to turn at up to
    /// `max_yaw_rate` (rad/s, smaller than the first) while commanded at most `max_speed`
    /// (m/s), and straight only above that ([`GaitOffer::faster_turning`]).
    pub fn then_turning(self, max_yaw_rate: f64, max_speed: f64) -> Self {
        GaitOffer { faster_turning: Some(TurnRating { max_yaw_rate, max_speed }), ..self }
    }

    /// The same offer rated straight only: a yaw-rate command is not tracked.
    pub fn straight_only(self) -> Self {
        GaitOffer { faster_turning: None, ..self.turning(0.0, 0.0) }
    }

    /// The turning rating in words, for messages: `"straight only"`, `"turns at up to 0.5
    /// rad/s"`, `"turns at up to 0.5 rad/s to 0.6 m/s"`, `"turns at up to 0.5 rad/s to 0.4
    /// m/s and 0.3 rad/s to 0.5 m/s"`, `"turning unrated"`.
    pub fn turning_text(&self) -> String {
        let (w, v) = (self.max_yaw_rate, self.max_turning_speed);
        let up_to = |w: f64, v: f64| {
            if v >= self.max_speed { format!("{w} rad/s") } else { format!("{w} rad/s to {v} m/s") }
        };
        if w.is_infinite() {
            "turning unrated".into()
        } else if w == 0.0 {
            "straight only".into()
        } else if let Some(t) = self.faster_turning {
            format!("turns at up to {} and {}", up_to(w, v), up_to(t.max_yaw_rate, t.max_speed))
        } else {
            format!("turns at up to {}", up_to(w, v))
        }
    }

    /// The largest yaw rate (rad/s) rated at a commanded planar `speed` (m/s).
    pub fn yaw_rate_rating(&self, speed: f64) -> f64 {
        let within = |limit: f64| speed.abs() <= limit + 1e-9;
        if self.gait == Gait::Stand {
            f64::INFINITY
        } else if within(self.max_turning_speed) {
            self.max_yaw_rate
        } else {
            match self.faster_turning {
                Some(t) if within(t.max_speed) => t.max_yaw_rate,
                _ => 0.0,
            }
        }
    }
}

/// Everything the [`crate::LocomotionController`] needs besides the model.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ControllerConfig {
    /// The robot description.
    pub robot: RobotSpec,
    /// The gaits this robot runs, with their periods and rated speeds. A command for a gait
    /// not listed is answered by standing still (and counted in
    /// [`crate::ControllerStatus::refused_gaits`]); [`ControllerConfig::offer`] says why
    /// before a run. Stand must be listed. (Default: every gait defined for the number of
    /// legs, unrated; the presets list what was measured on their robot.)
    pub gaits: Vec<GaitOffer>,
    /// Convex MPC.
    pub mpc: MpcConfig,
    /// Whole-body QP.
    pub wbc: WbcConfig,
    /// Torque computation (default: whole-body QP).
    pub mode: ControlMode,
    /// Time between MPC solves (s); the plan is followed in between (default: 0.02).
    pub mpc_period: f64,
    /// Whether the MPC is solved inside `tick` or on a worker thread (default:
    /// [`MpcExecution::Inline`], deterministic).
    pub mpc_execution: MpcExecution,
    /// Swing apex height above the lift-off/touch-down points (m) (default: 0.06).
    pub swing_height: f64,
    /// Use measured contacts (when given) to start each stance only at touch-down and to
    /// end swings that touch the ground in their second half; without it measured contacts
    /// only hold a robot that starts in the air in its stance until it has landed
    /// (default: true).
    pub touchdown_detection: bool,
    /// Speed (m/s) at which a foot that has not touched down at the scheduled end of its
    /// swing keeps descending (with measured contacts only) (default: 0.3).
    pub touchdown_speed: f64,
    /// Swing-foot task gains `k_p` (1/s²) and `k_d` (1/s) (default: 400, 40).
    pub swing_gains: (f64, f64),
    /// Cheap-path Cartesian swing stiffness (N/m) and damping (N·s/m) (default: 300, 10).
    pub cheap_swing_gains: (f64, f64),
    /// Body position gains `k_p` (1/s²) per axis for the WBC body task (default: [0, 0, 100]:
    /// only the height is held; horizontal position is free, velocity is tracked).
    pub body_kp_pos: [f64; 3],
    /// Body velocity gains `k_d` (1/s) (default: [20, 20, 20]).
    pub body_kd_vel: [f64; 3],
    /// Body orientation gains `k_p` (1/s²) about x, y, z (default: [150, 150, 100]).
    pub body_kp_ori: [f64; 3],
    /// Body angular-velocity gains `k_d` (1/s) (default: [20, 20, 20]).
    pub body_kd_ang: [f64; 3],
    /// Posture task gains `k_p`, `k_d` (default: 50, 10).
    pub posture_gains: (f64, f64),
    /// Joint PD gains sent with swing-leg targets (N·m/rad, N·m·s/rad) (default: 0, 0:
    /// torques only; set them for position-controlled joints).
    pub swing_joint_gains: (f64, f64),
    /// Joint PD gains sent with stance-leg targets while walking (the targets carry the
    /// body along its reference over the planted feet; standing uses none) (default: 0, 0).
    pub stance_joint_gains: (f64, f64),
    /// Posture PD gains of the invalid-state fallback (default: 20, 0.5).
    pub fallback_joint_gains: (f64, f64),
    /// Extra velocity-feedback gain of the foothold (s) (default: 0; the capture-point term
    /// is always on).
    pub raibert_kv: f64,
    /// Carry the footholds with the centre of mass instead of the body frame: the hip
    /// reference is the nominal foot offset from the CoM's horizontal position (default:
    /// false). For a tall biped whose trunk pitches, the body frame sways far from the CoM
    /// the capture point is about.
    pub foothold_from_com: bool,
    /// Position feedback of the footholds (1/s): swing footholds are planned for the velocity
    /// `v_cmd + k (p_ref − c)` (default: 0). The foothold then moves by
    /// `k (p_ref − c) (T_stance/2 − raibert_kv − √(h/g))`, which steers the CoM `c` back to
    /// its reference only while that bracket is negative (Humanoid: 0.17 − 0.2 − 0.29 s).
    pub foothold_position_gain: f64,
    /// Answer a [`Gait::Stand`] command by stepping in place with the walk gait (default:
    /// false). A biped on point feet cannot stand still: its support is a line, and only
    /// stepping can move the support under the CoM.
    pub step_in_place: bool,
    /// Rate limit of the commanded linear speed (m/s²) (default: 1.0).
    pub max_acceleration: f64,
    /// Largest horizontal distance (m) between the position reference (the integral of the
    /// commanded velocity) and the measured CoM; the reference is dragged along beyond it,
    /// e.g. after a push (default: 0.1).
    pub position_leash: f64,
    /// Speed (m/s) at which the position reference of a robot standing still moves to the
    /// centre of its support (the mean contact position) (default: 0.05).
    pub recenter_speed: f64,
    /// Rate limit of the commanded yaw rate (rad/s²) (default: 2.0).
    pub max_yaw_acceleration: f64,
    /// Stagger of the trot's diagonal partners per rad/s of commanded yaw rate, as a
    /// fraction of the cycle, clamped to [`crate::MAX_STAGGER`]
    /// ([`crate::GaitPattern::staggered`]: the inner legs lead, so that each pair's stance
    /// opens and closes on one foot, where a robot without abduction can yaw) (default: 0,
    /// off; only the trot is staggered).
    pub turn_stagger: f64,
    /// Swing apex height (m) while the trot is staggered for turning; 0: `swing_height`
    /// (default: 0). On one foot the body rolls toward its swinging legs, and a high swing
    /// curve lands them late, out of turn (see the Minitaur preset).
    pub turn_swing_height: f64,
    /// The trot is staggered for turning only while the commanded planar speed is at most
    /// this (m/s); above it a yaw-rate command turns the unstaggered trot (default:
    /// infinite, always).
    pub turn_max_speed: f64,
    /// The whole-body QP's body yaw-axis weight while the trot is staggered for turning;
    /// 0: `wbc.body_axis_weights[5]` (default: 0).
    pub turn_yaw_weight: f64,
    /// The whole-body QP's posture weight while the trot is staggered for turning; 0:
    /// `wbc.w_posture` (default: 0).
    pub turn_posture_weight: f64,
    /// The convex MPC's yaw-rate state weight (`mpc.state_weights[8]`) while the trot is
    /// staggered for turning; 0: the MPC's own (default: 0). The yaw-rate error is what a
    /// turn lags by; the other state weights are kept.
    pub turn_yaw_rate_weight: f64,
    /// Multiplies the trot's period while it is staggered for turning (default: 1). It
    /// takes effect with the stagger, at a cycle boundary.
    pub turn_period_scale: f64,
    /// Multiplies every gait period (default: 1.0).
    pub gait_period_scale: f64,
    /// Damping `λ` of the damped-least-squares IK (m) (default: 0.02).
    pub ik_damping: f64,
    /// Decay per failed MPC solve of the last feasible forces (default: 0.9).
    pub fallback_decay: f64,
}

/// The MPC force weight `R` of the Ant (the default is 1e-5). Forces that cancel between
/// feet move no body, so `R` alone sets them; at 1e-5 it is weak enough that the solver's
/// tolerance picks them (the structured solver and Clarabel, both at 1e-8, differ by up to
/// 7e-3·mg there), and a standing Ant twisted its feet: yaw drift median 0.055 rad over
/// seeds 0–9 with the structured solver, 0.013 with Clarabel. At 1e-4 the standing Ant's
/// median is 0.02 rad and the two solvers agree within 0.01 rad per seed (seeds 0–4);
/// trotting, the yaw drift varies with the seed (0.005–0.31 rad) with either solver and
/// either weight. The Minitaur's trot needs the weaker weight (at 1e-4 it falls after 1.4 s).
const FIRM_FORCE_WEIGHT: f64 = 1e-4;

/// What a `turn_*` setting of [`ControllerConfig`] gives: `turn` while the trot is staggered
/// for turning and the setting is on (> 0), else `otherwise` (the straight trot's value).
#[inline]
pub(crate) fn while_turning(staggered: bool, turn: f64, otherwise: f64) -> f64 {
    if staggered && turn > 0.0 { turn } else { otherwise }
}

impl ControllerConfig {
    fn with_robot(robot: RobotSpec) -> Self {
        let n_legs = robot.n_legs;
        Self {
            gaits: Gait::ALL
                .iter()
                .filter(|g| g.supported(n_legs))
                .map(|&g| GaitOffer::new(g, if g == Gait::Stand { 0.0 } else { f64::INFINITY }))
                .collect(),
            robot,
            mpc: MpcConfig::trot(),
            wbc: WbcConfig::default(),
            mode: ControlMode::WholeBody,
            mpc_period: 0.02,
            mpc_execution: MpcExecution::Inline,
            swing_height: 0.06,
            touchdown_detection: true,
            touchdown_speed: 0.3,
            swing_gains: (400.0, 40.0),
            cheap_swing_gains: (300.0, 10.0),
            body_kp_pos: [0.0, 0.0, 100.0],
            body_kd_vel: [20.0, 20.0, 20.0],
            body_kp_ori: [150.0, 150.0, 100.0],
            body_kd_ang: [20.0, 20.0, 20.0],
            posture_gains: (50.0, 10.0),
            swing_joint_gains: (0.0, 0.0),
            stance_joint_gains: (0.0, 0.0),
            fallback_joint_gains: (20.0, 0.5),
            raibert_kv: 0.0,
            foothold_from_com: false,
            foothold_position_gain: 0.0,
            step_in_place: false,
            max_acceleration: 1.0,
            position_leash: 0.1,
            recenter_speed: 0.05,
            max_yaw_acceleration: 2.0,
            turn_stagger: 0.0,
            turn_swing_height: 0.0,
            turn_max_speed: f64::INFINITY,
            turn_yaw_weight: 0.0,
            turn_posture_weight: 0.0,
            turn_yaw_rate_weight: 0.0,
            turn_period_scale: 1.0,
            gait_period_scale: 1.0,
            ik_damping: 0.02,
            fallback_decay: 0.9,
        }
    }

    /// Solo12 (`assets/solo12/solo12.urdf`, floating): MIT-Cheetah-style MPC + WBC, feet at
    /// the `*_FOOT` frames, standing pose HFE ±0.8, KFE ∓1.6, effort limit 2.7 N·m
    /// (0.025 N·m/A × 12 A × gear 9; the URDF says 1000).
    pub fn solo12() -> Self {
        let legs = ["FL", "FR", "HL", "HR"];
        let contacts = legs
            .iter()
            .enumerate()
            .map(|(i, l)| ContactSpec { frame: format!("{l}_FOOT"), offset: [0.0; 3], radius: 0.0, leg: i })
            .collect();
        let mut nominal = Vec::new();
        for l in legs {
            let s = if l.starts_with('F') { 1.0 } else { -1.0 };
            nominal.push((format!("{l}_HFE"), 0.8 * s));
            nominal.push((format!("{l}_KFE"), -1.6 * s));
        }
        let mut c = Self::with_robot(RobotSpec {
            base: BaseSpec::Floating,
            body_frame: "base_link".into(),
            contacts,
            n_legs: 4,
            passive_joints: vec![],
            effort_limit: Some(2.7),
            nominal_joints: nominal,
            loop_closures: vec![],
        });
        c.swing_height = 0.05;
        c
    }

    /// Ant (`assets/mujoco/ant.urdf`, floating, 2 dof per leg, gear 150), tuned for
    /// Gymnasium's 20 Hz control. Feet: spheres of radius 0.08 (the capsules' radius) at
    /// the far end of each `*_ankle_geom` capsule, `pos ± half-length · axis` =
    /// (±0.4, ±0.4, 0) in the `ankle_k_body` frames (sidecar: pos (0.2, 0.2, 0), half-length
    /// 0.2828 along (1, 1, 0)/√2). Legs FL = leg 1 (+x, +y), FR = leg 4 (+x, −y),
    /// HL = leg 2 (−x, +y), HR = leg 3 (−x, −y). Standing pose: the XML's custom
    /// `init_qpos` (ankles ±1 rad).
    ///
    /// The controller ticks at the env's 20 Hz; its joint PD part runs on the env's servo
    /// at the physics rate (100 Hz, `RobotEnv::set_servo`, as motor drivers would), and
    /// only the feed-forward torque is held for 50 ms. The task-space gains are still
    /// chosen for a 50 ms hold of the WBC's accelerations (`k_p T² ≤ 0.5`, `k_d T ≤ 1`:
    /// body 100/15); the swing legs' 400/30 pass through the servo. Gaits run at their table
    /// periods (a 0.3 s trot) and the MPC steps with the control period. A two-dof leg with
    /// its foot planted locks the body's height, roll and pitch to its forward motion, so
    /// stance legs also get joint PD targets (200 N·m/rad, 15 N·m·s/rad) that carry the body
    /// along its reference over the feet (the stance target of the contacts stage,
    /// `controller/contacts.rs`); the height task is soft (20/s²), the heading is weighted
    /// 10× the other body axes, and the WBC follows the MPC forces loosely (weight 1).
    /// Touch-down detection is off: at 20 Hz a swing reaches the ground late often enough
    /// that waiting for contact costs more than it saves (with it the 1 m/s trot made
    /// 0.42–0.48 m/s). A standing Ant is not re-centred: planted two-dof legs cannot move
    /// the body sideways without sliding their feet.
    ///
    /// Measured on seeds 0–4: before the servo, with the torques held 50 ms, a
    /// 0.6 s trot and swing gains 200/20, it trotted 0.3 m/s but made only 0.34–0.59 and
    /// 0.24–0.41 m/s at 0.6 and 1.0; the servo alone raised 1.0 m/s to 0.41–0.52, and the
    /// 0.3 s trot with the stiffer swing to 0.95–0.98.
    pub fn ant() -> Self {
        let contacts = vec![
            ContactSpec { frame: "ankle_1_body".into(), offset: [0.4, 0.4, 0.0], radius: 0.08, leg: 0 },
            ContactSpec { frame: "ankle_4_body".into(), offset: [0.4, -0.4, 0.0], radius: 0.08, leg: 1 },
            ContactSpec { frame: "ankle_2_body".into(), offset: [-0.4, 0.4, 0.0], radius: 0.08, leg: 2 },
            ContactSpec { frame: "ankle_3_body".into(), offset: [-0.4, -0.4, 0.0], radius: 0.08, leg: 3 },
        ];
        let nominal = vec![
            ("ankle_1".to_string(), 1.0),
            ("ankle_2".to_string(), -1.0),
            ("ankle_3".to_string(), -1.0),
            ("ankle_4".to_string(), 1.0),
        ];
        let mut c = Self::with_robot(RobotSpec {
            base: BaseSpec::Floating,
            body_frame: "torso".into(),
            contacts,
            n_legs: 4,
            passive_joints: vec![],
            effort_limit: None,
            nominal_joints: nominal,
            loop_closures: vec![],
        });
        c.swing_height = 0.08;
        c.mpc.dt = 0.05;
        c.gait_period_scale = 1.0;
        c.swing_gains = (400.0, 30.0);
        c.body_kp_pos = [0.0, 0.0, 20.0];
        c.body_kd_vel = [15.0; 3];
        c.body_kp_ori = [100.0; 3];
        c.body_kd_ang = [15.0; 3];
        c.posture_gains = (20.0, 4.0);
        c.stance_joint_gains = (200.0, 15.0);
        c.position_leash = 0.3;
        c.recenter_speed = 0.0;
        c.touchdown_detection = false;
        c.wbc.w_force = 1.0;
        // Heading held 10× harder than the other body axes: at 1 m/s yaw drifted up to
        // 0.25 rad with equal weights, 0.02–0.06 with this (seeds 0–2).
        c.wbc.body_axis_weights[5] = 10.0;
        c.mpc.force_weight = FIRM_FORCE_WEIGHT;
        // Rated to the speeds tracked within 15 % on seeds 0–4: the trot to 1.2 m/s
        // (1.03–1.17 m/s at 1.2), the static walk to 0.3 (0.294–0.298; at 0.4 one seed made
        // 0.32). Pace, bound and gallop stay up at 0.3 m/s but fall short or turn up to 1 rad,
        // so they are not offered. Turning (`centaur control --yaw-rate ±0.3, ±0.5
        // --measure-from 1`, seeds 0–4): the trot at 0.3, 0.6 and 1.0 m/s and the
        // walk at 0.3 m/s turn within 0.01 rad/s of the command on every seed; at 1.2 m/s the
        // trot lagged on one seed (−0.37 for −0.5, −0.11 for −0.3), so it turns to 1.0 m/s.
        c.gaits = vec![
            GaitOffer::new(Gait::Stand, 0.0),
            GaitOffer::new(Gait::Walk, 0.3).turning(0.5, 0.3),
            GaitOffer::new(Gait::Trot, 1.2).turning(0.5, 1.0),
        ];
        c
    }

    /// Walker2d (`assets/mujoco/walker2d.urdf`, fixed base with planar root joints):
    /// the **planar** MPC variant ([`MpcConfig::biped_planar`]) + WBC, biped walk. Each foot
    /// has two contact points, the bottoms of the ends of its capsule: (−0.2, 0, 0.04) and
    /// (0, 0, 0.04) in the `foot`/`foot_left` frames (capsule centre (−0.1, 0, 0.1),
    /// half-length 0.1 along −x, radius 0.06). The walk, rated 1.0 m/s, carries its own
    /// tuning ([`GaitOffer::duty`], [`GaitOffer::mpc_weights`],
    /// [`GaitOffer::body_angular_weight`]): each foot in stance for 0.35 of the cycle, the
    /// torso's pitch left to a weak WBC orientation task so that it leans back and the feet
    /// land ahead (the source has the measurements).
    pub fn walker2d() -> Self {
        let mut contacts = Vec::new();
        for (leg, f) in ["foot_left", "foot"].iter().enumerate() {
            contacts.push(ContactSpec { frame: f.to_string(), offset: [-0.2, 0.0, 0.1], radius: 0.06, leg });
            contacts.push(ContactSpec { frame: f.to_string(), offset: [0.0, 0.0, 0.1], radius: 0.06, leg });
        }
        let mut c = Self::with_robot(RobotSpec {
            base: BaseSpec::Planar {
                x_joint: "rootx".into(),
                z_joint: "rootz".into(),
                pitch_joint: "rooty".into(),
            },
            body_frame: "torso".into(),
            contacts,
            n_legs: 2,
            passive_joints: vec![],
            effort_limit: None,
            nominal_joints: vec![],
            loop_closures: vec![],
        });
        c.mpc = MpcConfig::biped_planar();
        c.swing_height = 0.08;
        // A stiffer body-velocity task: at the default 20 the walk lags its command by a
        // third (0.35 m/s for 0.5); at 80 it makes 0.42 (0.45 after the first second).
        c.body_kd_vel = [80.0; 3];
        // The walk's own tuning, measured with `control_probe walker2d walk 1.0 11
        // --measure-from 1 --set unrated=1` and the probe's `duty`, `offer_default_weights`
        // and `offer_w_ang` keys over seeds 0–4. With the gait table's stance
        // fraction (0.6) and the configuration's weights it made only 0.67–0.73 m/s: its
        // 0.32 s swings asked the swing hip for ~140 N·m (limit 100; a hip at its limit 28 %
        // of the time on seed 0), and the MPC braked each stance to pitch the torso upright,
        // while the torso must lean back for a foot to land ahead of the hip at all
        // (Gymnasium's thigh swings only backwards from the torso's axis, to 0°). Together
        // the three changes make 0.88 m/s (a hip at its limit 7 % of the time); short of
        // any of them it lags or falls:
        // - stance 0.35 of the cycle (0.52 s swings, no planned double support); with the
        //   configuration's weights that alone makes 0.54 m/s;
        // - no MPC pitch or pitch-rate weight, leaving the torso's pitch to the WBC; with
        //   the WBC's orientation weight at the configuration's 10 it falls within 4.5 s;
        // - the WBC's orientation weight 0.5: the torso leans up to 0.51–0.53 rad (the env's
        //   healthy band is ±1 rad); 0.2 makes the same 0.88 m/s at 0.62–0.71 rad, 1.0
        //   0.87 m/s at 0.43–0.45 rad.
        // The same weights at the table's stance fraction fall on 4 of 5 seeds.
        let mut walk_weights = c.mpc.state_weights;
        walk_weights[1] = 0.0;
        walk_weights[7] = 0.0;
        // Rated to 1.0 m/s; planar: it cannot turn.
        c.gaits = vec![
            GaitOffer::new(Gait::Stand, 0.0),
            GaitOffer::new(Gait::Walk, 1.0)
                .straight_only()
                .duty(0.35)
                .mpc_weights(walk_weights)
                .body_angular_weight(0.5),
        ];
        c
    }

    /// Humanoid (`assets/mujoco/humanoid.urdf`, floating, 17 hinges, no ankles) on two point
    /// feet (the bottoms of the foot spheres, (0, 0, 0.025) in `left_foot` / `right_foot`).
    /// Point feet support the robot along a line only, so it cannot stand still: a stand
    /// command steps in place ([`ControllerConfig::step_in_place`]) with the biped walk gait
    /// at 0.7 of its period (0.56 s), the standing MPC weights and the WBC. The footholds are
    /// a capture-point variant: carried with the CoM rather than the trunk (which sways 1.3 m
    /// above the feet), with velocity feedback 0.1 s and a position feedback (0.3/s) toward
    /// the integral of the commanded velocity. Commanded speeds ramp at 0.3 m/s². A posture
    /// task 4 × the default keeps the arms and abdomen from swinging the torso's heading. It
    /// walks (the same gait, moving) at up to 0.5 m/s (0.6 m/s unrated).
    pub fn humanoid() -> Self {
        let contacts = vec![
            ContactSpec { frame: "left_foot".into(), offset: [0.0, 0.0, 0.1], radius: 0.075, leg: 0 },
            ContactSpec { frame: "right_foot".into(), offset: [0.0, 0.0, 0.1], radius: 0.075, leg: 1 },
        ];
        let mut c = Self::with_robot(RobotSpec {
            base: BaseSpec::Floating,
            body_frame: "torso".into(),
            contacts,
            n_legs: 2,
            passive_joints: vec![],
            effort_limit: None,
            nominal_joints: vec![],
            loop_closures: vec![],
        });
        c.mpc = MpcConfig::stand();
        // The horizon is one gait cycle: 16 × 35 ms = 0.56 s. The yaw weight is 3 × the
        // standing weights' 10: a point foot turns the body only through its horizontal force
        // offset from the centre of mass, and with the weaker weight the heading swung with a
        // growing ~3 s oscillation until the robot fell.
        c.mpc.horizon = 16;
        c.mpc.dt = 0.035;
        c.mpc.state_weights[2] = 30.0;
        c.swing_height = 0.08;
        c.step_in_place = true;
        c.gait_period_scale = 0.7;
        // Footholds: velocity feedback 0.1 s on top of the capture point's √(h/g) ≈ 0.29 s,
        // position feedback 0.3/s. Measured with `control_probe humanoid walk … --set
        // unrated=1` over seeds 0–19, 10 s after a 1 s ramp:
        // - before (0.2 s, 0.15/s, 50 ms stages, yaw weight 10) the walk fell on 4 of
        //   seeds 0–4 at 0.3 m/s (its speed ran away to 0.45–0.56 m/s, its heading swung);
        // - 0.1 s and 0.3/s: 20/20 up at 0.3 m/s, 15/20 at 0.5 m/s; 0.3 s or 0.5 s (with 0.15/s) fell
        //   within 1.3–5 s on every seed, 0 s ran away to 0.7–0.85 m/s;
        // - with yaw weight 30 and 35 ms stages as well: 20/20 at 0.2, 0.3 and 0.4 m/s (yaw
        //   drift ≤ 0.21 rad), 17/20 at 0.5 m/s (30 or 40 ms stages: 9/15); the posture
        //   weight below lifted that to 40/40 at 0.5 and 0.6 m/s. Standing, it creeps
        //   half as far as before (0.22–0.31 m in 10 s) and survives 4 N·s pushes from every
        //   side on seeds 0–4 (before: 15 of those 20 runs).
        c.raibert_kv = 0.1;
        c.foothold_from_com = true;
        c.foothold_position_gain = 0.3;
        c.position_leash = 0.5;
        // Walking started more reliably from a slower speed ramp.
        c.max_acceleration = 0.3;
        // The WBC's posture task 4 × the default 0.05 (same probe, seeds 0–39):
        // with the weaker task the arms and the abdomen swung freely against the legs, the
        // torso's heading swung with them (point feet cannot hold it), and at 0.5 m/s the walk
        // fell on 3 of seeds 0–19 and drifted 0.24–0.59 rad on 2 more. With 0.15–0.3 it walks
        // at 0.3, 0.4, 0.5 and 0.6 m/s on 40 of 40 seeds each (0.1: 37 of 40 at 0.5 m/s; 0.5:
        // 31 of 40 at 0.6 m/s; 1.0: 3 of 20 at 0.5 m/s); 0.7 m/s holds on 13–14 of 20 and
        // 0.8 m/s on none.
        c.wbc.w_posture = 0.2;
        // Rated 0.5 m/s: 0.6 m/s meets the target unperturbed (above), but 4 N·s
        // pushed from its right it fell on 4 of seeds 0–4 (at 0.5 m/s, on 1 of 5 from either
        // side; 37 of 40 over seeds 0–9 from the four sides). A stand command steps in place.
        // Turning (`centaur control --yaw-rate … --measure-from 1`): ±0.5 rad/s
        // at 0.3 and 0.4 m/s within 0.04 rad/s on every seed (0–4; 0–9 at 0.4 m/s); at
        // 0.5 m/s +0.5 rad/s fell on seed 1 of 0–4, so it turns at up to 0.5 rad/s to
        // 0.4 m/s and, slower, at up to 0.3 rad/s to 0.5 m/s: ±0.3 rad/s at 0.45 and 0.5 m/s
        // held on seeds 0–9 (40 of 40 up, 0.280–0.313 rad/s, 0.49–0.55 m/s along the heading;
        // same probe).
        c.gaits = vec![
            GaitOffer::new(Gait::Stand, 0.0),
            GaitOffer::new(Gait::Walk, 0.5).turning(0.5, 0.4).then_turning(0.3, 0.5),
        ];
        c
    }

    /// Minitaur (`assets/minitaur/minitaur.urdf`, floating, 8 motors, 8 passive knees, four
    /// closed 5-bar legs). Contact = the toe, pivot (0, 0.005, 0.2) of `lower_leg_*R_link`;
    /// each loop is closed by keeping the `lower_leg_*L_link` pivot (0, 0.01, 0.2) on it
    /// along the two in-plane directions (x, z of the R lower leg; its y is the knee axis),
    /// as in the Rapier notes. Motor effort limit 3.5 N·m (the motor model's saturation).
    /// Standing pose: PyBullet's reset (motors ∓π/2, knees ±2.1834 by motor direction).
    pub fn minitaur() -> Self {
        let legs = ["front_left", "front_right", "back_left", "back_right"];
        let mut contacts = Vec::new();
        let mut closures = Vec::new();
        let mut nominal = Vec::new();
        for (i, l) in legs.iter().enumerate() {
            contacts.push(ContactSpec {
                frame: format!("lower_leg_{l}R_link"),
                offset: [0.0, 0.0, 0.195],
                radius: 0.005,
                leg: i,
            });
            closures.push(LoopClosureSpec {
                frame_a: format!("lower_leg_{l}R_link"),
                point_a: [0.0, 0.005, 0.2],
                frame_b: format!("lower_leg_{l}L_link"),
                point_b: [0.0, 0.01, 0.2],
                directions: vec![[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            });
            let dir = if l.ends_with("left") { -1.0 } else { 1.0 };
            for side in ["L", "R"] {
                nominal.push((format!("motor_{l}{side}_joint"), dir * std::f64::consts::FRAC_PI_2));
                nominal.push((format!("knee_{l}{side}_link"), -dir * 2.1834));
            }
        }
        let passive = nominal.iter().filter(|(n, _)| n.starts_with("knee")).map(|(n, _)| n.clone()).collect();
        let mut c = Self::with_robot(RobotSpec {
            base: BaseSpec::Floating,
            body_frame: "base_chassis_link".into(),
            contacts,
            n_legs: 4,
            passive_joints: passive,
            effort_limit: Some(3.5),
            nominal_joints: nominal,
            loop_closures: closures,
        });
        // A 7 cm swing and twice the default orientation stiffness keep the trot upright over
        // the env's whole randomisation range (±20 % base and leg mass, 14.8–16.8 V, friction
        // 0.8–1.5); at 4 cm and the default stiffness it fell with heavier legs or a full battery.
        c.swing_height = 0.07;
        c.body_kp_ori = c.body_kp_ori.map(|k| 2.0 * k);
        c.wbc.w_force = 10.0;
        c.touchdown_detection = false;
        // Every leg also gets motor PD targets, 4 N·m/rad and 0.2 N·m·s/rad: stance legs
        // towards the IK of the body carried along its reference over the planted feet
        // (`controller/contacts.rs`), swing legs towards the IK of the swing curve. Without
        // them the trot fell above 0.3 m/s on every seed (0.6 m/s after ≈ 2 s, 1.0 after
        // ≈ 1.5 s): the whole-body torques alone, recomputed at 100 Hz through a motor model
        // that saturates at 3.5 N·m, let the body fall behind its feet and pitch and roll
        // grow. With them (measured over seeds 0–4 with the env's randomisation,
        // `tools/closed_loop_table.py`) it trots 0.3–1.5 m/s (speed within 1 %, yaw drift
        // < 0.03 rad over 10 s), survives 2 N·s side pushes at 0.3 and 1.0 m/s, and keeps
        // trotting under Gaussian action noise of 10 % of the action range; with stance
        // gains alone (4, 0.1) it fell under that noise on 2 of 5 seeds.
        c.stance_joint_gains = (4.0, 0.2);
        c.swing_joint_gains = (4.0, 0.2);
        // Commands ramp at 3 m/s² (the default 1 m/s² took 2.5 s to reach 2.5 m/s, a tenth
        // of an episode); measured on seeds 0–4 at 0.3, 2.0 (with 10 % action noise, with
        // a 2 N·s push) and 2.5 m/s: 5/5 each, as at 1 m/s².
        c.max_acceleration = 3.0;
        // Turning without abduction: a foot pair in contact cannot yaw, one foot can, so a
        // yaw-rate command staggers the trot's diagonal partners (0.6 of the cycle per rad/s,
        // at most 0.2: each stance opens and closes on one foot). On one foot the body rolls
        // toward its swinging legs, and with the 7 cm swing they landed early, out of turn:
        // the Minitaur then turned left on seeds 0–2 but not right (−0.04 to −0.07 rad in
        // 10 s). With a 3 cm swing while staggered it turns both ways, 0.28–0.33 rad/s
        // commanded ±0.5 rad/s at 0.3–0.7 m/s (0.3 of the cycle fell); with the whole-body
        // QP's yaw axis weighted 20 while staggered (the default 1 lets the swing legs' and
        // the body's other tasks trade the heading away; 30 and 100 did no better) 0.37–0.50
        // rad/s. Staggered with that weight it fell at 0.7 m/s on 4 of 5 seeds and at 1.0 m/s
        // on 5 of 5 (within 0.5 s with the 3 cm swing; with the 7 cm swing it turned right at
        // only 0.11 rad/s, and a stagger of 0.1 of the cycle turned at 0.17–0.32 rad/s), while
        // at 0.6 m/s it turned on 5 of 5 seeds (+0.46–0.50, −0.41–0.46 rad/s commanded ±0.5;
        // ±0.28–0.30 commanded ±0.3), so trots above 0.6 m/s are not staggered
        // (`control_probe --set stagger=… --set turn_swing_height=… --set turn_yaw_weight=…
        // --set turn_max_speed=…`). Straight trots (no yaw command) are
        // unchanged, bit for bit.
        //
        // Right turns still lagged: 0.35–0.44 rad/s commanded −0.5 (seeds 0–4), the yaw error
        // pinned at its 0.3 rad leash, and at 0.6 m/s each ±0.5 rad/s row fell on a seed. What
        // lifted them, together (`control_probe --set turn_yaw_rate_weight=…
        // --set turn_period=…`, seeds 0–19): the MPC's yaw-rate weight 10 while staggered
        // (0.3 otherwise), a 5 cm swing (3 cm before), the WBC's yaw weight 40 (20 before) and
        // posture weight 0.1 (0.05 before), and a 5 % shorter cycle while staggered. Over
        // seeds 0–9 every ±0.5 rad/s row at 0.3, 0.5 and 0.6 m/s then turns within 15 %
        // (0.426–0.496 rad/s) without a fall; over seeds 10–19, −0.5 rad/s reaches
        // 0.405–0.486 and +0.5 at 0.6 m/s falls on 3 of 10 (before: 0.32–0.46, and 4 of 10
        // fell each way at 0.6 m/s). Less did less: without the shorter cycle and the
        // posture weight −0.5 made 0.420–0.460 (seeds 0–9), the yaw-rate weight alone
        // 0.38–0.44 (seeds 0–4); a 7 % shorter cycle fell at 0.6 m/s on 2 of seeds 0–9.
        c.turn_stagger = 0.6;
        c.turn_swing_height = 0.05;
        c.turn_yaw_weight = 40.0;
        c.turn_yaw_rate_weight = 10.0;
        c.turn_period_scale = 0.95;
        c.turn_max_speed = 0.6;
        // The whole-body QP's posture task 0.01 (the default 0.05) on straight trots: the
        // weaker pull toward the nominal joint accelerations leaves the legs to the body and
        // swing tasks at speed. Measured with `centaur control --unrated` (seeds
        // 0–4 unless said): 2.75 m/s on 5 of 5 seeds (3 of 5 before), 3.0 m/s on 8 of seeds
        // 0–9 (none of 0–4 before; 0 and 0.002–0.005 did the same on 0–4, 0.02 held 1 of 5),
        // 0.3–2.5 m/s, the walk, pushes and 10 % action noise as before with less tilt; a
        // hybrid on it reached 25.26 at 500k samples against 20.23 on the default weight (2
        // seeds each, README). Turning it kept the default: at 0.01 the staggered trot fell
        // on one seed of five turning ±0.5 rad/s at 0.5 m/s, which it held at 0.05 (0.1 since
        // later that day, above).
        c.wbc.w_posture = 0.01;
        c.turn_posture_weight = 0.1;
        // Only the gaits measured to work on the Minitaur are offered
        // (`tools/closed_loop_table.py`): the static walk needs a 0.6 s cycle (at the table's 0.8 s
        // it fell on every seed). The bound and the pronk need a shorter cycle and a higher body:
        // with the table's cycle (0.3 s) the bound fell within 0.4 s on every seed at 0.3–1 m/s, at
        // the standing CoM height (0.165 m) and at 0.19 m alike, by sinking below the env's 0.13 m
        // fall height as the body pitched ±0.2 rad; with half the cycle at the standing height it
        // stays up but lags (0.77–0.88 m/s for 1.0, 1.31–1.49 for 2.0, seeds 0–9). At 0.19 m and
        // half the table's cycle (0.15 s) the bound holds 0–2.5 m/s on seeds 0–9 (`control_probe
        // minitaur bound V 11 --set unrated=1 --set period=0.5 --height 0.19 --measure-from 1`;
        // at 2.0 m/s 1.79–1.92, at 2.5 2.12–2.34, one seed just outside 15 %), under 10
        // % action noise at 0.3, 1.0 and 2.0 m/s and 4 N·s side pushes at 1.0 and 2.0 m/s (seeds
        // 0–4; the trot fell under −y pushes at 2.0 m/s on 2 of 5; with the rise below, 4 of 5 each
        // way at 2.0 m/s). It also turns where the trot cannot: with its two front or two hind feet
        // planted the body yaws about their midpoint while each foot moves only fore and aft, in
        // its leg's plane. ±0.5 rad/s at 0.3, 0.6 and 1.0 m/s turned at 0.472–0.513 rad/s on seeds
        // 0–9 (at 1.5 m/s 0.18–0.47), ±0.3 rad/s at 1.2 m/s at 0.301–0.315 (at 1.5 m/s 0.17–0.31).
        // Cycles of 0.4–0.45 × with 0.20–0.21 m held 3.0 m/s straight (2.56–2.76 m/s) but turned
        // left at 0.17–0.38 rad/s on some seeds at 1.0 m/s; 0.6–0.7 × with 0.20 m turned at
        // 0.15–0.52. So the bound turns at 0.19 m and rises with speed, to 0.22 m from 2.5 m/s
        // (`rising_to`; at 0.20–0.22 m and half the cycle 3.0 m/s held on seeds 0–9 at 2.52–2.68
        // m/s, 0.21 and 0.22 m within 15 %): it then holds 1.5–3.0 m/s on seeds 0–9 (1.46–1.50,
        // 1.90–1.97, 2.21–2.33 and 2.61–2.66 m/s at 1.5, 2.0, 2.5 and 3.0), and below 1.2 m/s,
        // where it turns, it runs as before, bit for bit. It is rated 2.5 m/s: there 2 N·s side
        // pushes (seeds 0–4) and 10 % action noise (seeds 0–9) leave it up, but at 3.0 m/s 2 N·s
        // pushes felled it on 2 of 5 seeds, 4 N·s on 2 and 4 of 5, and the noise on 1 of 10. The
        // pronk, at the same cycle and height, holds 0–2.5 m/s straight (seeds 0–9; 2.23–2.31 at
        // 2.5) but turns at only 0.03–0.17 rad/s for ±0.5 (its four feet land together): rated 2.0,
        // straight only. The gallop is still refused: higher and faster (0.4–0.6 ×, 0.19–0.20 m) it
        // held 1 m/s on seeds 0–4 but drifted 0.09–0.30 rad in yaw and fell at 2 m/s on 2–4 of 5
        // (at 0.4 ×: up, at 1.1–1.6 m/s and 1.6 rad of drift). The pace is refused
        // for another reason: it holds straight runs (on an earlier controller, seeds
        // 0–4: 0.3–1.0 m/s, and at 0.3 and 0.6 m/s under 10 % action noise and 2 N·s
        // pushes), but a ±0.5 rad/s yaw-rate command topples it within 11 s on seeds 0–2
        // at 0.3 m/s (a lateral pair in contact cannot yaw, and only the trot is staggered
        // for turning), and at 1.0 m/s 10 % action noise fells it on 4 of 5 seeds.
        // The trot's cycle is 0.7 × the table's: at the table's period it fell at 2.5 m/s on
        // 2 of 3 seeds; at 0.7 × it trots 2.5 m/s (2.39 measured) on 5 of 5 and 2.75 m/s on
        // 3 of 5, and 0.3–2.0 m/s as before (`control_probe --set period=…`).
        // Turning: the staggered trot turns within 15 % of ±0.5 rad/s to `turn_max_speed`
        // (above); faster, unstaggered, it turned at 0.00–0.03 rad/s commanded ±0.3 or ±0.5
        // at 0.8–2.5 m/s (seeds 0–4), so it is rated straight there. The walk
        // turned at 0.06–0.13 rad/s commanded ±0.3 or ±0.5 at 0.3 and 0.5 m/s and fell in
        // three of the eight rows (on seed 3 twice, seed 0 once, of 0–4): straight only.
        c.gaits = vec![
            GaitOffer::new(Gait::Stand, 0.0),
            GaitOffer::new(Gait::Trot, 2.5).period(0.7).turning(0.5, c.turn_max_speed),
            GaitOffer::new(Gait::Walk, 0.5).period(0.75).straight_only(),
            GaitOffer::new(Gait::Bound, 2.5)
                .period(0.5)
                .com_height(0.19)
                .rising_to(0.22, 1.2, 2.5)
                .turning(0.5, 1.0)
                .then_turning(0.3, 1.2),
            GaitOffer::new(Gait::Pronk, 2.0).period(0.5).com_height(0.19).straight_only(),
        ];
        c
    }

    /// The configuration for `name` ("solo12", "ant", "walker2d", "humanoid", "minitaur").
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "solo12" => Some(Self::solo12()),
            "ant" => Some(Self::ant()),
            "walker2d" => Some(Self::walker2d()),
            "humanoid" => Some(Self::humanoid()),
            "minitaur" => Some(Self::minitaur()),
            _ => None,
        }
    }

    /// The offer of `gait`, or why it is refused ([`ConfigError::GaitNotOffered`], naming the
    /// gaits that are offered with their rated speeds).
    pub fn offer(&self, gait: Gait) -> Result<&GaitOffer, ConfigError> {
        self.find_offer(gait)
            .ok_or_else(|| ConfigError::GaitNotOffered { gait: gait.name(), offered: self.offered_gaits() })
    }

    /// The offer of `gait`, if any (allocation-free: the controller looks it up every tick).
    pub fn find_offer(&self, gait: Gait) -> Option<&GaitOffer> {
        self.gaits.iter().find(|o| o.gait == gait)
    }

    /// Multiplies the period of `gait`'s offer by `factor` (below 1 its clock steps faster);
    /// nothing for a gait not offered.
    pub fn scale_period(&mut self, gait: Gait, factor: f64) {
        for o in self.gaits.iter_mut().filter(|o| o.gait == gait) {
            o.period_scale *= factor;
        }
    }

    /// Lifts the gait offers, to show why a gait is not offered: every gait defined for the
    /// robot's leg count, with the period scale, CoM height, stance fraction and weights of
    /// its offer (the table's and the configuration's when not offered), unrated.
    pub fn offer_every_gait(&mut self) {
        let n_legs = self.robot.n_legs;
        let offered = std::mem::take(&mut self.gaits);
        self.gaits = Gait::ALL
            .iter()
            .filter(|g| g.supported(n_legs))
            .map(|&g| {
                let own = offered.iter().find(|o| o.gait == g);
                GaitOffer {
                    period_scale: own.map_or(1.0, |o| o.period_scale),
                    com_height: own.and_then(|o| o.com_height),
                    height_rise: own.and_then(|o| o.height_rise),
                    duty_factor: own.and_then(|o| o.duty_factor),
                    mpc_state_weights: own.and_then(|o| o.mpc_state_weights),
                    body_angular_weight: own.and_then(|o| o.body_angular_weight),
                    ..GaitOffer::new(g, f64::INFINITY)
                }
            })
            .collect();
    }

    /// The CoM height (m above the ground) the controller holds the body at under `command`
    /// at the commanded planar `speed` (m/s, after the ramp): the command's
    /// [`Command::body_height`], else the commanded gait's own ([`GaitOffer::height_at`]),
    /// else `nominal` (the robot's standing CoM height).
    pub fn com_height(&self, command: &Command, speed: f64, nominal: f64) -> f64 {
        command.com_height(self.find_offer(command.gait).and_then(|o| o.height_at(speed)).unwrap_or(nominal))
    }

    /// Checks that `gait` is offered, `speed` (m/s, planar) within its rating and
    /// `yaw_rate` (rad/s) within its turning rating at that speed.
    pub fn check_command(&self, gait: Gait, speed: f64, yaw_rate: f64) -> Result<(), ConfigError> {
        let offer = self.offer(gait)?;
        if gait == Gait::Stand {
            return Ok(());
        }
        if speed.abs() > offer.max_speed + 1e-12 {
            return Err(ConfigError::SpeedAboveRating {
                gait: gait.name(),
                speed,
                max_speed: offer.max_speed,
            });
        }
        if yaw_rate.abs() > offer.yaw_rate_rating(speed) + 1e-12 {
            return Err(ConfigError::YawRateAboveRating {
                gait: gait.name(),
                yaw_rate,
                speed,
                rating: offer.turning_text(),
            });
        }
        Ok(())
    }

    /// The offered gaits with their speed and turning ranges, for messages: `"stand, trot
    /// (0–2.5 m/s; turns at up to 0.5 rad/s to 0.6 m/s)"`.
    pub fn offered_gaits(&self) -> String {
        let list: Vec<String> = self
            .gaits
            .iter()
            .map(|o| match o.max_speed {
                _ if o.gait == Gait::Stand => o.gait.name().to_string(),
                m if m.is_infinite() && o.max_yaw_rate.is_infinite() => {
                    format!("{} (unrated)", o.gait.name())
                }
                m => format!("{} (0–{m} m/s; {})", o.gait.name(), o.turning_text()),
            })
            .collect();
        list.join(", ")
    }

    /// Stance fraction of each gait ([`Gait::index`]) for the gait scheduler
    /// ([`GaitOffer::duty_factor`]): 0 for the table's.
    pub fn duty_factors(&self) -> [f64; Gait::ALL.len()] {
        let mut duties = [0.0; Gait::ALL.len()];
        for o in &self.gaits {
            duties[o.gait.index()] = o.duty_factor.unwrap_or(0.0);
        }
        duties
    }

    /// The MPC's state weights while `gait` runs: its offer's own, else
    /// [`MpcConfig::state_weights`].
    pub fn mpc_state_weights(&self, gait: Gait) -> [f64; 12] {
        self.find_offer(gait).and_then(|o| o.mpc_state_weights).unwrap_or(self.mpc.state_weights)
    }

    /// The whole-body QP's body-orientation weight while `gait` runs: its offer's own, else
    /// [`WbcConfig::w_body_angular`].
    pub fn body_angular_weight(&self, gait: Gait) -> f64 {
        self.find_offer(gait).and_then(|o| o.body_angular_weight).unwrap_or(self.wbc.w_body_angular)
    }

    /// Period scale of each gait ([`Gait::index`]) for the gait scheduler: 0 for a gait not
    /// offered.
    pub fn period_scales(&self) -> [f64; Gait::ALL.len()] {
        let mut scales = [0.0; Gait::ALL.len()];
        for o in &self.gaits {
            scales[o.gait.index()] = self.gait_period_scale * o.period_scale;
        }
        // Stepping in place runs the walk for a stand command, offered or not.
        let walk = Gait::Walk.index();
        if self.step_in_place && scales[walk] == 0.0 {
            scales[walk] = self.gait_period_scale;
        }
        scales
    }

    /// The gait the controller runs for a commanded `gait` once on the ground: the walk
    /// gait for a stand command with [`ControllerConfig::step_in_place`], else `gait`.
    pub fn gait_for(&self, gait: Gait) -> Gait {
        match gait {
            Gait::Stand if self.step_in_place => Gait::Walk,
            g => g,
        }
    }

    /// Checks every number and the sub-configurations.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.mpc.validate()?;
        self.wbc.validate()?;
        let finite_nonneg = [
            ("mpc_period", self.mpc_period),
            ("swing_height", self.swing_height),
            ("touchdown_speed", self.touchdown_speed),
            ("swing_gains.0", self.swing_gains.0),
            ("swing_gains.1", self.swing_gains.1),
            ("cheap_swing_gains.0", self.cheap_swing_gains.0),
            ("cheap_swing_gains.1", self.cheap_swing_gains.1),
            ("posture_gains.0", self.posture_gains.0),
            ("posture_gains.1", self.posture_gains.1),
            ("swing_joint_gains.0", self.swing_joint_gains.0),
            ("swing_joint_gains.1", self.swing_joint_gains.1),
            ("stance_joint_gains.0", self.stance_joint_gains.0),
            ("stance_joint_gains.1", self.stance_joint_gains.1),
            ("fallback_joint_gains.0", self.fallback_joint_gains.0),
            ("fallback_joint_gains.1", self.fallback_joint_gains.1),
            ("raibert_kv", self.raibert_kv),
            ("foothold_position_gain", self.foothold_position_gain),
            ("max_acceleration", self.max_acceleration),
            ("position_leash", self.position_leash),
            ("recenter_speed", self.recenter_speed),
            ("max_yaw_acceleration", self.max_yaw_acceleration),
            ("turn_stagger", self.turn_stagger),
            ("turn_swing_height", self.turn_swing_height),
            ("turn_yaw_weight", self.turn_yaw_weight),
            ("turn_posture_weight", self.turn_posture_weight),
            ("turn_yaw_rate_weight", self.turn_yaw_rate_weight),
            ("ik_damping", self.ik_damping),
        ];
        if self.turn_max_speed.is_nan() || self.turn_max_speed < 0.0 {
            return Err(ConfigError::OutOfRange {
                field: "turn_max_speed",
                value: self.turn_max_speed,
                range: ">= 0 (may be infinite)",
            });
        }
        for (field, v) in finite_nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ConfigError::OutOfRange { field, value: v, range: "finite, >= 0" });
            }
        }
        for (field, arr) in [
            ("body_kp_pos", self.body_kp_pos),
            ("body_kd_vel", self.body_kd_vel),
            ("body_kp_ori", self.body_kp_ori),
            ("body_kd_ang", self.body_kd_ang),
        ] {
            if let Some(v) = arr.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                return Err(ConfigError::OutOfRange { field, value: *v, range: "finite, >= 0" });
            }
        }
        if !(self.gait_period_scale.is_finite() && self.gait_period_scale > 0.0) {
            return Err(ConfigError::OutOfRange {
                field: "gait_period_scale",
                value: self.gait_period_scale,
                range: "> 0",
            });
        }
        if !(self.turn_period_scale.is_finite() && self.turn_period_scale > 0.0) {
            return Err(ConfigError::OutOfRange {
                field: "turn_period_scale",
                value: self.turn_period_scale,
                range: "> 0",
            });
        }
        if !(0.0..=1.0).contains(&self.fallback_decay) {
            return Err(ConfigError::OutOfRange {
                field: "fallback_decay",
                value: self.fallback_decay,
                range: "0..=1",
            });
        }
        if self.robot.n_legs != 2 && self.robot.n_legs != 4 {
            return Err(ConfigError::OutOfRange {
                field: "robot.n_legs",
                value: self.robot.n_legs as f64,
                range: "2 or 4",
            });
        }
        if !self.gaits.iter().any(|o| o.gait == Gait::Stand) {
            return Err(ConfigError::Inconsistent("gaits: stand must be offered".into()));
        }
        for (i, o) in self.gaits.iter().enumerate() {
            if !o.gait.supported(self.robot.n_legs) {
                return Err(ConfigError::Inconsistent(format!(
                    "gaits: {} is not defined for a robot with {} legs",
                    o.gait.name(),
                    self.robot.n_legs
                )));
            }
            if self.gaits[..i].iter().any(|p| p.gait == o.gait) {
                return Err(ConfigError::Inconsistent(format!("gaits: {} is listed twice", o.gait.name())));
            }
            if !(o.period_scale.is_finite() && o.period_scale > 0.0) {
                return Err(ConfigError::OutOfRange {
                    field: "gaits.period_scale",
                    value: o.period_scale,
                    range: "> 0",
                });
            }
            for (field, value) in [
                ("gaits.max_speed", o.max_speed),
                ("gaits.max_yaw_rate", o.max_yaw_rate),
                ("gaits.max_turning_speed", o.max_turning_speed),
            ] {
                if value.is_nan() || value < 0.0 {
                    return Err(ConfigError::OutOfRange { field, value, range: ">= 0" });
                }
            }
            if let Some(h) = o.com_height
                && !(h.is_finite() && h > 0.0)
            {
                return Err(ConfigError::OutOfRange { field: "gaits.com_height", value: h, range: "> 0 m" });
            }
            if let Some(d) = o.duty_factor
                && !(d > 0.0 && d < 1.0 && o.gait != Gait::Stand)
            {
                return Err(ConfigError::OutOfRange {
                    field: "gaits.duty_factor",
                    value: d,
                    range: "in (0, 1), and none for stand",
                });
            }
            if let Some(w) = o.mpc_state_weights
                && let Some(v) = w.iter().find(|v| !(v.is_finite() && **v >= 0.0))
            {
                return Err(ConfigError::OutOfRange {
                    field: "gaits.mpc_state_weights",
                    value: *v,
                    range: "finite, >= 0",
                });
            }
            if let Some(w) = o.body_angular_weight
                && !(w.is_finite() && w >= 0.0)
            {
                return Err(ConfigError::OutOfRange {
                    field: "gaits.body_angular_weight",
                    value: w,
                    range: "finite, >= 0",
                });
            }
            if let Some(r) = o.height_rise {
                if o.com_height.is_none() {
                    return Err(ConfigError::Inconsistent(format!(
                        "gaits: {}'s height rises from its com_height, which is not set",
                        o.gait.name()
                    )));
                }
                if !(r.height.is_finite() && r.height > 0.0) {
                    return Err(ConfigError::OutOfRange {
                        field: "gaits.height_rise.height",
                        value: r.height,
                        range: "> 0 m",
                    });
                }
                if !(r.from_speed.is_finite() && r.from_speed >= 0.0) {
                    return Err(ConfigError::OutOfRange {
                        field: "gaits.height_rise.from_speed",
                        value: r.from_speed,
                        range: ">= 0 m/s",
                    });
                }
                if !(r.to_speed.is_finite() && r.to_speed > r.from_speed) {
                    return Err(ConfigError::OutOfRange {
                        field: "gaits.height_rise.to_speed",
                        value: r.to_speed,
                        range: "finite and above gaits.height_rise.from_speed",
                    });
                }
            }
            if let Some(t) = o.faster_turning {
                // Faster and slower than the first rating, or it says nothing new.
                if !(t.max_yaw_rate > 0.0 && t.max_yaw_rate < o.max_yaw_rate) {
                    return Err(ConfigError::OutOfRange {
                        field: "gaits.faster_turning.max_yaw_rate",
                        value: t.max_yaw_rate,
                        range: "> 0 and below gaits.max_yaw_rate",
                    });
                }
                if !(t.max_speed > o.max_turning_speed && t.max_speed.is_finite()) {
                    return Err(ConfigError::OutOfRange {
                        field: "gaits.faster_turning.max_speed",
                        value: t.max_speed,
                        range: "finite and above gaits.max_turning_speed",
                    });
                }
            }
        }
        if self.robot.n_legs != 2 && self.robot.n_legs != 4 {
            return Err(ConfigError::OutOfRange {
                field: "robot.n_legs",
                value: self.robot.n_legs as f64,
                range: "2 or 4",
            });
        }
        Ok(())
    }
}

/// What the robot should do.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Command {
    /// Forward velocity in the heading frame (m/s).
    pub forward_velocity: f64,
    /// Lateral velocity, positive to the left (m/s).
    pub lateral_velocity: f64,
    /// Yaw rate (rad/s).
    pub yaw_rate: f64,
    /// CoM height above the ground (m); `None` keeps the nominal standing height.
    pub body_height: Option<f64>,
    /// Gait (ignored if not defined for the robot's number of legs).
    pub gait: Gait,
}

impl Default for Command {
    fn default() -> Self {
        Self {
            forward_velocity: 0.0,
            lateral_velocity: 0.0,
            yaw_rate: 0.0,
            body_height: None,
            gait: Gait::Stand,
        }
    }
}

impl Command {
    /// Stand still.
    pub fn stand() -> Self {
        Self::default()
    }

    /// The CoM height (m above the ground) this command holds the body at: its
    /// `body_height`, or `nominal` (the robot's standing CoM height) without one.
    pub fn com_height(&self, nominal: f64) -> f64 {
        self.body_height.unwrap_or(nominal)
    }

    /// Move forward at `speed` with `gait`.
    pub fn forward(speed: f64, gait: Gait) -> Self {
        Self { forward_velocity: speed, gait, ..Self::default() }
    }

    /// Checks the numbers: finite velocities and yaw rate, and a finite positive body
    /// height if one is set. The controller answers a command that fails it with its
    /// posture fallback; the hybrid and `centaur control` refuse it when they are built.
    pub fn check(&self) -> Result<(), ConfigError> {
        for (field, value) in [
            ("command.forward_velocity", self.forward_velocity),
            ("command.lateral_velocity", self.lateral_velocity),
            ("command.yaw_rate", self.yaw_rate),
        ] {
            if !value.is_finite() {
                return Err(ConfigError::OutOfRange { field, value, range: "finite" });
            }
        }
        match self.body_height {
            Some(value) if !(value.is_finite() && value > 0.0) => {
                Err(ConfigError::OutOfRange { field: "command.body_height", value, range: "> 0 m" })
            }
            _ => Ok(()),
        }
    }
}
