//! The interior point's linear system, solved stage by stage by a Riccati recursion.
//!
//! Each Newton step of [`super::ipm`] solves, after the cone rows are eliminated, the
//! equality-constrained linear–quadratic problem
//!
//! ```text
//! H_x,k Δx_{k+1} − A_{k+1}ᵀ Δy_{k+1} + Δy_k = a_x,k     (k = 0 … N−1, no A_N term)
//! H_u,k Δu_k     − B_kᵀ Δy_k                = a_u,k
//! Δx_{k+1} − A_k Δx_k − B_k Δu_k           = e_k       (Δx₀ = 0)
//! ```
//!
//! (`H = P + Gᵀ W⁻² G`: diagonal on the states, 3 × 3 blocks per contact on the forces).
//! With `Δy_k = p_{k+1} − P_{k+1} Δx_{k+1}` the backward pass gives, for `P' = P_{k+1}`,
//! `p' = p_{k+1}`, `v' = p' − P' e_k`:
//!
//! ```text
//! Q_uu = H_u,k + B_kᵀ P' B_k = L Lᵀ
//! Δu_k = κ_k − L⁻ᵀ M_k Δx_k,   κ_k = Q_uu⁻¹ (a_u,k + B_kᵀ v'),   M_k = L⁻¹ B_kᵀ P' A_k
//! P_k  = H_x,k−1 + A_kᵀ P' A_k − M_kᵀ M_k
//! p_k  = a_x,k−1 + A_kᵀ (v' − P' B_k κ_k)
//! ```
//!
//! and the forward pass `Δx_{k+1} = A_k Δx_k + B_k Δu_k + e_k`. The factorisation
//! ([`Riccati::factor`]: `L_k`, `P' B_k`, `M_k`, `P_k`) depends on the scaling only and is
//! done once per interior-point iteration; each right-hand side then costs one
//! [`Riccati::solve`]. Cost per stage `O(n_x² n_u + n_x n_u² + n_u³)` with `n_x = 12`,
//! `n_u = 3 × (feet in stance)`; the state transition `A_k = I + E_k` has only the blocks
//! `Θ ← ω` (`R_zᵀ Δt`) and `p ← ṗ` (`Δt I`) off the diagonal and is applied as such.

use nalgebra::{Matrix3, SMatrix, SVector};

use crate::robot::MAX_CONTACTS;

/// Reduced state dimension (gravity is a constant, not a decision variable).
pub(crate) const NS: usize = 12;
/// Largest number of force variables per stage.
pub(crate) const MAX_NU: usize = 3 * MAX_CONTACTS;

pub(crate) type Vec12 = SVector<f64, NS>;
pub(crate) type Mat12 = SMatrix<f64, NS, NS>;

/// The dynamics of one stage: `x_{k+1} = A_k x_k + B_k u_k + c_k`.
#[derive(Clone, Debug)]
pub(crate) struct StageDynamics {
    /// `R_zᵀ Δt`: the `Θ ← ω` block of `A_k`.
    pub rzt_dt: Matrix3<f64>,
    /// `Δt`: the `p ← ṗ` block of `A_k` is `Δt I`.
    pub dt: f64,
    /// Number of force variables `n_u` (three per foot in stance).
    pub nu: usize,
    /// Columns of `B_k` (the first `nu`).
    pub b: [Vec12; MAX_NU],
}

impl StageDynamics {
    pub(crate) fn new() -> Self {
        StageDynamics { rzt_dt: Matrix3::zeros(), dt: 0.0, nu: 0, b: [Vec12::zeros(); MAX_NU] }
    }

    /// `A v`.
    #[inline]
    pub(crate) fn a_mul(&self, v: &Vec12) -> Vec12 {
        let mut r = *v;
        let w = self.rzt_dt * v.fixed_rows::<3>(6);
        for i in 0..3 {
            r[i] += w[i];
            r[3 + i] += self.dt * v[9 + i];
        }
        r
    }

    /// `Aᵀ v`.
    #[inline]
    pub(crate) fn at_mul(&self, v: &Vec12) -> Vec12 {
        let mut r = *v;
        let w = self.rzt_dt.tr_mul(&v.fixed_rows::<3>(0));
        for i in 0..3 {
            r[6 + i] += w[i];
            r[9 + i] += self.dt * v[3 + i];
        }
        r
    }

