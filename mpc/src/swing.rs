//! Swing-foot planning: footholds and swing curves.
//!
//! **Foothold** (Raibert 1986 with the capture-point correction used by the MIT Cheetah
//! controller, Di Carlo et al. 2018 eq. 31–32):
//!
//! ```text
//! p_foot = p_hip(t_td) + (T_stance / 2) v_cmd + k_v (v − v_cmd) + √(h/g) (v − v_cmd)
//!          + ½ (h/g) (v × ω_cmd)
//! ```
//!
//! `p_hip(t_td)` is the hip reference (the nominal foot under the body) carried forward to the
//! touch-down time with the commanded velocity; the `√(h/g)` term is the instantaneous
//! capture point of a linear inverted pendulum of height `h`, which places the foot where
//! it stops an unwanted velocity.
//!
//! **Swing curve**: horizontally a cubic Bézier with control points `(p₀, p₀, p₁, p₁)`,
//! i.e. `p = p₀ + (p₁ − p₀) b(s)` with `b(s) = 3s² − 2s³` (zero velocity at both ends);
//! vertically two cubic Bézier halves rising from `z₀` to the apex `max(z₀, z₁) + h_apex`
//! at `s = ½` and falling to `z₁`, each with zero vertical velocity at its ends.

use centaur_dynamics::nalgebra::Vector3;

/// Position, velocity and acceleration of a point.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PointTarget {
    /// Position (m).
    pub p: Vector3<f64>,
    /// Velocity (m/s).
    pub v: Vector3<f64>,
    /// Acceleration (m/s²).
    pub a: Vector3<f64>,
}

/// `b(s) = 3s² − 2s³` and its first two derivatives.
#[inline]
pub fn smoothstep(s: f64) -> (f64, f64, f64) {
    let s = s.clamp(0.0, 1.0);
    (3.0 * s * s - 2.0 * s * s * s, 6.0 * s - 6.0 * s * s, 6.0 - 12.0 * s)
}

/// The swing curve from `p0` to `p1` with apex height `apex` above the higher end, at
/// progress `s ∈ [0, 1]` of a swing lasting `duration` seconds.
pub fn swing_curve(p0: &Vector3<f64>, p1: &Vector3<f64>, apex: f64, s: f64, duration: f64) -> PointTarget {
    let s = s.clamp(0.0, 1.0);
    let inv_t = 1.0 / duration.max(1e-6);
    let (b, db, ddb) = smoothstep(s);
    let d = p1 - p0;
    let mut p = p0 + d * b;
    let mut v = d * (db * inv_t);
    let mut a = d * (ddb * inv_t * inv_t);
    let top = p0.z.max(p1.z) + apex;
    // Vertical: halves over σ = 2s (rise) and σ = 2s − 1 (fall); dσ/dt = 2/T.
    let (z_start, z_end, sigma) = if s < 0.5 { (p0.z, top, 2.0 * s) } else { (top, p1.z, 2.0 * s - 1.0) };
    let (bz, dbz, ddbz) = smoothstep(sigma);
    let dz = z_end - z_start;
    p.z = z_start + dz * bz;
    v.z = dz * dbz * 2.0 * inv_t;
    a.z = dz * ddbz * 4.0 * inv_t * inv_t;
    PointTarget { p, v, a }
}

