//! The structured solver ([`super::MpcSolver::Structured`]): a primal–dual interior point
//! for the MPC's second-order-cone program whose Newton systems are solved stage by stage
//! by a Riccati recursion ([`super::riccati`]).
//!
//! **Problem.** Gravity is constant, so it leaves the state (`x ∈ ℝ¹²`) for the affine term
//! `c_k`; forces are measured in units of the nominal weight `m · 9.81` (better scaled);
//! feet in swing have no variables (the sparse formulation's are zero at its optimum):
//!
//! ```text
//! minimise   ½ vᵀ P v + qᵀ v,     v = (x₁ … x_N, u₀ … u_{N−1})
//! subject to E v = b_E            x_{k+1} − A_k x_k − B_k u_k = c_k   (c₀ includes A₀ x₀)
//!            G v + s = h,  s ∈ K  f_z ≤ f_max, friction cones (or pyramids), hard bounds
//! ```
//!
//! **Algorithm** (the homogeneous self-dual embedding of a conic QP, as in Clarabel:
//! Goulart & Chen 2024, "Clarabel: an interior-point solver for conic programs with
//! quadratic objectives", §§ 2–3; cones and scalings from Vandenberghe 2010, "The CVXOPT
//! linear and quadratic cone program solvers"). Unknowns `(v, y, z, s, τ, κ)`; residuals
//!
//! ```text
//! r_v = P v + Eᵀy + Gᵀz + q τ,   r_y = E v − b_E τ,   r_z = G v + s − h τ,
//! r_τ = qᵀv + b_Eᵀy + hᵀz + κ + vᵀPv/τ,   μ = (sᵀz + τκ)/(ν + 1)
//! ```
//!
//! (`ν`: the cones' degree). Each iteration scales the cones (Nesterov–Todd, `λ = W z =
//! W⁻¹ s`), factors `K = [P Eᵀ Gᵀ; E 0 0; G 0 −W²]` once, solves `K (v₁, y₁, z₁) =
//! (−q, b_E, h)` and two Newton systems — Mehrotra's predictor (`d_s = λ ∘ λ`) and the
//! corrector with centring `σ = (1 − α_aff)³` and second-order term
//! `(W⁻¹Δs_aff) ∘ (W Δz_aff)` — each as `K (v₂, y₂, z₂) = (−d_v, −d_y, −d_z + W(λ \ d_s))`
//! followed by the scalar `Δτ`, and steps 99 % of the way to the cones' boundary.
//! `K` is solved by eliminating the cone rows in the scaled dual `z̃ = W Δz`
//! (`z̃ = W⁻¹(G Δv − r_z)`, [`Kkt`]), which leaves a linear–quadratic control problem
//! with Hessian `P + Gᵀ W⁻² G` — diagonal in the states, 3 × 3 blocks per foot — for the
//! Riccati recursion, refined iteratively once the scalings are ill-conditioned; `Δs`
//! comes from the primal rows `G Δv + Δs = h Δτ − d_z`, which the iterates then satisfy
//! to rounding.
//!
//! **Termination** (on `v̂ = v/τ`, `ŷ, ẑ, ŝ` likewise): solved when the primal and dual
//! residuals, relative to `max(1, ‖b‖ + ‖v̂‖ + ‖ŝ‖)` and `max(1, ‖q‖ + ‖v̂‖ + ‖ẑ‖)`, and
//! the duality gap (absolute, or relative to the objective) are below the tolerance
//! (∞-norms); primal infeasible when `(y, z)` is a certificate: `b_Eᵀy + hᵀz < 0` and
//! `‖Eᵀy + Gᵀz‖ ≤ tol · |b_Eᵀy + hᵀz|`. Dual infeasibility cannot occur: the objective is
//! bounded below by `−Σ x_refᵀ Q x_ref` on any feasible point. A run that stops early
//! (iteration limit, no progress) reports [`QpStatus::AlmostSolved`] when the iterate meets
//! the reduced tolerances (feasibility 1e-4, gap 5e-5, as Clarabel's defaults).

use nalgebra::{Matrix3, Vector3};

use super::cones::{SocScaling, nonneg_step, soc_divide, soc_min_eig, soc_product, soc_step};
use super::problem::{MpcConfig, MpcInput, NX, SrbModel};
use super::riccati::{MAX_NU, NS, Riccati, StageDynamics, Vec12};
use crate::qp::QpStatus;
use crate::robot::MAX_CONTACTS;

/// Reduced tolerances for an early stop (Clarabel's defaults).
const REDUCED_FEAS: f64 = 1e-4;
const REDUCED_GAP: f64 = 5e-5;
/// Tolerance of the infeasibility certificate.
const TOL_INFEAS: f64 = 1e-8;
/// Fraction of the step to the boundary.
const STEP_FRACTION: f64 = 0.99;
/// Smallest step before the solve is declared stuck.
const MIN_STEP: f64 = 1e-10;

/// A nonnegative-cone row: `a · (entries of one state or one foot's force)`.
#[derive(Clone, Copy, Debug)]
enum RowVar {
    /// Entry `i` of `x_{k+1}` (coefficient `a[0]`).
    State { k: usize, i: usize },
    /// The force of foot block `b` (`u[3b..3b + 3]`).
    Force { b: usize },
}

#[derive(Clone, Copy, Debug)]
struct Row {
    var: RowVar,
    a: [f64; 3],
}

/// A point (or direction, or residual) of the embedding: states `x` per stage, forces `u`
/// (three per foot in stance, stage after stage), dynamics multipliers `y`, cone
/// multipliers `z`, slacks `s`, and `τ`, `κ`.
#[derive(Clone, Debug)]
struct Point {
    x: Vec<Vec12>,
    u: Vec<f64>,
    y: Vec<Vec12>,
    z: Vec<f64>,
    s: Vec<f64>,
    /// The scaled cone multipliers `W z` (directions only).
    zt: Vec<f64>,
    tau: f64,
    kappa: f64,
}

impl Point {
    /// `self += a v` on the `x, u, y, z` parts.
    fn add_kkt(&mut self, p: &Problem, a: f64, v: &Point) {
        for k in 0..p.n {
            self.x[k] += v.x[k] * a;
            self.y[k] += v.y[k] * a;
        }
        for (s, o) in self.u[..p.nu()].iter_mut().zip(&v.u) {
            *s += a * o;
        }
        for (s, o) in self.z[..p.m()].iter_mut().zip(&v.z) {
            *s += a * o;
        }
    }

    /// `self += a v` on the `x, u, y, z̃` parts (a scaled KKT solution).
    fn add_scaled(&mut self, p: &Problem, a: f64, v: &Point) {
        for k in 0..p.n {
            self.x[k] += v.x[k] * a;
            self.y[k] += v.y[k] * a;
        }
        for (s, o) in self.u[..p.nu()].iter_mut().zip(&v.u) {
            *s += a * o;
        }
        for (s, o) in self.zt[..p.m()].iter_mut().zip(&v.zt) {
            *s += a * o;
        }
    }

