//! The two cones of the MPC's interior point ([`super::ipm`]): the nonnegative orthant
//! (force limits, pyramid faces, hard bounds) and the three-dimensional second-order cone
//! `K = {(t, v) ∈ ℝ × ℝ²: t ≥ ‖v‖}` (exact friction cones), with their Nesterov–Todd
//! scalings, Jordan products and step lengths.
//!
//! Notation of Vandenberghe's "The CVXOPT linear and quadratic cone program solvers"
//! (2010), §§ 2–4: for `s, z ∈ int K` the NT scaling is the symmetric `W` with
//! `W z = W⁻¹ s = λ`; the Jordan product is `u ∘ v = (uᵀv, u₀ v̄ + v₀ ū)` with identity
//! `e = (1, 0, 0)`, and `J = diag(1, −1, −1)`. For the orthant all of this is elementwise:
//! `W = diag(√(s/z))`, `λ = √(s z)`, `u ∘ v = u v`, `e = 1`.

/// `J v` for the second-order cone.
#[inline]
fn jv(v: &[f64; 3]) -> [f64; 3] {
    [v[0], -v[1], -v[2]]
}

/// `vᵀ J v`.
#[inline]
fn jnorm2(v: &[f64; 3]) -> f64 {
    v[0] * v[0] - v[1] * v[1] - v[2] * v[2]
}

#[inline]
fn dot3(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Distance of `v` to the boundary of `K` along `e`: `v₀ − ‖v̄‖` (its smaller eigenvalue).
#[inline]
pub(crate) fn soc_min_eig(v: &[f64; 3]) -> f64 {
    v[0] - v[1].hypot(v[2])
}

/// Nesterov–Todd scaling of one second-order cone: `W = η W̄` with
/// `W̄ = [w₀, w̄ᵀ; w̄, I + w̄ w̄ᵀ/(1 + w₀)]` (a hyperbolic reflection, `wᵀJw = 1`), built from
/// the normalised points `s̃ = s/√(sᵀJs)`, `z̃ = z/√(zᵀJz)` as
/// `w = (s̃ + J z̃) / (2γ)`, `γ = √((1 + s̃ᵀz̃)/2)`, `η = (sᵀJs / zᵀJz)^{1/4}`
/// (CVXOPT notes, § 4.2). `W̄⁻¹ = J W̄ J`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SocScaling {
    eta: f64,
    w: [f64; 3],
    /// `W⁻¹` as a matrix (applied many times per iteration).
    winv: [[f64; 3]; 3],
}

impl SocScaling {
    /// The scaling for `s, z ∈ int K`; `None` when either is not strictly inside.
    pub(crate) fn new(s: &[f64; 3], z: &[f64; 3]) -> Option<Self> {
        let (ss, zz) = (jnorm2(s), jnorm2(z));
        if !(ss > 0.0 && zz > 0.0 && s[0] > 0.0 && z[0] > 0.0) {
            return None;
        }
        let (ns, nz) = (ss.sqrt(), zz.sqrt());
        let st = [s[0] / ns, s[1] / ns, s[2] / ns];
        let zt = [z[0] / nz, z[1] / nz, z[2] / nz];
        let gamma = ((1.0 + dot3(&st, &zt)) * 0.5).sqrt();
        let jz = jv(&zt);
        let w = [
            (st[0] + jz[0]) / (2.0 * gamma),
            (st[1] + jz[1]) / (2.0 * gamma),
            (st[2] + jz[2]) / (2.0 * gamma),
        ];
        Some(SocScaling::from_parts((ss / zz).sqrt().sqrt(), w))
    }

    fn from_parts(eta: f64, w: [f64; 3]) -> Self {
        let mut s = SocScaling { eta, w, winv: [[0.0; 3]; 3] };
        for c in 0..3 {
            let mut e = [0.0; 3];
            e[c] = 1.0;
            let col = jv(&s.wbar(&jv(&e)));
            for r in 0..3 {
                s.winv[r][c] = col[r] / eta;
            }
        }
        s
    }

    /// `W = I`.
    pub(crate) fn identity() -> Self {
        SocScaling::from_parts(1.0, [1.0, 0.0, 0.0])
    }

    /// `W̄ v`.
    #[inline]
    fn wbar(&self, v: &[f64; 3]) -> [f64; 3] {
        let w = &self.w;
        let wv = w[1] * v[1] + w[2] * v[2];
        let c = v[0] + wv / (1.0 + w[0]);
        [w[0] * v[0] + wv, v[1] + c * w[1], v[2] + c * w[2]]
    }

    /// `W v`.
    #[inline]
    pub(crate) fn mul(&self, v: &[f64; 3]) -> [f64; 3] {
        let r = self.wbar(v);
        [self.eta * r[0], self.eta * r[1], self.eta * r[2]]
    }

    /// `W⁻¹ v = J W̄ J v / η`.
    #[inline]
    pub(crate) fn div(&self, v: &[f64; 3]) -> [f64; 3] {
        let m = &self.winv;
        [dot3(&m[0], v), dot3(&m[1], v), dot3(&m[2], v)]
    }

    /// `W⁻² = J W̄² J / η²` as a symmetric matrix, with `W̄² = 2 w wᵀ − J`.
    pub(crate) fn inv_square(&self) -> [[f64; 3]; 3] {
        let w = jv(&self.w);
        let e = 1.0 / (self.eta * self.eta);
        let mut m = [[0.0; 3]; 3];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = 2.0 * w[r] * w[c];
            }
        }
        // −J J J = −J.
        m[0][0] -= 1.0;
        m[1][1] += 1.0;
        m[2][2] += 1.0;
        for row in &mut m {
            for v in row {
                *v *= e;
            }
        }
        m
    }
}

