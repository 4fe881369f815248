//! Composite-rigid-body algorithm (Featherstone §6.2) in the world frame, and the
//! quantities that share its composite inertias: centre of mass, its Jacobian and the
//! centroidal momentum matrix (Orin, Goswami & Lee 2013).
//!
//! In the world frame every joint subspace `⁰Sⱼ` is a column of `data.jacobians`, and the
//! composite inertias `⁰Y_c,i = Σ_{k ∈ subtree(i)} ⁰Y_k` add without transforms, so
//! `M[r, c] = ⁰S_rᵀ (⁰Y_c,i ⁰S_c)` for every dof `r` on the support of dof `c` (of joint `i`).

use nalgebra::{DMatrix, Matrix3xX, Matrix6xX, Vector3};

use crate::data::{Data, check_len};
use crate::model::Model;
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
/// Also fills `data.jacobians`, `data.o_m_i`, and the robot's mass and centre of mass
/// (`data.mass[0]`, `data.com[0]`).
#[track_caller]
pub fn crba<'a>(model: &Model, data: &'a mut Data, q: &[f64]) -> &'a DMatrix<f64> {
    check_len("q", q.len(), model.nq);
    let mut acc = std::mem::take(&mut data.o_ycrb);
    forward_world_inertias(model, data, q, &mut acc);
    for i in (1..model.njoints()).rev() {
        let p = model.joints[i].parent;
        let yi = acc[i];
        acc[p].add_assign(&yi);
    }
    // Small, separate loops: fusing them costs 10–20 % in register spills (measured).
    let nv = model.nv;
    let jac = data.jacobians.as_slice();
    let fcrb = data.f_crb.as_mut_slice();
    for c in 0..nv {
        let s: &[f64; 6] = jac[6 * c..6 * c + 6].try_into().expect("6 rows");
        let f = acc[model.joint_of_dof(c)]
            .mul_motion(&Motion::new(Vector3::new(s[0], s[1], s[2]), Vector3::new(s[3], s[4], s[5])));
        fcrb[6 * c..6 * c + 6].copy_from_slice(&[
            f.linear.x,
            f.linear.y,
            f.linear.z,
            f.angular.x,
            f.angular.y,
            f.angular.z,
        ]);
    }
    // Row r against the contiguous columns of its subtree (Pinocchio's layout):
    // M[r, c] = ⁰S_r · F_c for c in r..r + nv_subtree(r).
    let mm = data.mass_matrix.as_mut_slice();
    for r in 0..nv {
        let s: &[f64; 6] = jac[6 * r..6 * r + 6].try_into().expect("6 rows");
        let end = r + model.nv_subtree(r);
        for (c, f) in fcrb[6 * r..6 * end].chunks_exact(6).enumerate() {
            let c = r + c;
            let mrc = s[0] * f[0] + s[1] * f[1] + s[2] * f[2] + s[3] * f[3] + s[4] * f[4] + s[5] * f[5];
            // Column-major storage: (r, c) lives at r + c·nv.
            mm[r + c * nv] = mrc;
            mm[c + r * nv] = mrc;
        }
    }
    data.mass[0] = acc[0].mass;
    data.com[0] = if acc[0].mass > 0.0 { acc[0].first_moment / acc[0].mass } else { Vector3::zeros() };
    data.o_ycrb = acc;
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