    /// `Aᵀ P A` for symmetric `P`.
    fn at_p_a(&self, p: &Mat12) -> Mat12 {
        // T = P A: columns ω += P[:, Θ] R_zᵀΔt, columns ṗ += Δt P[:, p].
        let mut t = *p;
        for c in 0..3 {
            for r in 0..3 {
                let a = self.rzt_dt[(r, c)];
                for i in 0..NS {
                    t[(i, 6 + c)] += p[(i, r)] * a;
                }
            }
            for i in 0..NS {
                t[(i, 9 + c)] += self.dt * p[(i, 3 + c)];
            }
        }
        // Aᵀ T: rows ω += (R_zᵀΔt)ᵀ T[Θ, :], rows ṗ += Δt T[p, :].
        let mut out = t;
        for j in 0..NS {
            for c in 0..3 {
                let mut acc = 0.0;
                for r in 0..3 {
                    acc += self.rzt_dt[(r, c)] * t[(r, j)];
                }
                out[(6 + c, j)] += acc;
                out[(9 + c, j)] += self.dt * t[(3 + c, j)];
            }
        }
        out
    }
}

/// One stage's factors.
#[derive(Clone, Debug)]
struct StageFactor {
    /// `P_{k+1}`.
    p_next: Mat12,
    /// Lower Cholesky factor of `Q_uu`, row-major with stride `MAX_NU`.
    l: [f64; MAX_NU * MAX_NU],
    /// Columns of `P_{k+1} B_k`.
    pb: [Vec12; MAX_NU],
    /// Rows of `M_k = L⁻¹ B_kᵀ P_{k+1} A_k` (stage 0 has none: `Δx₀ = 0`).
    m: [Vec12; MAX_NU],
    /// `κ_k` of the current solve.
    kappa: [f64; MAX_NU],
    /// `p_{k+1}` of the current solve.
    p_vec: Vec12,
}

/// The Riccati factorisation and solves for a horizon of up to `n` stages, allocated once.
#[derive(Clone, Debug)]
pub(crate) struct Riccati {
    stages: Vec<StageFactor>,
}

/// `Q_uu` was not positive definite (non-finite or non-positive pivot).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct NotPositiveDefinite;

impl Riccati {
    pub(crate) fn new(n: usize) -> Self {
        let f = StageFactor {
            p_next: Mat12::zeros(),
            l: [0.0; MAX_NU * MAX_NU],
            pb: [Vec12::zeros(); MAX_NU],
            m: [Vec12::zeros(); MAX_NU],
            kappa: [0.0; MAX_NU],
            p_vec: Vec12::zeros(),
        };
        Riccati { stages: vec![f; n] }
    }

    /// Factors the system for stage dynamics `dyn_`, state Hessians `hx[k]` (diagonal, of
    /// `x_{k+1}`) and force Hessians `hu(k, i, j)` (entry `(i, j)` of stage `k`'s block,
    /// zero outside a foot's 3 × 3 block, which `hu` is only asked for).
    pub(crate) fn factor(
        &mut self,
        dyn_: &[StageDynamics],
        hx: &[Vec12],
        hu: impl Fn(usize, usize, usize) -> f64,
    ) -> Result<(), NotPositiveDefinite> {
        let n = dyn_.len();
        let mut p = Mat12::from_diagonal(&hx[n - 1]);
        for k in (0..n).rev() {
            let d = &dyn_[k];
            let f = &mut self.stages[k];
            f.p_next = p;
            let nu = d.nu;
            for j in 0..nu {
                f.pb[j] = p * d.b[j];
            }
            // Q_uu (lower triangle) and its Cholesky factor, in place.
            for i in 0..nu {
                for j in 0..=i {
                    let same_foot = i / 3 == j / 3;
                    let h = if same_foot { hu(k, i, j) } else { 0.0 };
                    f.l[i * MAX_NU + j] = h + d.b[i].dot(&f.pb[j]);
                }
            }
            cholesky(&mut f.l, nu)?;
            if k == 0 {
                break;
            }
            // M = L⁻¹ (P' B)ᵀ A: row j is L⁻¹ applied to the rows Aᵀ (P' b_j).
            for j in 0..nu {
                let mut r = d.at_mul(&f.pb[j]);
                for i in 0..j {
                    r -= f.m[i] * f.l[j * MAX_NU + i];
                }
                f.m[j] = r / f.l[j * MAX_NU + j];
            }
            let mut pk = d.at_p_a(&p);
            for j in 0..nu {
                pk.ger(-1.0, &f.m[j], &f.m[j], 1.0);
            }
            for i in 0..NS {
                pk[(i, i)] += hx[k - 1][i];
            }
            p = (pk + pk.transpose()) * 0.5;
        }
        Ok(())
    }

