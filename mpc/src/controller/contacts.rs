//! Stage 3, contacts and swing: which contact points bear weight, where the swinging ones
//! land and the curve they follow there.
//!
//! The effective contact of a point is its scheduled stance, refined by measured contacts
//! when [`crate::LocomotionController::tick_with_contacts`] provides them: a stance that
//! has not touched down (also at the first tick) is still a swing whose foot descends at
//! `touchdown_speed` over the foothold, and a swing touching the ground in its second half
//! ends early; without measured contacts the schedule is followed. Footholds are Raibert's
//! heuristic plus a capture-point term ([`crate::swing::raibert_foothold`]); swing curves
//! are Bézier ([`crate::swing::swing_curve`]).

use centaur_dynamics::nalgebra::{Matrix3, Rotation3, Vector3};

use super::estimate::Estimate;
use super::targets::{LocomotionTargets, TickContext};
use crate::config::while_turning;
use crate::swing::{PointTarget, raibert_foothold, swing_curve};

/// Height (m) below which an unmeasured contact point counts as touching the ground plane
/// z = 0 when the controller decides whether a robot that started in the air has landed.
pub const LANDING_HEIGHT: f64 = 0.03;

/// The range [`crate::LocomotionController::set_swing_height_scale`] holds the scale of the
/// swing apex in: a quarter to 1.75 times the configured `swing_height`.
pub const SWING_SCALE_RANGE: (f64, f64) = (0.25, 1.75);

/// The largest foothold offset (m, ahead or behind)
/// [`crate::LocomotionController::set_foothold_offset`] holds: 10 cm, a bound on how far a
/// steering policy may move a foot from where the controller plans it, small against the
/// ground a stance sweeps at speed (the Minitaur hybrid's at 4.5 m/s and 7.8 touchdowns per
/// foot a second: ≈ 0.3 m).
pub const MAX_FOOTHOLD_OFFSET: f64 = 0.1;

/// Contact bookkeeping per contact point.
pub(crate) struct Contacts {
    was_stance: Vec<bool>,
    /// Measured contact flags of this tick (valid if `measured_valid`).
    measured: Vec<bool>,
    measured_valid: bool,
    /// Contacts measured on the ground at least once, and whether all have been.
    ever_touched: Vec<bool>,
    landed: bool,
    /// A scheduled stance whose foot has touched the ground (measured).
    touched: Vec<bool>,
    /// A swing that ended early by touching the ground in its second half (measured).
    early: Vec<bool>,
    liftoff: Vec<Vector3<f64>>,
    /// The scale of the swing apex that swings lifting off from now on take.
    swing_scale: f64,
    /// Each contact point's swing apex scale, taken from `swing_scale` at its lift-off (a
    /// swing keeps its curve whatever the scale does meanwhile).
    apex_scale: Vec<f64>,
    /// The forward offset (m, along the heading) that swings lifting off from now on add
    /// to their foothold.
    foothold_offset: f64,
    /// Each contact point's foothold offset, taken from `foothold_offset` at its lift-off.
    step_offset: Vec<f64>,
}

impl Contacts {
    pub(crate) fn new(nc: usize) -> Self {
        Contacts {
            was_stance: vec![true; nc],
            measured: vec![false; nc],
            measured_valid: false,
            ever_touched: vec![false; nc],
            landed: false,
            touched: vec![true; nc],
            early: vec![false; nc],
            liftoff: vec![Vector3::zeros(); nc],
            swing_scale: 1.0,
            apex_scale: vec![1.0; nc],
            foothold_offset: 0.0,
            step_offset: vec![0.0; nc],
        }
    }

    /// Forgets every phase (an episode reset).
    pub(crate) fn reset(&mut self) {
        self.was_stance.iter_mut().for_each(|s| *s = true);
        self.touched.iter_mut().for_each(|s| *s = true);
        self.early.iter_mut().for_each(|s| *s = false);
        self.ever_touched.iter_mut().for_each(|s| *s = false);
        self.landed = false;
        self.swing_scale = 1.0;
        self.apex_scale.iter_mut().for_each(|s| *s = 1.0);
        self.foothold_offset = 0.0;
        self.step_offset.iter_mut().for_each(|s| *s = 0.0);
    }

    /// Scales the apex of the swings lifting off from now on by `scale`, clamped to
    /// [`SWING_SCALE_RANGE`]; a non-finite scale counts as 1.
    pub(crate) fn set_swing_scale(&mut self, scale: f64) {
        let (low, high) = SWING_SCALE_RANGE;
        self.swing_scale = if scale.is_finite() { scale.clamp(low, high) } else { 1.0 };
    }

    /// The scale the next swings take ([`Contacts::set_swing_scale`]).
    pub(crate) fn swing_scale(&self) -> f64 {
        self.swing_scale
    }

