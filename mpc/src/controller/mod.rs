//! [`LocomotionController`]: the locomotion pipeline as a list of stages, each a file that
//! owns its state, allocation-free after construction:
//!
//! | stage | file | reads | writes |
//! |---|---|---|---|
//! | estimate | `estimate.rs` | the state | kinematics, dynamics and task Jacobians of the robot as measured |
//! | reference | `reference.rs` | the command, the estimate | the shaped command: rate-limited velocity, yaw and position references |
//! | contacts and swing | `contacts.rs` | gait schedule, measured contacts, estimate, reference | effective stance, footholds, swing and stance targets ([`LocomotionTargets`](targets::LocomotionTargets)) |
//! | plan | `plan.rs` | estimate, reference, targets | the convex MPC's plan and this tick's contact forces |
//! | torques | `torques.rs` | estimate, reference, targets | feed-forward torques (whole-body QP or the cheap path), PD targets and gains |
//! | status | `status.rs` | everything | [`ControllerStatus`] |
//!
//! The planning stages hand their output to the torque stage in one typed struct,
//! `LocomotionTargets`, as the MIT Cheetah controller hands `LocomotionCtrlData` from its
//! planner to its whole-body controller.

mod contacts;
mod estimate;
mod plan;
mod reference;
mod status;
mod targets;
mod torques;

use centaur_dynamics::nalgebra::DVector;
use centaur_dynamics::{Data, Model, RobotState};

pub use contacts::{LANDING_HEIGHT, MAX_FOOTHOLD_OFFSET, SWING_SCALE_RANGE};
pub use reference::wrap_pi;
pub use status::{ControllerStatus, Fallback, JointCommand};

use contacts::Contacts;
use estimate::Estimate;
use plan::Planner;
use reference::Reference;
use targets::{LocomotionTargets, TickContext};
use torques::Torques;

use crate::config::{Command, ControllerConfig};
use crate::convex_mpc::ConvexMpc;
use crate::error::ConfigError;
use crate::gait::{Gait, GaitScheduler};
use crate::robot::LeggedRobot;

/// The body heights a command may set ([`Command::body_height`]), as fractions of the
/// robot's standing CoM height ([`LocomotionController::check_command`]).
pub const BODY_HEIGHT_RANGE: (f64, f64) = (0.5, 2.0);

/// The locomotion controller. See the crate documentation for the pipeline.
pub struct LocomotionController {
    cfg: ControllerConfig,
    robot: LeggedRobot,
    data: Data,
    gait: GaitScheduler,
    estimate: Estimate,
    reference: Reference,
    contacts: Contacts,
    planner: Planner,
    torques: Torques,
    targets: LocomotionTargets,
    command: JointCommand,
    status: ControllerStatus,
    /// Time of the last tick (`None` after construction or a reset).
    last_t: Option<f64>,
    contact_frame_names: Vec<String>,
}

impl std::fmt::Debug for LocomotionController {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LocomotionController").field("robot", &self.robot.model.name).finish()
    }
}

impl LocomotionController {
    /// Resolves the configuration against `model` and allocates everything.
    pub fn new(model: &Model, config: ControllerConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let robot = LeggedRobot::new(model, &config.robot)?;
        let nc = robot.n_contacts();
        let planner = Planner::new(&config, &robot)?;
        let torques = Torques::new(&config, &robot)?;
        let mut command = JointCommand::new(robot.n_actuated());
        for (i, &iq) in robot.actuated_q.iter().enumerate() {
            command.q_des[i] = robot.q_nominal[iq];
        }
        Ok(Self {
            gait: GaitScheduler::with_period_scales(robot.n_legs, config.period_scales())
                .with_duty_factors(config.duty_factors()),
            data: Data::new(&robot.model),
            estimate: Estimate::new(&robot),
            reference: Reference::new(),
            contacts: Contacts::new(nc),
            planner,
            torques,
            targets: LocomotionTargets::new(nc),
            command,
            status: ControllerStatus::new(nc, config.mpc.horizon),
            last_t: None,
            contact_frame_names: config.robot.contacts.iter().map(|c| c.frame.clone()).collect(),
            robot,
            cfg: config,
        })
    }

    /// Names of the actuated joints: the order of every vector in [`JointCommand`].
    pub fn joint_names(&self) -> &[String] {
        &self.robot.actuated_names
    }

    /// Checks `command` for this robot: [`Command::check`]'s numbers, and a set body height
    /// within [`BODY_HEIGHT_RANGE`] times the robot's standing CoM height (a height in
    /// centimetres, or far beyond the legs, would only make the robot fall). Every tick
    /// answers a command that fails it with the posture fallback; the hybrid refuses one
    /// when it is built.
    pub fn check_command(&self, command: &Command) -> Result<(), ConfigError> {
        command.check()?;
        match command.body_height {
            Some(h)
                if !(h >= BODY_HEIGHT_RANGE.0 * self.robot.nominal_com_height
                    && h <= BODY_HEIGHT_RANGE.1 * self.robot.nominal_com_height) =>
            {
                Err(ConfigError::OutOfRange {
                    field: "command.body_height",
                    value: h,
                    range: "within 0.5–2 × the robot's standing CoM height",
                })
            }
            _ => Ok(()),
        }
    }

    /// The resolved robot (model with contact frames, nominal pose, mass, inertia).
    pub fn robot(&self) -> &LeggedRobot {
        &self.robot
    }

    /// The configuration.
    pub fn config(&self) -> &ControllerConfig {
        &self.cfg
    }

