//! Is an inertia one a rigid body can have? Pure functions and the loader's thresholds.
//!
//! A rigid body's rotational inertia about its centre of mass has principal moments
//! `λ₁ ≤ λ₂ ≤ λ₃` with `λ₁ ≥ 0` and `λ₁ + λ₂ ≥ λ₃` (each moment is `∫ (r² − rₖ²) dm`, so
//! `λᵢ + λⱼ − λₖ = 2 ∫ rₖ² dm ≥ 0`). Published URDFs break these in three ways that matter
//! differently: rounding residue on dummy links (`[−2.2e−22, 0, 3e−6]`), wrong numbers on
//! links that are merged into a physical body anyway (a sensor mount), and wrong numbers on
//! a body the dynamics uses. Only the last, on a body that carries mass, is refused.

use nalgebra::{Matrix3, SymmetricEigen};

/// A violation below this fraction of the body's own trace is rounding.
pub(crate) const REL_TOL: f64 = 1e-6;
/// A violation below this fraction of the largest trace among the model's bodies is
/// rounding too (iCub's bodies with zero rotational inertia written as ±1e−18).
pub(crate) const ROBOT_TOL: f64 = 1e-9;
/// A body lighter than this fraction of the robot's mass carries no mass to speak of.
pub(crate) const NEGLIGIBLE_MASS: f64 = 1e-3;
/// A pivot of `M = U D Uᵀ` below this fraction of `M`'s largest diagonal entry is zero.
pub(crate) const SINGULAR_PIVOT: f64 = 1e-12;

/// Principal moments, ascending.
pub(crate) fn principal_moments(inertia: &Matrix3<f64>) -> [f64; 3] {
    let eig = SymmetricEigen::new(*inertia).eigenvalues;
    let mut p = [eig[0], eig[1], eig[2]];
    p.sort_by(|a, b| a.total_cmp(b));
    p
}

/// How far principal moments are from a rigid body's: `max(−λ₁, λ₃ − λ₁ − λ₂, 0)` in
/// kg·m². For `[1, 1, 3]` it is `3 − 2 = 1`; for `[−0.5, 1, 1]` it is `0.5`.
pub(crate) fn violation(p: [f64; 3]) -> f64 {
    (-p[0]).max(p[2] - p[0] - p[1]).max(0.0)
}

/// The conditions that fail, in words and numbers (a negative moment only when it is more
/// than rounding of the others, so that `[−2.2e−22, 0, 3e−6]` reads as a triangle violation).
pub(crate) fn describe(p: [f64; 3]) -> String {
    let negative = -p[0] > REL_TOL * (p[1].abs() + p[2].abs());
    let triangle = p[2] - p[0] - p[1];
    match (negative, triangle > 0.0) {
        (true, true) => format!(
            "principal moment {:e} is negative and the moments {p:?} violate the triangle inequality \
             (λ₁ + λ₂ < λ₃ by {triangle:e})",
            p[0]
        ),
        (true, false) => format!("principal moment {:e} is negative (moments {p:?})", p[0]),
        _ => {
            format!("principal moments {p:?} violate the triangle inequality (λ₁ + λ₂ < λ₃ by {triangle:e})")
        }
    }
}

/// The largest trace of a rotational inertia among `inertias`: the model's inertia scale.
pub(crate) fn robot_scale<'a>(inertias: impl Iterator<Item = &'a Matrix3<f64>>) -> f64 {
    inertias.map(|i| i.trace().abs()).fold(0.0, f64::max)
}

/// Whether a violation `v` of moments `p` is rounding, given the model's scale.
pub(crate) fn is_rounding(p: [f64; 3], v: f64, robot_scale: f64) -> bool {
    v <= REL_TOL * (p[0].abs() + p[1].abs() + p[2].abs()) + ROBOT_TOL * robot_scale
}

/// Whether the smallest moment of `p` is negative beyond rounding (the tolerances of
/// [`is_rounding`]): such a body makes the joint-space mass matrix indefinite.
pub(crate) fn is_negative(p: [f64; 3], robot_scale: f64) -> bool {
    -p[0] > REL_TOL * (p[0].abs() + p[1].abs() + p[2].abs()) + ROBOT_TOL * robot_scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn violation_of_hand_computed_moments() {
        // A solid box of sides (a, b, c) has moments m/12 (b² + c²), …: physical.
        let (a, b, c, m) = (0.3, 0.2, 0.1, 12.0);
        let box_p = principal_moments(&Matrix3::from_diagonal(&nalgebra::Vector3::new(
            m / 12.0 * (b * b + c * c),
            m / 12.0 * (a * a + c * c),
            m / 12.0 * (a * a + b * b),
        )));
        assert_eq!(violation(box_p), 0.0);
        // A thin rod (0, I, I) is the limit case: λ₁ + λ₂ = λ₃ exactly.
        assert_eq!(violation([0.0, 2.0, 2.0]), 0.0);
        // [1, 1, 3]: 1 + 1 falls short of 3 by 1.
        assert_eq!(violation([1.0, 1.0, 3.0]), 1.0);
        assert!(describe([1.0, 1.0, 3.0]).contains("triangle"));
        // [−0.5, 1, 1]: the negative moment is the larger violation (0.5 against −0.5 + 1 − 1).
        assert_eq!(violation([-0.5, 1.0, 1.0]), 0.5);
        assert!(describe([-0.5, 1.0, 1.0]).contains("negative"));
        let both = describe([-1.0, 1.0, 3.0]);
        assert!(both.contains("negative") && both.contains("triangle"), "{both}");
        assert!(!describe([-2.2e-22, 0.0, 3e-6]).contains("negative"));
    }

    #[test]
    fn rounding_is_relative_to_the_body_and_to_the_robot() {
        // Go1's dummy base on its own: a violation of 3e-6 on a trace of 3e-6 is not rounding,
        // unless the robot's scale makes it so (it does not at 1e-9 of 0.5 kg·m²).
        let p = [-2.2e-22, 0.0, 3e-6];
        assert!(!is_rounding(p, violation(p), 0.5));
        // iCub's point-mass bodies: ±1e-18 against a robot scale of 0.1 is rounding.
        let p = [-1.8e-22, 0.0, 4.1e-18];
        assert!(is_rounding(p, violation(p), 0.1));
        // One part in 10⁷ of the body's own moments is rounding.
        let p = [1.0, 1.0, 2.0 + 1e-7];
        assert!(is_rounding(p, violation(p), 0.0));
        assert!(!is_rounding([1.0, 1.0, 2.0 + 1e-4], 1e-4, 0.0));
    }

    #[test]
    fn principal_moments_are_sorted_and_rotation_invariant() {
        let r = *nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1).matrix();
        let i = r * Matrix3::from_diagonal(&nalgebra::Vector3::new(3.0, 1.0, 2.0)) * r.transpose();
        let p = principal_moments(&i);
        for (got, want) in p.iter().zip([1.0, 2.0, 3.0]) {
            assert!((got - want).abs() < 1e-12, "{p:?}");
        }
    }
}
