//! Composite-rigid-body algorithm (Featherstone §6.2), and the quantities that use
//! composite inertias: centre of mass, its Jacobian and the centroidal momentum matrix
//! (Orin, Goswami & Lee 2013).
//!
//! [`crba`] accumulates the composites in joint frames (see its docs). The centre-of-mass
//! and centroidal functions use world-frame composites instead: there every joint subspace
//! `⁰Sⱼ` is a column of `data.jacobians` and the composite inertias
//! `⁰Y_c,i = Σ_{k ∈ subtree(i)} ⁰Y_k` add without transforms, so each column of their
//! result is `⁰Y_c,i ⁰S_c`.

use nalgebra::{DMatrix, Matrix3xX, Matrix6xX, Vector3};

use crate::data::{Data, check_len};
use crate::kinematics::joint_placement;
use crate::model::{JointKind, Model};
use crate::spatial::{Force, Motion, OriginInertia};

/// Forward pass shared by the algorithms below: joint placements, world Jacobian columns
/// and each body's inertia at the world origin (into `acc`, not yet accumulated).
#[inline]
fn forward_world_inertias(model: &Model, data: &mut Data, q: &[f64], acc: &mut [OriginInertia]) {
    crate::jacobian::compute_joint_jacobians(model, data, q);
    for i in 1..model.njoints() {
        acc[i] = OriginInertia::from_placed_inertia(&data.o_m_i[i], &model.inertias[i]);
    }
    acc[0] = OriginInertia::zero();
}

/// Forward pass, then every composite inertia (`acc[i]` = subtree of `i`, `acc[0]` = robot),
/// with subtree masses and centres of mass in `data.mass` / `data.com`.
fn composite_inertias(model: &Model, data: &mut Data, q: &[f64], acc: &mut [OriginInertia]) {
    forward_world_inertias(model, data, q, acc);
    for i in (1..model.njoints()).rev() {
        let p = model.joints[i].parent;
        let yi = acc[i];
        acc[p].add_assign(&yi);
    }
    for i in 0..model.njoints() {
        data.mass[i] = acc[i].mass;
        data.com[i] = if acc[i].mass > 0.0 { acc[i].first_moment / acc[i].mass } else { Vector3::zeros() };
    }
}

#[inline]
fn column(jac: &Matrix6xX<f64>, k: usize) -> Motion {
    let c = jac.column(k);
    Motion::new(Vector3::new(c[0], c[1], c[2]), Vector3::new(c[3], c[4], c[5]))
}

/// Joint-space inertia matrix `M(q)` into `data.mass_matrix` (both triangles filled).
/// Also fills `data.li_m_i` and the robot's mass and centre of mass (`data.mass[0]`,
/// `data.com[0]`).
///
/// Composite inertias are accumulated in the joint frames (Featherstone's original form,
/// Pinocchio's default convention): `Fᶜ = Y_c,i S_c` is formed in the frame of joint `i`,
/// each row block `M[i, subtree(i)] = S_iᵀ F` is read there, and the subtree's `F`
/// columns and inertia are then moved to the parent frame. No world placement or world
/// Jacobian is needed, and `S_iᵀ F` is a 3-term product for revolute joints.
#[track_caller]
pub fn crba<'a>(model: &Model, data: &'a mut Data, q: &[f64]) -> &'a DMatrix<f64> {
    check_len("q", q.len(), model.nq);
    let nv = model.nv;
    let ycrb = &mut data.ycrb;
    ycrb[0] = OriginInertia::zero();
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        data.li_m_i[i] = joint_placement(j, model.axis_planes[i], q);
        ycrb[i] = OriginInertia::from_inertia(&model.inertias[i]);
    }
    let fcrb = &mut data.f_crb;
    let mm = data.mass_matrix.as_mut_slice();
    for i in (1..model.njoints()).rev() {
        let j = &model.joints[i];
        let start = j.idx_v;
        let end = start + if j.nv() > 0 { model.nv_subtree(start) } else { 0 };
        let y = &ycrb[i];
        for k in 0..j.nv() {
            fcrb[start + k] = match &j.kind {
                // `Y (0, a) = (a × h, I_O a)`.
                JointKind::Revolute { axis } | JointKind::RevoluteUnbounded { axis } => {
                    Force { linear: axis.cross(&y.first_moment), angular: y.rotational * axis }
                }
                kind => y.mul_motion(&kind.subspace_column(k)),
            };
        }
        // Row block `M[i, c] = S_iᵀ F_c` for c ≥ the row, specialised per joint kind.
        let put = |mm: &mut [f64], r: usize, c: usize, m: f64| {
            // Column-major storage: (r, c) lives at r + c·nv.
            mm[r + c * nv] = m;
            mm[c + r * nv] = m;
        };
        match &j.kind {
            JointKind::Revolute { axis } | JointKind::RevoluteUnbounded { axis } => {
                for c in start..end {
                    put(mm, start, c, axis.dot(&fcrb[c].angular));
                }
            }
            JointKind::Prismatic { axis } => {
                for c in start..end {
                    put(mm, start, c, axis.dot(&fcrb[c].linear));
                }
            }
            JointKind::FreeFlyer => {
                for c in start..end {
                    let f = &fcrb[c];
                    let parts = [f.linear.x, f.linear.y, f.linear.z, f.angular.x, f.angular.y, f.angular.z];
                    for (k, &m) in parts.iter().enumerate().take(c - start + 1) {
                        put(mm, start + k, c, m);
                    }
                }
            }
            JointKind::Universe => {}
        }
        let x = &data.li_m_i[i];
        if j.parent > 0 {
            for f in &mut fcrb[start..end] {
                *f = x.act_force(f);
            }
            let moved = ycrb[i].transformed(x);
            ycrb[j.parent].add_assign(&moved);
        } else {
            // Only the robot's mass and centre of mass are wanted at the root: move the
            // first moment, not the rotational inertia.
            let y = ycrb[i];
            ycrb[0].mass += y.mass;
            ycrb[0].first_moment += x.rotation * y.first_moment + x.translation * y.mass;
        }
    }
    // The universe's mass and first moment are the whole robot's, in world axes.
    data.mass[0] = ycrb[0].mass;
    data.com[0] = if ycrb[0].mass > 0.0 { ycrb[0].first_moment / ycrb[0].mass } else { Vector3::zeros() };
    data.chol_ready = false;
    &data.mass_matrix
}

