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
//! (`H = P + Gᵀ W⁻² G`: diagonal on the states, 3 × 3 blocks per foot on the forces).
//! With `Δy_k = p_{k+1} − P_{k+1} Δx_{k+1}` the backward pass gives, for `P' = P_{k+1}`,
//! `p' = p_{k+1}`, `v' = p' − P' e_k`:
//!
//! ```text
//! Q_uu = H_u,k + B_kᵀ P' B_k = L Lᵀ
//! Δu_k = κ_k − Q_uu⁻¹ B_kᵀ P' A_k Δx_k,   κ_k = Q_uu⁻¹ (a_u,k + B_kᵀ v')
//! P_k  = H_x,k−1 + A_kᵀ P' A_k − (B_kᵀ P' A_k)ᵀ Q_uu⁻¹ (B_kᵀ P' A_k)
//! p_k  = a_x,k−1 + A_kᵀ (v' − P' B_k κ_k)
//! ```
//!
//! and the forward pass `Δx_{k+1} = A_k Δx_k + B_k Δu_k + e_k`.
//!
//! **Structure.** Forces act on the body only through the net wrench: `B_k = B̃_k G_k`
//! with `G_k u = (Σ fᵢ, Σ rᵢ × fᵢ)` (6 × n_u, `rᵢ` the lever from the CoM) and `B̃_k`
//! (12 × 6) `Θ ← R_zᵀ I_w⁻¹ Δt²/2 · τ`, `p ← Δt²/(2m) · f`, `ω ← I_w⁻¹ Δt · τ`,
//! `ṗ ← Δt/m · f`. So with `Z = P' B̃` and `W₆ = Zᵀ A_k` (both 12 × 6),
//! `Q_uu = H_u + Gᵀ (B̃ᵀ Z) G` and `(BᵀP'A)ᵀ Q_uu⁻¹ (BᵀP'A) = W₆ᵀ C W₆` with the 6 × 6
//! `C = G Q_uu⁻¹ Gᵀ = XᵀX`, `X = L⁻¹ Gᵀ`: every product with the 12-dimensional state is
//! six wide whatever the number of feet in stance, which only sizes the small `Q_uu`. The
//! state transition `A_k = I + E_k` has only the blocks `Θ ← ω` (`R_zᵀ Δt`) and `p ← ṗ`
//! (`Δt I`) off the diagonal and is applied as such.
//!
//! The factorisation ([`Riccati::factor`]) depends on the scaling only and is done once
//! per interior-point iteration; each right-hand side then costs one [`Riccati::solve`].

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::robot::MAX_CONTACTS;

/// Reduced state dimension (gravity is a constant, not a decision variable).
pub(crate) const NS: usize = 12;
/// Largest number of force variables per stage.
pub(crate) const MAX_NU: usize = 3 * MAX_CONTACTS;

pub(crate) type Vec12 = SVector<f64, NS>;
pub(crate) type Mat12 = SMatrix<f64, NS, NS>;
type Vec6 = SVector<f64, 6>;
type Mat6 = SMatrix<f64, 6, 6>;

/// The dynamics of one stage: `x_{k+1} = A_k x_k + B̃_k G_k u_k + c_k`.
#[derive(Clone, Debug)]
pub(crate) struct StageDynamics {
    /// `R_zᵀ Δt`: the `Θ ← ω` block of `A_k`.
    pub rzt_dt: Matrix3<f64>,
    /// `Δt`: the `p ← ṗ` block of `A_k` is `Δt I`.
    pub dt: f64,
    /// `B̃_k`: position and velocity per unit net force (scalars), attitude and angular
    /// velocity per unit net moment (3 × 3).
    pub force_p: f64,
    pub force_v: f64,
    pub moment_theta: Matrix3<f64>,
    pub moment_omega: Matrix3<f64>,
    /// Feet in stance and their levers `rᵢ` (CoM to foot); `planar`: lateral forces do
    /// not act.
    pub feet: usize,
    pub lever: [Vector3<f64>; MAX_CONTACTS],
    pub planar: bool,
}

impl StageDynamics {
    pub(crate) fn new() -> Self {
        StageDynamics {
            rzt_dt: Matrix3::zeros(),
            dt: 0.0,
            force_p: 0.0,
            force_v: 0.0,
            moment_theta: Matrix3::zeros(),
            moment_omega: Matrix3::zeros(),
            feet: 0,
            lever: [Vector3::zeros(); MAX_CONTACTS],
            planar: false,
        }
    }

