//! Coulomb friction at a point contact on flat ground (normal `+z`): the exact cone
//! `‖(f_x, f_y)‖ ≤ μ f_z` (a second-order cone, `SecondOrderConeT(3)` in Clarabel with
//! `s = (μ f_z, f_x, f_y)`) and its linearisation by a four-sided pyramid
//! `|f_x| ≤ μ' f_z`, `|f_y| ≤ μ' f_z`, where `μ' = μ` for the pyramid circumscribing the
//! cone and `μ' = μ/√2` for the inscribed one (which never allows a force outside the cone).

/// How friction is imposed on contact forces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum FrictionModel {
    /// The exact second-order cone.
    #[default]
    Cone,
    /// Four-sided pyramid whose edges touch the cone (`μ' = μ/√2`; conservative).
    InscribedPyramid,
    /// Four-sided pyramid whose faces touch the cone (`μ' = μ`; allows up to `√2 μ f_z` on
    /// the diagonals).
    CircumscribedPyramid,
}

impl FrictionModel {
    /// The pyramid coefficient `μ'` for friction coefficient `mu` (`mu` for the cone).
    #[inline]
    pub fn pyramid_mu(&self, mu: f64) -> f64 {
        match self {
            FrictionModel::InscribedPyramid => mu * std::f64::consts::FRAC_1_SQRT_2,
            FrictionModel::Cone | FrictionModel::CircumscribedPyramid => mu,
        }
    }

    /// Whether the model is linear (a pyramid).
    #[inline]
    pub fn is_pyramid(&self) -> bool {
        !matches!(self, FrictionModel::Cone)
    }

    /// Whether the force `f` (world axes, ground reaction) satisfies this model for
    /// friction coefficient `mu`, with absolute slack `tol`.
    #[inline]
    pub fn contains(&self, f: &[f64; 3], mu: f64, tol: f64) -> bool {
        match self {
            FrictionModel::Cone => in_cone(f, mu, tol),
            _ => in_pyramid(f, self.pyramid_mu(mu), tol),
        }
    }

    /// The largest tangential force the model allows along the unit ground direction
    /// `(cos θ, sin θ)` for normal force `fz`: `μ f_z` for the cone; for a pyramid
    /// `μ' f_z / max(|cos θ|, |sin θ|)`.
    pub fn max_tangential(&self, mu: f64, fz: f64, theta: f64) -> f64 {
        match self {
            FrictionModel::Cone => mu * fz,
            _ => {
                let mp = self.pyramid_mu(mu);
                mp * fz / theta.cos().abs().max(theta.sin().abs())
            }
        }
    }
}

/// The four pyramid rows `aₖ · f ≤ 0` for coefficient `mu_p`:
/// `f_x − μ' f_z ≤ 0`, `−f_x − μ' f_z ≤ 0`, `f_y − μ' f_z ≤ 0`, `−f_y − μ' f_z ≤ 0`.
#[inline]
pub fn pyramid_rows(mu_p: f64) -> [[f64; 3]; 4] {
    [[1.0, 0.0, -mu_p], [-1.0, 0.0, -mu_p], [0.0, 1.0, -mu_p], [0.0, -1.0, -mu_p]]
}

/// Whether `f` lies in the cone `‖(f_x, f_y)‖ ≤ μ f_z` (with absolute slack `tol`).
#[inline]
fn in_cone(f: &[f64; 3], mu: f64, tol: f64) -> bool {
    f[0].hypot(f[1]) <= mu * f[2] + tol
}

/// Whether `f` satisfies the pyramid rows for `mu_p` (with slack `tol`).
#[inline]
fn in_pyramid(f: &[f64; 3], mu_p: f64, tol: f64) -> bool {
    pyramid_rows(mu_p).iter().all(|a| a[0] * f[0] + a[1] * f[1] + a[2] * f[2] <= tol)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_4, SQRT_2};

    #[test]
    fn cone_limits() {
        // μ = 0.5, f_z = 100 N: at most 50 N sideways in any direction.
        assert!(in_cone(&[50.0, 0.0, 100.0], 0.5, 1e-12));
        assert!(in_cone(&[30.0, 40.0, 100.0], 0.5, 1e-12)); // ‖(30, 40)‖ = 50
        assert!(!in_cone(&[30.0, 40.1, 100.0], 0.5, 1e-12));
        assert_eq!(FrictionModel::Cone.max_tangential(0.5, 100.0, 0.3), 50.0);
    }

    #[test]
    fn circumscribed_pyramid_limits() {
        // Along an axis the outer pyramid equals the cone (50 N); on the diagonal it allows
        // |f_x| = |f_y| = 50 N, i.e. 50√2 ≈ 70.7 N, outside the cone.
        let m = FrictionModel::CircumscribedPyramid;
        assert!((m.max_tangential(0.5, 100.0, 0.0) - 50.0).abs() < 1e-12);
        assert!((m.max_tangential(0.5, 100.0, FRAC_PI_4) - 50.0 * SQRT_2).abs() < 1e-9);
        assert!(in_pyramid(&[50.0, 50.0, 100.0], 0.5, 1e-12));
        assert!(!in_cone(&[50.0, 50.0, 100.0], 0.5, 1e-12));
    }

    #[test]
    fn inscribed_pyramid_limits() {
        // μ' = 0.5/√2 ≈ 0.3536: along an axis 35.36 N; on the diagonal |f_x| = |f_y| = 35.36,
        // norm exactly 50 N, touching the cone.
        let m = FrictionModel::InscribedPyramid;
        assert!((m.max_tangential(0.5, 100.0, 0.0) - 50.0 / SQRT_2).abs() < 1e-9);
        assert!((m.max_tangential(0.5, 100.0, FRAC_PI_4) - 50.0).abs() < 1e-9);
        let mp = m.pyramid_mu(0.5);
        let d = [mp * 100.0, mp * 100.0, 100.0];
        assert!(in_pyramid(&d, mp, 1e-9) && in_cone(&d, 0.5, 1e-9));
        // Every inscribed-pyramid force is inside the cone.
        for i in 0..36 {
            let th = i as f64 * 10f64.to_radians();
            let t = m.max_tangential(0.5, 100.0, th);
            assert!(in_cone(&[t * th.cos(), t * th.sin(), 100.0], 0.5, 1e-9));
        }
    }

    #[test]
    fn pyramid_rows_are_the_four_faces() {
        let r = pyramid_rows(0.4);
        // f = (4, −4, 10) lies on the faces f_x = 0.4 f_z and −f_y = 0.4 f_z.
        let f = [4.0, -4.0, 10.0];
        let v: Vec<f64> = r.iter().map(|a| a[0] * f[0] + a[1] * f[1] + a[2] * f[2]).collect();
        assert_eq!(v, vec![0.0, -8.0, -8.0, 0.0]);
    }
}
