//! Forward kinematics, frame placements and velocities, and configuration-space calculus.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::data::{Data, check_len};
use crate::model::{AxisPlane, Joint, JointKind, Model, rotate_about_axis};
use crate::spatial::{Motion, Se3, exp6, log6};

/// In which frame a Jacobian, velocity or acceleration is expressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceFrame {
    /// World axes, at the world origin (spatial vectors, as in `data.jacobians`).
    World,
    /// World axes, at the frame's origin: the linear part is the velocity of the frame
    /// origin in the world.
    LocalWorldAligned,
    /// The frame's own axes, at its origin (body twist).
    Local,
}

/// `ⁱ⁻¹Mᵢ(q) = placement · M_J(q)` of joint `j` (whose axis turns in `plane`), specialised
/// per joint kind; `q` is the whole configuration.
#[inline(always)]
pub(crate) fn joint_placement(j: &Joint, plane: AxisPlane, q: &[f64]) -> Se3 {
    // A joint edited without `Model::finalize` would keep a stale plane.
    debug_assert_eq!(plane, AxisPlane::of(&j.kind), "joint '{}' changed: call Model::finalize", j.name);
    let placement = &j.placement;
    let iq = j.idx_q;
    match &j.kind {
        JointKind::Revolute { axis } => Se3 {
            rotation: rotate_about_axis(&placement.rotation, axis, plane, q[iq].sin_cos()),
            translation: placement.translation,
        },
        // Pinocchio's unbounded joint: q holds (cos θ, sin θ) already.
        JointKind::RevoluteUnbounded { axis } => Se3 {
            rotation: rotate_about_axis(&placement.rotation, axis, plane, (q[iq + 1], q[iq])),
            translation: placement.translation,
        },
        JointKind::Prismatic { axis } => Se3 {
            rotation: placement.rotation,
            translation: placement.rotation * (axis * q[iq]) + placement.translation,
        },
        JointKind::Universe => *placement,
        kind @ JointKind::FreeFlyer => placement.mul(&kind.transform(&q[iq..iq + 7])),
    }
}

/// Forward kinematics of the joint placements: fills `data.li_m_i` and `data.o_m_i`.
#[track_caller]
pub fn forward_kinematics(model: &Model, data: &mut Data, q: &[f64]) {
    check_len("q", q.len(), model.nq);
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        let li = joint_placement(j, model.axis_planes[i], q);
        data.li_m_i[i] = li;
        data.o_m_i[i] = if j.parent == 0 { li } else { data.o_m_i[j.parent].mul(&li) };
    }
}

/// Forward kinematics with velocities: also fills `data.v` (body twists in joint frames).
#[track_caller]
pub fn forward_kinematics_velocity(model: &Model, data: &mut Data, q: &[f64], v: &[f64]) {
    check_len("q", q.len(), model.nq);
    check_len("v", v.len(), model.nv);
    data.v[0] = Motion::zero();
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        let li = joint_placement(j, model.axis_planes[i], q);
        data.li_m_i[i] = li;
        data.o_m_i[i] = if j.parent == 0 { li } else { data.o_m_i[j.parent].mul(&li) };
        let vj = j.kind.motion(&v[j.idx_v..j.idx_v + j.nv()]);
        data.v[i] = li.act_inv_motion(&data.v[j.parent]) + vj;
    }
}

/// Forward kinematics with velocities and accelerations: also fills `data.a` (body
/// accelerations in joint frames, without gravity).
#[track_caller]
pub fn forward_kinematics_acceleration(model: &Model, data: &mut Data, q: &[f64], v: &[f64], a: &[f64]) {
    check_len("q", q.len(), model.nq);
    check_len("v", v.len(), model.nv);
    check_len("a", a.len(), model.nv);
    data.v[0] = Motion::zero();
    data.a[0] = Motion::zero();
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        let li = joint_placement(j, model.axis_planes[i], q);
        data.li_m_i[i] = li;
        data.o_m_i[i] = if j.parent == 0 { li } else { data.o_m_i[j.parent].mul(&li) };
        let vj = j.kind.motion(&v[j.idx_v..j.idx_v + j.nv()]);
        let vi = li.act_inv_motion(&data.v[j.parent]) + vj;
        data.v[i] = vi;
        data.a[i] = li.act_inv_motion(&data.a[j.parent])
            + j.kind.motion(&a[j.idx_v..j.idx_v + j.nv()])
            + vi.cross(&vj);
    }
}

