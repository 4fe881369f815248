//! PyBullet's leg model: two motors per leg moved apart (swing) or together (extension).

/// Converts a leg-model action to the 8 desired motor angles (PyBullet's
/// `ConvertFromLegModel`): for motor `i` of leg `l = i / 2`,
/// `q*ᵢ = π − (π/4)(a[l+4] + 1.5) + sᵢ (π/4) a[l]` with `sᵢ = (−1)ⁱ` on the left legs
/// (`i < 4`) and `−(−1)ⁱ` on the right. `a[0..4]` moves the two motors of a leg apart
/// (PyBullet calls it extension; physically it swings the leg), `a[4..8]` together (leg
/// length). `a = 0` gives 5π/8 on every motor.
pub fn leg_model_to_motor_angles(a: &[f64; 8]) -> [f64; 8] {
    let quarter_pi = std::f64::consts::FRAC_PI_4;
    let mut out = [0.0; 8];
    for (i, o) in out.iter_mut().enumerate() {
        let leg = i / 2;
        let common = -quarter_pi * (a[leg + 4] + 1.5);
        let mut differential = if i % 2 == 0 { quarter_pi * a[leg] } else { -quarter_pi * a[leg] };
        if i >= 4 {
            differential = -differential;
        }
        *o = std::f64::consts::PI + common + differential;
    }
    out
}

/// The inverse of [`leg_model_to_motor_angles`]: the leg-model action whose motor angles
/// are `q` (exact when `q` is reachable; actions outside [−1, 1] mean the angles are).
pub fn motor_angles_to_leg_model(q: &[f64; 8]) -> [f64; 8] {
    let quarter_pi = std::f64::consts::FRAC_PI_4;
    let mut a = [0.0; 8];
    for leg in 0..4 {
        let (q0, q1) = (q[2 * leg], q[2 * leg + 1]);
        let sign = if leg < 2 { 1.0 } else { -1.0 };
        a[leg] = sign * (q0 - q1) / (2.0 * quarter_pi);
        a[leg + 4] = (std::f64::consts::PI - (q0 + q1) / 2.0) / quarter_pi - 1.5;
    }
    a
}
