//! Identities of rigid-body dynamics checked on random states of real robot models.
//!
//! Each test draws seeded random (q, v, a) for every model of `common::test_models()` and
//! checks an identity that holds exactly in exact arithmetic; tolerances allow round-off
//! (or the O(h²) error of central differences with h = 1e-5 where derivatives are taken).

mod common;

use centaur_dynamics::spatial::Motion;
use centaur_dynamics::{
    Data, Force, Model, ReferenceFrame, aba, center_of_mass, center_of_mass_velocity, centroidal_momentum,
    cholesky_decompose, compute_joint_jacobians, crba, difference, forward_kinematics,
    forward_kinematics_velocity, frame_jacobian, frame_placement, frame_velocity, gravity_torques, integrate,
    jacobian_center_of_mass, kinetic_energy, mass_matrix_inverse, mass_matrix_solve, nonlinear_effects,
    potential_energy, rnea,
};
use common::{Rng, random_q, random_v, rel_err, test_models};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix6xX, Vector3};

const CASES: usize = 8;
const H: f64 = 1e-5;

fn for_each_state(mut f: impl FnMut(&Model, &mut Data, &DVector<f64>, &DVector<f64>, &DVector<f64>)) {
    let mut rng = Rng(42);
    for model in test_models() {
        let mut data = Data::new(&model);
        for _ in 0..CASES {
            let q = random_q(&model, &mut rng);
            let v = random_v(&model, &mut rng);
            let a = random_v(&model, &mut rng);
            f(&model, &mut data, &q, &v, &a);
        }
    }
}

fn step(model: &Model, q: &DVector<f64>, v: &DVector<f64>, h: f64) -> DVector<f64> {
    let mut out = DVector::zeros(model.nq);
    integrate(model, q.as_slice(), (v * h).as_slice(), out.as_mut_slice());
    out
}

#[test]
fn aba_undoes_rnea() {
    for_each_state(|model, data, q, v, a| {
        let tau = rnea(model, data, q.as_slice(), v.as_slice(), a.as_slice()).clone();
        let ddq = aba(model, data, q.as_slice(), v.as_slice(), tau.as_slice()).clone();
        let e = rel_err(ddq.as_slice(), a.as_slice());
        assert!(e < 1e-9, "{}: aba(rnea(a)) differs from a by {e:e}", model.name);
    });
}

#[test]
fn crba_columns_equal_rnea_differences() {
    for_each_state(|model, data, q, v, _| {
        let m = crba(model, data, q.as_slice()).clone();
        assert!((&m - m.transpose()).abs().max() == 0.0, "{}: M not symmetric", model.name);
        let nle = nonlinear_effects(model, data, q.as_slice(), v.as_slice()).clone();
        for k in 0..model.nv {
            let mut e = DVector::zeros(model.nv);
            e[k] = 1.0;
            let tau = rnea(model, data, q.as_slice(), v.as_slice(), e.as_slice()).clone();
            let col = &tau - &nle;
            let err = rel_err(col.as_slice(), m.column(k).as_slice());
            assert!(err < 1e-10, "{}: M column {k} vs RNEA difference: {err:e}", model.name);
        }
    });
}

#[test]
fn nle_and_gravity_are_rnea_special_cases() {
    for_each_state(|model, data, q, v, _| {
        let zero = DVector::zeros(model.nv);
        let nle = nonlinear_effects(model, data, q.as_slice(), v.as_slice()).clone();
        let r = rnea(model, data, q.as_slice(), v.as_slice(), zero.as_slice()).clone();
        assert!(rel_err(nle.as_slice(), r.as_slice()) < 1e-14);
        let g = gravity_torques(model, data, q.as_slice()).clone();
        let r0 = rnea(model, data, q.as_slice(), zero.as_slice(), zero.as_slice()).clone();
        assert!(rel_err(g.as_slice(), r0.as_slice()) < 1e-12, "{}", model.name);
    });
}

/// Rotation vector of `a · bᵀ`.
fn rotation_log(a: &Matrix3<f64>, b: &Matrix3<f64>) -> Vector3<f64> {
    centaur_dynamics::spatial::log3(&(a * b.transpose()))
}