/// Fills `data.o_m_f` from `data.o_m_i` (call after any forward kinematics).
pub fn update_frame_placements(model: &Model, data: &mut Data) {
    for (k, f) in model.frames.iter().enumerate() {
        data.o_m_f[k] = data.o_m_i[f.parent_joint].mul(&f.placement);
    }
}

/// The world placement of one frame, from `data.o_m_i`.
#[track_caller]
pub fn frame_placement(model: &Model, data: &Data, frame: usize) -> Se3 {
    let f = &model.frames[frame];
    data.o_m_i[f.parent_joint].mul(&f.placement)
}

/// Velocity of a frame from `data.v` (after [`forward_kinematics_velocity`]).
#[track_caller]
pub fn frame_velocity(model: &Model, data: &Data, frame: usize, rf: ReferenceFrame) -> Motion {
    let f = &model.frames[frame];
    let local = f.placement.act_inv_motion(&data.v[f.parent_joint]);
    express_local_motion(&data.o_m_i[f.parent_joint].mul(&f.placement), &local, rf)
}

/// Spatial acceleration of a frame from `data.a` (after [`forward_kinematics_acceleration`]).
/// With [`ReferenceFrame::LocalWorldAligned`] this is the spatial (not classical)
/// acceleration; see [`frame_classical_acceleration`].
#[track_caller]
pub fn frame_acceleration(model: &Model, data: &Data, frame: usize, rf: ReferenceFrame) -> Motion {
    let f = &model.frames[frame];
    let local = f.placement.act_inv_motion(&data.a[f.parent_joint]);
    express_local_motion(&data.o_m_i[f.parent_joint].mul(&f.placement), &local, rf)
}

/// Classical linear acceleration of a frame's origin in world axes, `a_lin + ω × v_lin`
/// (what an accelerometer without gravity would read, rotated to the world).
#[track_caller]
pub fn frame_classical_acceleration(model: &Model, data: &Data, frame: usize) -> Vector3<f64> {
    let f = &model.frames[frame];
    let vl = f.placement.act_inv_motion(&data.v[f.parent_joint]);
    let al = f.placement.act_inv_motion(&data.a[f.parent_joint]);
    let o_m_f = data.o_m_i[f.parent_joint].mul(&f.placement);
    o_m_f.rotation * (al.linear + vl.angular.cross(&vl.linear))
}

fn express_local_motion(o_m_f: &Se3, local: &Motion, rf: ReferenceFrame) -> Motion {
    match rf {
        ReferenceFrame::Local => *local,
        ReferenceFrame::LocalWorldAligned => {
            Motion::new(o_m_f.rotation * local.linear, o_m_f.rotation * local.angular)
        }
        ReferenceFrame::World => o_m_f.act_motion(local),
    }
}