    /// ∞-norm of the `x, u, y` parts.
    fn xuy_norm(&self, p: &Problem) -> f64 {
        inf12(&self.x).max(inf12(&self.y)).max(inf(&self.u[..p.nu()]))
    }

    /// ∞-norm of the `x, u, y, z̃` parts.
    fn scaled_norm(&self, p: &Problem) -> f64 {
        self.xuy_norm(p).max(inf(&self.zt[..p.m()]))
    }

    /// ∞-norm of the `x, u, y, z` parts.
    fn kkt_norm(&self, p: &Problem) -> f64 {
        self.xuy_norm(p).max(inf(&self.z[..p.m()]))
    }

    /// The constant right-hand side `(−q, 0, b_E, h)`.
    fn set_constant(&mut self, p: &Problem) {
        for k in 0..p.n {
            self.x[k] = -p.q[k];
            self.y[k] = p.c[k];
        }
        self.u[..p.nu()].fill(0.0);
        let m = p.m();
        self.z[..m].copy_from_slice(&p.h[..m]);
    }

    fn new(n: usize, nu: usize, m: usize) -> Self {
        Point {
            x: vec![Vec12::zeros(); n],
            u: vec![0.0; nu],
            y: vec![Vec12::zeros(); n],
            z: vec![0.0; m],
            s: vec![0.0; m],
            zt: vec![0.0; m],
            tau: 0.0,
            kappa: 0.0,
        }
    }
}

/// The problem data of one solve.
#[derive(Clone, Debug)]
struct Problem {
    n: usize,
    dynamics: Vec<StageDynamics>,
    /// `c_k`.
    c: Vec<Vec12>,
    /// Diagonal of `P` on a state (`2Q`, every stage) and on a force (`2R`, scaled).
    p_state: Vec12,
    p_force: f64,
    /// `q` on `x_{k+1}` (zero on forces).
    q: Vec<Vec12>,
    /// Feet in stance at stage `k`: contact indices, and the first foot block of the stage.
    stance: Vec<[usize; MAX_CONTACTS]>,
    block_start: Vec<usize>,
    /// `3 × block_start`: where stage `k`'s forces start in `u`.
    u_start: Vec<usize>,
    /// Foot blocks in use (three force variables each).
    n_blocks: usize,
    /// Friction: exact cones (one per foot block) or pyramid rows.
    cone: bool,
    mu: f64,
    /// Nonnegative rows, their count, and `h` (nonnegative rows, then three per cone).
    rows: Vec<Row>,
    n_rows: usize,
    h: Vec<f64>,
}

impl Problem {
    fn n_soc(&self) -> usize {
        if self.cone { self.n_blocks } else { 0 }
    }

    fn m(&self) -> usize {
        self.n_rows + 3 * self.n_soc()
    }

    fn nu(&self) -> usize {
        3 * self.n_blocks
    }

    /// Degree of the cone (nonnegative rows count one each, a second-order cone one).
    fn degree(&self) -> f64 {
        (self.n_rows + self.n_soc()) as f64
    }

    /// `out = G v` on the cone rows.
    fn g_mul(&self, x: &[Vec12], u: &[f64], out: &mut [f64]) {
        for (o, r) in out.iter_mut().zip(&self.rows[..self.n_rows]) {
            *o = match r.var {
                RowVar::State { k, i } => r.a[0] * x[k][i],
                RowVar::Force { b } => r.a[0] * u[3 * b] + r.a[1] * u[3 * b + 1] + r.a[2] * u[3 * b + 2],
            };
        }
        // Cone c on block c: s = (μ f_z, f_x, f_y), i.e. G = −[e_z μ; e_x; e_y].
        for c in 0..self.n_soc() {
            let (o, f) = (self.n_rows + 3 * c, 3 * c);
            out[o] = -self.mu * u[f + 2];
            out[o + 1] = -u[f];
            out[o + 2] = -u[f + 1];
        }
    }

    /// `(gx, gu) += Gᵀ w`.
    fn gt_mul_add(&self, w: &[f64], gx: &mut [Vec12], gu: &mut [f64]) {
        for (wi, r) in w.iter().zip(&self.rows[..self.n_rows]) {
            match r.var {
                RowVar::State { k, i } => gx[k][i] += r.a[0] * wi,
                RowVar::Force { b } => {
                    for d in 0..3 {
                        gu[3 * b + d] += r.a[d] * wi;
                    }
                }
            }
        }
        for c in 0..self.n_soc() {
            let (o, f) = (self.n_rows + 3 * c, 3 * c);
            gu[f + 2] -= self.mu * w[o];
            gu[f] -= w[o + 1];
            gu[f + 1] -= w[o + 2];
        }
    }

    /// `out = E v` (dynamics rows without the `x₀` term).
    fn e_mul(&self, x: &[Vec12], u: &[f64], out: &mut [Vec12]) {
        for k in 0..self.n {
            let d = &self.dynamics[k];
            let mut r = x[k];
            if k > 0 {
                r -= d.a_mul(&x[k - 1]);
            }
            let f0 = 3 * self.block_start[k];
            r -= d.b_mul(&u[f0..f0 + d.nu()]);
            out[k] = r;
        }
    }

    /// `(gx, gu) += Eᵀ y`.
    fn et_mul_add(&self, y: &[Vec12], gx: &mut [Vec12], gu: &mut [f64]) {
        for k in 0..self.n {
            let d = &self.dynamics[k];
            gx[k] += y[k];
            if k > 0 {
                gx[k - 1] -= d.at_mul(&y[k]);
            }
            let f0 = 3 * self.block_start[k];
            let mut g = [0.0; MAX_NU];
            d.bt_mul(&y[k], &mut g);
            for (o, gj) in gu[f0..f0 + d.nu()].iter_mut().zip(&g) {
                *o -= gj;
            }
        }
    }

    /// `vᵀ P v`.
    fn quad(&self, x: &[Vec12], u: &[f64]) -> f64 {
        let xs: f64 = x.iter().map(|xk| xk.component_mul(xk).dot(&self.p_state)).sum();
        xs + self.p_force * u[..self.nu()].iter().map(|v| v * v).sum::<f64>()
    }

    /// `qᵀ v`.
    fn q_dot(&self, x: &[Vec12]) -> f64 {
        x.iter().zip(&self.q).map(|(a, b)| a.dot(b)).sum()
    }

    /// `b_Eᵀ y + hᵀ z`.
    fn b_dot(&self, y: &[Vec12], z: &[f64]) -> f64 {
        let e: f64 = y.iter().zip(&self.c).map(|(a, b)| a.dot(b)).sum();
        e + self.h[..self.m()].iter().zip(z).map(|(a, b)| a * b).sum::<f64>()
    }
}