    /// Moves the footholds of the swings lifting off from now on `offset` metres forward
    /// along the heading, clamped to ±[`MAX_FOOTHOLD_OFFSET`]; a non-finite offset counts
    /// as 0.
    pub(crate) fn set_foothold_offset(&mut self, offset: f64) {
        self.foothold_offset =
            if offset.is_finite() { offset.clamp(-MAX_FOOTHOLD_OFFSET, MAX_FOOTHOLD_OFFSET) } else { 0.0 };
    }

    /// The offset the next swings take ([`Contacts::set_foothold_offset`]).
    pub(crate) fn foothold_offset(&self) -> f64 {
        self.foothold_offset
    }

    /// This tick's measured contact flags (`None`: follow the schedule).
    pub(crate) fn set_measured(&mut self, contacts: Option<&[bool]>) {
        self.measured_valid = contacts.is_some();
        if let Some(c) = contacts {
            self.measured.copy_from_slice(c);
        }
    }

    /// Whether the robot has landed: a robot that starts in the air stands until every
    /// contact point has touched the ground once (measured contacts, or without them a
    /// contact point within [`LANDING_HEIGHT`] of the ground plane z = 0).
    pub(crate) fn update_landing(&mut self, est: &Estimate) -> bool {
        if !self.landed {
            for (c, seen) in self.ever_touched.iter_mut().enumerate() {
                *seen |=
                    if self.measured_valid { self.measured[c] } else { est.p_contact[c].z < LANDING_HEIGHT };
            }
            self.landed = self.ever_touched.iter().all(|s| *s);
        }
        self.landed
    }

