//! Articulated-body algorithm (Featherstone §7.3): forward dynamics
//! `q̈ = M(q)⁻¹ (τ − C(q, q̇) q̇ − g(q))` in O(n).
//!
//! Pass 1 (root to leaves): velocities `vᵢ`, velocity-product accelerations
//! `cᵢ = vᵢ × S q̇ᵢ`, rigid-body inertias `Iᴬᵢ = Iᵢ` and bias forces `pᴬᵢ = vᵢ ×* Iᵢ vᵢ`.
//! Pass 2 (leaves to root): `Uᵢ = Iᴬᵢ Sᵢ`, `Dᵢ = Sᵢᵀ Uᵢ`, `uᵢ = τᵢ − Sᵢᵀ pᴬᵢ`, and the
//! parent receives `Iᵃ = Iᴬ − U D⁻¹ Uᵀ` and `pᵃ = pᴬ + Iᵃ c + U D⁻¹ u`.
//! Pass 3 (root to leaves): `a' = ⁱXₚ aₚ + cᵢ`, `q̈ᵢ = D⁻¹(u − Uᵀ a')`, `aᵢ = a' + S q̈ᵢ`,
//! starting from the upward gravity acceleration of the world.

use nalgebra::{DVector, Matrix6, Vector3, Vector6};

use crate::data::{Data, check_len};
use crate::kinematics::joint_placement;
use crate::model::{JointKind, Model};
use crate::spatial::{Force, Motion};

/// Forward dynamics `q̈ = aba(q, v, τ)` (gravity included); result in `data.ddq`.
/// Also fills `data.li_m_i`, `data.v` and `data.a_gf`.
///
/// For a free-flyer the 6×6 articulated inertia is factorised by Cholesky; a body with no
/// mass behind a joint makes `D = 0` and the result non-finite (the model is singular).
#[track_caller]
pub fn aba<'a>(model: &Model, data: &'a mut Data, q: &[f64], v: &[f64], tau: &[f64]) -> &'a DVector<f64> {
    check_len("q", q.len(), model.nq);
    check_len("v", v.len(), model.nv);
    check_len("tau", tau.len(), model.nv);
    let n = model.njoints();
    data.v[0] = Motion::zero();
    for i in 1..n {
        let j = &model.joints[i];
        let li = joint_placement(j, model.axis_planes[i], q);
        data.li_m_i[i] = li;
        let vj = j.kind.motion(&v[j.idx_v..j.idx_v + j.nv()]);
        let vi = li.act_inv_motion(&data.v[j.parent]) + vj;
        data.v[i] = vi;
        data.c_aba[i] = vi.cross(&vj);
        let y = &model.inertias[i];
        y.write_matrix(&mut data.y_aba[i]);
        data.p_aba[i] = vi.cross_force(&y.mul_motion(&vi));
    }
    for i in (1..n).rev() {
        let j = &model.joints[i];
        let iv = j.idx_v;
        let yi = data.y_aba[i];
        let pi = data.p_aba[i];
        let ci = data.c_aba[i].to_vector();
        let (ya, pa): (Matrix6<f64>, Vector6<f64>) = match j.kind {
            JointKind::Revolute { .. }
            | JointKind::RevoluteUnbounded { .. }
            | JointKind::Prismatic { .. } => {
                let s = j.kind.subspace_column(0).to_vector();
                let u = yi * s;
                let d = s.dot(&u);
                let d_inv = 1.0 / d;
                let uu = tau[iv] - s.dot(&pi.to_vector());
                data.u_aba.set_column(iv, &u);
                data.d_inv[iv] = d_inv;
                data.uu[iv] = uu;
                let ya = yi - u * u.transpose() * d_inv;
                let pa = pi.to_vector() + ya * ci + u * (uu * d_inv);
                (ya, pa)
            }
            JointKind::FreeFlyer => {
                // S = 𝟙₆: nothing of the inertia passes the joint, the applied wrench does.
                let t = Vector6::from_column_slice(&tau[iv..iv + 6]);
                (Matrix6::zeros(), t)
            }
            JointKind::Universe => (yi, pi.to_vector()),
        };
        let p = j.parent;
        if p > 0 {
            let li = data.li_m_i[i];
            if j.kind != JointKind::FreeFlyer {
                data.y_aba[p] += li.act_matrix6(&ya);
            }
            data.p_aba[p] += li.act_force(&Force::from_vector(&pa));
        }
    }
    data.a_gf[0] = Motion::new(-model.gravity, Vector3::zeros());
    for i in 1..n {
        let j = &model.joints[i];
        let iv = j.idx_v;
        let a_prime = data.li_m_i[i].act_inv_motion(&data.a_gf[j.parent]) + data.c_aba[i];
        match j.kind {
            JointKind::Revolute { .. }
            | JointKind::RevoluteUnbounded { .. }
            | JointKind::Prismatic { .. } => {
                let u = data.u_aba.column(iv);
                let qdd = data.d_inv[iv] * (data.uu[iv] - u.dot(&a_prime.to_vector()));
                data.ddq[iv] = qdd;
                data.a_gf[i] = a_prime + j.kind.subspace_column(0).scale(qdd);
            }
            JointKind::FreeFlyer => {
                // Iᴬ a = τ − pᴬ  ⇒  q̈ = a − a'.
                let rhs = Vector6::from_column_slice(&tau[iv..iv + 6]) - data.p_aba[i].to_vector();
                let a = match data.y_aba[i].cholesky() {
                    Some(ch) => ch.solve(&rhs),
                    None => Vector6::repeat(f64::NAN),
                };
                let qdd = a - a_prime.to_vector();
                data.ddq.as_mut_slice()[iv..iv + 6].copy_from_slice(qdd.as_slice());
                data.a_gf[i] = Motion::from_vector(&a);
            }
            JointKind::Universe => data.a_gf[i] = a_prime,
        }
    }
    &data.ddq
}
