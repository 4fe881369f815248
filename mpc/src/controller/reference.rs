//! Stage 2, the reference: the user's [`Command`] shaped into what the controller tracks.
//! Speeds are rate-limited, the yaw reference integrates the commanded yaw rate and stays
//! within reach of the measured yaw, and the horizontal position reference `p_ref`
//! integrates the commanded velocity (see [`Reference::update_position`]).

use centaur_dynamics::nalgebra::Vector3;

use super::estimate::Estimate;
use crate::config::{Command, ControllerConfig};
use crate::gait::{Gait, ramp};

/// The shaped command (world axes).
#[derive(Clone, Debug)]
pub(crate) struct Reference {
    /// Commanded planar velocity after the rate limit.
    pub v_cmd: Vector3<f64>,
    /// Commanded yaw rate after the rate limit.
    pub yaw_rate_cmd: f64,
    /// Yaw reference.
    pub yaw_ref: f64,
    /// Horizontal position reference of the CoM (`z = 0`).
    pub p_ref: Vector3<f64>,
}

/// What this tick's command asks for, once shaped.
pub(crate) struct Shaped {
    /// The gait to run.
    pub gait: Gait,
    /// The commanded planar velocity before the rate limit (world axes).
    pub target_velocity: Vector3<f64>,
    /// Body (CoM) height.
    pub height: f64,
    /// The commanded gait is not offered: the robot stands instead.
    pub refused: bool,
    /// The commanded speed or yaw rate was above the gait's rating and was clamped to it.
    pub clamped: bool,
}

impl Reference {
    pub(crate) fn new() -> Self {
        Reference { v_cmd: Vector3::zeros(), yaw_rate_cmd: 0.0, yaw_ref: 0.0, p_ref: Vector3::zeros() }
    }

    /// Forgets the ramps (an episode reset).
    pub(crate) fn reset(&mut self) {
        self.v_cmd = Vector3::zeros();
        self.yaw_rate_cmd = 0.0;
    }

    /// Holds the references at the measured state (the first tick, or while in the air).
    pub(crate) fn hold_at(&mut self, est: &Estimate) {
        self.yaw_ref = est.rpy.z;
        self.p_ref = Vector3::new(est.com.x, est.com.y, 0.0);
    }

    /// Rate-limits the command over `dt` and integrates the yaw reference. `airborne`: the
    /// robot has not landed yet, it is held standing. A gait the configuration does not offer
    /// is answered by standing; a planar speed above the gait's rated maximum is scaled down
    /// to it, and a yaw rate above the gait's turning rating at that speed is clamped to it
    /// ([`crate::GaitOffer::yaw_rate_rating`]).
    pub(crate) fn shape(
        &mut self,
        cfg: &ControllerConfig,
        est: &Estimate,
        command: &Command,
        dt: f64,
        airborne: bool,
        nominal_height: f64,
    ) -> Shaped {
        let command = if airborne { &Command::stand() } else { command };
        // A gait that is not offered: stand still. A speed above the gait's rating: clamped
        // (a stand command's speed only shifts the body over its planted feet, within
        // `position_leash`, and is not rated).
        let offer = cfg.find_offer(command.gait);
        let (command_gait, max_speed, refused) = match offer {
            Some(o) if o.gait == Gait::Stand => (o.gait, f64::INFINITY, false),
            Some(o) => (o.gait, o.max_speed, false),
            None => (Gait::Stand, 0.0, true),
        };
        let gait = if airborne { command_gait } else { cfg.gait_for(command_gait) };
        let (c, s) = (self.yaw_ref.cos(), self.yaw_ref.sin());
        let planar = cfg.mpc.planar;
        let lat = if planar { 0.0 } else { command.lateral_velocity };
        let (mut fwd, mut lat) = (command.forward_velocity, lat);
        let speed = fwd.hypot(lat);
        let mut clamped = speed > max_speed && !refused;
        if speed > max_speed {
            let k = if speed > 0.0 { max_speed / speed } else { 0.0 };
            fwd *= k;
            lat *= k;
        }
        let mut yr = if planar { 0.0 } else { command.yaw_rate };
        if let Some(o) = offer {
            let max_yaw_rate = o.yaw_rate_rating(speed.min(max_speed));
            if yr.abs() > max_yaw_rate {
                yr = yr.clamp(-max_yaw_rate, max_yaw_rate);
                clamped = true;
            }
        }
        let target = Vector3::new(c * fwd - s * lat, s * fwd + c * lat, 0.0);
        let step = cfg.max_acceleration * dt;
        self.v_cmd.x = ramp(self.v_cmd.x, target.x, step);
        self.v_cmd.y = ramp(self.v_cmd.y, target.y, step);
        self.yaw_rate_cmd = ramp(self.yaw_rate_cmd, yr, cfg.max_yaw_acceleration * dt);
        self.yaw_ref += self.yaw_rate_cmd * dt;
        // Keep the yaw reference within reach of the measured yaw (after a push or a spin).
        let e = wrap_pi(self.yaw_ref - est.rpy.z);
        self.yaw_ref = est.rpy.z + e.clamp(-0.3, 0.3);
        Shaped {
            gait,
            target_velocity: target,
            height: cfg.com_height(command, self.v_cmd.xy().norm(), nominal_height),
            refused,
            clamped,
        }
    }

    /// The horizontal position reference `p_ref`: the integral of the (rate-limited)
    /// commanded velocity; standing still (`standing`: the gait in force is stand), it moves
    /// at `recenter_speed` to the centre of the support (the mean contact position), the
    /// statically safest place for the CoM; it never strays more than `position_leash`
    /// from the measured CoM.
    pub(crate) fn update_position(
        &mut self,
        cfg: &ControllerConfig,
        est: &Estimate,
        dt: f64,
        target_velocity: &Vector3<f64>,
        standing: bool,
    ) {
        self.p_ref += self.v_cmd * dt;
        self.p_ref.z = 0.0;
        let nc = est.p_contact.len();
        let standing = standing && target_velocity.norm() < 1e-9 && self.v_cmd.norm() < 1e-9;
        if standing {
            let mut target = Vector3::zeros();
            for ci in 0..nc {
                target += est.p_contact[ci];
            }
            target /= nc as f64;
            let e = Vector3::new(target.x - self.p_ref.x, target.y - self.p_ref.y, 0.0);
            let step = cfg.recenter_speed * dt;
            let n = e.norm();
            self.p_ref += if n > step { e * (step / n) } else { e };
        }
        if cfg.mpc.planar {
            self.p_ref.y = est.com.y;
        }
        let e = Vector3::new(self.p_ref.x - est.com.x, self.p_ref.y - est.com.y, 0.0);
        let n = e.norm();
        let leash = cfg.position_leash;
        if n > leash {
            self.p_ref = Vector3::new(est.com.x, est.com.y, 0.0) + e * (leash / n);
        }
    }
}

/// Wraps an angle to `(−π, π]`.
#[inline]
pub fn wrap_pi(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let r = (a + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI;
    if r <= -std::f64::consts::PI { r + two_pi } else { r }
}

#[cfg(test)]
mod tests {
    use super::wrap_pi;
    use std::f64::consts::PI;

    #[test]
    fn wrap_pi_maps_into_the_half_open_interval() {
        // 3π/2 is −π/2; −π is π; 5π is π; 0.1 stays.
        for (a, want) in [(1.5 * PI, -0.5 * PI), (-PI, PI), (5.0 * PI, PI), (0.1, 0.1), (PI, PI)] {
            assert!((wrap_pi(a) - want).abs() < 1e-12, "wrap_pi({a}) = {}", wrap_pi(a));
        }
    }
}
