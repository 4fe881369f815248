//! Sparse `M = U D Uᵀ` factorisation of the joint-space inertia matrix (Featherstone 2005,
//! "Efficient factorization of the joint-space inertia matrix for branched kinematic
//! trees"), exploiting that `M[r, c] ≠ 0` only when one dof supports the other.
//!
//! With joints in depth-first order the subtree of dof `j` is the range
//! `j..j + nv_subtree(j)`, so for `j` from last to first:
//! `D_j = M_jj − Σ_{k ∈ sub(j)} U_jk² D_k`, and for every ancestor `i` of `j`
//! `U_ij = (M_ij − Σ_{k ∈ sub(j)} U_ik D_k U_jk) / D_j`.

use nalgebra::DMatrix;

use crate::data::{Data, check_len};
use crate::model::Model;

/// Factorises `data.mass_matrix` (from [`crate::crba`]) as `U D Uᵀ`.
/// Returns `false` if a pivot is not positive (the matrix is not positive definite).
pub fn cholesky_decompose(model: &Model, data: &mut Data) -> bool {
    let nv = model.nv;
    let m = &data.mass_matrix;
    let u = &mut data.chol_u;
    let d = &mut data.chol_d;
    let tmp = &mut data.chol_tmp;
    let mut ok = true;
    for j in (0..nv).rev() {
        let end = j + model.nv_subtree(j);
        let mut dj = m[(j, j)];
        for k in (j + 1)..end {
            tmp[k] = u[(j, k)] * d[k];
            dj -= u[(j, k)] * tmp[k];
        }
        if dj.is_nan() || dj <= 0.0 {
            ok = false;
        }
        d[j] = dj;
        u[(j, j)] = 1.0;
        let mut i = model.parent_dof(j);
        while let Some(r) = i {
            let mut s = m[(r, j)];
            for k in (j + 1)..end {
                s -= u[(r, k)] * tmp[k];
            }
            u[(r, j)] = s / dj;
            i = model.parent_dof(r);
        }
    }
    data.chol_ready = ok;
    ok
}

/// Solves `M x = b` in place (`b` becomes `x`) with the factor of [`cholesky_decompose`].
///
/// # Panics
/// If the factor is not ready (call [`crate::crba`] then [`cholesky_decompose`] first) or
/// `b` has the wrong length.
#[track_caller]
pub fn mass_matrix_solve(model: &Model, data: &Data, b: &mut [f64]) {
    check_len("b", b.len(), model.nv);
    assert!(data.chol_ready, "mass_matrix_solve: call crba and cholesky_decompose first");
    let nv = model.nv;
    let u = &data.chol_u;
    // U z = b (U unit upper triangular, row k reaches only its subtree).
    for k in (0..nv).rev() {
        let end = k + model.nv_subtree(k);
        let mut s = b[k];
        for m in (k + 1)..end {
            s -= u[(k, m)] * b[m];
        }
        b[k] = s;
    }
    for k in 0..nv {
        b[k] /= data.chol_d[k];
    }
    // Uᵀ x = z (column k reaches only the ancestors of k).
    for k in 0..nv {
        let mut s = b[k];
        let mut i = model.parent_dof(k);
        while let Some(r) = i {
            s -= u[(r, k)] * b[r];
            i = model.parent_dof(r);
        }
        b[k] = s;
    }
}

/// `M⁻¹` into `out` (nv × nv), column by column, with the factor of [`cholesky_decompose`].
#[track_caller]
pub fn mass_matrix_inverse(model: &Model, data: &Data, out: &mut DMatrix<f64>) {
    assert!(
        out.nrows() == model.nv && out.ncols() == model.nv,
        "mass_matrix_inverse: output is {}×{}, expected {}×{}",
        out.nrows(),
        out.ncols(),
        model.nv,
        model.nv
    );
    out.fill(0.0);
    for c in 0..model.nv {
        out[(c, c)] = 1.0;
        let mut col = out.column_mut(c);
        mass_matrix_solve(model, data, col.as_mut_slice());
    }
}