/// Cone scalings and the scaled point `λ`.
#[derive(Clone, Debug)]
struct Scaling {
    /// Nonnegative rows: `W² = s/z`, `W⁻¹ = √(z/s)` and `λ = √(s z)`.
    w2: Vec<f64>,
    w_inv: Vec<f64>,
    lam: Vec<f64>,
    /// Second-order cones.
    soc: Vec<SocScaling>,
    soc_lam: Vec<[f64; 3]>,
}

impl Scaling {
    /// The identity scaling (`W = I`), for the initial point.
    fn identity(&mut self, p: &Problem) {
        self.w2[..p.n_rows].fill(1.0);
        self.w_inv[..p.n_rows].fill(1.0);
        for w in &mut self.soc[..p.n_soc()] {
            *w = SocScaling::identity();
        }
    }

    /// Nesterov–Todd scalings at `(s, z)`; `false` if a point left its cone.
    fn update(&mut self, p: &Problem, s: &[f64], z: &[f64]) -> bool {
        for i in 0..p.n_rows {
            if !(s[i] > 0.0 && z[i] > 0.0) {
                return false;
            }
            self.w2[i] = s[i] / z[i];
            self.w_inv[i] = (z[i] / s[i]).sqrt();
            self.lam[i] = (s[i] * z[i]).sqrt();
        }
        for c in 0..p.n_soc() {
            let o = p.n_rows + 3 * c;
            let (sc, zc) = (cone3(s, o), cone3(z, o));
            let Some(w) = SocScaling::new(&sc, &zc) else { return false };
            self.soc[c] = w;
            self.soc_lam[c] = w.mul(&zc);
        }
        true
    }

    /// `out = W⁻¹ v`.
    fn inv_mul(&self, p: &Problem, v: &[f64], out: &mut [f64]) {
        for i in 0..p.n_rows {
            out[i] = v[i] * self.w_inv[i];
        }
        for c in 0..p.n_soc() {
            let o = p.n_rows + 3 * c;
            let r = self.soc[c].div(&cone3(v, o));
            out[o..o + 3].copy_from_slice(&r);
        }
    }

    /// `out = W² v`.
    #[cfg(test)]
    fn square_mul(&self, p: &Problem, v: &[f64], out: &mut [f64]) {
        for i in 0..p.n_rows {
            out[i] = v[i] * self.w2[i];
        }
        for c in 0..p.n_soc() {
            let o = p.n_rows + 3 * c;
            let r = self.soc[c].mul(&self.soc[c].mul(&cone3(v, o)));
            out[o..o + 3].copy_from_slice(&r);
        }
    }

    /// `out = W (λ \ d)`.
    fn scaled_divide(&self, p: &Problem, d: &[f64], out: &mut [f64]) {
        for i in 0..p.n_rows {
            out[i] = self.w2[i].sqrt() * d[i] / self.lam[i];
        }
        for c in 0..p.n_soc() {
            let o = p.n_rows + 3 * c;
            let r = self.soc[c].mul(&soc_divide(&self.soc_lam[c], &cone3(d, o)));
            out[o..o + 3].copy_from_slice(&r);
        }
    }
}

#[inline]
fn cone3(v: &[f64], o: usize) -> [f64; 3] {
    [v[o], v[o + 1], v[o + 2]]
}

/// Refinement steps at most per solve of `K`, and the relative residual that ends them.
const MAX_REFINE: usize = 3;
const REFINE_TOL: f64 = 1e-14;

/// Whether a solve measures its residual: always (the first solve with new factors), or
/// only if the first solve with these factors needed refinement (a residual costs about a
/// solve, and whether refinement pays depends on the factors' conditioning, not on the
/// right-hand side).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Refine {
    Probe,
    IfNeeded,
}

/// The Newton matrix `K = [P Eᵀ Gᵀ; E 0 0; G 0 −W²]`, solved in the scaled dual
/// `z̃ = W Δz`, i.e. as `K̃ = [P Eᵀ (W⁻¹G)ᵀ; E 0 0; W⁻¹G 0 −I]` with the cone rows'
/// right-hand side `W⁻¹ r_z` (CVXOPT's form). Near the end of a solve a saturated friction
/// cone has `w₀ ≈ 10⁴`: `W²` then has condition number `(2w₀)⁴ ≈ 10¹⁸` and any route that
/// composes `W²` with `W⁻²` (the unscaled z rows, their residual) loses every digit,
/// while `W⁻¹` alone has `(2w₀)² ≈ 10⁹`. Holds the Riccati factorisation of
/// `P + Gᵀ W⁻² G` and scratch.
#[derive(Clone, Debug)]
struct Kkt {
    riccati: Riccati,
    /// Hessian blocks: state diagonals per stage, 3 × 3 per foot block.
    hx: Vec<Vec12>,
    hu: Vec<Matrix3<f64>>,
    /// The reduced right-hand side `r_v + Gᵀ W⁻¹ r̃`.
    reduced_x: Vec<Vec12>,
    reduced_u: Vec<f64>,
    /// Whether the probing solve with the current factors needed refinement.
    needs_refinement: bool,
    /// The scaled cone rows' right-hand side `r̃ = W⁻¹ r_z`, and cone-sized scratch.
    rt: Vec<f64>,
    w: Vec<f64>,
    gv: Vec<f64>,
}

impl Kkt {
    fn new(n: usize, nu: usize, m: usize) -> Self {
        Kkt {
            riccati: Riccati::new(n),
            hx: vec![Vec12::zeros(); n],
            hu: vec![Matrix3::zeros(); nu / 3],
            reduced_x: vec![Vec12::zeros(); n],
            reduced_u: vec![0.0; nu],
            needs_refinement: true,
            rt: vec![0.0; m],
            w: vec![0.0; m],
            gv: vec![0.0; m],
        }
    }

    /// Factors `K` at scaling `sc`: `H = P + Gᵀ W⁻² G`, then the Riccati recursion.
    fn factor(&mut self, p: &Problem, sc: &Scaling) -> bool {
        for h in &mut self.hx {
            *h = p.p_state;
        }
        for b in &mut self.hu[..p.n_blocks] {
            *b = Matrix3::from_diagonal_element(p.p_force);
        }
        for (r, w2) in p.rows[..p.n_rows].iter().zip(&sc.w2) {
            let d = 1.0 / w2;
            match r.var {
                RowVar::State { k, i } => self.hx[k][i] += d * r.a[0] * r.a[0],
                RowVar::Force { b } => {
                    for i in 0..3 {
                        for j in 0..3 {
                            self.hu[b][(i, j)] += d * r.a[i] * r.a[j];
                        }
                    }
                }
            }
        }
        // Mᵀ W⁻² M with M (f_x, f_y, f_z) = (μ f_z, f_x, f_y): force x ↔ row 1, y ↔ row 2,
        // z ↔ μ · row 0.
        let map = [(1, 1.0), (2, 1.0), (0, p.mu)];
        for c in 0..p.n_soc() {
            let v = sc.soc[c].inv_square();
            let h = &mut self.hu[c];
            for (i, &(ri, fi)) in map.iter().enumerate() {
                for (j, &(rj, fj)) in map.iter().enumerate() {
                    h[(i, j)] += fi * fj * v[ri][rj];
                }
            }
        }
        self.riccati.factor(&p.dynamics, &self.hx, &self.hu, &p.block_start).is_ok()
    }