#[test]
fn frame_jacobians_equal_finite_differences_of_forward_kinematics() {
    for_each_state(|model, data, q, v, _| {
        let (qp, qm) = (step(model, q, v, H), step(model, q, v, -H));
        let mut dp = Data::new(model);
        let mut dm = Data::new(model);
        forward_kinematics(model, &mut dp, qp.as_slice());
        forward_kinematics(model, &mut dm, qm.as_slice());
        compute_joint_jacobians(model, data, q.as_slice());
        forward_kinematics_velocity(model, data, q.as_slice(), v.as_slice());
        let mut j = Matrix6xX::zeros(model.nv);
        for f in 0..model.frames.len() {
            let (mp, mm) = (frame_placement(model, &dp, f), frame_placement(model, &dm, f));
            let lin_fd = (mp.translation - mm.translation) / (2.0 * H);
            let ang_fd = rotation_log(&mp.rotation, &mm.rotation) / (2.0 * H);
            frame_jacobian(model, data, f, ReferenceFrame::LocalWorldAligned, &mut j);
            let jv = &j * v;
            let fd = [lin_fd.as_slice(), ang_fd.as_slice()].concat();
            let err = rel_err(jv.as_slice(), &fd);
            assert!(err < 1e-7, "{} frame {}: J v vs FD {err:e}", model.name, model.frames[f].name);
            // The same velocity from the kinematic recursion.
            let vel = frame_velocity(model, data, f, ReferenceFrame::LocalWorldAligned).to_vector();
            assert!(rel_err(vel.as_slice(), jv.as_slice()) < 1e-12);
            // World and local Jacobians are the LWA one seen from other frames.
            let o_m_f = frame_placement(model, data, f);
            let lwa = Motion::from_vector(&jv.fixed_rows::<6>(0).into_owned());
            frame_jacobian(model, data, f, ReferenceFrame::World, &mut j);
            let w = Motion::from_vector(&(&j * v).fixed_rows::<6>(0).into_owned());
            let lin_w = lwa.linear - lwa.angular.cross(&o_m_f.translation);
            assert!((w.linear - lin_w).norm() < 1e-9 * (1.0 + lin_w.norm()));
            frame_jacobian(model, data, f, ReferenceFrame::Local, &mut j);
            let l = Motion::from_vector(&(&j * v).fixed_rows::<6>(0).into_owned());
            assert!((o_m_f.rotation * l.linear - lwa.linear).norm() < 1e-9 * (1.0 + lwa.linear.norm()));
        }
    });
}

#[test]
fn mass_matrix_derivative_minus_twice_coriolis_is_skew() {
    // ½ q̇ᵀ Ṁ q̇ = q̇ᵀ C(q, q̇) q̇ with C q̇ = nle − g: the power form of Ṁ − 2C skew-symmetry.
    for_each_state(|model, data, q, v, _| {
        let mp = crba(model, data, step(model, q, v, H).as_slice()).clone();
        let mm = crba(model, data, step(model, q, v, -H).as_slice()).clone();
        let mdot = (mp - mm) / (2.0 * H);
        let lhs = 0.5 * v.dot(&(&mdot * v));
        let nle = nonlinear_effects(model, data, q.as_slice(), v.as_slice()).clone();
        let g = gravity_torques(model, data, q.as_slice()).clone();
        let rhs = v.dot(&(nle - g));
        assert!((lhs - rhs).abs() < 1e-6 * (1.0 + rhs.abs()), "{}: {lhs} vs {rhs}", model.name);
    });
}

#[test]
fn energies_match_mass_matrix_and_gravity_torques() {
    for_each_state(|model, data, q, v, _| {
        let m = crba(model, data, q.as_slice()).clone();
        let t = kinetic_energy(model, data, q.as_slice(), v.as_slice());
        let t_m = 0.5 * v.dot(&(&m * v));
        assert!((t - t_m).abs() < 1e-10 * (1.0 + t_m.abs()), "{}: T {t} vs ½vᵀMv {t_m}", model.name);
        // dV/dt along v equals g(q)ᵀ v.
        let vp = potential_energy(model, data, step(model, q, v, H).as_slice());
        let vm = potential_energy(model, data, step(model, q, v, -H).as_slice());
        let g = gravity_torques(model, data, q.as_slice()).clone();
        let dv = (vp - vm) / (2.0 * H);
        assert!(
            (dv - g.dot(v)).abs() < 1e-6 * (1.0 + dv.abs()),
            "{}: dV {dv} vs gᵀv {}",
            model.name,
            g.dot(v)
        );
    });
}

