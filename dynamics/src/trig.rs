//! Sine and cosine of many angles at once, for the revolute joints of a configuration.
//!
//! Every algorithm starts by placing each joint, and for a revolute joint that needs
//! `sin q` and `cos q`. One libm `sincos` call per joint was a fifth of CRBA's time on the
//! Minitaur (16 revolute joints). [`sin_cos_many`] evaluates them in one branch-free loop
//! that the compiler vectorises:
//!
//! ```text
//! k = round(x · 2/π),   r = x − k·π/2  ∈ [−π/4, π/4]
//! sin r = r − r³/3! + … + r¹⁷/17!,   cos r = 1 − r²/2! + … + r¹⁶/16!
//! (sin x, cos x) = (sin r, cos r), (cos r, −sin r), (−sin r, −cos r), (−cos r, sin r)
//!                  for k mod 4 = 0, 1, 2, 3
//! ```
//!
//! `k·π/2` is subtracted in three parts (Cody & Waite 1980): the first two hold 32
//! significant bits each, so their products with `k` are exact for `|k| < 2²¹`; the
//! third is the remainder rounded to `f64`. The Taylor series are truncated where the
//! next term is below 10⁻¹⁸ at `|r| = π/4`, and the rounding error of `1 − r²/2` is
//! carried into the small terms, so the results are within 1.05 ulp of libm's (which is
//! itself within about half an ulp of the true value): measured on 600 000 random angles up
//! to `|x| = 10⁶` in `sin_cos_many_matches_libm`. Angles beyond `|x| ≤ 10⁶` (and NaN or ±∞) take libm's
//! path for the whole batch, which returns the same values libm always did.

/// First 32 significant bits of π/2.
const PIO2_HI: f64 = 1.5707963267341256;
/// Next 32 significant bits of π/2.
const PIO2_MID: f64 = 6.077100506303966e-11;
/// π/2 − PIO2_HI − PIO2_MID, rounded.
const PIO2_LO: f64 = 2.0222662487959506e-21;
/// Largest |x| reduced by the vectorised path (`|k| < 2²⁰`).
const MAX_REDUCED: f64 = 1e6;
/// 1.5 · 2⁵²: adding it rounds a value below 2⁵¹ in magnitude to an integer (ties to
/// even), which then sits in the low mantissa bits.
const ROUNDER: f64 = 6755399441055744.0;

// Taylor coefficients (−1)ⁿ/(2n+1)! and (−1)ⁿ/(2n)!.
const S1: f64 = -1.0 / 6.0;
const S2: f64 = 1.0 / 120.0;
const S3: f64 = -1.0 / 5040.0;
const S4: f64 = 1.0 / 362880.0;
const S5: f64 = -1.0 / 39916800.0;
const S6: f64 = 1.0 / 6227020800.0;
const S7: f64 = -1.0 / 1307674368000.0;
const S8: f64 = 1.0 / 355687428096000.0;
const C2: f64 = 1.0 / 24.0;
const C3: f64 = -1.0 / 720.0;
const C4: f64 = 1.0 / 40320.0;
const C5: f64 = -1.0 / 3628800.0;
const C6: f64 = 1.0 / 479001600.0;
const C7: f64 = -1.0 / 87178291200.0;
const C8: f64 = 1.0 / 20922789888000.0;

/// `sin[i], cos[i] = sin x[i], cos x[i]` for every `i` (the three slices have one length).
#[inline]
pub(crate) fn sin_cos_many(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    debug_assert!(x.len() == sin.len() && x.len() == cos.len());
    if !x.iter().all(|x| x.abs() <= MAX_REDUCED) {
        for ((x, s), c) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
            (*s, *c) = x.sin_cos();
        }
        return;
    }
    pulp::Arch::new().dispatch(Reduced { x, sin, cos });
}

/// The vectorised loop as a [`pulp::WithSimd`] operation, so that it is compiled for
/// AVX2 (4 lanes) where the CPU has it and for SSE2 (2 lanes) otherwise; the arithmetic,
/// and so every result, is the same on both paths (no FMA contraction).
struct Reduced<'a> {
    x: &'a [f64],
    sin: &'a mut [f64],
    cos: &'a mut [f64],
}

impl pulp::WithSimd for Reduced<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        for ((&x, s), c) in self.x.iter().zip(self.sin.iter_mut()).zip(self.cos.iter_mut()) {
            (*s, *c) = reduced_sin_cos(x);
        }
    }
}

