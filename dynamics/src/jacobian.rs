//! Joint and frame Jacobians.

use nalgebra::Matrix6xX;

use crate::data::{Data, check_len};
use crate::kinematics::{ReferenceFrame, joint_placement};
use crate::model::Model;
use crate::spatial::{Motion, Se3};

/// Forward kinematics plus the world-frame Jacobian of every joint: column `k` of
/// `data.jacobians` is the motion subspace of dof `k` expressed at the world origin,
/// `⁰Xᵢ Sᵢ`. Also fills `data.li_m_i` and `data.o_m_i`.
#[track_caller]
pub fn compute_joint_jacobians(model: &Model, data: &mut Data, q: &[f64]) {
    check_len("q", q.len(), model.nq);
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        let li = joint_placement(j, model.axis_planes[i], q);
        data.li_m_i[i] = li;
        let o = if j.parent == 0 { li } else { data.o_m_i[j.parent].mul(&li) };
        data.o_m_i[i] = o;
        write_joint_columns(model, i, &o, &mut data.jacobians);
    }
}

/// Writes the world-frame subspace columns of joint `i` placed at `o_m_i`.
#[inline]
pub(crate) fn write_joint_columns(model: &Model, i: usize, o_m_i: &Se3, jac: &mut Matrix6xX<f64>) {
    let j = &model.joints[i];
    if let Some((axis, sign)) = model.axis_planes[i].unit() {
        // A revolute joint about `sign · e_axis`: ω = sign · R e_axis, v = p × ω.
        let angular = o_m_i.rotation.column(axis) * sign;
        let linear = o_m_i.translation.cross(&angular);
        let mut col = jac.column_mut(j.idx_v);
        col[0] = linear.x;
        col[1] = linear.y;
        col[2] = linear.z;
        col[3] = angular.x;
        col[4] = angular.y;
        col[5] = angular.z;
        return;
    }
    for k in 0..j.nv() {
        let s = o_m_i.act_motion(&j.kind.subspace_column(k));
        let mut col = jac.column_mut(j.idx_v + k);
        col[0] = s.linear.x;
        col[1] = s.linear.y;
        col[2] = s.linear.z;
        col[3] = s.angular.x;
        col[4] = s.angular.y;
        col[5] = s.angular.z;
    }
}

#[inline]
fn column_motion(jac: &Matrix6xX<f64>, k: usize) -> Motion {
    let c = jac.column(k);
    Motion::new(nalgebra::Vector3::new(c[0], c[1], c[2]), nalgebra::Vector3::new(c[3], c[4], c[5]))
}

/// Writes into `out` (6 × nv) the Jacobian of a point rigidly attached to joint `joint` at
/// world placement `o_m`: columns outside the joint's support are zero. Requires
/// `data.jacobians` from [`compute_joint_jacobians`].
fn point_jacobian(
    model: &Model,
    data: &Data,
    joint: usize,
    o_m: &Se3,
    rf: ReferenceFrame,
    out: &mut Matrix6xX<f64>,
) {
    assert!(
        out.ncols() == model.nv,
        "Jacobian output has {} columns, but the model has nv = {}",
        out.ncols(),
        model.nv
    );
    out.fill(0.0);
    let j = &model.joints[joint];
    if j.nv() == 0 && joint == 0 {
        return;
    }
    // Walk the support from the last dof of `joint` (or of its nearest moving ancestor).
    let mut k = if j.nv() > 0 {
        Some(j.idx_v + j.nv() - 1)
    } else {
        model.support(joint).iter().rev().find(|&&a| model.joints[a].nv() > 0).map(|&a| {
            let ja = &model.joints[a];
            ja.idx_v + ja.nv() - 1
        })
    };
    while let Some(col) = k {
        let s = column_motion(&data.jacobians, col);
        let m = match rf {
            ReferenceFrame::World => s,
            ReferenceFrame::LocalWorldAligned => {
                Motion::new(s.linear + s.angular.cross(&o_m.translation), s.angular)
            }
            ReferenceFrame::Local => o_m.act_inv_motion(&s),
        };
        let mut c = out.column_mut(col);
        c[0] = m.linear.x;
        c[1] = m.linear.y;
        c[2] = m.linear.z;
        c[3] = m.angular.x;
        c[4] = m.angular.y;
        c[5] = m.angular.z;
        k = model.parent_dof(col);
    }
}

/// Jacobian of a joint frame (6 × nv) in the requested frame, after
/// [`compute_joint_jacobians`].
#[track_caller]
pub fn joint_jacobian(
    model: &Model,
    data: &Data,
    joint: usize,
    rf: ReferenceFrame,
    out: &mut Matrix6xX<f64>,
) {
    let o = data.o_m_i[joint];
    point_jacobian(model, data, joint, &o, rf, out);
}

/// Jacobian of a frame (6 × nv) in the requested frame, after [`compute_joint_jacobians`]:
/// `v_frame = J q̇`, with [`ReferenceFrame::LocalWorldAligned`] giving the world velocity of
/// the frame origin and the world angular velocity.
#[track_caller]
pub fn frame_jacobian(
    model: &Model,
    data: &Data,
    frame: usize,
    rf: ReferenceFrame,
    out: &mut Matrix6xX<f64>,
) {
    let f = &model.frames[frame];
    let o = data.o_m_i[f.parent_joint].mul(&f.placement);
    point_jacobian(model, data, f.parent_joint, &o, rf, out);
}
