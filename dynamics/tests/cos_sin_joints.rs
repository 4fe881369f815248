//! Continuous joints parametrised by `(cos θ, sin θ)` (`JointKind::RevoluteUnbounded`, as
//! Pinocchio loads them): the loader option, agreement with the angle parametrisation on
//! every algorithm, and the configuration-space operations.

mod common;

use centaur_dynamics::nalgebra::{DVector, Matrix3, Vector3};
use centaur_dynamics::{
    BaseKind, Data, Inertia, JointKind, Model, Se3, aba, centroidal_map, compute_joint_jacobians, crba,
    difference, forward_kinematics, integrate, normalize, rnea,
};
use common::{Rng, asset, minitaur_cos_sin, random_q, random_v, rel_err};

fn minitaur_angles() -> Model {
    Model::from_urdf_file(asset("minitaur/minitaur.urdf"), BaseKind::Floating).unwrap()
}

/// The angle-parametrised `q` of `angles` written in the layout of `cos_sin`.
fn to_cos_sin(angles: &Model, cos_sin: &Model, q: &DVector<f64>) -> DVector<f64> {
    let mut out = DVector::zeros(cos_sin.nq);
    for (ja, jc) in angles.joints[1..].iter().zip(&cos_sin.joints[1..]) {
        assert_eq!(ja.name, jc.name);
        match jc.kind {
            JointKind::RevoluteUnbounded { .. } => {
                let (s, c) = q[ja.idx_q].sin_cos();
                (out[jc.idx_q], out[jc.idx_q + 1]) = (c, s);
            }
            _ => {
                for k in 0..jc.nq() {
                    out[jc.idx_q + k] = q[ja.idx_q + k];
                }
            }
        }
    }
    out
}

#[test]
fn continuous_joints_load_as_cos_sin_pairs_on_request() {
    let angles = minitaur_angles();
    let cos_sin = minitaur_cos_sin();
    assert_eq!((angles.nq, angles.nv), (23, 22));
    assert_eq!((cos_sin.nq, cos_sin.nv), (31, 22), "Pinocchio's dimensions for the Minitaur");
    let unbounded: Vec<&str> = cos_sin
        .joints
        .iter()
        .filter(|j| matches!(j.kind, JointKind::RevoluteUnbounded { .. }))
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(unbounded.len(), 8, "{unbounded:?}");
    assert!(
        unbounded.iter().all(|n| n.starts_with("motor_")),
        "the motor joints are continuous: {unbounded:?}"
    );
    let q0 = cos_sin.neutral_configuration();
    for j in &cos_sin.joints[1..] {
        if let JointKind::RevoluteUnbounded { .. } = j.kind {
            assert_eq!((q0[j.idx_q], q0[j.idx_q + 1]), (1.0, 0.0), "{}: neutral is θ = 0", j.name);
            for k in 0..2 {
                assert_eq!(cos_sin.lower_position_limit[j.idx_q + k], f64::NEG_INFINITY);
                assert_eq!(cos_sin.upper_position_limit[j.idx_q + k], f64::INFINITY);
            }
        }
    }
}

/// Draws a random state of `angles` and checks that `cos_sin` gives the same joint
/// transforms, RNEA, CRBA, ABA, joint Jacobians, centroidal map and joint placements.
fn assert_agree(angles: &Model, cos_sin: &Model, rng: &mut Rng) {
    let (mut da, mut dc) = (Data::new(angles), Data::new(cos_sin));
    let qa = random_q(angles, rng);
    let qc = to_cos_sin(angles, cos_sin, &qa);
    let (qa, qc) = (qa.as_slice(), qc.as_slice());
    let (v, a, tau) = (random_v(angles, rng), random_v(angles, rng), random_v(angles, rng));
    let (v, a, tau) = (v.as_slice(), a.as_slice(), tau.as_slice());
    let close = |x: &[f64], y: &[f64], what: &str| {
        let e = rel_err(x, y);
        assert!(e < 1e-13, "{}: {what} differs by {e:e}", cos_sin.name);
    };
    for (ja, jc) in angles.joints[1..].iter().zip(&cos_sin.joints[1..]) {
        // The joint's own transform, `M_J(q)`.
        let (ta, tc) = (ja.kind.transform(&qa[ja.idx_q..]), jc.kind.transform(&qc[jc.idx_q..]));
        close(tc.rotation.as_slice(), ta.rotation.as_slice(), &jc.name);
    }
    close(rnea(cos_sin, &mut dc, qc, v, a).as_slice(), rnea(angles, &mut da, qa, v, a).as_slice(), "rnea");
    close(crba(cos_sin, &mut dc, qc).as_slice(), crba(angles, &mut da, qa).as_slice(), "crba");
    close(aba(cos_sin, &mut dc, qc, v, tau).as_slice(), aba(angles, &mut da, qa, v, tau).as_slice(), "aba");
    compute_joint_jacobians(angles, &mut da, qa);
    compute_joint_jacobians(cos_sin, &mut dc, qc);
    close(dc.jacobians.as_slice(), da.jacobians.as_slice(), "joint jacobians");
    close(
        centroidal_map(cos_sin, &mut dc, qc).as_slice(),
        centroidal_map(angles, &mut da, qa).as_slice(),
        "centroidal map",
    );
    forward_kinematics(angles, &mut da, qa);
    forward_kinematics(cos_sin, &mut dc, qc);
    for (pa, pc) in da.o_m_i.iter().zip(&dc.o_m_i) {
        close(pc.rotation.as_slice(), pa.rotation.as_slice(), "joint rotation");
        close(pc.translation.as_slice(), pa.translation.as_slice(), "joint translation");
    }
}