    /// Contact states, lift-off bookkeeping, footholds and targets of every contact point
    /// (into `out`). `first`: the controller's first tick. Swing targets carry the mean
    /// reference acceleration over the coming control interval `Δt` (the last tick
    /// interval), `ā = (v_ref(t + Δt) − v_ref(t))/Δt`, so that torques held for `Δt`
    /// follow the curve.
    pub(crate) fn update(&mut self, cx: &TickContext<'_>, first: bool, out: &mut LocomotionTargets) {
        let (cfg, robot, est, reference, gait) = (cx.cfg, cx.robot, cx.est, cx.reference, cx.gait);
        let (height, dt) = (cx.height, cx.dt);
        let pat = *gait.pattern();
        let phase = gait.phase();
        let g = robot.model.gravity.z.abs().max(1e-3);
        let yaw = est.rpy.z;
        let (c, s) = (yaw.cos(), yaw.sin());
        let mut body = est.body_origin;
        if cfg.foothold_from_com {
            // Where the body frame would be if it stood over the CoM as in the nominal pose.
            let nc = robot.nominal_com_body;
            body.x = est.com.x - (c * nc.x - s * nc.y);
            body.y = est.com.y - (s * nc.x + c * nc.y);
        }
        let v_cmd = reference.v_cmd;
        let v_xy = Vector3::new(est.com_vel.x, est.com_vel.y, 0.0);
        let kp = cfg.foothold_position_gain;
        let p_ref = reference.p_ref;
        let v_foothold = v_cmd + Vector3::new(kp * (p_ref.x - est.com.x), kp * (p_ref.y - est.com.y), 0.0);
        for ci in 0..robot.n_contacts() {
            let leg = robot.contact_leg[ci];
            let stance = pat.in_stance(phase, leg);
            let swing_progress = pat.swing_progress(phase, leg);
            if self.was_stance[ci] && !stance || first {
                self.liftoff[ci] = est.p_contact[ci];
                self.apex_scale[ci] = self.swing_scale;
                self.step_offset[ci] = self.foothold_offset;
            }
            if self.was_stance[ci] != stance || first {
                // A new phase (or the first tick): a stance has not touched down yet, a swing
                // has not ended early.
                self.touched[ci] = false;
                self.early[ci] = false;
            }
            self.was_stance[ci] = stance;
            let measured = (self.measured_valid && cfg.touchdown_detection).then(|| self.measured[ci]);
            let (contact, late) = match measured {
                None => (stance, false),
                Some(m) if stance => {
                    self.touched[ci] |= m;
                    (self.touched[ci], !self.touched[ci])
                }
                Some(m) => {
                    self.early[ci] |= m && swing_progress.unwrap_or(0.0) > 0.5;
                    (self.early[ci], false)
                }
            };
            out.stance[ci] = contact;
            // Hip reference: nominal contact under the body, rotated by the yaw the body will
            // have at the middle of the coming stance, `turn` after now (the commanded yaw
            // rate turns the footholds: the legs on the outside of the turn step further).
            let nb = robot.nominal_contacts_body[ci];
            let hip_at = |turn: f64| {
                let (c, s) = if turn == 0.0 { (c, s) } else { ((yaw + turn).cos(), (yaw + turn).sin()) };
                let mut hip = body + Vector3::new(c * nb.x - s * nb.y, s * nb.x + c * nb.y, 0.0);
                if cfg.mpc.planar {
                    hip.y = est.p_contact[ci].y;
                }
                hip
            };
            let t_td = gait.time_to_touchdown(leg);
            let w = reference.yaw_rate_cmd;
            let mut hip = hip_at(w * (t_td + 0.5 * pat.stance_duration(leg)));
            hip += v_cmd * t_td;
            let mut fh = raibert_foothold(
                &hip,
                &v_xy,
                &v_foothold,
                reference.yaw_rate_cmd,
                pat.stance_duration(leg),
                height,
                cfg.raibert_kv,
                self.liftoff[ci].z,
                g,
            );
            // The steered offset along the heading (zero unless set: the controller as
            // configured, to the bit).
            let ahead = self.step_offset[ci];
            if ahead != 0.0 {
                fh.x += c * ahead;
                fh.y += s * ahead;
            }
            if cfg.mpc.planar {
                fh.y = est.p_contact[ci].y;
            }
            out.foothold[ci] = fh;
            // Where the MPC expects the next stance: this swing's foothold, or for a leg in
            // stance the one after its coming swing (hip carried forward to that touch-down,
            // Raibert term at the commanded velocity). The position feedback is left out of
            // this look-ahead on purpose: with it there too the Humanoid, the one preset that
            // uses it, fell after a 4 N·s push from behind that it survives without.
            out.next_foothold[ci] = if stance && !late {
                let t_next = gait.stance_time_left(leg) + pat.swing_duration(leg);
                let t_mid = t_next + 0.5 * pat.stance_duration(leg);
                let mut p = hip_at(w * t_mid) + v_cmd * t_td + v_cmd * t_mid;
                if self.foothold_offset != 0.0 {
                    p.x += c * self.foothold_offset;
                    p.y += s * self.foothold_offset;
                }
                p.z = est.p_contact[ci].z;
                if cfg.mpc.planar {
                    p.y = est.p_contact[ci].y;
                }
                p
            } else {
                fh
            };
            out.motion[ci] = if contact {
                // A planted foot, seen from a body that follows the reference: the IK of the
                // joint PD targets then moves the body along the reference over its feet.
                stance_target(
                    &est.p_contact[ci],
                    &est.com,
                    &est.rot,
                    &Vector3::new(p_ref.x, p_ref.y, height),
                    reference.yaw_ref,
                    &v_cmd,
                    reference.yaw_rate_cmd,
                )
            } else if late {
                // Keep reaching down for the ground at `touchdown_speed` (faster than a falling
                // body), over the foothold.
                PointTarget {
                    p: Vector3::new(fh.x, fh.y, est.p_contact[ci].z),
                    v: Vector3::new(0.0, 0.0, est.com_vel.z.min(0.0) - cfg.touchdown_speed),
                    a: Vector3::zeros(),
                }
            } else {
                let sp = swing_progress.unwrap_or(1.0);
                let t_sw = pat.swing_duration(leg);
                let height = self.apex_scale[ci]
                    * while_turning(pat.stagger != 0.0, cfg.turn_swing_height, cfg.swing_height);
                let mut tg = swing_curve(&self.liftoff[ci], &fh, height, sp, t_sw);
                if dt > 0.0 {
                    let ahead = swing_curve(&self.liftoff[ci], &fh, height, sp + dt / t_sw, t_sw);
                    tg.a = (ahead.v - tg.v) / dt;
                }
                tg
            };
        }
    }
}

/// The target of a planted foot at `p` for the stance joint PD: where the foot should be
/// relative to the current body if the body (CoM `c`, orientation `R`) were at its
/// reference (CoM `c*`, upright with yaw `ψ*`), `p* = c + R R*ᵀ (p − c*)`, and its
/// velocity relative to a body moving at the commanded `v*` and yaw rate `ψ̇*`,
/// `ṗ* = −v* − ψ̇* ẑ × (p − c)`.
fn stance_target(
    p: &Vector3<f64>,
    c: &Vector3<f64>,
    rot: &Matrix3<f64>,
    c_ref: &Vector3<f64>,
    yaw_ref: f64,
    v_cmd: &Vector3<f64>,
    yaw_rate_cmd: f64,
) -> PointTarget {
    let r_ref = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw_ref);
    let target = c + rot * (r_ref.matrix().transpose() * (p - c_ref));
    let v = -v_cmd - Vector3::new(0.0, 0.0, yaw_rate_cmd).cross(&(p - c));
    PointTarget { p: target, v, a: Vector3::zeros() }
}