    /// The CoM height (m above the ground) the controller holds the body at under
    /// `command` ([`ControllerConfig::com_height`] over the robot's nominal standing CoM
    /// height, at the planar speed of its velocity command after the ramp, as of the last
    /// tick).
    pub fn height_reference(&self, command: &Command) -> f64 {
        self.cfg.com_height(command, self.reference.v_cmd.xy().norm(), self.robot.nominal_com_height)
    }

    /// The status of the last tick.
    pub fn status(&self) -> &ControllerStatus {
        &self.status
    }

    /// Generalized accelerations `q̈` the whole-body QP planned in the last tick that solved
    /// it (model `v` layout).
    pub fn planned_accelerations(&self) -> &DVector<f64> {
        &self.torques.wbc.output.qdd
    }

    /// The convex MPC with its last problem ([`ConvexMpc::input`]) and solution, when it
    /// runs inside `tick` ([`crate::MpcExecution::Inline`]); `None` when it runs on the
    /// worker thread.
    pub fn mpc(&self) -> Option<&ConvexMpc> {
        self.planner.mpc()
    }

    /// The last command.
    pub fn command(&self) -> &JointCommand {
        &self.command
    }

    /// A state standing still at the nominal pose.
    pub fn nominal_state(&self) -> RobotState {
        let mut s = RobotState::new(&self.robot.model);
        s.q.copy_from(&self.robot.q_nominal);
        s
    }

    /// Forgets the gait phase, command ramps and MPC plan (e.g. at an episode reset).
    pub fn reset(&mut self) {
        self.gait.reset();
        self.last_t = None;
        self.planner.reset();
        self.reference.reset();
        self.contacts.reset();
    }

    /// Sets the rate of the gait clock: 1 runs every gait at its own period, above 1 the
    /// gait steps faster (each cycle takes 1/rate of its period), below 1 slower. The clock
    /// follows at a bounded slew and the phase carries on, so no contact jumps; clamped to
    /// [`crate::GAIT_RATE_RANGE`], a non-finite rate counts as 1, and [`Self::reset`] goes
    /// back to 1 ([`crate::GaitScheduler::set_rate`]). A hybrid's policy steers it
    /// (`Steering::cadence` in `centaur`).
    pub fn set_gait_rate(&mut self, rate: f64) {
        self.gait.set_rate(rate);
    }

    /// The rate the gait clock runs at now ([`Self::set_gait_rate`]).
    pub fn gait_rate(&self) -> f64 {
        self.gait.rate()
    }

    /// Moves every stepping gait's stance fractions by `shift` from their own (below 0 the
    /// feet lift off sooner: a trot with flight phases). The shift follows at a bounded
    /// slew and each leg's phase carries on; clamped to ±[`crate::MAX_DUTY_SHIFT`], the
    /// fractions held in [`crate::DUTY_RANGE`], a non-finite shift counts as 0, and
    /// [`Self::reset`] goes back to 0 ([`crate::GaitScheduler::set_duty_shift`]). A hybrid's
    /// policy steers it (`Steering::duty` in `centaur`).
    pub fn set_gait_duty_shift(&mut self, shift: f64) {
        self.gait.set_duty_shift(shift);
    }

    /// The shift of the stance fractions in force now ([`Self::set_gait_duty_shift`]).
    pub fn gait_duty_shift(&self) -> f64 {
        self.gait.duty_shift()
    }

    /// Scales the swing feet's apex height (the configured `swing_height`, or
    /// `turn_swing_height` while turning) by `scale` for every swing that lifts off from now
    /// on; a swing under way keeps its curve. Clamped to [`crate::SWING_SCALE_RANGE`], a
    /// non-finite scale counts as 1, and [`Self::reset`] goes back to 1. A hybrid's policy
    /// steers it (`Steering::swing` in `centaur`).
    pub fn set_swing_height_scale(&mut self, scale: f64) {
        self.contacts.set_swing_scale(scale);
    }

    /// The scale the next swings' apex takes ([`Self::set_swing_height_scale`]).
    pub fn swing_height_scale(&self) -> f64 {
        self.contacts.swing_scale()
    }

    /// Moves the footholds of every swing that lifts off from now on `offset` metres
    /// forward along the body's heading (negative: behind), on top of Raibert's neutral
    /// point and its capture-point correction; a swing under way keeps its foothold's
    /// offset, and the MPC's look-ahead of the stance legs' next footholds takes the offset
    /// in force. Clamped to ±[`crate::MAX_FOOTHOLD_OFFSET`], a non-finite offset counts as
    /// 0, and [`Self::reset`] goes back to 0. A hybrid's policy steers it
    /// (`Steering::foothold` in `centaur`).
    pub fn set_foothold_offset(&mut self, offset: f64) {
        self.contacts.set_foothold_offset(offset);
    }

    /// The foothold offset the next swings take ([`Self::set_foothold_offset`]).
    pub fn foothold_offset(&self) -> f64 {
        self.contacts.foothold_offset()
    }

    /// One control step at time `t` (s). Never panics on a non-finite state (it falls back
    /// to posture PD and says so in the status).
    ///
    /// # Panics
    /// If `state` does not have the model's `nq`/`nv` (a programming error).
    #[track_caller]
    pub fn tick(&mut self, state: &RobotState, command: &Command, t: f64) -> &JointCommand {
        self.contacts.set_measured(None);
        self.tick_inner(state, command, t)
    }