#[test]
fn cos_sin_and_angle_models_agree_on_every_algorithm() {
    let (angles, cos_sin) = (minitaur_angles(), minitaur_cos_sin());
    let mut rng = Rng(7);
    for _ in 0..20 {
        assert_agree(&angles, &cos_sin, &mut rng);
    }
}

#[test]
fn integrate_turns_the_pair_and_difference_wraps_the_angle() {
    let model = minitaur_cos_sin();
    let mut rng = Rng(3);
    let q0 = random_q(&model, &mut rng);
    // Turns of up to 3 rad: many joints pass ±π.
    let v = DVector::from_fn(model.nv, |_, _| rng.range(-3.0, 3.0));
    let mut q1 = DVector::zeros(model.nq);
    integrate(&model, q0.as_slice(), v.as_slice(), q1.as_mut_slice());
    let mut back = DVector::zeros(model.nv);
    difference(&model, q0.as_slice(), q1.as_slice(), back.as_mut_slice());
    for j in &model.joints[1..] {
        if let JointKind::RevoluteUnbounded { .. } = j.kind {
            let (c0, s0, c1, s1) = (q0[j.idx_q], q0[j.idx_q + 1], q1[j.idx_q], q1[j.idx_q + 1]);
            assert!((c1.hypot(s1) - 1.0).abs() < 1e-15, "{}: off the unit circle", j.name);
            let turned = s0.atan2(c0) + v[j.idx_v];
            assert!((c1 - turned.cos()).abs() < 1e-14 && (s1 - turned.sin()).abs() < 1e-14, "{}", j.name);
        }
    }
    assert!(rel_err(back.as_slice(), v.as_slice()) < 1e-12, "difference undoes integrate for |θ̇| < π");
    // A turn of 4 rad comes back as 4 − 2π.
    let mut v4 = DVector::zeros(model.nv);
    let k =
        model.joints.iter().find(|j| matches!(j.kind, JointKind::RevoluteUnbounded { .. })).unwrap().idx_v;
    v4[k] = 4.0;
    integrate(&model, q0.as_slice(), v4.as_slice(), q1.as_mut_slice());
    difference(&model, q0.as_slice(), q1.as_slice(), back.as_mut_slice());
    assert!((back[k] - (4.0 - 2.0 * std::f64::consts::PI)).abs() < 1e-12, "{}", back[k]);
}

#[test]
fn normalize_puts_the_pairs_back_on_the_unit_circle() {
    let model = minitaur_cos_sin();
    let iq: Vec<usize> = model
        .joints
        .iter()
        .filter(|j| matches!(j.kind, JointKind::RevoluteUnbounded { .. }))
        .map(|j| j.idx_q)
        .collect();
    let mut q = model.neutral_configuration();
    (q[iq[0]], q[iq[0] + 1]) = (1.2, 1.6);
    (q[iq[1]], q[iq[1] + 1]) = (0.0, 0.0);
    (q[iq[2]], q[iq[2] + 1]) = (f64::NAN, 1.0);
    normalize(&model, q.as_mut_slice());
    assert!((q[iq[0]] - 0.6).abs() < 1e-15 && (q[iq[0] + 1] - 0.8).abs() < 1e-15);
    assert_eq!((q[iq[1]], q[iq[1] + 1]), (1.0, 0.0), "a zero pair becomes θ = 0");
    assert_eq!((q[iq[2]], q[iq[2] + 1]), (1.0, 0.0), "a NaN pair becomes θ = 0");
}

/// A fixed-base chain turning about x, −y and an oblique axis, with each joint either
/// [`JointKind::Revolute`] or [`JointKind::RevoluteUnbounded`].
fn chain(cos_sin: bool) -> Model {
    let axes = [Vector3::x(), -Vector3::y(), Vector3::new(0.6, 0.0, 0.8), Vector3::z()];
    let mut m = Model::new("chain");
    let mut parent = 0;
    for (k, axis) in axes.into_iter().enumerate() {
        let kind = if cos_sin { JointKind::RevoluteUnbounded { axis } } else { JointKind::Revolute { axis } };
        let placement = Se3::new(Matrix3::identity(), Vector3::new(0.1, 0.05 * k as f64, 0.3));
        parent = m.add_joint(format!("j{k}"), kind, parent, placement);
        let rot = Matrix3::new(0.02, 0.001, 0.0, 0.001, 0.03, 0.002, 0.0, 0.002, 0.025);
        m.inertias[parent] = Inertia::new(1.0 + k as f64, Vector3::new(0.05, -0.02, 0.1), rot);
    }
    m
}

#[test]
fn every_axis_plane_agrees_with_the_angle_joint() {
    let (angles, cos_sin) = (chain(false), chain(true));
    assert_eq!((cos_sin.nq, cos_sin.nv), (8, 4));
    let mut rng = Rng(11);
    for _ in 0..10 {
        assert_agree(&angles, &cos_sin, &mut rng);
    }
}