/// Jordan product `u ∘ v`.
#[inline]
pub(crate) fn soc_product(u: &[f64; 3], v: &[f64; 3]) -> [f64; 3] {
    [dot3(u, v), u[0] * v[1] + v[0] * u[1], u[0] * v[2] + v[0] * u[2]]
}

/// `u \ d`: the `x` with `u ∘ x = d` (`u ∈ int K`), i.e. the inverse of the arrow matrix
/// `[u₀, ūᵀ; ū, u₀ I]`: `x₀ = (u₀ d₀ − ūᵀd̄)/ρ`, `x̄ = (d̄ − x₀ ū)/u₀`, `ρ = uᵀJu`.
#[inline]
pub(crate) fn soc_divide(u: &[f64; 3], d: &[f64; 3]) -> [f64; 3] {
    let rho = jnorm2(u);
    let x0 = (u[0] * d[0] - u[1] * d[1] - u[2] * d[2]) / rho;
    [x0, (d[1] - x0 * u[1]) / u[0], (d[2] - x0 * u[2]) / u[0]]
}

/// Largest `α ≥ 0` with `v + α d ∈ K` for `v ∈ int K` (`f64::INFINITY` when the ray stays
/// inside). The boundary is the smallest positive root of
/// `f(α) = (v + αd)ᵀ J (v + αd) = a α² + 2bα + c` (`c > 0`): before it `f > 0` and the
/// ray cannot reach `t < 0` without crossing `f = 0` first.
pub(crate) fn soc_step(v: &[f64; 3], d: &[f64; 3]) -> f64 {
    let a = jnorm2(d);
    let b = v[0] * d[0] - v[1] * d[1] - v[2] * d[2];
    let c = jnorm2(v);
    let disc = b * b - a * c;
    if disc < 0.0 {
        return f64::INFINITY;
    }
    // Roots of a α² + 2 b α + c in the stable form q/a and c/q, q = −(b + sign(b)√disc).
    let q = -(b + disc.sqrt().copysign(b));
    let mut best = f64::INFINITY;
    for r in [q / a, c / q] {
        if r.is_finite() && r > 0.0 {
            best = best.min(r);
        }
    }
    best
}

/// Largest `α ≥ 0` with `v + α d ≥ 0` for `v > 0`.
#[inline]
pub(crate) fn nonneg_step(v: f64, d: f64) -> f64 {
    if d < 0.0 { -v / d } else { f64::INFINITY }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64; 3], b: &[f64; 3], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol * (1.0 + y.abs()))
    }

    const POINTS: [([f64; 3], [f64; 3]); 4] = [
        ([2.0, 0.3, -0.5], [1.0, -0.2, 0.4]),
        ([1.0, 0.0, 0.0], [3.0, 2.9, 0.1]),
        ([5.0, 4.99, 0.0], [0.01, 0.0, 0.001]),
        ([0.3, -0.1, 0.25], [7.0, 1.0, -6.5]),
    ];

    #[test]
    fn nt_scaling_maps_z_and_s_to_the_same_point() {
        for (s, z) in POINTS {
            let w = SocScaling::new(&s, &z).unwrap();
            let lz = w.mul(&z);
            let ls = w.div(&s);
            assert!(close(&lz, &ls, 1e-12), "{lz:?} vs {ls:?}");
            // W⁻¹ W v = v, and W⁻² is the inverse of W W.
            let v = [0.7, -1.3, 0.2];
            assert!(close(&w.div(&w.mul(&v)), &v, 1e-12));
            let m = w.inv_square();
            let ww = w.mul(&w.mul(&v));
            let back = [dot3(&m[0], &ww), dot3(&m[1], &ww), dot3(&m[2], &ww)];
            assert!(close(&back, &v, 1e-10), "{back:?}");
            // λ lies inside the cone.
            assert!(soc_min_eig(&lz) > 0.0);
        }
    }

    #[test]
    fn jordan_division_inverts_the_product() {
        let u = [2.0, 0.5, -1.0];
        let x = [0.3, -4.0, 2.0];
        let d = soc_product(&u, &x);
        assert!(close(&soc_divide(&u, &d), &x, 1e-12));
        // e is the identity.
        assert_eq!(soc_product(&[1.0, 0.0, 0.0], &x), x);
    }

    #[test]
    fn step_reaches_the_boundary_exactly() {
        let cases = [
            ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 1.0),  // sideways: ‖v̄‖ = 1 at α = 1
            ([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], 1.0), // through the apex
            ([2.0, 1.0, 0.0], [1.0, 0.0, 0.0], f64::INFINITY), // up the axis
            ([1.0, 0.5, 0.0], [1.0, 1.0, 0.0], f64::INFINITY), // parallel to a ray of ∂K
        ];
        for (v, d, want) in cases {
            let a = soc_step(&v, &d);
            if want.is_infinite() {
                assert!(a.is_infinite(), "{v:?} + α {d:?}: {a}");
            } else {
                assert!((a - want).abs() < 1e-12, "{v:?} + α {d:?}: {a}");
            }
        }
        // A random direction: at the step the point is on the boundary.
        let (v, d) = ([3.0, 1.0, -1.0], [-2.0, 4.0, 1.0]);
        let a = soc_step(&v, &d);
        let p = [v[0] + a * d[0], v[1] + a * d[1], v[2] + a * d[2]];
        assert!(soc_min_eig(&p).abs() < 1e-12 && p[0] > 0.0, "{p:?}");
        assert_eq!(nonneg_step(2.0, -4.0), 0.5);
        assert!(nonneg_step(2.0, 1.0).is_infinite());
    }
}