    /// [`LocomotionController::tick`] with measured contact flags, one per contact point in
    /// [`LocomotionController::contact_frames`] order (e.g. from foot switches or the
    /// simulator). A scheduled stance starts only when its foot touches the ground (until
    /// then the foot keeps descending at `touchdown_speed`), and a swing that touches the
    /// ground in its second half ends early.
    ///
    /// # Panics
    /// If `state` does not have the model's `nq`/`nv` or `contacts` does not have one flag
    /// per contact point (programming errors).
    #[track_caller]
    pub fn tick_with_contacts(
        &mut self,
        state: &RobotState,
        command: &Command,
        t: f64,
        contacts: &[bool],
    ) -> &JointCommand {
        let nc = self.robot.n_contacts();
        assert!(contacts.len() == nc, "{} contact flags for {nc} contact points", contacts.len());
        self.contacts.set_measured(Some(contacts));
        self.tick_inner(state, command, t)
    }

    /// Names of the frames the contact points are attached to, in contact order.
    pub fn contact_frames(&self) -> &[String] {
        &self.contact_frame_names
    }

    /// The pipeline: estimate → reference → contacts and swing → plan → torques → status.
    #[track_caller]
    fn tick_inner(&mut self, state: &RobotState, command: &Command, t: f64) -> &JointCommand {
        let (model_nq, model_nv) = (self.robot.model.nq, self.robot.model.nv);
        assert!(
            state.q.len() == model_nq && state.v.len() == model_nv,
            "state has nq = {}, nv = {}, but the model expects {model_nq}, {model_nv}",
            state.q.len(),
            state.v.len()
        );
        self.status.begin(t);
        if !state.is_finite()
            || !t.is_finite()
            || self.check_command(command).is_err()
            || !self.estimate.set_state(&self.robot, &state.q, &state.v)
        {
            self.posture_fallback();
            return &self.command;
        }
        let dt = match self.last_t {
            Some(t0) if t >= t0 && t - t0 <= 0.1 => t - t0,
            _ => 0.0,
        };
        let first = self.last_t.is_none();
        self.last_t = Some(t);
        let cfg = &self.cfg;

        self.estimate.update(&mut self.robot, &mut self.data, (cfg.wbc.closure_kp, cfg.wbc.closure_kd));
        let est = &self.estimate;
        if first {
            self.reference.hold_at(est);
        }
        let airborne = !self.contacts.update_landing(est);
        if airborne {
            // Nothing to hold the body to until it lands: references follow the state.
            self.reference.hold_at(est);
        }
        let shaped = self.reference.shape(cfg, est, command, dt, airborne, self.robot.nominal_com_height);
        self.status.refused_gaits += u64::from(shaped.refused);
        self.status.clamped_commands += u64::from(shaped.clamped);
        // The planar speed of the (ramped) velocity command, whatever the heading; the
        // tolerance keeps a command of exactly `turn_max_speed` staggered at every heading.
        let stagger = if self.reference.v_cmd.xy().norm() <= cfg.turn_max_speed + 1e-9 {
            cfg.turn_stagger * self.reference.yaw_rate_cmd
        } else {
            0.0
        };
        self.gait.set_stagger(stagger);
        self.gait.set_stagger_period_scale(cfg.turn_period_scale);
        let gait_changed = self.gait.update(t, shaped.gait);
        let standing = self.gait.pattern().gait == Gait::Stand;
        self.reference.update_position(cfg, est, dt, &shaped.target_velocity, standing);
        let cx = TickContext {
            cfg,
            robot: &self.robot,
            est,
            reference: &self.reference,
            gait: &self.gait,
            t,
            dt,
            height: shaped.height,
        };
        self.contacts.update(&cx, self.status.ticks == 1, &mut self.targets);
        self.planner.update(&cx, gait_changed, &mut self.targets, &mut self.status);
        self.torques.update(&cx, &mut self.targets, &mut self.command, &mut self.status);
        self.status.fill(&self.gait, &self.planner.schedule, est, &self.reference, &self.targets);
        &self.command
    }

    fn posture_fallback(&mut self) {
        self.status.invalid_states += 1;
        self.status.fallback = Fallback::PosturePd;
        let (kp, kd) = self.cfg.fallback_joint_gains;
        for (i, &iq) in self.robot.actuated_q.iter().enumerate() {
            self.command.tau[i] = 0.0;
            self.command.q_des[i] = self.robot.q_nominal[iq];
            self.command.qd_des[i] = 0.0;
            self.command.kp[i] = kp;
            self.command.kd[i] = kd;
        }
    }
}

#[cfg(test)]
mod tests {
    use centaur_dynamics::{BaseKind, Model};

    use super::*;
    use crate::config::GaitOffer;
    use crate::qp::QpStatus;