    /// `out = K̃⁻¹ (src.x, src.u, src.y, rt)` (scaled dual into `out.zt`) by elimination of
    /// the cone rows, `z̃ = W⁻¹G Δv − r̃`, and one Riccati solve.
    fn solve_once(&mut self, p: &Problem, sc: &Scaling, src: &Point, rt: &[f64], out: &mut Point) {
        let m = p.m();
        // Reduced right-hand side r_v + Gᵀ W⁻¹ r̃.
        sc.inv_mul(p, &rt[..m], &mut self.w[..m]);
        self.reduced_x.copy_from_slice(&src.x);
        self.reduced_u[..p.nu()].copy_from_slice(&src.u[..p.nu()]);
        p.gt_mul_add(&self.w[..m], &mut self.reduced_x, &mut self.reduced_u);
        self.riccati.solve(
            &p.dynamics,
            &self.reduced_x,
            &self.reduced_u,
            &p.u_start,
            &src.y,
            &mut out.x,
            &mut out.u,
            &mut out.y,
        );
        // z̃ = W⁻¹ G Δv − r̃.
        p.g_mul(&out.x, &out.u, &mut self.gv[..m]);
        sc.inv_mul(p, &self.gv[..m], &mut out.zt[..m]);
        for (d, r) in out.zt[..m].iter_mut().zip(&rt[..m]) {
            *d -= r;
        }
    }

    /// `resid = (rhs.x, rhs.u, rhs.y, r̃) − K̃ out`; returns its ∞-norm.
    fn residual(&mut self, p: &Problem, sc: &Scaling, rhs: &Point, out: &Point, resid: &mut Point) -> f64 {
        let (m, nu) = (p.m(), p.nu());
        // K̃ out: (P v + Eᵀy + Gᵀ W⁻¹ z̃, E v, W⁻¹ G v − z̃).
        for k in 0..p.n {
            resid.x[k] = out.x[k].component_mul(&p.p_state);
        }
        for j in 0..nu {
            resid.u[j] = p.p_force * out.u[j];
        }
        p.et_mul_add(&out.y, &mut resid.x, &mut resid.u);
        sc.inv_mul(p, &out.zt[..m], &mut self.w[..m]);
        p.gt_mul_add(&self.w[..m], &mut resid.x, &mut resid.u);
        p.e_mul(&out.x, &out.u, &mut resid.y);
        p.g_mul(&out.x, &out.u, &mut self.gv[..m]);
        sc.inv_mul(p, &self.gv[..m], &mut self.w[..m]);
        // rhs − K̃ out.
        for k in 0..p.n {
            resid.x[k] = rhs.x[k] - resid.x[k];
            resid.y[k] = rhs.y[k] - resid.y[k];
        }
        for j in 0..nu {
            resid.u[j] = rhs.u[j] - resid.u[j];
        }
        for i in 0..m {
            resid.zt[i] = self.rt[i] - (self.w[i] - out.zt[i]);
        }
        resid.scaled_norm(p)
    }

    /// `out = K⁻¹ rhs` (`rhs.z` unscaled; `out.z` and `out.zt = W out.z` both written) with
    /// iterative refinement: each step solves `K̃ δ = rhs − K̃ out` with the same factors
    /// and keeps `out + δ` while the residual falls (Clarabel refines likewise). `resid`
    /// and `delta` are scratch.
    #[allow(clippy::too_many_arguments)]
    fn solve(
        &mut self,
        p: &Problem,
        sc: &Scaling,
        refine: Refine,
        rhs: &Point,
        out: &mut Point,
        resid: &mut Point,
        delta: &mut Point,
    ) {
        let m = p.m();
        let mut rt = std::mem::take(&mut self.rt);
        sc.inv_mul(p, &rhs.z[..m], &mut rt[..m]);
        self.solve_once(p, sc, rhs, &rt, out);
        self.rt = rt;
        let scale = 1.0 + rhs.xuy_norm(p).max(inf(&self.rt[..m]));
        if refine == Refine::IfNeeded && !self.needs_refinement {
            sc.inv_mul(p, &out.zt[..m], &mut out.z[..m]);
            return;
        }
        let mut err = self.residual(p, sc, rhs, out, resid);
        if refine == Refine::Probe {
            self.needs_refinement = err > REFINE_TOL * scale;
        }
        for _ in 0..MAX_REFINE {
            if err <= REFINE_TOL * scale {
                break;
            }
            let rt = std::mem::take(&mut resid.zt);
            self.solve_once(p, sc, resid, &rt, delta);
            resid.zt = rt;
            out.add_scaled(p, 1.0, delta);
            let next = self.residual(p, sc, rhs, out, resid);
            if next.is_nan() || next >= err {
                out.add_scaled(p, -1.0, delta);
                break;
            }
            err = next;
        }
        sc.inv_mul(p, &out.zt[..m], &mut out.z[..m]);
    }
}

/// The structured interior point, its problem and workspace allocated once.
#[derive(Clone, Debug)]
pub(crate) struct StructuredMpc {
    prob: Problem,
    force_scale: f64,
    tol: f64,
    max_iter: u32,
    scaling: Scaling,
    kkt: Kkt,
    /// Iterate, residuals, the constant solution, the direction and the predictor.
    pt: Point,
    res: Point,
    sol1: Point,
    dir: Point,
    aff: Point,
    /// Right-hand side of the next Newton solve, and the refinement's scratch.
    rhs: Point,
    resid: Point,
    delta: Point,
    /// `d_s` and `W (λ \ d_s)`.
    ds: Vec<f64>,
    w_ds: Vec<f64>,
    iterations: u32,
    objective: f64,
}