/// The branch-free kernel of [`sin_cos_many`], valid for `|x| ≤ MAX_REDUCED`.
#[inline(always)]
fn reduced_sin_cos(x: f64) -> (f64, f64) {
    let shifted = x * std::f64::consts::FRAC_2_PI + ROUNDER;
    let k = shifted - ROUNDER;
    let quadrant = shifted.to_bits();
    let r = ((x - k * PIO2_HI) - k * PIO2_MID) - k * PIO2_LO;
    let r2 = r * r;
    let sin_r =
        r + r * r2 * (S1 + r2 * (S2 + r2 * (S3 + r2 * (S4 + r2 * (S5 + r2 * (S6 + r2 * (S7 + r2 * S8)))))));
    // cos r = (1 − r²/2) + r⁴(…), with the rounding error of the subtraction carried into
    // the small term (`1 − w` is exact for r²/2 ≤ 1/2, so `err` is that error exactly).
    let half_r2 = 0.5 * r2;
    let w = 1.0 - half_r2;
    let err = (1.0 - w) - half_r2;
    let tail = r2 * r2 * (C2 + r2 * (C3 + r2 * (C4 + r2 * (C5 + r2 * (C6 + r2 * (C7 + r2 * C8))))));
    let cos_r = w + (tail + err);
    // Odd quadrants swap the two; sin changes sign in quadrants 2 and 3, cos in 1 and 2.
    let swap = 0u64.wrapping_sub(quadrant & 1);
    let (sb, cb) = (sin_r.to_bits(), cos_r.to_bits());
    let sin_sign = (quadrant & 2) << 62;
    let cos_sign = (quadrant.wrapping_add(1) & 2) << 62;
    let sin = f64::from_bits(((sb & !swap) | (cb & swap)) ^ sin_sign);
    let cos = f64::from_bits(((cb & !swap) | (sb & swap)) ^ cos_sign);
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place of the larger of the two magnitudes.
    fn ulps(a: f64, b: f64) -> f64 {
        let scale = a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
        (a - b).abs() / (scale * f64::EPSILON)
    }

    #[test]
    fn split_of_half_pi_is_exact_where_it_must_be() {
        // The first two parts have 32 significant bits, so k · part is exact for |k| < 2²¹.
        assert_eq!(PIO2_HI.to_bits() & ((1 << 21) - 1), 0);
        assert_eq!(PIO2_MID.to_bits() & ((1 << 21) - 1), 0);
        assert_eq!(PIO2_HI + PIO2_MID + PIO2_LO, std::f64::consts::FRAC_PI_2);
    }

    #[test]
    fn sin_cos_many_matches_libm() {
        // SplitMix64 → uniform in [−range, range).
        let mut state = 7u64;
        let mut uniform = |range: f64| {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            let u = ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64;
            range * (2.0 * u - 1.0)
        };
        for &range in &[std::f64::consts::PI, 50.0, MAX_REDUCED] {
            let x: Vec<f64> = (0..200_000).map(|_| uniform(range)).collect();
            let (mut s, mut c) = (vec![0.0; x.len()], vec![0.0; x.len()]);
            sin_cos_many(&x, &mut s, &mut c);
            let mut worst = 0.0f64;
            for i in 0..x.len() {
                let (ls, lc) = x[i].sin_cos();
                worst = worst.max(ulps(s[i], ls)).max(ulps(c[i], lc));
            }
            assert!(worst <= 1.5, "|x| ≤ {range}: {worst} ulp from libm");
        }
    }

    #[test]
    fn quadrant_boundaries_and_special_values() {
        use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
        let x = [0.0, -0.0, FRAC_PI_4, FRAC_PI_2, PI, -PI, 1.5 * PI, 2.0 * PI, -FRAC_PI_2, 1e-300];
        let (mut s, mut c) = ([0.0; 10], [0.0; 10]);
        sin_cos_many(&x, &mut s, &mut c);
        for i in 0..x.len() {
            let (ls, lc) = x[i].sin_cos();
            assert!(
                (s[i] - ls).abs() <= 2.0 * f64::EPSILON && (c[i] - lc).abs() <= 2.0 * f64::EPSILON,
                "x = {}",
                x[i]
            );
        }
        assert_eq!(s[0].to_bits(), 0.0f64.to_bits());
        assert_eq!(c[0], 1.0);
        // Outside the reduced range, or not finite: libm's values for the whole batch.
        let x = [0.5, 1e7, f64::NAN, f64::INFINITY];
        let (mut s, mut c) = ([0.0; 4], [0.0; 4]);
        sin_cos_many(&x, &mut s, &mut c);
        assert_eq!((s[0], c[0]), 0.5f64.sin_cos());
        assert_eq!((s[1], c[1]), 1e7f64.sin_cos());
        assert!(s[2].is_nan() && c[2].is_nan() && s[3].is_nan() && c[3].is_nan());
    }
}
