//! Recursive Newton–Euler algorithm (Featherstone, *Rigid Body Dynamics Algorithms*, §5.3):
//! inverse dynamics `τ = M(q) q̈ + C(q, q̇) q̇ + g(q)`.

use nalgebra::DVector;

use crate::data::{Data, check_len};
use crate::kinematics::joint_placement;
use crate::model::{JointKind, Model};
use crate::spatial::{Force, Motion};

/// Writes `Sᵀ f` for joint `kind` into `out` (length nv of the joint).
#[inline]
pub(crate) fn project_force(kind: &JointKind, f: &Force, out: &mut [f64]) {
    match kind {
        JointKind::Revolute { axis } | JointKind::RevoluteUnbounded { axis } => out[0] = axis.dot(&f.angular),
        JointKind::Prismatic { axis } => out[0] = axis.dot(&f.linear),
        JointKind::FreeFlyer => {
            out[..3].copy_from_slice(f.linear.as_slice());
            out[3..6].copy_from_slice(f.angular.as_slice());
        }
        JointKind::Universe => {}
    }
}

/// Forward pass (velocities, accelerations, body forces) and backward pass (joint forces)
/// into `out`. `a = None` means zero acceleration.
fn rnea_into(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    v: &[f64],
    a: Option<&[f64]>,
    out: &mut DVector<f64>,
) {
    data.v[0] = Motion::zero();
    // Gravity enters as an upward acceleration of the world (the "fictitious" base acceleration).
    data.a_gf[0] = Motion::new(-model.gravity, nalgebra::Vector3::zeros());
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        let nv = j.nv();
        let li = joint_placement(j, model.axis_planes[i], q);
        data.li_m_i[i] = li;
        let vj = j.kind.motion(&v[j.idx_v..j.idx_v + nv]);
        let vi = li.act_inv_motion(&data.v[j.parent]) + vj;
        let mut ai = li.act_inv_motion(&data.a_gf[j.parent]) + vi.cross(&vj);
        if let Some(a) = a {
            ai += j.kind.motion(&a[j.idx_v..j.idx_v + nv]);
        }
        data.v[i] = vi;
        data.a_gf[i] = ai;
        let y = &model.inertias[i];
        data.f[i] = y.mul_motion(&ai) + vi.cross_force(&y.mul_motion(&vi));
    }
    for i in (1..model.njoints()).rev() {
        let j = &model.joints[i];
        let fi = data.f[i];
        project_force(&j.kind, &fi, &mut out.as_mut_slice()[j.idx_v..j.idx_v + j.nv()]);
        if j.parent > 0 {
            let fp = data.li_m_i[i].act_force(&fi);
            data.f[j.parent] += fp;
        }
    }
}

/// Inverse dynamics `τ = rnea(q, v, a)` including gravity; result in `data.tau`.
/// Also fills `data.li_m_i`, `data.v`, `data.a_gf`, `data.f`.
#[track_caller]
pub fn rnea<'a>(model: &Model, data: &'a mut Data, q: &[f64], v: &[f64], a: &[f64]) -> &'a DVector<f64> {
    check_len("q", q.len(), model.nq);
    check_len("v", v.len(), model.nv);
    check_len("a", a.len(), model.nv);
    let mut out = std::mem::take(&mut data.tau);
    rnea_into(model, data, q, v, Some(a), &mut out);
    data.tau = out;
    &data.tau
}

/// Nonlinear effects `C(q, v) v + g(q) = rnea(q, v, 0)`; result in `data.nle`.
#[track_caller]
pub fn nonlinear_effects<'a>(model: &Model, data: &'a mut Data, q: &[f64], v: &[f64]) -> &'a DVector<f64> {
    check_len("q", q.len(), model.nq);
    check_len("v", v.len(), model.nv);
    let mut out = std::mem::take(&mut data.nle);
    rnea_into(model, data, q, v, None, &mut out);
    data.nle = out;
    &data.nle
}

/// Gravity torques `g(q) = rnea(q, 0, 0)`; result in `data.g`.
#[track_caller]
pub fn gravity_torques<'a>(model: &Model, data: &'a mut Data, q: &[f64]) -> &'a DVector<f64> {
    check_len("q", q.len(), model.nq);
    data.a_gf[0] = Motion::new(-model.gravity, nalgebra::Vector3::zeros());
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        let li = joint_placement(j, model.axis_planes[i], q);
        data.li_m_i[i] = li;
        let ai = li.act_inv_motion(&data.a_gf[j.parent]);
        data.a_gf[i] = ai;
        data.f[i] = model.inertias[i].mul_motion(&ai);
    }
    for i in (1..model.njoints()).rev() {
        let j = &model.joints[i];
        let fi = data.f[i];
        project_force(&j.kind, &fi, &mut data.g.as_mut_slice()[j.idx_v..j.idx_v + j.nv()]);
        if j.parent > 0 {
            let fp = data.li_m_i[i].act_force(&fi);
            data.f[j.parent] += fp;
        }
    }
    &data.g
}