    /// Number of force variables.
    #[inline]
    pub(crate) fn nu(&self) -> usize {
        3 * self.feet
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

    /// `Π`: the identity, or `diag(1, 0, 1)` for the planar variant (lateral forces do
    /// not act).
    #[inline]
    fn projection(&self) -> Matrix3<f64> {
        Matrix3::from_diagonal(&Vector3::new(1.0, if self.planar { 0.0 } else { 1.0 }, 1.0))
    }

    /// The net wrench `G u`.
    #[inline]
    pub(crate) fn wrench(&self, u: &[f64]) -> Vec6 {
        let (mut f, mut m) = (Vector3::zeros(), Vector3::zeros());
        for i in 0..self.feet {
            let mut fi = Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]);
            if self.planar {
                fi.y = 0.0;
            }
            f += fi;
            m += self.lever[i].cross(&fi);
        }
        Vec6::new(f.x, f.y, f.z, m.x, m.y, m.z)
    }

    /// `out = Gᵀ w`: per foot `F − r × T`.
    #[inline]
    fn wrench_t(&self, w: &Vec6, out: &mut [f64]) {
        let (f, t) = (Vector3::new(w[0], w[1], w[2]), Vector3::new(w[3], w[4], w[5]));
        for i in 0..self.feet {
            let g = f - self.lever[i].cross(&t);
            out[3 * i] = g.x;
            out[3 * i + 1] = if self.planar { 0.0 } else { g.y };
            out[3 * i + 2] = g.z;
        }
    }

    /// `B̃ w`.
    #[inline]
    fn btilde_mul(&self, w: &Vec6) -> Vec12 {
        let t = Vector3::new(w[3], w[4], w[5]);
        let th = self.moment_theta * t;
        let om = self.moment_omega * t;
        let mut r = Vec12::zeros();
        for i in 0..3 {
            r[i] = th[i];
            r[3 + i] = self.force_p * w[i];
            r[6 + i] = om[i];
            r[9 + i] = self.force_v * w[i];
        }
        r
    }

    /// `B̃ᵀ v`.
    #[inline]
    fn btilde_t_mul(&self, v: &Vec12) -> Vec6 {
        let m =
            self.moment_theta.tr_mul(&v.fixed_rows::<3>(0)) + self.moment_omega.tr_mul(&v.fixed_rows::<3>(6));
        Vec6::new(
            self.force_p * v[3] + self.force_v * v[9],
            self.force_p * v[4] + self.force_v * v[10],
            self.force_p * v[5] + self.force_v * v[11],
            m.x,
            m.y,
            m.z,
        )
    }

    /// `B u`.
    #[inline]
    pub(crate) fn b_mul(&self, u: &[f64]) -> Vec12 {
        self.btilde_mul(&self.wrench(u))
    }

    /// `out = Bᵀ v`.
    #[inline]
    pub(crate) fn bt_mul(&self, v: &Vec12, out: &mut [f64]) {
        self.wrench_t(&self.btilde_t_mul(v), out);
    }

    /// `P B̃` for symmetric `P`: the six columns.
    fn p_btilde(&self, p: &Mat12) -> [Vec12; 6] {
        let mut z = [Vec12::zeros(); 6];
        for c in 0..3 {
            z[c] = p.column(3 + c) * self.force_p + p.column(9 + c) * self.force_v;
            let mut acc = Vec12::zeros();
            for r in 0..3 {
                acc += p.column(r) * self.moment_theta[(r, c)] + p.column(6 + r) * self.moment_omega[(r, c)];
            }
            z[3 + c] = acc;
        }
        z
    }

    /// `M A`: columns `ω += M[:, Θ] R_zᵀΔt`, columns `ṗ += Δt M[:, p]`.
    fn mul_a(&self, m: &Mat12) -> Mat12 {
        let mut t = *m;
        for c in 0..3 {
            let mut acc = m.column(6 + c).into_owned();
            for r in 0..3 {
                acc += m.column(r) * self.rzt_dt[(r, c)];
            }
            t.set_column(6 + c, &acc);
            t.set_column(9 + c, &(m.column(9 + c) + m.column(3 + c) * self.dt));
        }
        t
    }

    /// `Aᵀ P A` for symmetric `P`: `((P A)ᵀ) A`.
    fn at_p_a(&self, p: &Mat12) -> Mat12 {
        self.mul_a(&self.mul_a(p).transpose())
    }
}

