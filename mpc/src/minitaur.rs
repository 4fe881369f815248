//! Mapping the controller's joint command to the Minitaur env's action spaces
//! (PyBullet `MinitaurBulletEnv-v0` conventions, see `shared/notes/reference-envs.md`).
//!
//! * Motor order ([`MOTOR_NAMES`]): `front_leftL, front_leftR, back_leftL, back_leftR,
//!   front_rightL, front_rightR, back_rightL, back_rightR`; legs `l = i / 2`: front-left,
//!   back-left, front-right, back-right.
//! * Motor frame: `θ_motor = d_i · q_joint` with `d = [−1, −1, −1, −1, 1, 1, 1, 1]`.
//! * Leg model (`ConvertFromLegModel`): `θᵢ = π − (π/4)(a[l+4] + 1.5) + sᵢ (π/4) a[l]` with
//!   `sᵢ = (−1)ⁱ` for `i < 4` and `−(−1)ⁱ` for `i ≥ 4`; inverted here per leg from the sum
//!   and difference of its two motor angles.
//!
//! The controller's PD-target mapping ([`crate::JointCommand::position_targets`]) turns its
//! torque into a position offset `τ / k_p,motor`; with PyBullet's motor model the
//! small-signal stiffness is ≈ 8.6 N·m/rad (16 V / 0.186 Ω × ~0.1 N·m/A).

use std::f64::consts::PI;

use crate::controller::JointCommand;

/// PyBullet's motor order (observation and action order).
pub const MOTOR_NAMES: [&str; 8] = [
    "motor_front_leftL_joint",
    "motor_front_leftR_joint",
    "motor_back_leftL_joint",
    "motor_back_leftR_joint",
    "motor_front_rightL_joint",
    "motor_front_rightR_joint",
    "motor_back_rightL_joint",
    "motor_back_rightR_joint",
];

/// `motor_direction` of `minitaur.py`.
pub const MOTOR_DIRECTION: [f64; 8] = [-1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0];

/// Small-signal stiffness of PyBullet's accurate motor model (N·m/rad).
pub const MOTOR_STIFFNESS: f64 = 8.6;

fn sign(i: usize) -> f64 {
    let alt = if i.is_multiple_of(2) { 1.0 } else { -1.0 };
    if i < 4 { alt } else { -alt }
}

/// `ConvertFromLegModel`: leg-model action → motor angles (motor frame).
pub fn motor_angles_from_leg_model(a: &[f64; 8]) -> [f64; 8] {
    let mut m = [0.0; 8];
    for (i, mi) in m.iter_mut().enumerate() {
        let l = i / 2;
        *mi = PI - PI / 4.0 * (a[l + 4] + 1.5) + sign(i) * PI / 4.0 * a[l];
    }
    m
}

/// The inverse of [`motor_angles_from_leg_model`]: `a[l+4] = (2π − θ₂ₗ − θ₂ₗ₊₁)/(π/2) − 1.5`,
/// `a[l] = (θ₂ₗ − θ₂ₗ₊₁) / (s₂ₗ π/2)`. Not clipped.
pub fn leg_model_from_motor_angles(m: &[f64; 8]) -> [f64; 8] {
    let mut a = [0.0; 8];
    for l in 0..4 {
        let (m0, m1) = (m[2 * l], m[2 * l + 1]);
        a[l + 4] = (2.0 * PI - m0 - m1) / (PI / 2.0) - 1.5;
        a[l] = (m0 - m1) / (sign(2 * l) * PI / 2.0);
    }
    a
}

/// For each of [`MOTOR_NAMES`], its index in the controller's joint order (`None` if the
/// names do not contain it).
pub fn motor_indices(joint_names: &[String]) -> Option<[usize; 8]> {
    let mut idx = [0; 8];
    for (k, name) in MOTOR_NAMES.iter().enumerate() {
        idx[k] = joint_names.iter().position(|n| n == name)?;
    }
    Some(idx)
}

/// The env's motor-angle action (motor frame, PyBullet order) for `cmd`: position targets
/// `q_des + τ / k_p,motor` mapped through the motor directions.
pub fn motor_angle_action(cmd: &JointCommand, indices: &[usize; 8], kp_motor: f64) -> [f64; 8] {
    let mut out = [0.0; 8];
    for k in 0..8 {
        let i = indices[k];
        out[k] = MOTOR_DIRECTION[k] * (cmd.q_des[i] + cmd.tau[i] / kp_motor);
    }
    out
}

/// The env's leg-model action (clipped to ±1) for `cmd`.
pub fn leg_model_action(cmd: &JointCommand, indices: &[usize; 8], kp_motor: f64) -> [f64; 8] {
    let mut a = leg_model_from_motor_angles(&motor_angle_action(cmd, indices, kp_motor));
    a.iter_mut().for_each(|x| *x = x.clamp(-1.0, 1.0));
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_pybullet_examples() {
        // reference-envs.md: ConvertFromLegModel(e0) = [2.7489, 1.1781, 1.9635, …],
        // (e4) = [1.1781, 1.1781, 1.9635, …]; a = 0 gives 5π/8 = 1.9635 everywhere.
        let mut e0 = [0.0; 8];
        e0[0] = 1.0;
        let m = motor_angles_from_leg_model(&e0);
        assert!((m[0] - 2.7489).abs() < 1e-4 && (m[1] - 1.1781).abs() < 1e-4 && (m[2] - 1.9635).abs() < 1e-4);
        let mut e4 = [0.0; 8];
        e4[4] = 1.0;
        let m = motor_angles_from_leg_model(&e4);
        assert!((m[0] - 1.1781).abs() < 1e-4 && (m[1] - 1.1781).abs() < 1e-4);
    }

    #[test]
    fn leg_model_round_trip() {
        let a = [0.3, -0.2, 0.5, -0.7, 0.1, 0.9, -0.4, 0.0];
        let back = leg_model_from_motor_angles(&motor_angles_from_leg_model(&a));
        for k in 0..8 {
            assert!((a[k] - back[k]).abs() < 1e-12);
        }
    }
}