impl StructuredMpc {
    pub(crate) fn new(model: &SrbModel) -> Self {
        let cfg = &model.cfg;
        let (n, nc) = (cfg.horizon, model.nc);
        let blocks = n * nc;
        let nu = 3 * blocks;
        let hard =
            cfg.hard.max_height_drop.map_or(0, |_| n) + cfg.hard.terminal_velocity_band.map_or(0, |_| 4);
        let per_foot = if cfg.friction.is_pyramid() { 5 } else { 1 };
        let n_rows_max = blocks * per_foot + hard;
        let m = n_rows_max + if cfg.friction.is_pyramid() { 0 } else { 3 * blocks };
        let row = Row { var: RowVar::Force { b: 0 }, a: [0.0; 3] };
        let mut p_state = Vec12::zeros();
        for (i, w) in cfg.state_weights.iter().enumerate() {
            p_state[i] = 2.0 * w;
        }
        let force_scale = model.mass * 9.81;
        let prob = Problem {
            n,
            dynamics: vec![StageDynamics::new(); n],
            c: vec![Vec12::zeros(); n],
            p_state,
            p_force: 2.0 * cfg.force_weight * force_scale * force_scale,
            q: vec![Vec12::zeros(); n],
            stance: vec![[0; MAX_CONTACTS]; n],
            block_start: vec![0; n + 1],
            u_start: vec![0; n + 1],
            n_blocks: 0,
            cone: !cfg.friction.is_pyramid(),
            mu: cfg.mu,
            rows: vec![row; n_rows_max],
            n_rows: 0,
            h: vec![0.0; m],
        };
        let point = || Point::new(n, nu, m);
        StructuredMpc {
            prob,
            force_scale,
            tol: cfg.tolerance,
            max_iter: cfg.max_iter,
            scaling: Scaling {
                w2: vec![1.0; m],
                w_inv: vec![1.0; m],
                lam: vec![1.0; m],
                soc: vec![SocScaling::identity(); blocks],
                soc_lam: vec![[1.0, 0.0, 0.0]; blocks],
            },
            kkt: Kkt::new(n, nu, m),
            pt: point(),
            res: point(),
            sol1: point(),
            dir: point(),
            aff: point(),
            rhs: point(),
            resid: point(),
            delta: point(),
            ds: vec![0.0; m],
            w_ds: vec![0.0; m],
            iterations: 0,
            objective: f64::NAN,
        }
    }

    /// Interior-point iterations of the last solve.
    pub(crate) fn iterations(&self) -> u32 {
        self.iterations
    }

    /// `½ vᵀPv + qᵀv` at the last solution (Clarabel's objective of the same problem).
    pub(crate) fn objective(&self) -> f64 {
        self.objective
    }

    /// Builds the problem of `input`.
    fn fill(&mut self, model: &SrbModel, input: &MpcInput) {
        let cfg: &MpcConfig = &model.cfg;
        let p = &mut self.prob;
        let (n, nc, dt) = (cfg.horizon, model.nc, cfg.dt);
        let fs = self.force_scale;
        let g = input.x0[NX - 1];
        let mut gravity = Vec12::zeros();
        gravity[5] = 0.5 * dt * dt * g;
        gravity[11] = dt * g;
        p.n_rows = 0;
        for (ps, w) in p.p_state.iter_mut().zip(&input.state_weights) {
            *ps = 2.0 * w;
        }
        let mut blocks = 0;
        let fmax = cfg.max_normal_force_ratio * model.mass * g.abs() / fs;
        let (force_p, force_v) = (0.5 * dt * dt * fs / model.mass, dt * fs / model.mass);
        for k in 0..n {
            let frame = model.step_frame(input, k);
            let d = &mut p.dynamics[k];
            d.rzt_dt = frame.rzt * dt;
            d.dt = dt;
            d.force_p = force_p;
            d.force_v = force_v;
            d.moment_theta = frame.rzt * frame.iw_inv * (0.5 * dt * dt * fs);
            d.moment_omega = frame.iw_inv * (dt * fs);
            d.planar = cfg.planar;
            p.block_start[k] = blocks;
            let mut feet = 0;
            for i in 0..nc {
                let Some(r) = model.lever(input, &frame, k, i) else { continue };
                p.dynamics[k].lever[feet] = r;
                p.stance[k][feet] = i;
                let b = blocks + feet;
                push_row(p, RowVar::Force { b }, [0.0, 0.0, 1.0], fmax);
                if !p.cone {
                    for a in crate::friction::pyramid_rows(cfg.friction.pyramid_mu(cfg.mu)) {
                        push_row(p, RowVar::Force { b }, a, 0.0);
                    }
                }
                feet += 1;
            }
            p.dynamics[k].feet = feet;
            blocks += feet;
            // q on x_{k+1}: −2 Q x_ref.
            for s in 0..NS {
                p.q[k][s] = -2.0 * input.state_weights[s] * input.x_ref[k][s];
            }
            p.c[k] = gravity;
            if let Some(dz) = cfg.hard.max_height_drop {
                push_row(p, RowVar::State { k, i: 5 }, [-1.0, 0.0, 0.0], -(input.x0[5] - dz));
            }
        }
        p.block_start[n] = blocks;
        p.n_blocks = blocks;
        for (u, b) in p.u_start.iter_mut().zip(&p.block_start) {
            *u = 3 * b;
        }
        if let Some(band) = cfg.hard.terminal_velocity_band {
            let v = &input.x_ref[n - 1];
            for (i, sg) in [(9, 1.0), (9, -1.0), (10, 1.0), (10, -1.0)] {
                push_row(p, RowVar::State { k: n - 1, i }, [sg, 0.0, 0.0], sg * v[i] + band);
            }
        }
        // c₀ = A₀ x₀ + gravity, A₀ at the current yaw.
        let frame = model.step_frame(input, 0);
        let mut a0 = StageDynamics::new();
        a0.rzt_dt = frame.rzt * dt;
        a0.dt = dt;
        p.c[0] += a0.a_mul(&Vec12::from_column_slice(&input.x0[..NS]));
        // The cone rows follow the nonnegative ones, with h = 0.
        let m = p.m();
        p.h[p.n_rows..m].fill(0.0);
    }

    /// Solves the problem of `input`; writes forces (N, world) and predicted states.
    pub(crate) fn solve(
        &mut self,
        model: &SrbModel,
        input: &MpcInput,
        forces: &mut [Vector3<f64>],
        states: &mut [[f64; NX]],
    ) -> QpStatus {
        self.fill(model, input);
        self.objective = f64::NAN;
        let status = self.run();
        if status.is_ok() {
            let p = &self.prob;
            let (pt, tau) = (&self.pt, self.pt.tau);
            let nc = model.nc;
            for k in 0..p.n {
                for (i, s) in states[k].iter_mut().enumerate().take(NS) {
                    *s = pt.x[k][i] / tau;
                }
                states[k][NX - 1] = input.x0[NX - 1];
                for f in &mut forces[k * nc..(k + 1) * nc] {
                    *f = Vector3::zeros();
                }
                let b0 = p.block_start[k];
                for j in 0..p.block_start[k + 1] - b0 {
                    let u = &pt.u[3 * (b0 + j)..3 * (b0 + j) + 3];
                    let mut f = Vector3::new(u[0], u[1], u[2]) * (self.force_scale / tau);
                    if model.cfg.planar {
                        f.y = 0.0;
                    }
                    forces[k * nc + p.stance[k][j]] = f;
                }
            }
            self.objective = 0.5 * p.quad(&pt.x, &pt.u) / (tau * tau) + p.q_dot(&pt.x) / tau;
        }
        status
    }