#[test]
fn centroidal_momentum_equals_sum_of_link_momenta() {
    for_each_state(|model, data, q, v, _| {
        let h = centroidal_momentum(model, data, q.as_slice(), v.as_slice());
        let com = data.com[0];
        forward_kinematics_velocity(model, data, q.as_slice(), v.as_slice());
        let mut sum = Force::zero();
        for i in 1..model.njoints() {
            let local = model.inertias[i].mul_motion(&data.v[i]);
            sum += data.o_m_i[i].act_force(&local);
        }
        let about_com = Force::new(sum.linear, sum.angular - com.cross(&sum.linear));
        let err = rel_err(h.to_vector().as_slice(), about_com.to_vector().as_slice());
        assert!(err < 1e-10, "{}: A_g v vs Σ link momenta {err:e}", model.name);
    });
}

#[test]
fn com_jacobian_equals_finite_differences() {
    for_each_state(|model, data, q, v, _| {
        let jc = jacobian_center_of_mass(model, data, q.as_slice()).clone();
        let c0 = data.com[0];
        assert!((center_of_mass(model, data, q.as_slice()) - c0).norm() < 1e-14);
        let cp = center_of_mass(model, data, step(model, q, v, H).as_slice());
        let cm = center_of_mass(model, data, step(model, q, v, -H).as_slice());
        let fd = (cp - cm) / (2.0 * H);
        let jv = &jc * v;
        assert!(rel_err(jv.as_slice(), fd.as_slice()) < 1e-7, "{}", model.name);
        let cv = center_of_mass_velocity(model, data, q.as_slice(), v.as_slice());
        assert!(rel_err(cv.as_slice(), jv.as_slice()) < 1e-12, "{}: J_com v summed", model.name);
        assert!((data.com[0] - c0).norm() < 1e-14, "{}: the CoM beside it", model.name);
    });
}

#[test]
fn cholesky_solves_and_inverts_the_mass_matrix() {
    for_each_state(|model, data, q, v, _| {
        let m = crba(model, data, q.as_slice()).clone();
        assert!(cholesky_decompose(model, data), "{}: M not positive definite", model.name);
        let mut x = v.clone();
        mass_matrix_solve(model, data, x.as_mut_slice());
        assert!(rel_err((&m * &x).as_slice(), v.as_slice()) < 1e-9, "{}", model.name);
        let mut inv = DMatrix::zeros(model.nv, model.nv);
        mass_matrix_inverse(model, data, &mut inv);
        let id = &m * &inv;
        assert!((id - DMatrix::identity(model.nv, model.nv)).abs().max() < 1e-8, "{}", model.name);
    });
}

#[test]
fn integrate_and_difference_are_inverse() {
    for_each_state(|model, _, q, v, _| {
        let q1 = step(model, q, v, 0.3);
        let mut d = DVector::zeros(model.nv);
        difference(model, q.as_slice(), q1.as_slice(), d.as_mut_slice());
        assert!(rel_err(d.as_slice(), (v * 0.3).as_slice()) < 1e-9, "{}", model.name);
    });
}

#[test]
fn free_fall_of_a_floating_base_is_g() {
    // With zero torques and zero velocity a floating robot accelerates at g: the base
    // acceleration (in the base frame) is Rᵀ g for the linear part.
    let mut rng = Rng(7);
    for model in test_models().into_iter().filter(|m| m.has_floating_base()) {
        let mut data = Data::new(&model);
        let q = random_q(&model, &mut rng);
        let zero = DVector::zeros(model.nv);
        let ddq = aba(&model, &mut data, q.as_slice(), zero.as_slice(), zero.as_slice()).clone();
        forward_kinematics(&model, &mut data, q.as_slice());
        let r = data.o_m_i[1].rotation;
        let expected = r.transpose() * model.gravity;
        // Joints do not move and the base does not rotate: every body falls together.
        assert!((ddq.fixed_rows::<3>(0) - expected).norm() < 1e-9, "{}", model.name);
        assert!(ddq.rows(3, model.nv - 3).abs().max() < 1e-9, "{}", model.name);
    }
}