/// `q ⊕ v`: the configuration reached from `q` after moving with velocity `v` for unit time.
/// Free-flyers move along the body twist (`M · exp6(v)`), `(cos θ, sin θ)` pairs
/// ([`JointKind::RevoluteUnbounded`]) turn by their rate and are renormalised, other joints
/// add.
#[track_caller]
pub fn integrate(model: &Model, q: &[f64], v: &[f64], out: &mut [f64]) {
    check_len("q", q.len(), model.nq);
    check_len("v", v.len(), model.nv);
    check_len("out", out.len(), model.nq);
    for j in &model.joints[1..] {
        let (iq, iv) = (j.idx_q, j.idx_v);
        match j.kind {
            JointKind::FreeFlyer => {
                let m = j.kind.transform(&q[iq..iq + 7]);
                let nu = Motion::new(
                    Vector3::new(v[iv], v[iv + 1], v[iv + 2]),
                    Vector3::new(v[iv + 3], v[iv + 4], v[iv + 5]),
                );
                let next = m.mul(&exp6(&nu));
                write_free_flyer(&next, &mut out[iq..iq + 7]);
            }
            JointKind::Revolute { .. } | JointKind::Prismatic { .. } => out[iq] = q[iq] + v[iv],
            JointKind::RevoluteUnbounded { .. } => {
                // Turn (cos θ, sin θ) by v, then back onto the unit circle.
                let (c, s) = (q[iq], q[iq + 1]);
                let (sv, cv) = v[iv].sin_cos();
                let (c1, s1) = (c * cv - s * sv, s * cv + c * sv);
                let n = c1.hypot(s1);
                (out[iq], out[iq + 1]) = (c1 / n, s1 / n);
            }
            JointKind::Universe => {}
        }
    }
}

/// `q1 ⊖ q0`: the velocity `v` with `q0 ⊕ v = q1` (for a `(cos θ, sin θ)` pair, the angle
/// from `q0` to `q1` wrapped into (−π, π]).
#[track_caller]
pub fn difference(model: &Model, q0: &[f64], q1: &[f64], out: &mut [f64]) {
    check_len("q0", q0.len(), model.nq);
    check_len("q1", q1.len(), model.nq);
    check_len("out", out.len(), model.nv);
    for j in &model.joints[1..] {
        let (iq, iv) = (j.idx_q, j.idx_v);
        match j.kind {
            JointKind::FreeFlyer => {
                let m0 = j.kind.transform(&q0[iq..iq + 7]);
                let m1 = j.kind.transform(&q1[iq..iq + 7]);
                let nu = log6(&m0.inv_mul(&m1));
                out[iv..iv + 3].copy_from_slice(nu.linear.as_slice());
                out[iv + 3..iv + 6].copy_from_slice(nu.angular.as_slice());
            }
            JointKind::Revolute { .. } | JointKind::Prismatic { .. } => out[iv] = q1[iq] - q0[iq],
            JointKind::RevoluteUnbounded { .. } => {
                // The angle from q0 to q1, in (−π, π].
                let (c0, s0, c1, s1) = (q0[iq], q0[iq + 1], q1[iq], q1[iq + 1]);
                out[iv] = (c0 * s1 - s0 * c1).atan2(c0 * c1 + s0 * s1);
            }
            JointKind::Universe => {}
        }
    }
}

/// Normalises in place the quaternions of free-flyer joints and the `(cos θ, sin θ)` pairs
/// of [`JointKind::RevoluteUnbounded`] joints; a zero or non-finite one becomes the
/// neutral `(0, 0, 0, 1)` / `(1, 0)`.
pub fn normalize(model: &Model, q: &mut [f64]) {
    fn unit(s: &mut [f64], neutral: &[f64]) {
        let n = s.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 0.0 && n.is_finite() {
            s.iter_mut().for_each(|x| *x /= n);
        } else {
            s.copy_from_slice(neutral);
        }
    }
    for j in &model.joints[1..] {
        match j.kind {
            JointKind::FreeFlyer => unit(&mut q[j.idx_q + 3..j.idx_q + 7], &[0.0, 0.0, 0.0, 1.0]),
            JointKind::RevoluteUnbounded { .. } => unit(&mut q[j.idx_q..j.idx_q + 2], &[1.0, 0.0]),
            _ => {}
        }
    }
}

pub(crate) fn write_free_flyer(m: &Se3, out: &mut [f64]) {
    let q: UnitQuaternion<f64> = m.quaternion();
    let q: &Quaternion<f64> = q.quaternion();
    out[0] = m.translation.x;
    out[1] = m.translation.y;
    out[2] = m.translation.z;
    out[3] = q.i;
    out[4] = q.j;
    out[5] = q.k;
    out[6] = q.w;
}