    /// The interior-point iterations on the filled problem.
    fn run(&mut self) -> QpStatus {
        self.iterations = 0;
        if !self.initial_point() {
            return QpStatus::NumericalError;
        }
        loop {
            let mu = self.residuals();
            match self.check(self.tol, self.tol) {
                Some(s) => return s,
                None if self.iterations >= self.max_iter => return self.stuck(QpStatus::MaxIterations),
                None => {}
            }
            self.iterations += 1;
            if !self.scaling.update(&self.prob, &self.pt.s, &self.pt.z)
                || !self.kkt.factor(&self.prob, &self.scaling)
            {
                return self.stuck(QpStatus::NumericalError);
            }
            // (v₁, y₁, z₁) = K⁻¹ (−q, b_E, h).
            self.rhs.set_constant(&self.prob);
            let (p, sc) = (&self.prob, &self.scaling);
            self.kkt.solve(p, sc, Refine::Probe, &self.rhs, &mut self.sol1, &mut self.resid, &mut self.delta);
            // Predictor: d = (r, λ ∘ λ, τκ).
            self.direction(0.0, mu, false);
            let alpha_aff = self.step_length().min(1.0);
            let sigma = (1.0 - alpha_aff).powi(3);
            std::mem::swap(&mut self.aff, &mut self.dir);
            // Corrector with centring σμ and Mehrotra's second-order term.
            self.direction(sigma, mu, true);
            let alpha = (STEP_FRACTION * self.step_length()).min(1.0);
            if alpha.is_nan() || alpha <= MIN_STEP {
                return self.stuck(QpStatus::InsufficientProgress);
            }
            self.take_step(alpha);
        }
    }

    /// A stop without convergence at the full tolerance: almost solved (or almost
    /// infeasible) if the reduced tolerances hold, else `status`.
    fn stuck(&mut self, status: QpStatus) -> QpStatus {
        self.residuals();
        self.check(REDUCED_FEAS, REDUCED_GAP).map_or(status, almost)
    }

    /// Initial point: `K (v, y, z) = (−q, b_E, h)` with `W = I`, then `s = −z` and `z`
    /// each shifted into their cones (CVXOPT's rule), `τ = κ = 1`.
    fn initial_point(&mut self) -> bool {
        let p = &self.prob;
        self.scaling.identity(p);
        if !self.kkt.factor(p, &self.scaling) {
            return false;
        }
        self.rhs.set_constant(p);
        self.kkt.solve(
            p,
            &self.scaling,
            Refine::Probe,
            &self.rhs,
            &mut self.pt,
            &mut self.resid,
            &mut self.delta,
        );
        let (pt, m) = (&mut self.pt, p.m());
        for i in 0..m {
            pt.s[i] = -pt.z[i];
        }
        shift_into_cone(p, &mut pt.s[..m]);
        shift_into_cone(p, &mut pt.z[..m]);
        pt.tau = 1.0;
        pt.kappa = 1.0;
        pt.kkt_norm(p).is_finite()
    }

    /// Residuals at the current point into `res`; returns `μ`.
    fn residuals(&mut self) -> f64 {
        let (p, pt, r) = (&self.prob, &self.pt, &mut self.res);
        let (m, nu) = (p.m(), p.nu());
        // r_v = P v + Eᵀy + Gᵀz + q τ.
        for k in 0..p.n {
            r.x[k] = pt.x[k].component_mul(&p.p_state) + p.q[k] * pt.tau;
        }
        for j in 0..nu {
            r.u[j] = p.p_force * pt.u[j];
        }
        p.et_mul_add(&pt.y, &mut r.x, &mut r.u);
        p.gt_mul_add(&pt.z[..m], &mut r.x, &mut r.u);
        // r_y = E v − b_E τ.
        p.e_mul(&pt.x, &pt.u, &mut r.y);
        for k in 0..p.n {
            r.y[k] -= p.c[k] * pt.tau;
        }
        // r_z = G v + s − h τ.
        p.g_mul(&pt.x, &pt.u, &mut r.z[..m]);
        for i in 0..m {
            r.z[i] += pt.s[i] - p.h[i] * pt.tau;
        }
        // r_τ = qᵀv + bᵀ(y, z) + κ + vᵀPv/τ.
        r.tau = p.q_dot(&pt.x) + p.b_dot(&pt.y, &pt.z) + pt.kappa + p.quad(&pt.x, &pt.u) / pt.tau;
        let sz: f64 = pt.s[..m].iter().zip(&pt.z[..m]).map(|(a, b)| a * b).sum();
        (sz + pt.tau * pt.kappa) / (p.degree() + 1.0)
    }

    /// Termination test at tolerances `feas` and `gap` on the residuals in `res`.
    fn check(&mut self, feas: f64, gap: f64) -> Option<QpStatus> {
        let btz = self.prob.b_dot(&self.pt.y, &self.pt.z);
        // (The certificate is only consulted once τ < κ.)
        let cert = if btz < 0.0 && self.pt.kappa > self.pt.tau {
            self.certificate_residual()
        } else {
            f64::INFINITY
        };
        let (p, pt, r) = (&self.prob, &self.pt, &self.res);
        let m = p.m();
        let tau = pt.tau;
        let norm_x = inf12(&pt.x).max(inf(&pt.u[..p.nu()])) / tau;
        let norm_s = inf(&pt.s[..m]) / tau;
        let norm_z = inf12(&pt.y).max(inf(&pt.z[..m])) / tau;
        let norm_b = inf12(&p.c).max(inf(&p.h[..m]));
        let norm_q = inf12(&p.q);
        let res_p = inf12(&r.y).max(inf(&r.z[..m])) / tau;
        let res_d = inf12(&r.x).max(inf(&r.u[..p.nu()])) / tau;
        let quad = p.quad(&pt.x, &pt.u) / (tau * tau);
        let pobj = 0.5 * quad + p.q_dot(&pt.x) / tau;
        let dobj = -0.5 * quad - btz / tau;
        if !(pobj.is_finite() && dobj.is_finite() && res_p.is_finite() && res_d.is_finite()) {
            return Some(QpStatus::NumericalError);
        }
        let gap_abs = (pobj - dobj).abs();
        let gap_rel = gap_abs / pobj.abs().min(dobj.abs()).max(1.0);
        // Optimality needs τ ≥ κ: when τ → 0 (an infeasible problem) the residuals relative
        // to ‖v̂‖ = ‖v‖/τ are met for nothing.
        if pt.kappa <= tau
            && res_p < feas * (norm_b + norm_x + norm_s).max(1.0)
            && res_d < feas * (norm_q + norm_x + norm_z).max(1.0)
            && (gap_abs < gap || gap_rel < gap)
        {
            return Some(QpStatus::Solved);
        }
        // Certificate of primal infeasibility: Eᵀy + Gᵀz = 0 with bᵀ(y, z) < 0.
        let nz = inf12(&pt.y).max(inf(&pt.z[..m]));
        if pt.kappa > tau && btz < 0.0 && cert <= TOL_INFEAS.max(feas) * -btz && -btz > TOL_INFEAS * nz {
            return Some(QpStatus::PrimalInfeasible);
        }
        None
    }