/// Off-diagonal blocks of a block lower triangle over up to `MAX_CONTACTS` feet.
const MAX_TRI: usize = MAX_CONTACTS * (MAX_CONTACTS - 1) / 2;

/// Index of block `(a, b)`, `a > b`, in a packed block lower triangle.
#[inline]
fn tri(a: usize, b: usize) -> usize {
    a * (a - 1) / 2 + b
}

type Mat3x6 = SMatrix<f64, 3, 6>;

/// One stage's factors. `Q_uu` is a matrix of 3 × 3 blocks, one per pair of feet in stance,
/// factored by block Cholesky.
#[derive(Clone, Debug)]
struct StageFactor {
    /// `P_{k+1}`.
    p_next: Mat12,
    /// `L`: the off-diagonal blocks `L_ab` (`a > b`, packed) and the inverses `L_aa⁻¹` of
    /// the diagonal ones (lower triangular).
    l_off: [Matrix3<f64>; MAX_TRI],
    l_inv: [Matrix3<f64>; MAX_CONTACTS],
    /// `K = Q_uu⁻¹ Gᵀ`, one 3 × 6 block per foot: the forward pass's `Δu = κ − K W₆ Δx`.
    k_gain: [Mat3x6; MAX_CONTACTS],
    /// `Z = P_{k+1} B̃_k` and `W₆ = Zᵀ A_k` (as columns: `Aᵀ Z`).
    z: [Vec12; 6],
    w6: [Vec12; 6],
    /// `κ_k` of the current solve.
    kappa: [f64; MAX_NU],
    /// `p_{k+1}` of the current solve.
    p_vec: Vec12,
}

impl StageFactor {
    /// `b ← Q_uu⁻¹ b` for the `feet` blocks of `b`.
    fn solve_quu(&self, feet: usize, b: &mut [f64]) {
        let v = |b: &[f64], a: usize| Vector3::new(b[3 * a], b[3 * a + 1], b[3 * a + 2]);
        let mut y = [Vector3::zeros(); MAX_CONTACTS];
        for a in 0..feet {
            let mut r = v(b, a);
            for c in 0..a {
                r -= self.l_off[tri(a, c)] * y[c];
            }
            y[a] = self.l_inv[a] * r;
        }
        for a in (0..feet).rev() {
            let mut r = y[a];
            for c in a + 1..feet {
                r -= self.l_off[tri(c, a)].tr_mul(&y[c]);
            }
            y[a] = self.l_inv[a].tr_mul(&r);
            b[3 * a..3 * a + 3].copy_from_slice(y[a].as_slice());
        }
    }
}

/// The Riccati factorisation and solves for a horizon of up to `n` stages, allocated once.
#[derive(Clone, Debug)]
pub(crate) struct Riccati {
    stages: Vec<StageFactor>,
    /// Per-stage scratch: `S G` per foot (top and bottom 3 × 3), and `X = L⁻¹ Gᵀ` blocks.
    t_top: [Matrix3<f64>; MAX_CONTACTS],
    t_bottom: [Matrix3<f64>; MAX_CONTACTS],
    x: [Mat3x6; MAX_CONTACTS],
}

/// `Q_uu` was not positive definite (non-finite or non-positive pivot).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct NotPositiveDefinite;

impl Riccati {
    pub(crate) fn new(n: usize) -> Self {
        let f = StageFactor {
            p_next: Mat12::zeros(),
            l_off: [Matrix3::zeros(); MAX_TRI],
            l_inv: [Matrix3::zeros(); MAX_CONTACTS],
            k_gain: [Mat3x6::zeros(); MAX_CONTACTS],
            z: [Vec12::zeros(); 6],
            w6: [Vec12::zeros(); 6],
            kappa: [0.0; MAX_NU],
            p_vec: Vec12::zeros(),
        };
        Riccati {
            stages: vec![f; n],
            t_top: [Matrix3::zeros(); MAX_CONTACTS],
            t_bottom: [Matrix3::zeros(); MAX_CONTACTS],
            x: [Mat3x6::zeros(); MAX_CONTACTS],
        }
    }