/// Centre of mass of the robot (and of every subtree) in the world: `data.com[0]`, with the
/// moved mass in `data.mass[0]`. Also fills `data.o_m_i` and `data.jacobians`.
#[track_caller]
pub fn center_of_mass(model: &Model, data: &mut Data, q: &[f64]) -> Vector3<f64> {
    check_len("q", q.len(), model.nq);
    let mut acc = std::mem::take(&mut data.o_ycrb);
    composite_inertias(model, data, q, &mut acc);
    data.o_ycrb = acc;
    data.com[0]
}

/// Jacobian of the centre of mass (3 × nv) into `data.jacobian_com`:
/// column `c` of joint `i` is `(m_i / m)(⁰v_c + ⁰ω_c × c_i)` with `m_i`, `c_i` the mass and
/// centre of mass of the subtree of `i`. Also computes the centre of mass.
#[track_caller]
pub fn jacobian_center_of_mass<'a>(model: &Model, data: &'a mut Data, q: &[f64]) -> &'a Matrix3xX<f64> {
    check_len("q", q.len(), model.nq);
    let mut acc = std::mem::take(&mut data.o_ycrb);
    composite_inertias(model, data, q, &mut acc);
    let total = acc[0].mass;
    let inv = if total > 0.0 { 1.0 / total } else { 0.0 };
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        for k in 0..j.nv() {
            let c = j.idx_v + k;
            let f = acc[i].mul_motion(&column(&data.jacobians, c));
            let mut col = data.jacobian_com.column_mut(c);
            col[0] = f.linear.x * inv;
            col[1] = f.linear.y * inv;
            col[2] = f.linear.z * inv;
        }
    }
    data.o_ycrb = acc;
    &data.jacobian_com
}

/// Velocity of the centre of mass in the world, `J_com(q) v`, summed column by column
/// (no allocation). Fills `data.jacobian_com` and `data.com` as
/// [`jacobian_center_of_mass`] does.
#[track_caller]
pub fn center_of_mass_velocity(model: &Model, data: &mut Data, q: &[f64], v: &[f64]) -> Vector3<f64> {
    check_len("v", v.len(), model.nv);
    let jc = jacobian_center_of_mass(model, data, q);
    let mut cv = Vector3::zeros();
    for (k, vk) in v.iter().enumerate() {
        cv += jc.column(k) * *vk;
    }
    cv
}

/// Centroidal momentum matrix `A_g(q)` (6 × nv) into `data.centroidal_map`: `A_g v` is the
/// robot's linear momentum and its angular momentum about the centre of mass, in world
/// axes. Also computes the centre of mass.
#[track_caller]
pub fn centroidal_map<'a>(model: &Model, data: &'a mut Data, q: &[f64]) -> &'a Matrix6xX<f64> {
    check_len("q", q.len(), model.nq);
    let mut acc = std::mem::take(&mut data.o_ycrb);
    composite_inertias(model, data, q, &mut acc);
    let com = data.com[0];
    for i in 1..model.njoints() {
        let j = &model.joints[i];
        for k in 0..j.nv() {
            let c = j.idx_v + k;
            let f = acc[i].mul_motion(&column(&data.jacobians, c));
            // Moment about the centre of mass instead of the world origin.
            let n = f.angular - com.cross(&f.linear);
            let mut col = data.centroidal_map.column_mut(c);
            col[0] = f.linear.x;
            col[1] = f.linear.y;
            col[2] = f.linear.z;
            col[3] = n.x;
            col[4] = n.y;
            col[5] = n.z;
        }
    }
    data.o_ycrb = acc;
    &data.centroidal_map
}

/// Centroidal map and centroidal momentum `h_g = A_g(q) v` (into
/// `data.centroidal_momentum`).
#[track_caller]
pub fn centroidal_momentum(model: &Model, data: &mut Data, q: &[f64], v: &[f64]) -> Force {
    check_len("v", v.len(), model.nv);
    centroidal_map(model, data, q);
    let mut h = [0.0; 6];
    for (r, hr) in h.iter_mut().enumerate() {
        *hr = (0..model.nv).map(|c| data.centroidal_map[(r, c)] * v[c]).sum();
    }
    data.centroidal_momentum = Force::new(Vector3::new(h[0], h[1], h[2]), Vector3::new(h[3], h[4], h[5]));
    data.centroidal_momentum
}