    /// `‖Eᵀy + Gᵀz‖∞` at the current point (the predictor's buffers as scratch: it is
    /// recomputed before use).
    fn certificate_residual(&mut self) -> f64 {
        let (p, pt) = (&self.prob, &self.pt);
        let (gx, gu) = (&mut self.aff.x[..p.n], &mut self.aff.u[..p.nu()]);
        gx.fill(Vec12::zeros());
        gu.fill(0.0);
        p.et_mul_add(&pt.y, gx, gu);
        p.gt_mul_add(&pt.z[..p.m()], gx, gu);
        inf12(gx).max(inf(gu))
    }

    /// The Newton direction into `dir`: the predictor (`corrector == false`, `σ = 0`) or
    /// the corrector (using the predictor in `aff`).
    fn direction(&mut self, sigma: f64, mu: f64, corrector: bool) {
        let (p, pt, r, sc) = (&self.prob, &self.pt, &self.res, &self.scaling);
        let m = p.m();
        let (tau, kappa) = (pt.tau, pt.kappa);
        let keep = 1.0 - sigma;
        // d_s = λ ∘ λ (+ (W⁻¹Δs_a) ∘ (WΔz_a) − σμe).
        let ds = &mut self.ds;
        for i in 0..p.n_rows {
            ds[i] = sc.lam[i] * sc.lam[i];
            if corrector {
                ds[i] += self.aff.s[i] * self.aff.z[i] - sigma * mu;
            }
        }
        for c in 0..p.n_soc() {
            let o = p.n_rows + 3 * c;
            let l = sc.soc_lam[c];
            let mut d = soc_product(&l, &l);
            if corrector {
                let ws = sc.soc[c].div(&cone3(&self.aff.s, o));
                let wz = cone3(&self.aff.zt, o);
                let sz = soc_product(&ws, &wz);
                d = [d[0] + sz[0] - sigma * mu, d[1] + sz[1], d[2] + sz[2]];
            }
            ds[o..o + 3].copy_from_slice(&d);
        }
        let d_kappa =
            if corrector { tau * kappa + self.aff.tau * self.aff.kappa - sigma * mu } else { tau * kappa };
        let d_tau = keep * r.tau;
        // (v₂, y₂, z₂) = K⁻¹ (−d_v, −d_y, −d_z + W(λ \ d_s)).
        sc.scaled_divide(p, &ds[..m], &mut self.w_ds[..m]);
        let rhs = &mut self.rhs;
        for k in 0..p.n {
            rhs.x[k] = -r.x[k] * keep;
            rhs.y[k] = -r.y[k] * keep;
        }
        for j in 0..p.nu() {
            rhs.u[j] = -r.u[j] * keep;
        }
        for i in 0..m {
            rhs.z[i] = -r.z[i] * keep + self.w_ds[i];
        }
        let out = &mut self.dir;
        self.kkt.solve(p, sc, Refine::IfNeeded, rhs, out, &mut self.resid, &mut self.delta);
        // Δτ from the τ row, with ξ = v/τ and the denominator in its negative-definite form
        // −(v₁ − ξ)ᵀP(v₁ − ξ) − ‖W z₁‖² − κ/τ.
        let s1 = &self.sol1;
        let mut num = d_kappa / tau - d_tau;
        let mut den = -kappa / tau;
        for k in 0..p.n {
            let xi = pt.x[k] / tau;
            let g = p.q[k] + xi.component_mul(&p.p_state) * 2.0;
            num -= g.dot(&out.x[k]) + p.c[k].dot(&out.y[k]);
            let dv = s1.x[k] - xi;
            den -= dv.component_mul(&dv).dot(&p.p_state);
        }
        for j in 0..p.nu() {
            let xi = pt.u[j] / tau;
            num -= 2.0 * p.p_force * xi * out.u[j];
            let dv = s1.u[j] - xi;
            den -= p.p_force * dv * dv;
        }
        num -= p.h[..m].iter().zip(&out.z[..m]).map(|(a, b)| a * b).sum::<f64>();
        den -= s1.zt[..m].iter().map(|v| v * v).sum::<f64>();
        let dtau = num / den;
        out.add_kkt(p, dtau, s1);
        // Δs from the primal rows, G Δv + Δs − h Δτ = −d_z. (Equal to −W(λ \ d_s) − W²Δz,
        // which composes W² with the W⁻² of the solve: near the cones' boundary their
        // condition number grows like w₀⁴ and that route loses primal feasibility.)
        let gdv = &mut self.kkt.gv;
        p.g_mul(&out.x, &out.u, &mut gdv[..m]);
        for i in 0..m {
            out.s[i] = p.h[i] * dtau - keep * r.z[i] - gdv[i];
        }
        out.tau = dtau;
        out.kappa = -(d_kappa + kappa * dtau) / tau;
    }

    /// Largest step `α` keeping `s`, `z`, `τ`, `κ` in their cones along `dir`.
    fn step_length(&self) -> f64 {
        let (p, pt, d) = (&self.prob, &self.pt, &self.dir);
        let mut a = nonneg_step(pt.tau, d.tau).min(nonneg_step(pt.kappa, d.kappa));
        for i in 0..p.n_rows {
            a = a.min(nonneg_step(pt.s[i], d.s[i])).min(nonneg_step(pt.z[i], d.z[i]));
        }
        for c in 0..p.n_soc() {
            let o = p.n_rows + 3 * c;
            a = a.min(soc_step(&cone3(&pt.s, o), &cone3(&d.s, o)));
            a = a.min(soc_step(&cone3(&pt.z, o), &cone3(&d.z, o)));
        }
        a
    }

    /// `pt += α dir`.
    fn take_step(&mut self, alpha: f64) {
        let (p, pt, d) = (&self.prob, &mut self.pt, &self.dir);
        pt.add_kkt(p, alpha, d);
        let m = p.m();
        for i in 0..m {
            pt.s[i] += alpha * d.s[i];
        }
        pt.tau += alpha * d.tau;
        pt.kappa += alpha * d.kappa;
    }
}

#[inline]
fn inf(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, b| a.max(b.abs()))
}

#[inline]
fn inf12(v: &[Vec12]) -> f64 {
    v.iter().fold(0.0f64, |a, b| a.max(b.amax()))
}

/// Appends a nonnegative row `a · var ≤ h`.
fn push_row(p: &mut Problem, var: RowVar, a: [f64; 3], h: f64) {
    p.rows[p.n_rows] = Row { var, a };
    p.h[p.n_rows] = h;
    p.n_rows += 1;
}