    /// Factors the system for stage dynamics `dyn_`, state Hessians `hx[k]` (diagonal, of
    /// `x_{k+1}`) and force Hessians, one 3 × 3 block per foot in stance, stage after stage
    /// (stage `k`'s from `hu_start[k]`).
    pub(crate) fn factor(
        &mut self,
        dyn_: &[StageDynamics],
        hx: &[Vec12],
        hu: &[Matrix3<f64>],
        hu_start: &[usize],
    ) -> Result<(), NotPositiveDefinite> {
        let n = dyn_.len();
        let mut p = Mat12::from_diagonal(&hx[n - 1]);
        for k in (0..n).rev() {
            let d = &dyn_[k];
            let f = &mut self.stages[k];
            f.p_next = p;
            let feet = d.feet;
            f.z = d.p_btilde(&p);
            // S = B̃ᵀ Z (6 × 6) in 3 × 3 blocks.
            let mut s = Mat6::zeros();
            for (j, zj) in f.z.iter().enumerate() {
                s.set_column(j, &d.btilde_t_mul(zj));
            }
            let s_ff: Matrix3<f64> = s.fixed_view::<3, 3>(0, 0).into_owned();
            let s_fm: Matrix3<f64> = s.fixed_view::<3, 3>(0, 3).into_owned();
            let s_mf: Matrix3<f64> = s.fixed_view::<3, 3>(3, 0).into_owned();
            let s_mm: Matrix3<f64> = s.fixed_view::<3, 3>(3, 3).into_owned();
            // Foot a: G_a = [Π; [r_a]× Π] (Π drops the lateral force in the planar
            // variant), T_a = S G_a.
            let proj = d.projection();
            let (t_top, t_bottom, x) = (&mut self.t_top, &mut self.t_bottom, &mut self.x);
            for a in 0..feet {
                let rp = d.lever[a].cross_matrix() * proj;
                t_top[a] = s_ff * proj + s_fm * rp;
                t_bottom[a] = s_mf * proj + s_mm * rp;
            }
            // Block Cholesky of Q_uu = H_u + Gᵀ S G: Q_ab = Π (T_b,top + [r_a]×ᵀ T_b,bottom).
            let q_block =
                |a: usize, b: usize| proj * (t_top[b] + d.lever[a].cross_matrix().tr_mul(&t_bottom[b]));
            for a in 0..feet {
                for b in 0..a {
                    let mut m = q_block(a, b);
                    for c in 0..b {
                        m -= f.l_off[tri(a, c)] * f.l_off[tri(b, c)].transpose();
                    }
                    f.l_off[tri(a, b)] = m * f.l_inv[b].transpose();
                }
                let mut m = q_block(a, a) + hu[hu_start[k] + a];
                for c in 0..a {
                    let l = &f.l_off[tri(a, c)];
                    m -= l * l.transpose();
                }
                f.l_inv[a] = lower_cholesky_inverse(&m)?;
            }
            if k == 0 {
                break;
            }
            for j in 0..6 {
                f.w6[j] = d.at_mul(&f.z[j]);
            }
            // X = L⁻¹ Gᵀ (block rows 3 × 6), C = G Q_uu⁻¹ Gᵀ = XᵀX, K = L⁻ᵀ X.
            let mut c = Mat6::zeros();
            for a in 0..feet {
                let mut g_t = Mat3x6::zeros();
                g_t.fixed_view_mut::<3, 3>(0, 0).copy_from(&proj);
                g_t.fixed_view_mut::<3, 3>(0, 3).copy_from(&(proj * d.lever[a].cross_matrix().transpose()));
                for b in 0..a {
                    g_t -= f.l_off[tri(a, b)] * x[b];
                }
                x[a] = f.l_inv[a] * g_t;
                c += x[a].tr_mul(&x[a]);
            }
            for a in (0..feet).rev() {
                let mut r = x[a];
                for b in a + 1..feet {
                    r -= f.l_off[tri(b, a)].tr_mul(&f.k_gain[b]);
                }
                f.k_gain[a] = f.l_inv[a].tr_mul(&r);
            }
            // P_k = H_x + Aᵀ P' A − W₆ᵀ C W₆, on the lower triangle, then mirrored.
            let mut pk = d.at_p_a(&p);
            for i in 0..6 {
                let mut t = Vec12::zeros();
                for j in 0..6 {
                    t += f.w6[j] * c[(i, j)];
                }
                pk.syger(-1.0, &f.w6[i], &t, 1.0);
            }
            for i in 0..NS {
                pk[(i, i)] += hx[k - 1][i];
            }
            pk.fill_upper_triangle_with_lower_triangle();
            p = pk;
        }
        Ok(())
    }

