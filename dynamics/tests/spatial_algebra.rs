//! Properties of the spatial algebra, checked with proptest on random transforms, motions,
//! forces and inertias.

use centaur_dynamics::spatial::{exp6, log6};
use centaur_dynamics::{Force, Inertia, Motion, OriginInertia, Se3};
use nalgebra::{Matrix3, Matrix6, UnitQuaternion, Vector3};
use proptest::prelude::*;

fn v3() -> impl Strategy<Value = Vector3<f64>> {
    (-2.0..2.0f64, -2.0..2.0f64, -2.0..2.0f64).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn se3() -> impl Strategy<Value = Se3> {
    (v3(), v3())
        .prop_map(|(axis_angle, p)| Se3::from_quaternion(&UnitQuaternion::from_scaled_axis(axis_angle), p))
}

fn motion() -> impl Strategy<Value = Motion> {
    (v3(), v3()).prop_map(|(l, a)| Motion::new(l, a))
}

fn force() -> impl Strategy<Value = Force> {
    (v3(), v3()).prop_map(|(l, a)| Force::new(l, a))
}

/// A physical inertia: positive mass, and principal moments from a random box.
fn inertia() -> impl Strategy<Value = Inertia> {
    (0.1..5.0f64, v3(), (0.05..1.0f64, 0.05..1.0f64, 0.05..1.0f64), v3()).prop_map(
        |(m, c, (a, b, d), rot)| {
            let diag = Matrix3::from_diagonal(&Vector3::new(b * b + d * d, a * a + d * d, a * a + b * b))
                * (m / 12.0);
            let r = UnitQuaternion::from_scaled_axis(rot).to_rotation_matrix().into_inner();
            Inertia::new(m, c, r * diag * r.transpose())
        },
    )
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-10 * (1.0 + a.abs().max(b.abs()))
}

fn close6(a: &nalgebra::Vector6<f64>, b: &nalgebra::Vector6<f64>) -> bool {
    (a - b).amax() <= 1e-10 * (1.0 + a.amax().max(b.amax()))
}

/// Force transform `X*` as a 6×6 matrix: `[[R, 0], [[p]ₓR, R]]`.
fn force_matrix(m: &Se3) -> Matrix6<f64> {
    let mut x = Matrix6::zeros();
    x.fixed_view_mut::<3, 3>(0, 0).copy_from(&m.rotation);
    x.fixed_view_mut::<3, 3>(3, 3).copy_from(&m.rotation);
    x.fixed_view_mut::<3, 3>(3, 0).copy_from(&(centaur_dynamics::spatial::skew(&m.translation) * m.rotation));
    x
}

proptest! {
    #[test]
    fn act_and_act_inv_are_inverse(m in se3(), nu in motion(), f in force()) {
        prop_assert!(close6(&m.act_inv_motion(&m.act_motion(&nu)).to_vector(), &nu.to_vector()));
        prop_assert!(close6(&m.act_inv_force(&m.act_force(&f)).to_vector(), &f.to_vector()));
        prop_assert!(close6(&m.inverse().act_motion(&nu).to_vector(), &m.act_inv_motion(&nu).to_vector()));
    }

    #[test]
    fn transforms_preserve_power(m in se3(), nu in motion(), f in force()) {
        prop_assert!(close(m.act_motion(&nu).dot(&m.act_force(&f)), nu.dot(&f)));
    }

    #[test]
    fn composition_acts_like_successive_actions(a in se3(), b in se3(), nu in motion()) {
        let lhs = a.mul(&b).act_motion(&nu);
        let rhs = a.act_motion(&b.act_motion(&nu));
        prop_assert!(close6(&lhs.to_vector(), &rhs.to_vector()));
        prop_assert!(close6(&(a.motion_matrix() * nu.to_vector()), &a.act_motion(&nu).to_vector()));
        let inv = a.inv_mul(&b);
        let expect = a.inverse().mul(&b);
        prop_assert!((inv.rotation - expect.rotation).amax() < 1e-12);
    }

    #[test]
    fn cross_products_are_dual(m1 in motion(), m2 in motion(), f in force()) {
        // (m₁ ×* f) · m₂ = −f · (m₁ × m₂), and m × m = 0.
        prop_assert!(close(m2.dot(&m1.cross_force(&f)), -m1.cross(&m2).dot(&f)));
        prop_assert!(m1.cross(&m1).to_vector().amax() < 1e-12);
    }

    #[test]
    fn inertia_matrix_matches_inertia_product(y in inertia(), nu in motion()) {
        let by_matrix = y.matrix() * nu.to_vector();
        prop_assert!(close6(&by_matrix, &y.mul_motion(&nu).to_vector()));
        let o = OriginInertia::from_inertia(&y);
        prop_assert!(close6(&o.mul_motion(&nu).to_vector(), &by_matrix));
        let back = o.to_inertia();
        prop_assert!((back.rotational - y.rotational).amax() < 1e-10 && (back.lever - y.lever).amax() < 1e-12);
        prop_assert!(y.kinetic_energy(&nu) >= 0.0);
    }

    #[test]
    fn inertia_sum_is_the_sum_of_matrices(a in inertia(), b in inertia()) {
        let sum = a.add(&b).matrix();
        prop_assert!((sum - (a.matrix() + b.matrix())).amax() < 1e-10 * (1.0 + sum.amax()));
    }

    #[test]
    fn transformed_inertia_is_the_congruence(m in se3(), y in inertia()) {
        // Y_a = X* Y_b X⁻¹, for rigid inertias and through the articulated-inertia routine.
        let xf = force_matrix(&m);
        let xm_inv = m.inverse().motion_matrix();
        let expect = xf * y.matrix() * xm_inv;
        prop_assert!((m.act_inertia(&y).matrix() - expect).amax() < 1e-9 * (1.0 + expect.amax()));
        prop_assert!((m.act_matrix6(&y.matrix()) - expect).amax() < 1e-9 * (1.0 + expect.amax()));
    }

    #[test]
    fn exp6_and_log6_are_inverse(nu in motion()) {
        let nu = nu.scale(0.9); // rotation angle below π
        let back = log6(&exp6(&nu));
        prop_assert!(close6(&back.to_vector(), &nu.to_vector()));
    }
}

#[test]
fn urdf_rpy_is_fixed_axis_xyz() {
    // rpy = (π/2, 0, 0) turns y into z.
    let m = Se3::from_xyz_rpy([0.0; 3], [std::f64::consts::FRAC_PI_2, 0.0, 0.0]);
    assert!((m.rotation * Vector3::y() - Vector3::z()).norm() < 1e-15);
    // rpy = (0, 0, π/2) then: Rz(yaw)·Ry(pitch)·Rx(roll) sends x to y.
    let m = Se3::from_xyz_rpy([0.0; 3], [0.3, 0.0, std::f64::consts::FRAC_PI_2]);
    assert!((m.rotation * Vector3::x() - Vector3::y()).norm() < 1e-15);
}
