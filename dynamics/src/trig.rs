//! Sines and cosines for the joint transforms.
//!
//! Every revolute joint needs `(sin q, cos q)` in every algorithm. `f64::sin_cos` calls libm
//! (14–20 ns per angle on the benchmark machine); [`JointTrig::fill`] computes the table for
//! a whole configuration in one branch-free loop that the compiler vectorises (about 6 ns per
//! angle), and [`sin_cos`] is the same arithmetic for one angle.
//!
//! Method: `x = n·π/2 + r` with `n` the nearest integer to `2x/π` and `|r| ≤ π/4`, reduced
//! in three steps by three 33-bit parts of `π/2` (Cody & Waite), so that every `n·part` is
//! exact; then the minimax polynomials of fdlibm's `__kernel_sin` and `__kernel_cos` on
//! `[−π/4, π/4]` (the coefficients are the published figures, the code is ours); the
//! quadrant `n mod 4` picks and signs the pair. Results are within 2 ulp of libm's (the
//! tests sweep the joint range and the neighbourhoods of the multiples of π/2). Angles
//! beyond `|x| > 10⁵` and non-finite ones go to the standard library, which reduces them
//! exactly.

/// Largest `|x|` reduced here; `n < 2¹⁷` keeps every `n·part` product exact.
const FAST_LIMIT: f64 = 1.0e5;
const TWO_OVER_PI: f64 = std::f64::consts::FRAC_2_PI;
const ROUNDING_SHIFT: f64 = 6_755_399_441_055_744.0; // 1.5 · 2⁵²
/// `π/2` as the sum of three parts of 33 significant bits each (fdlibm's `pio2_1..3`).
const PIO2_1: f64 = 1.570_796_326_734_125_614_17;
const PIO2_2: f64 = 6.077_100_506_303_965_976_6e-11;
const PIO2_3: f64 = 2.022_266_248_711_166_455_8e-21;

// Minimax coefficients on [−π/4, π/4] (fdlibm, k_sin.c and k_cos.c).
const S1: f64 = -1.666_666_666_666_663_243_48e-1;
const S2: f64 = 8.333_333_333_322_489_461_24e-3;
const S3: f64 = -1.984_126_982_985_794_931_34e-4;
const S4: f64 = 2.755_731_370_707_006_767_89e-6;
const S5: f64 = -2.505_076_025_340_686_341_95e-8;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;
const C1: f64 = 4.166_666_666_666_660_190_37e-2;
const C2: f64 = -1.388_888_888_887_410_957_49e-3;
const C3: f64 = 2.480_158_728_947_672_941_78e-5;
const C4: f64 = -2.755_731_435_139_066_330_35e-7;
const C5: f64 = 2.087_572_321_298_174_827_9e-9;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// `(sin x, cos x)`.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if in_fast_range(x) { reduced(x) } else { x.sin_cos() }
}

/// `|x| ≤ FAST_LIMIT` (false for NaN).
#[inline(always)]
fn in_fast_range(x: f64) -> bool {
    x.abs() <= FAST_LIMIT
}

/// The sines and cosines of every generalized coordinate, computed together so that the
/// loop vectorises (two lanes on baseline x86-64: about 6 ns per angle against 14 ns for
/// `f64::sin_cos` on the benchmark machine), for the algorithms to read per joint.
#[derive(Clone, Debug)]
pub(crate) struct JointTrig {
    sin: Vec<f64>,
    cos: Vec<f64>,
}

impl JointTrig {
    pub(crate) fn new(nq: usize) -> Self {
        Self { sin: vec![0.0; nq], cos: vec![0.0; nq] }
    }

    /// Fills the table from `q` (length `nq`; quaternion entries are computed too, unused).
    #[inline]
    pub(crate) fn fill(&mut self, q: &[f64]) {
        for ((&x, s), c) in q.iter().zip(&mut self.sin).zip(&mut self.cos) {
            (*s, *c) = reduced(x);
        }
        // Angles too large for the fast reduction (or not finite) are rare: redo them.
        if !q.iter().all(|&x| in_fast_range(x)) {
            for (k, &x) in q.iter().enumerate() {
                if !in_fast_range(x) {
                    (self.sin[k], self.cos[k]) = x.sin_cos();
                }
            }
        }
    }

    /// `(sin q_k, cos q_k)` from the last [`JointTrig::fill`].
    #[inline(always)]
    pub(crate) fn get(&self, k: usize) -> (f64, f64) {
        (self.sin[k], self.cos[k])
    }
}