/// Raibert foothold with capture-point correction (see the module docs); `hip` is the hip
/// reference at touch-down, `v` and `v_cmd` horizontal velocities, `yaw_rate_cmd` the
/// commanded yaw rate, `height` the CoM height, `k_v` the extra velocity-feedback gain.
/// The result lies on the ground plane `z = ground_z`.
pub fn raibert_foothold(
    hip: &Vector3<f64>,
    v: &Vector3<f64>,
    v_cmd: &Vector3<f64>,
    yaw_rate_cmd: f64,
    stance_duration: f64,
    height: f64,
    k_v: f64,
    ground_z: f64,
    g: f64,
) -> Vector3<f64> {
    let dv = Vector3::new(v.x - v_cmd.x, v.y - v_cmd.y, 0.0);
    let t_cp = (height.max(0.0) / g).sqrt();
    let w = Vector3::new(0.0, 0.0, yaw_rate_cmd);
    let centrifugal = v.cross(&w) * (0.5 * height / g);
    let mut p = hip + v_cmd * (0.5 * stance_duration) + dv * (k_v + t_cp) + centrifugal;
    p.z = ground_z;
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoothstep_values() {
        // b(½) = 3/4 − 2/8 = ½; b'(½) = 3 − 1.5 = 1.5; b''(½) = 0.
        assert_eq!(smoothstep(0.5), (0.5, 1.5, 0.0));
        assert_eq!(smoothstep(0.0), (0.0, 0.0, 6.0));
        assert_eq!(smoothstep(1.0).0, 1.0);
    }

    #[test]
    fn swing_reaches_apex_and_lands() {
        let p0 = Vector3::new(0.0, 0.0, 0.0);
        let p1 = Vector3::new(0.1, 0.0, 0.0);
        let mid = swing_curve(&p0, &p1, 0.05, 0.5, 0.2);
        // Halfway: x = 0.05, z = apex 0.05, vertical velocity 0, horizontal 0.1·1.5/0.2 = 0.75.
        assert!((mid.p.x - 0.05).abs() < 1e-12 && (mid.p.z - 0.05).abs() < 1e-12);
        assert!(mid.v.z.abs() < 1e-12 && (mid.v.x - 0.75).abs() < 1e-12);
        let end = swing_curve(&p0, &p1, 0.05, 1.0, 0.2);
        assert!((end.p - p1).norm() < 1e-12 && end.v.norm() < 1e-12);
        let start = swing_curve(&p0, &p1, 0.05, 0.0, 0.2);
        assert!((start.p - p0).norm() < 1e-12 && start.v.norm() < 1e-12);
    }

    #[test]
    fn swing_velocity_is_the_derivative() {
        let p0 = Vector3::new(0.0, 0.1, 0.02);
        let p1 = Vector3::new(0.15, 0.08, 0.0);
        let t = 0.25;
        for i in 1..20 {
            let s = i as f64 / 20.0 + 0.013;
            let h = 1e-6;
            let a = swing_curve(&p0, &p1, 0.06, s - h / t, t);
            let b = swing_curve(&p0, &p1, 0.06, s + h / t, t);
            let fd = (b.p - a.p) / (2.0 * h);
            let c = swing_curve(&p0, &p1, 0.06, s, t);
            assert!((fd - c.v).norm() < 1e-5, "s = {s}: {fd:?} vs {:?}", c.v);
            let fda = (b.v - a.v) / (2.0 * h);
            assert!((fda - c.a).norm() < 1e-3, "s = {s}");
        }
    }

    #[test]
    fn foothold_terms() {
        let hip = Vector3::new(0.2, 0.1, 0.3);
        // At the commanded speed: hip + T/2 v_cmd = 0.2 + 0.15·0.5 = 0.275.
        let v = Vector3::new(0.5, 0.0, 0.0);
        let p = raibert_foothold(&hip, &v, &v, 0.0, 0.15, 0.3, 0.0, 0.0, 9.81);
        assert!((p.x - (0.2 + 0.5 * 0.15 * 0.5)).abs() < 1e-12 && p.z == 0.0 && p.y == 0.1);
        // 0.2 m/s too fast: capture point √(0.3/9.81) · 0.2 = 0.03497 m further.
        let fast = Vector3::new(0.7, 0.0, 0.0);
        let q = raibert_foothold(&hip, &fast, &v, 0.0, 0.15, 0.3, 0.0, 0.0, 9.81);
        assert!((q.x - p.x - (0.3f64 / 9.81).sqrt() * 0.2).abs() < 1e-12);
    }
}