    /// Solves for the right-hand sides `ax[k]` (of `x_{k+1}`), `au` (the forces, stage
    /// after stage: stage `k`'s from `u_start[k]`) and `e[k]`, writing `Δx_{k+1}`, `Δu`
    /// (same layout) and `Δy_k` into `dx`, `du`, `dy`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn solve(
        &mut self,
        dyn_: &[StageDynamics],
        ax: &[Vec12],
        au: &[f64],
        u_start: &[usize],
        e: &[Vec12],
        dx: &mut [Vec12],
        du: &mut [f64],
        dy: &mut [Vec12],
    ) {
        let n = dyn_.len();
        let mut p = ax[n - 1];
        for k in (0..n).rev() {
            let d = &dyn_[k];
            let f = &mut self.stages[k];
            f.p_vec = p;
            let v = p - sym_mul(&f.p_next, &e[k]);
            let nu = d.nu();
            d.bt_mul(&v, &mut f.kappa);
            let a = &au[u_start[k]..u_start[k] + nu];
            for (kj, aj) in f.kappa[..nu].iter_mut().zip(a) {
                *kj += aj;
            }
            let mut kappa = f.kappa;
            f.solve_quu(d.feet, &mut kappa[..nu]);
            f.kappa = kappa;
            if k > 0 {
                // w = v' − P' B κ = v' − Z (G κ).
                let wr = d.wrench(&f.kappa[..nu]);
                let mut w = v;
                for j in 0..6 {
                    w -= f.z[j] * wr[j];
                }
                p = ax[k - 1] + d.at_mul(&w);
            }
        }
        let mut x = Vec12::zeros();
        for k in 0..n {
            let d = &dyn_[k];
            let f = &self.stages[k];
            let nu = d.nu();
            let u = &mut du[u_start[k]..u_start[k] + nu];
            u.copy_from_slice(&f.kappa[..nu]);
            if k > 0 {
                // Δu = κ − K (W₆ Δx).
                let t = Vec6::from_fn(|j, _| f.w6[j].dot(&x));
                for a in 0..d.feet {
                    let ka = f.k_gain[a] * t;
                    for i in 0..3 {
                        u[3 * a + i] -= ka[i];
                    }
                }
            }
            let next = d.a_mul(&x) + d.b_mul(u) + e[k];
            dx[k] = next;
            dy[k] = f.p_vec - sym_mul(&f.p_next, &next);
            x = next;
        }
    }
}

/// The inverse of the lower Cholesky factor of the symmetric 3 × 3 `m` (its lower
/// triangle read).
fn lower_cholesky_inverse(m: &Matrix3<f64>) -> Result<Matrix3<f64>, NotPositiveDefinite> {
    let pivot = |d: f64| if d > 0.0 && d.is_finite() { Ok(d.sqrt()) } else { Err(NotPositiveDefinite) };
    let l00 = pivot(m[(0, 0)])?;
    let l10 = m[(1, 0)] / l00;
    let l20 = m[(2, 0)] / l00;
    let l11 = pivot(m[(1, 1)] - l10 * l10)?;
    let l21 = (m[(2, 1)] - l20 * l10) / l11;
    let l22 = pivot(m[(2, 2)] - l20 * l20 - l21 * l21)?;
    // Inverse of [l00 0 0; l10 l11 0; l20 l21 l22].
    let (i00, i11, i22) = (1.0 / l00, 1.0 / l11, 1.0 / l22);
    let i10 = -l10 * i00 * i11;
    let i21 = -l21 * i11 * i22;
    let i20 = -(l20 * i00 + l21 * i10) * i22;
    Ok(Matrix3::new(i00, 0.0, 0.0, i10, i11, 0.0, i20, i21, i22))
}

/// `P v` for a 12 × 12 matrix, column by column (inlined; the generic product is not).
#[inline(always)]
fn sym_mul(p: &Mat12, v: &Vec12) -> Vec12 {
    let mut r = Vec12::zeros();
    for c in 0..NS {
        r += p.column(c) * v[c];
    }
    r
}