    #[test]
    fn infeasible_joint_limit_bounds_are_dropped_not_failed() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/mujoco/walker2d.urdf");
        let model = Model::from_urdf_file(path, BaseKind::Fixed).unwrap();
        let mut c = LocomotionController::new(&model, ControllerConfig::walker2d()).unwrap();
        let s = c.nominal_state();
        c.tick(&s, &Command::stand(), 0.0);
        assert!(c.status().wbc_status.is_ok());
        assert_eq!(c.status().wbc_limit_relaxations, 0);
        // With the input of that tick, demand 10⁶ rad/s² of the first limited joint: no
        // 100 N·m motor gives that, so the QP is infeasible with the bound and solved without.
        let first = c.torques.wbc.limited_joints()[0];
        c.torques.wbc.input.qdd_lower[0] = 1e6;
        assert_eq!(c.torques.wbc.solve(), QpStatus::Solved);
        assert!(c.torques.wbc.limits_relaxed());
        assert!(c.torques.wbc.output.qdd[first.v] < 1e3);
        // A reachable bound holds as a constraint: bend the joint away from its upper limit.
        let (q, v) = (c.estimate.q.clone(), c.estimate.v.clone());
        c.torques.wbc.set_joint_limit_bounds(q.as_slice(), v.as_slice());
        c.torques.wbc.input.qdd_upper[0] = -5.0;
        assert_eq!(c.torques.wbc.solve(), QpStatus::Solved);
        assert!(!c.torques.wbc.limits_relaxed());
        assert!(c.torques.wbc.output.qdd[first.v] <= -5.0 + 1e-6, "{}", c.torques.wbc.output.qdd[first.v]);
    }

    /// Feet in swing at some tick of `seconds` of stand commands from the nominal state
    /// raised by `lift` metres, and the gait run.
    fn stand_for(config: ControllerConfig, seconds: f64, lift: f64) -> ([bool; 2], Gait) {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/mujoco/humanoid.urdf");
        let model = Model::from_urdf_file(path, BaseKind::Floating).unwrap();
        let mut c = LocomotionController::new(&model, config).unwrap();
        let mut s = c.nominal_state();
        s.q[2] += lift;
        let mut swung = [false; 2];
        for k in 0..(seconds / 0.015) as usize {
            c.tick(&s, &Command::stand(), k as f64 * 0.015);
            for (leg, sw) in swung.iter_mut().enumerate() {
                *sw |= !c.status().contact[leg];
            }
        }
        (swung, c.status().gait)
    }

    #[test]
    fn gaits_not_offered_are_refused_and_speeds_above_the_rating_clamped() {
        let cfg = ControllerConfig::minitaur();
        let e = cfg.offer(Gait::Gallop).unwrap_err();
        assert!(matches!(e, ConfigError::GaitNotOffered { gait: "gallop", .. }));
        let msg = e.to_string();
        assert!(msg.contains("stand") && msg.contains("trot (0–2.5 m/s;") && msg.contains("walk"), "{msg}");
        assert!(cfg.check_command(Gait::Trot, 2.5, 0.0).is_ok());
        assert!(matches!(
            cfg.check_command(Gait::Trot, -2.6, 0.0),
            Err(ConfigError::SpeedAboveRating { .. })
        ));
        assert!(
            cfg.check_command(Gait::Stand, 1.0, 1.0).is_ok(),
            "a stand's command shifts the body, unrated"
        );
        // Turning: the trot ±0.5 rad/s to 0.6 m/s, straight above; the walk straight only.
        assert!(
            cfg.check_command(Gait::Trot, 0.6, -0.5).is_ok()
                && cfg.check_command(Gait::Trot, 2.5, 0.0).is_ok()
        );
        let turn_err = |v: f64, w: f64, gait: Gait| match cfg.check_command(gait, v, w) {
            Err(e @ ConfigError::YawRateAboveRating { .. }) => e.to_string(),
            other => panic!("{gait:?} at {v} m/s, {w} rad/s: {other:?}"),
        };
        assert!(turn_err(0.6, 0.51, Gait::Trot).contains("turns at up to 0.5 rad/s to 0.6 m/s"));
        assert!(turn_err(1.0, 0.1, Gait::Trot).contains("trot turning at 0.1 rad/s at 1 m/s"));
        assert!(turn_err(0.3, -0.05, Gait::Walk).contains("straight only"));
        assert!(msg.contains("trot (0–2.5 m/s; turns at up to 0.5 rad/s to 0.6 m/s)"), "{msg}");
        assert!(msg.contains("walk (0–0.5 m/s; straight only)"), "{msg}");
        assert!(
            msg.contains("bound (0–2.5 m/s; turns at up to 0.5 rad/s to 1 m/s and 0.3 rad/s to 1.2 m/s)"),
            "{msg}"
        );
        assert!(msg.contains("pronk (0–2 m/s; straight only)"), "{msg}");
        // The bound turns where the trot cannot: ±0.5 rad/s to 1 m/s, ±0.3 to 1.2 m/s.
        assert!(
            cfg.check_command(Gait::Bound, 1.0, -0.5).is_ok()
                && cfg.check_command(Gait::Bound, 1.2, 0.3).is_ok()
        );
        assert!(turn_err(1.2, 0.31, Gait::Bound).contains("0.3 rad/s to 1.2 m/s"));
        assert!(turn_err(1.5, 0.1, Gait::Bound).contains("bound turning at 0.1 rad/s at 1.5 m/s"));
        // The walk runs at 0.75 of its table period, the trot at 0.7, the bound and the
        // pronk at 0.5; the gallop is not run.
        let scales = cfg.period_scales();
        assert_eq!(scales[Gait::Walk.index()], 0.75);
        assert_eq!(scales[Gait::Trot.index()], 0.7);
        assert_eq!(scales[Gait::Bound.index()], 0.5);
        assert_eq!(scales[Gait::Pronk.index()], 0.5);
        assert_eq!(scales[Gait::Gallop.index()], 0.0);
        // Lifted (`--unrated`): every quadruped gait, the offered ones at their own scales.
        let mut all = cfg.clone();
        all.offer_every_gait();
        assert!(all.validate().is_ok());
        assert_eq!(all.gaits.len(), Gait::ALL.len());
        assert!(
            all.check_command(Gait::Bound, 5.0, 0.0).is_ok()
                && all.check_command(Gait::Trot, 5.0, 3.0).is_ok()
        );
        assert_eq!(all.period_scales()[Gait::Walk.index()], 0.75);
        assert_eq!(all.period_scales()[Gait::Bound.index()], 0.5);
        assert_eq!(all.period_scales()[Gait::Gallop.index()], 1.0);
        assert_eq!(all.find_offer(Gait::Bound).and_then(|o| o.com_height), Some(0.19), "kept when lifted");
        assert_eq!(all.find_offer(Gait::Gallop).and_then(|o| o.com_height), None);
        // The Humanoid offers its walk to 0.5 m/s; lifted, a biped gets stand and walk only.
        let humanoid = ControllerConfig::humanoid();
        assert!(humanoid.check_command(Gait::Walk, 0.5, 0.0).is_ok());
        assert!(humanoid.check_command(Gait::Walk, 0.4, -0.5).is_ok());
        assert!(matches!(
            humanoid.check_command(Gait::Walk, 0.6, 0.0),
            Err(ConfigError::SpeedAboveRating { .. })
        ));
        // Its turning in two ratings: ±0.5 rad/s to 0.4 m/s, ±0.3 rad/s to 0.5 m/s.
        assert!(humanoid.check_command(Gait::Walk, 0.5, -0.3).is_ok());
        let e = humanoid.check_command(Gait::Walk, 0.5, 0.5).unwrap_err();
        assert!(matches!(e, ConfigError::YawRateAboveRating { .. }));
        assert!(e.to_string().ends_with("turns at up to 0.5 rad/s to 0.4 m/s and 0.3 rad/s"), "{e}");
        let walk = humanoid.offer(Gait::Walk).unwrap();
        assert_eq!([0.0, 0.4, 0.45, 0.5, -0.5].map(|v| walk.yaw_rate_rating(v)), [0.5, 0.5, 0.3, 0.3, 0.3]);
        assert!(
            humanoid
                .offered_gaits()
                .contains("walk (0–0.5 m/s; turns at up to 0.5 rad/s to 0.4 m/s and 0.3 rad/s)")
        );
        let mut biped = humanoid.clone();
        biped.offer_every_gait();
        assert_eq!(biped.gaits.iter().map(|o| o.gait).collect::<Vec<_>>(), [Gait::Stand, Gait::Walk]);
        // Validation: stand must be offered, once; scales positive; gaits defined for the legs.
        let bad =
            |gaits: Vec<GaitOffer>| ControllerConfig { gaits, ..ControllerConfig::minitaur() }.validate();
        assert!(bad(vec![GaitOffer::new(Gait::Trot, 1.0)]).is_err());
        assert!(bad(vec![GaitOffer::new(Gait::Stand, 0.0), GaitOffer::new(Gait::Stand, 0.0)]).is_err());
        assert!(
            bad(vec![GaitOffer::new(Gait::Stand, 0.0), GaitOffer::new(Gait::Trot, 1.0).period(0.0)]).is_err()
        );
        assert!(bad(vec![GaitOffer::new(Gait::Stand, 0.0), GaitOffer::new(Gait::Trot, f64::NAN)]).is_err());
        let trot = GaitOffer::new(Gait::Trot, 1.0);
        assert!(bad(vec![GaitOffer::new(Gait::Stand, 0.0), trot.turning(-0.1, 1.0)]).is_err());
        assert!(bad(vec![GaitOffer::new(Gait::Stand, 0.0), trot.turning(0.5, f64::NAN)]).is_err());
        // Unrated above both, and the second rating must turn slower to a higher speed.
        let two = GaitOffer::new(Gait::Trot, 2.0).turning(0.5, 0.6).then_turning(0.3, 1.0);
        assert_eq!([1.0, 1.01, 2.0].map(|v| two.yaw_rate_rating(v)), [0.3, 0.0, 0.0]);
        assert!(two.turning_text().ends_with("0.5 rad/s to 0.6 m/s and 0.3 rad/s to 1 m/s"));
        assert!(bad(vec![GaitOffer::new(Gait::Stand, 0.0), two]).is_ok());
        for wrong in [two.then_turning(0.5, 1.0), two.then_turning(0.0, 1.0), two.then_turning(0.3, 0.6)]
            .into_iter()
            .chain([two.then_turning(f64::NAN, 1.0), two.then_turning(0.3, f64::INFINITY)])
        {
            let e = bad(vec![GaitOffer::new(Gait::Stand, 0.0), wrong]).unwrap_err().to_string();
            assert!(e.contains("gaits.faster_turning"), "{e}");
        }
        assert_eq!(two.straight_only().yaw_rate_rating(0.8), 0.0);
        for h in [0.0, -0.1, f64::NAN, f64::INFINITY] {
            let e = bad(vec![GaitOffer::new(Gait::Stand, 0.0), trot.com_height(h)]).unwrap_err().to_string();
            assert!(e.contains("gaits.com_height"), "{e}");
        }
        let biped = ControllerConfig {
            gaits: vec![GaitOffer::new(Gait::Stand, 0.0), GaitOffer::new(Gait::Trot, 1.0)],
            ..ControllerConfig::humanoid()
        };
        assert!(biped.validate().is_err());

        // In the controller: a Humanoid offered stand and walk to 0.3 m/s.
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/mujoco/humanoid.urdf");
        let model = Model::from_urdf_file(path, BaseKind::Floating).unwrap();
        let cfg = ControllerConfig {
            gaits: vec![GaitOffer::new(Gait::Stand, 0.0), GaitOffer::new(Gait::Walk, 0.3)],
            ..ControllerConfig::humanoid()
        };
        let mut c = LocomotionController::new(&model, cfg).unwrap();
        let s = c.nominal_state();
        c.tick(&s, &Command::forward(0.2, Gait::Pronk), 0.0);
        assert_eq!((c.status().refused_gaits, c.status().clamped_commands), (1, 0));
        c.tick(&s, &Command::forward(1.0, Gait::Walk), 0.015);
        assert_eq!((c.status().refused_gaits, c.status().clamped_commands), (1, 1));
        // The clamped command ramps towards 0.3 m/s, not 1.0: after 2 s at 0.3 m/s² it is 0.3.
        for k in 2..140 {
            c.tick(&s, &Command::forward(1.0, Gait::Walk), k as f64 * 0.015);
        }
        assert!((c.reference.v_cmd.norm() - 0.3).abs() < 1e-9, "{}", c.reference.v_cmd.norm());

        // A yaw rate beyond the turning rating is clamped to it, and counted: the preset
        // Humanoid turns at up to 0.5 rad/s to 0.4 m/s and 0.3 rad/s to 0.5 m/s (its walk's
        // top speed); the rating's straight-only reach is checked with a cut-down offer below.
        let mut c = LocomotionController::new(&model, ControllerConfig::humanoid()).unwrap();
        let turn = |v: f64, w: f64| Command { yaw_rate: w, ..Command::forward(v, Gait::Walk) };
        for k in 0..100 {
            c.tick(&s, &turn(0.3, -0.8), k as f64 * 0.015);
        }
        assert_eq!(c.status().clamped_commands, 100);
        assert!((c.reference.yaw_rate_cmd + 0.5).abs() < 1e-12, "{}", c.reference.yaw_rate_cmd);
        for k in 100..200 {
            c.tick(&s, &turn(0.5, 0.4), k as f64 * 0.015);
        }
        assert_eq!(c.status().clamped_commands, 200);
        assert!((c.reference.yaw_rate_cmd - 0.3).abs() < 1e-12, "{}", c.reference.yaw_rate_cmd);
        let straight_above = ControllerConfig {
            gaits: vec![GaitOffer::new(Gait::Stand, 0.0), GaitOffer::new(Gait::Walk, 0.5).turning(0.5, 0.4)],
            ..ControllerConfig::humanoid()
        };
        let mut c = LocomotionController::new(&model, straight_above).unwrap();
        for k in 0..100 {
            c.tick(&s, &turn(0.3, -0.8), k as f64 * 0.015);
        }
        for k in 100..200 {
            c.tick(&s, &turn(0.5, 0.3), k as f64 * 0.015);
        }
        assert_eq!(c.status().clamped_commands, 200);
        assert!(c.reference.yaw_rate_cmd.abs() < 1e-12, "{}", c.reference.yaw_rate_cmd);
        for k in 200..300 {
            c.tick(&s, &turn(0.4, 0.3), k as f64 * 0.015);
        }
        assert_eq!(c.status().clamped_commands, 200, "within the rating: not clamped");
        assert!((c.reference.yaw_rate_cmd - 0.3).abs() < 1e-12, "{}", c.reference.yaw_rate_cmd);
    }

    #[test]
    fn a_yaw_command_staggers_the_minitaur_trot_below_its_turning_speed() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/minitaur/minitaur.urdf");
        let model = Model::from_urdf_file(path, BaseKind::Floating).unwrap();
        let stagger_after_2s_heading = |speed: f64, yaw_rate: f64, heading: f64| {
            let mut c = LocomotionController::new(&model, ControllerConfig::minitaur()).unwrap();
            let mut s = c.nominal_state();
            // Base orientation (x, y, z, w) of a robot facing `heading`.
            s.q[5] = (0.5 * heading).sin();
            s.q[6] = (0.5 * heading).cos();
            let command = Command { yaw_rate, ..Command::forward(speed, Gait::Trot) };
            for k in 0..200 {
                c.tick(&s, &command, k as f64 * 0.01);
            }
            c.gait.pattern().stagger
        };
        let stagger_after_2s = |speed: f64, yaw_rate: f64| stagger_after_2s_heading(speed, yaw_rate, 0.0);
        assert_eq!(stagger_after_2s(0.5, 0.0), 0.0, "straight: no stagger");
        // The preset's controller after 2 s trotting at 0.5 m/s and `yaw_rate`.
        let trot_2s = |yaw_rate: f64| {
            let mut c = LocomotionController::new(&model, ControllerConfig::minitaur()).unwrap();
            let s = c.nominal_state();
            let command = Command { yaw_rate, ..Command::forward(0.5, Gait::Trot) };
            for k in 0..200 {
                c.tick(&s, &command, k as f64 * 0.01);
            }
            c
        };
        // The whole-body QP's posture weight: the preset's 0.01 on a straight trot, its
        // turning weight 0.1 while staggered.
        let posture_after_2s = |yaw_rate: f64| trot_2s(yaw_rate).torques.wbc.config().w_posture;
        assert_eq!(ControllerConfig::minitaur().wbc.w_posture, 0.01);
        assert_eq!(posture_after_2s(0.0), 0.01);
        assert_eq!(posture_after_2s(0.5), ControllerConfig::minitaur().turn_posture_weight);
        assert_eq!(ControllerConfig::minitaur().turn_posture_weight, 0.1);
        // While staggered the MPC weighs the yaw rate 10 (0.3 straight) and the cycle is
        // 5 % shorter.
        let turn_after_2s = |yaw_rate: f64| {
            let c = trot_2s(yaw_rate);
            (c.mpc().unwrap().input.state_weights, c.gait.pattern().period)
        };
        let cfg = ControllerConfig::minitaur();
        let (w_straight, period_straight) = turn_after_2s(0.0);
        assert_eq!(w_straight, cfg.mpc.state_weights);
        let (w_turn, period_turn) = turn_after_2s(-0.5);
        assert_eq!(w_turn[8], 10.0);
        assert_eq!(w_turn[..8], w_straight[..8]);
        assert_eq!(w_turn[9..], w_straight[9..]);
        assert!((period_turn - 0.95 * period_straight).abs() < 1e-12, "{period_turn} {period_straight}");
        // 0.6 of the cycle per rad/s, clamped at MAX_STAGGER; the left legs lead a left turn.
        assert!((stagger_after_2s(0.5, 0.2) - 0.12).abs() < 1e-9);
        assert_eq!(stagger_after_2s(0.5, 0.5), crate::MAX_STAGGER);
        assert_eq!(stagger_after_2s(0.5, -0.5), -crate::MAX_STAGGER);
        assert_eq!(stagger_after_2s(0.6, -0.5), -crate::MAX_STAGGER);
        // Above `turn_max_speed` (0.6 m/s) the trot is not staggered.
        assert_eq!(stagger_after_2s(1.0, 0.5), 0.0);
        assert_eq!(stagger_after_2s(0.7, -0.5), 0.0);
        // The gate is the planar speed, whatever the heading (it once read the world x
        // component, and a robot facing sideways was staggered at any speed).
        for heading in [0.0, 0.8, 1.5, -2.5] {
            assert_eq!(stagger_after_2s_heading(1.0, 0.5, heading), 0.0, "heading {heading}");
            assert_eq!(stagger_after_2s_heading(0.6, 0.5, heading), crate::MAX_STAGGER, "heading {heading}");
        }
        let bad = |c: ControllerConfig| c.validate().unwrap_err().to_string();
        let nan = bad(ControllerConfig { turn_max_speed: f64::NAN, ..ControllerConfig::minitaur() });
        assert!(nan.contains("turn_max_speed"), "{nan}");
        let low = bad(ControllerConfig { turn_swing_height: -0.01, ..ControllerConfig::minitaur() });
        assert!(low.contains("turn_swing_height"), "{low}");
        let neg = bad(ControllerConfig { turn_posture_weight: -0.01, ..ControllerConfig::minitaur() });
        assert!(neg.contains("turn_posture_weight"), "{neg}");
        let neg = bad(ControllerConfig { turn_yaw_rate_weight: -1.0, ..ControllerConfig::minitaur() });
        assert!(neg.contains("turn_yaw_rate_weight"), "{neg}");
        for p in [0.0, -0.5, f64::NAN, f64::INFINITY] {
            let e = bad(ControllerConfig { turn_period_scale: p, ..ControllerConfig::minitaur() });
            assert!(e.contains("turn_period_scale"), "{e}");
        }
    }

    #[test]
    fn a_gait_runs_with_its_own_stance_fraction_and_weights() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/mujoco/walker2d.urdf");
        let model = Model::from_urdf_file(path, BaseKind::Fixed).unwrap();
        let cfg = ControllerConfig::walker2d();
        let walk = *cfg.offer(Gait::Walk).unwrap();
        let (own_weights, own_angular) = (walk.mpc_state_weights.unwrap(), walk.body_angular_weight.unwrap());
        assert_eq!((walk.duty_factor, own_angular), (Some(0.35), 0.5));
        assert_eq!((own_weights[1], own_weights[7]), (0.0, 0.0));
        assert_ne!(own_weights, cfg.mpc.state_weights);
        // After `seconds` of `command` from the nominal state: the pattern in force, the
        // MPC's state weights and the WBC's orientation weight.
        let after = |cfg: ControllerConfig, command: Command, seconds: f64| {
            let mut c = LocomotionController::new(&model, cfg).unwrap();
            let s = c.nominal_state();
            for k in 0..(seconds / 0.01) as usize {
                c.tick(&s, &command, k as f64 * 0.01);
            }
            (*c.gait.pattern(), c.mpc().unwrap().input.state_weights, c.torques.wbc.config().w_body_angular)
        };
        // Standing: the configuration's own.
        let (p, w, a) = after(cfg.clone(), Command::stand(), 0.5);
        assert_eq!((p.gait, w, a), (Gait::Stand, cfg.mpc.state_weights, cfg.wbc.w_body_angular));
        // Walking: the offer's, and each foot in stance for 0.35 of the cycle.
        let (p, w, a) = after(cfg.clone(), Command::forward(0.5, Gait::Walk), 1.0);
        assert_eq!((p.gait, w, a), (Gait::Walk, own_weights, own_angular));
        assert_eq!(p.duty[..2], [0.35, 0.35]);
        // An offer without its own: the table's stance fraction and the configuration's.
        let mut plain = cfg.clone();
        plain.gaits = vec![GaitOffer::new(Gait::Stand, 0.0), GaitOffer::new(Gait::Walk, 1.0)];
        let (p, w, a) = after(plain, Command::forward(0.5, Gait::Walk), 1.0);
        assert_eq!((w, a), (cfg.mpc.state_weights, cfg.wbc.w_body_angular));
        assert_eq!(p.duty[..2], crate::GaitPattern::new(Gait::Walk, 2).unwrap().duty[..2]);
        // Lifting the offers for a probe keeps each offer's own tuning.
        let mut lifted = cfg.clone();
        lifted.offer_every_gait();
        let l = lifted.offer(Gait::Walk).unwrap();
        assert_eq!(
            (l.duty_factor, l.mpc_state_weights, l.body_angular_weight),
            (walk.duty_factor, Some(own_weights), Some(own_angular))
        );
        assert!(l.max_speed.is_infinite());
        // Bad values are refused by name.
        let bad = |offer: GaitOffer| {
            let mut c = ControllerConfig::walker2d();
            c.gaits = vec![GaitOffer::new(Gait::Stand, 0.0), offer];
            c.validate().unwrap_err().to_string()
        };
        for d in [0.0, 1.0, -0.2, f64::NAN] {
            let e = bad(GaitOffer::new(Gait::Walk, 1.0).duty(d));
            assert!(e.contains("gaits.duty_factor"), "{e}");
        }
        let mut stand = ControllerConfig::walker2d();
        stand.gaits[0] = GaitOffer::new(Gait::Stand, 0.0).duty(0.5);
        assert!(stand.validate().unwrap_err().to_string().contains("gaits.duty_factor"));
        let mut nan = own_weights;
        nan[3] = f64::NAN;
        let e = bad(GaitOffer::new(Gait::Walk, 1.0).mpc_weights(nan));
        assert!(e.contains("gaits.mpc_state_weights"), "{e}");
        let e = bad(GaitOffer::new(Gait::Walk, 1.0).body_angular_weight(-1.0));
        assert!(e.contains("gaits.body_angular_weight"), "{e}");
        // Recorded only where set: the Minitaur's offers read as before.
        let json = serde_json::to_string(&ControllerConfig::minitaur().gaits).unwrap();
        for key in ["duty_factor", "mpc_state_weights", "body_angular_weight"] {
            assert!(!json.contains(key), "{key} in {json}");
        }
        assert!(serde_json::to_string(&cfg.gaits).unwrap().contains("\"duty_factor\":0.35"));
    }

    #[test]
    fn a_gait_runs_at_its_own_com_height_unless_the_command_sets_one() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/minitaur/minitaur.urdf");
        let model = Model::from_urdf_file(path, BaseKind::Floating).unwrap();
        let c = LocomotionController::new(&model, ControllerConfig::minitaur()).unwrap();
        let nominal = c.robot().nominal_com_height;
        let bound = Command::forward(1.0, Gait::Bound);
        // The trot at the standing height, the bound at its offer's 0.19 m, a commanded
        // height above both, and a gait not offered (answered by standing) at the standing one.
        assert_eq!(c.height_reference(&Command::forward(1.0, Gait::Trot)), nominal);
        assert_eq!(c.height_reference(&bound), 0.19);
        assert_eq!(c.height_reference(&Command { body_height: Some(0.2), ..bound }), 0.2);
        assert_eq!(c.height_reference(&Command::forward(1.0, Gait::Gallop)), nominal);
        // The MPC is given that height: its reference's z after half a second of each.
        let z_ref = |command: Command| {
            let mut c = LocomotionController::new(&model, ControllerConfig::minitaur()).unwrap();
            let s = c.nominal_state();
            for k in 0..50 {
                c.tick(&s, &command, k as f64 * 0.01);
            }
            c.mpc().unwrap().input.x_ref[0][5]
        };
        let (z_trot, z_bound) =
            (z_ref(Command::forward(0.5, Gait::Trot)), z_ref(Command::forward(0.5, Gait::Bound)));
        assert!((z_bound - z_trot - (0.19 - nominal)).abs() < 1e-9, "{z_trot} {z_bound} {nominal}");
        // Faster, the bound runs higher: 0.19 m to 1.2 m/s, rising to 0.22 m at 2.5 m/s.
        let offer = *c.config().offer(Gait::Bound).unwrap();
        let heights = [0.0, 1.2, 1.85, 2.5, 4.0, -1.85].map(|v| offer.height_at(v).unwrap());
        for (h, want) in heights.iter().zip([0.19, 0.19, 0.205, 0.22, 0.22, 0.205]) {
            assert!((h - want).abs() < 1e-12, "{heights:?}");
        }
        assert_eq!(ControllerConfig::minitaur().offer(Gait::Trot).unwrap().height_at(2.0), None);
        // The speed is the command's after the ramp: 1.5 s at 2.5 m/s (3 m/s²) reaches it.
        let mut c = LocomotionController::new(&model, ControllerConfig::minitaur()).unwrap();
        let (s, fast) = (c.nominal_state(), Command::forward(2.5, Gait::Bound));
        c.tick(&s, &fast, 0.0);
        assert!((c.height_reference(&fast) - 0.19).abs() < 1e-12, "a standing start");
        for k in 1..150 {
            c.tick(&s, &fast, k as f64 * 0.01);
        }
        assert!((c.height_reference(&fast) - 0.22).abs() < 1e-12, "{}", c.height_reference(&fast));
        // Validation: a rise needs a base height, a positive height and speeds in order.
        let bad = |o: GaitOffer| {
            let gaits = vec![GaitOffer::new(Gait::Stand, 0.0), o];
            ControllerConfig { gaits, ..ControllerConfig::minitaur() }.validate().unwrap_err().to_string()
        };
        let bound = GaitOffer::new(Gait::Bound, 2.5);
        assert!(bad(bound.rising_to(0.22, 1.2, 2.5)).contains("com_height"));
        let bound = bound.com_height(0.19);
        assert!(bad(bound.rising_to(f64::NAN, 1.2, 2.5)).contains("height_rise.height"));
        assert!(bad(bound.rising_to(0.22, -1.0, 2.5)).contains("height_rise.from_speed"));
        assert!(bad(bound.rising_to(0.22, 1.2, 1.2)).contains("height_rise.to_speed"));
    }

    #[test]
    fn a_humanoid_told_to_stand_steps_in_place_with_both_feet() {
        let (swung, gait) = stand_for(ControllerConfig::humanoid(), 1.2, 0.0);
        assert_eq!(gait, Gait::Walk);
        assert_eq!(swung, [true, true]);
        let still = ControllerConfig { step_in_place: false, ..ControllerConfig::humanoid() };
        let (swung, gait) = stand_for(still, 1.2, 0.0);
        assert_eq!(gait, Gait::Stand);
        assert_eq!(swung, [false, false]);
        // In the air (dropped from 10 cm, not landed yet) it waits on both feet.
        let (swung, gait) = stand_for(ControllerConfig::humanoid(), 0.3, 0.1);
        assert_eq!(gait, Gait::Stand);
        assert_eq!(swung, [false, false]);
    }
}