/// Moves `v` into the interior of the cones when it is not clearly inside: `v += (1 − t) e`
/// with `t` the smallest eigenvalue over all cones (CVXOPT's initialisation).
fn shift_into_cone(p: &Problem, v: &mut [f64]) {
    let mut t = f64::INFINITY;
    for &vi in &v[..p.n_rows] {
        t = t.min(vi);
    }
    for c in 0..p.n_soc() {
        t = t.min(soc_min_eig(&cone3(v, p.n_rows + 3 * c)));
    }
    let scale = v.iter().fold(1.0f64, |a, b| a.max(b.abs()));
    if t.is_finite() && t <= 1e-8 * scale {
        let shift = 1.0 - t;
        for vi in &mut v[..p.n_rows] {
            *vi += shift;
        }
        for c in 0..p.n_soc() {
            v[p.n_rows + 3 * c] += shift;
        }
    }
}

/// The status of a stop that met only the reduced tolerances.
fn almost(s: QpStatus) -> QpStatus {
    match s {
        QpStatus::Solved => QpStatus::AlmostSolved,
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::convex_mpc::MpcConfig;
    use nalgebra::{DMatrix, DVector, Matrix3};

    /// A trotting problem: feet 0 and 3 in stance for the first half, 1 and 2 after.
    fn problem(cfg: &MpcConfig) -> (SrbModel, MpcInput) {
        let model = SrbModel {
            cfg: cfg.clone(),
            nc: 4,
            mass: 10.0,
            inertia_body: Matrix3::from_diagonal(&Vector3::new(0.1, 0.3, 0.35)),
        };
        let n = cfg.horizon;
        let feet = [
            Vector3::new(0.2, 0.15, 0.0),
            Vector3::new(0.2, -0.15, 0.0),
            Vector3::new(-0.2, 0.15, 0.0),
            Vector3::new(-0.2, -0.15, 0.0),
        ];
        let mut x0 = [0.0; NX];
        x0[2] = 0.3;
        x0[5] = 0.3;
        x0[6] = 0.1;
        x0[9] = 0.2;
        x0[12] = -9.81;
        let mut x_ref = vec![x0; n];
        for (k, r) in x_ref.iter_mut().enumerate() {
            r[3] = 0.01 * k as f64;
            r[2] = 0.3 + 0.01 * k as f64;
        }
        let contact = (0..n).map(|k| (0..4).map(|i| (k < n / 2) == (i == 0 || i == 3)).collect()).collect();
        let foot = vec![feet.to_vec(); n];
        let state_weights = model.cfg.state_weights;
        (model, MpcInput { x0, x_ref, contact, foot, state_weights })
    }

    /// Flattens the `x, u, y, z` parts of a point.
    fn flat(p: &Problem, v: &Point) -> DVector<f64> {
        let mut out = Vec::new();
        for x in &v.x {
            out.extend(x.iter());
        }
        out.extend(&v.u[..p.nu()]);
        for y in &v.y {
            out.extend(y.iter());
        }
        out.extend(&v.z[..p.m()]);
        DVector::from_vec(out)
    }

    fn unflat(p: &Problem, f: &DVector<f64>, v: &mut Point) {
        let mut it = f.iter().copied();
        for x in &mut v.x {
            for e in x.iter_mut() {
                *e = it.next().unwrap();
            }
        }
        for e in &mut v.u[..p.nu()] {
            *e = it.next().unwrap();
        }
        for y in &mut v.y {
            for e in y.iter_mut() {
                *e = it.next().unwrap();
            }
        }
        for e in &mut v.z[..p.m()] {
            *e = it.next().unwrap();
        }
    }

    /// `out = K v` (the `x, u, y, z` parts), unscaled.
    fn kkt_mul(p: &Problem, sc: &Scaling, v: &Point, out: &mut Point) {
        let m = p.m();
        for k in 0..p.n {
            out.x[k] = v.x[k].component_mul(&p.p_state);
        }
        for j in 0..p.nu() {
            out.u[j] = p.p_force * v.u[j];
        }
        p.et_mul_add(&v.y, &mut out.x, &mut out.u);
        p.gt_mul_add(&v.z[..m], &mut out.x, &mut out.u);
        p.e_mul(&v.x, &v.u, &mut out.y);
        p.g_mul(&v.x, &v.u, &mut out.z[..m]);
        let mut w2z = vec![0.0; m];
        sc.square_mul(p, &v.z[..m], &mut w2z);
        for i in 0..m {
            out.z[i] -= w2z[i];
        }
    }

    #[test]
    fn riccati_solves_the_kkt_system() {
        for cfg in [
            MpcConfig::trot(),
            MpcConfig {
                friction: crate::FrictionModel::InscribedPyramid,
                hard: super::super::HardConstraints {
                    max_height_drop: Some(0.05),
                    terminal_velocity_band: Some(0.2),
                },
                ..MpcConfig::trot()
            },
        ] {
            let (model, input) = problem(&cfg);
            let mut s = StructuredMpc::new(&model);
            s.fill(&model, &input);
            let p = s.prob.clone();
            let m = p.m();
            // A scaling at some interior point.
            let mut sv = vec![0.0; m];
            let mut zv = vec![0.0; m];
            for i in 0..m {
                sv[i] = 1.0 + 0.37 * ((i * 7) % 5) as f64;
                zv[i] = 0.5 + 0.21 * ((i * 3) % 7) as f64;
            }
            for c in 0..p.n_soc() {
                let o = p.n_rows + 3 * c;
                sv[o] = 3.0;
                zv[o] = 2.5;
                sv[o + 1] = 0.4;
                zv[o + 2] = -0.7;
            }
            assert!(s.scaling.update(&p, &sv, &zv));
            assert!(s.kkt.factor(&p, &s.scaling));
            // Dense K from K e_j.
            let dim = flat(&p, &s.pt).len();
            let mut kd = DMatrix::zeros(dim, dim);
            let mut e = Point::new(p.n, p.nu(), m);
            let mut ke = e.clone();
            for j in 0..dim {
                let mut unit = DVector::zeros(dim);
                unit[j] = 1.0;
                unflat(&p, &unit, &mut e);
                kkt_mul(&p, &s.scaling, &e, &mut ke);
                kd.set_column(j, &flat(&p, &ke));
            }
            assert!((&kd - kd.transpose()).amax() < 1e-12, "K is symmetric");
            let rhs = DVector::from_fn(dim, |i, _| ((i * 13) % 11) as f64 - 5.0);
            let want = kd.clone().lu().solve(&rhs).unwrap();
            // Our solve, without and with refinement.
            let mut r = Point::new(p.n, p.nu(), m);
            unflat(&p, &rhs, &mut r);
            let mut out = Point::new(p.n, p.nu(), m);
            s.kkt.solve(&p, &s.scaling, Refine::Probe, &r, &mut out, &mut s.resid, &mut s.delta);
            let got = flat(&p, &out);
            let err = (&got - &want).amax() / want.amax();
            assert!(err < 1e-9, "relative error {err}");
        }
    }
}