/// The fast path for `|x| ≤ FAST_LIMIT`, without branches (random angles would
/// mispredict them, and a branch-free body vectorises).
#[inline(always)]
fn reduced(x: f64) -> (f64, f64) {
    // Round to nearest by the 1.5·2⁵² shift (`f64::round` is a libm call on baseline
    // x86-64); the low bits of the shifted value's representation are then those of `n`.
    let shifted = x * TWO_OVER_PI + ROUNDING_SHIFT;
    let n = shifted - ROUNDING_SHIFT;
    // `n·PIO2_k` is exact for |n| < 2²⁰; angles within ±π/4 have n = 0 and stay exact.
    let r = ((x - n * PIO2_1) - n * PIO2_2) - n * PIO2_3;
    let (s, c) = kernel(r);
    // Quadrant `n mod 4`: odd quadrants swap the pair, quadrants 2 and 3 negate the sine,
    // quadrants 1 and 2 the cosine.
    let q = shifted.to_bits();
    let swap = (q & 1).wrapping_neg();
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let (first, second) = ((sb & !swap) | (cb & swap), (cb & !swap) | (sb & swap));
    let sign = |q: u64| (q & 2) << 62;
    (f64::from_bits(first ^ sign(q)), f64::from_bits(second ^ sign(q.wrapping_add(1))))
}

/// Both polynomials on `|r| ≤ π/4` (a little beyond is harmless).
#[inline(always)]
fn kernel(r: f64) -> (f64, f64) {
    let z = r * r;
    let sin_tail = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
    let sin = r + z * r * (S1 + z * sin_tail);
    // cos r = 1 − z/2 + z² p(z): the sum of the small terms is formed first and the rounding
    // of `1 − z/2` is added back, which keeps the result within an ulp for |r| ≤ π/4.
    let p = z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let cos = w + (((1.0 - w) - hz) + p);
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two finite doubles of the same sign
    /// region (measured through their ordered integer representations).
    fn ulps(a: f64, b: f64) -> u64 {
        let key = |x: f64| {
            let bits = x.to_bits() as i64;
            if bits < 0 { i64::MIN - bits } else { bits }
        };
        key(a).abs_diff(key(b))
    }

    /// Error relative to libm in ulps of the larger of the value and a floor, so that values
    /// crossing zero (where ulps explode) are judged by their absolute error.
    fn close(fast: f64, reference: f64) -> bool {
        ulps(fast, reference) <= 2 || (fast - reference).abs() <= 2.0 * f64::EPSILON * 1e-3
    }

    #[test]
    fn matches_libm_across_the_joint_range() {
        let mut x = -40.0;
        while x <= 40.0 {
            let (s, c) = sin_cos(x);
            let (rs, rc) = x.sin_cos();
            assert!(close(s, rs), "sin({x}) = {s}, libm {rs}");
            assert!(close(c, rc), "cos({x}) = {c}, libm {rc}");
            x += 0.000_731;
        }
    }

    #[test]
    fn stays_accurate_near_multiples_of_half_pi_and_far_out() {
        for k in -2000i32..=2000 {
            let centre = f64::from(k) * std::f64::consts::FRAC_PI_2;
            for x in [centre, centre.next_up(), centre.next_down(), centre + 1e-9, centre - 1e-7] {
                let (s, c) = sin_cos(x);
                let (rs, rc) = x.sin_cos();
                // Near a zero of sin or cos the value is ~1e-16 or smaller; compare absolutely.
                assert!((s - rs).abs() <= 2.0 * f64::EPSILON * rs.abs().max(1e-3), "sin({x})");
                assert!((c - rc).abs() <= 2.0 * f64::EPSILON * rc.abs().max(1e-3), "cos({x})");
            }
        }
        for x in [9.9e4, -9.99e4, 1.0e5, 3.0e7, -1e300, 0.0, -0.0, f64::MIN_POSITIVE] {
            let (s, c) = sin_cos(x);
            let (rs, rc) = x.sin_cos();
            assert!((s - rs).abs() <= 1e-15 && (c - rc).abs() <= 1e-15, "x = {x}");
        }
    }

    #[test]
    fn the_joint_table_matches_the_scalar_function_and_handles_large_angles() {
        let q = [0.3, -2.9, 1e6, f64::NAN, 4.0, -1e-20, 7.5, f64::INFINITY, -3.2];
        let mut table = JointTrig::new(q.len());
        table.fill(&q);
        for (k, &x) in q.iter().enumerate() {
            let (s, c) = table.get(k);
            let (rs, rc) = sin_cos(x);
            assert!(s.to_bits() == rs.to_bits() || (s.is_nan() && rs.is_nan()), "sin({x})");
            assert!(c.to_bits() == rc.to_bits() || (c.is_nan() && rc.is_nan()), "cos({x})");
        }
        assert_eq!(table.get(2), 1e6f64.sin_cos());
    }

    #[test]
    fn non_finite_angles_give_nan_like_libm() {
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan(), "x = {x}");
        }
    }
}