    /// Solves for the right-hand sides `ax[k]` (of `x_{k+1}`), `au(k)` (stage `k`'s forces)
    /// and `e[k]`, writing `Δx_{k+1}`, `Δu_k` and `Δy_k` through `dx`, `du(k)`, `dy`.
    pub(crate) fn solve(
        &mut self,
        dyn_: &[StageDynamics],
        ax: &[Vec12],
        au: impl Fn(usize) -> [f64; MAX_NU],
        e: &[Vec12],
        dx: &mut [Vec12],
        mut du: impl FnMut(usize, &[f64]),
        dy: &mut [Vec12],
    ) {
        let n = dyn_.len();
        let mut p = ax[n - 1];
        for k in (0..n).rev() {
            let d = &dyn_[k];
            let f = &mut self.stages[k];
            f.p_vec = p;
            let v = p - f.p_next * e[k];
            let a = au(k);
            for j in 0..d.nu {
                f.kappa[j] = a[j] + d.b[j].dot(&v);
            }
            chol_solve(&f.l, d.nu, &mut f.kappa);
            if k > 0 {
                let mut w = v;
                for j in 0..d.nu {
                    w -= f.pb[j] * f.kappa[j];
                }
                p = ax[k - 1] + d.at_mul(&w);
            }
        }
        let mut x = Vec12::zeros();
        for k in 0..n {
            let d = &dyn_[k];
            let f = &self.stages[k];
            let nu = d.nu;
            let mut u = [0.0; MAX_NU];
            if k > 0 {
                for j in 0..nu {
                    u[j] = f.m[j].dot(&x);
                }
                // Lᵀ t = M Δx.
                for j in (0..nu).rev() {
                    let mut s = u[j];
                    for i in j + 1..nu {
                        s -= f.l[i * MAX_NU + j] * u[i];
                    }
                    u[j] = s / f.l[j * MAX_NU + j];
                }
            }
            for j in 0..nu {
                u[j] = f.kappa[j] - u[j];
            }
            let mut next = d.a_mul(&x) + e[k];
            for j in 0..nu {
                next += d.b[j] * u[j];
            }
            du(k, &u[..nu]);
            dx[k] = next;
            dy[k] = f.p_vec - f.p_next * next;
            x = next;
        }
    }
}

/// In-place lower Cholesky factor of the `n × n` matrix in the lower triangle of `a`
/// (row-major, stride `MAX_NU`).
fn cholesky(a: &mut [f64; MAX_NU * MAX_NU], n: usize) -> Result<(), NotPositiveDefinite> {
    for j in 0..n {
        let mut d = a[j * MAX_NU + j];
        for k in 0..j {
            d -= a[j * MAX_NU + k] * a[j * MAX_NU + k];
        }
        if !(d > 0.0 && d.is_finite()) {
            return Err(NotPositiveDefinite);
        }
        let d = d.sqrt();
        a[j * MAX_NU + j] = d;
        for i in j + 1..n {
            let mut s = a[i * MAX_NU + j];
            for k in 0..j {
                s -= a[i * MAX_NU + k] * a[j * MAX_NU + k];
            }
            a[i * MAX_NU + j] = s / d;
        }
    }
    Ok(())
}

/// Solves `L Lᵀ x = b` in place.
fn chol_solve(l: &[f64; MAX_NU * MAX_NU], n: usize, b: &mut [f64; MAX_NU]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * MAX_NU + k] * b[k];
        }
        b[i] = s / l[i * MAX_NU + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * MAX_NU + i] * b[k];
        }
        b[i] = s / l[i * MAX_NU + i];
    }
}
