//! Action distributions as pure functions, with the gradients the algorithms need.
//!
//! * Diagonal Gaussian `N(μ, diag σ²)` with a state-independent `log σ` (PPO, A2C):
//!   `log π(a) = Σᵢ [−(aᵢ − μᵢ)² / (2σᵢ²) − log σᵢ − ½ log 2π]`,
//!   entropy `H = Σᵢ [½ + ½ log 2π + log σᵢ]`.
//! * Tanh-squashed Gaussian (SAC, Haarnoja et al. 2018, appendix C): `u ~ N(μ, σ²)`,
//!   `a = tanh u`, `log π(a) = log N(u; μ, σ²) − Σᵢ log(1 − tanh² uᵢ)`, with the correction
//!   in the numerically stable form `log(1 − tanh² u) = 2 (log 2 − u − softplus(−2u))`
//!   (exact: `1 − tanh² u = 4 e^{−2u} / (1 + e^{−2u})²`).
//! * Deterministic tanh head (TD3, DDPG): `a = tanh y`, `∂a/∂y = 1 − a²`.

use crate::nn::tanh_fast;

/// `½ log 2π`.
pub const HALF_LOG_2PI: f32 = 0.918_938_5;

/// `log 2`.
const LN_2: f32 = std::f32::consts::LN_2;

/// `softplus x = log(1 + eˣ)`, computed as `max(x, 0) + log(1 + e^{−|x|})` so that it
/// neither overflows nor loses precision for large `|x|`.
#[inline]
pub fn softplus(x: f32) -> f32 {
    x.max(0.0) + (-x.abs()).exp().ln_1p()
}

/// `log N(a; μ, σ²)` of a diagonal Gaussian, summed over dimensions.
#[track_caller]
#[inline]
pub fn gaussian_log_prob(a: &[f32], mean: &[f32], log_std: &[f32]) -> f32 {
    assert!(a.len() == mean.len() && a.len() == log_std.len(), "gaussian_log_prob: sizes differ");
    let mut lp = 0.0;
    for ((a, m), ls) in a.iter().zip(mean).zip(log_std) {
        let z = (a - m) * (-ls).exp();
        lp += -0.5 * z * z - ls - HALF_LOG_2PI;
    }
    lp
}

/// Entropy of a diagonal Gaussian: `Σᵢ (½ + ½ log 2π + log σᵢ)`.
#[inline]
pub fn gaussian_entropy(log_std: &[f32]) -> f32 {
    log_std.iter().map(|ls| 0.5 + HALF_LOG_2PI + ls).sum()
}

/// Gradients of `log N(a; μ, σ²)` for one sample: `∂/∂μᵢ = (aᵢ − μᵢ)/σᵢ²` into `d_mean`
/// and `∂/∂log σᵢ = (aᵢ − μᵢ)²/σᵢ² − 1` into `d_log_std` (both overwritten).
#[track_caller]
#[inline]
pub fn gaussian_log_prob_grad(
    a: &[f32],
    mean: &[f32],
    log_std: &[f32],
    d_mean: &mut [f32],
    d_log_std: &mut [f32],
) {
    assert!(
        a.len() == mean.len()
            && a.len() == log_std.len()
            && a.len() == d_mean.len()
            && a.len() == d_log_std.len(),
        "gaussian_log_prob_grad: sizes differ"
    );
    for i in 0..a.len() {
        let inv_var = (-2.0 * log_std[i]).exp();
        let d = a[i] - mean[i];
        d_mean[i] = d * inv_var;
        d_log_std[i] = d * d * inv_var - 1.0;
    }
}

/// `log(1 − tanh² u) = 2 (log 2 − u − softplus(−2u))`, exact and finite for all `u`.
#[inline]
pub fn log_one_minus_tanh_sq(u: f32) -> f32 {
    2.0 * (LN_2 - u - softplus(-2.0 * u))
}

/// A reparameterised sample of the tanh-squashed Gaussian: `u = μ + σ ε`, `a = tanh u`
/// (written to `action`); returns `log π(a) = Σᵢ [−ε²/2 − log σᵢ − ½ log 2π − log(1 − aᵢ²)]`
/// with the stable correction.
///
/// Gradients for the reparameterised loss (ε held fixed), per dimension, with
/// `∂/∂u log(1 − tanh² u) = −2 tanh u`:
/// `∂ log π/∂μᵢ = 2aᵢ`, `∂ log π/∂log σᵢ = −1 + 2aᵢ σᵢ εᵢ`, `∂aᵢ/∂μᵢ = 1 − aᵢ²`,
/// `∂aᵢ/∂log σᵢ = (1 − aᵢ²) σᵢ εᵢ` ([`squashed_gaussian_backward`] combines them).
#[track_caller]
#[inline]
pub fn squashed_gaussian_sample(mean: &[f32], log_std: &[f32], eps: &[f32], action: &mut [f32]) -> f32 {
    assert!(
        mean.len() == log_std.len() && mean.len() == eps.len() && mean.len() == action.len(),
        "squashed_gaussian_sample: sizes differ"
    );
    let mut lp = 0.0;
    for i in 0..mean.len() {
        let u = mean[i] + log_std[i].exp() * eps[i];
        action[i] = tanh_fast(u);
        lp += -0.5 * eps[i] * eps[i] - log_std[i] - HALF_LOG_2PI - log_one_minus_tanh_sq(u);
    }
    lp
}

/// Backward through [`squashed_gaussian_sample`]: given `∂ℓ/∂a` (`d_action`) and
/// `∂ℓ/∂log π` (`d_log_prob`), writes `∂ℓ/∂μ` and `∂ℓ/∂log σ`.
#[track_caller]
#[inline]
pub fn squashed_gaussian_backward(
    log_std: &[f32],
    eps: &[f32],
    action: &[f32],
    d_action: &[f32],
    d_log_prob: f32,
    d_mean: &mut [f32],
    d_log_std: &mut [f32],
) {
    assert!(
        log_std.len() == eps.len()
            && eps.len() == action.len()
            && action.len() == d_action.len()
            && d_action.len() == d_mean.len()
            && d_mean.len() == d_log_std.len(),
        "squashed_gaussian_backward: sizes differ"
    );
    for i in 0..action.len() {
        let a = action[i];
        let sigma_eps = log_std[i].exp() * eps[i];
        let du = d_action[i] * (1.0 - a * a) + d_log_prob * 2.0 * a;
        d_mean[i] = du;
        d_log_std[i] = du * sigma_eps - d_log_prob;
    }
}

/// Deterministic tanh head: `a = tanh y` in place, returned in `y`.
#[inline]
pub fn tanh_in_place(y: &mut [f32]) {
    y.iter_mut().for_each(|v| *v = tanh_fast(*v));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_log_prob_and_entropy_by_hand() {
        // 1-D: a = 1, μ = 0, log σ = 0: −½ − 0 − 0.9189385 = −1.4189385.
        assert!((gaussian_log_prob(&[1.0], &[0.0], &[0.0]) + 1.418_938_5).abs() < 1e-6);
        // 2-D: a = (0.5, −1), μ = (0, 0), log σ = (ln 2, 0):
        // dim 1: z = 0.25, −0.03125 − 0.6931472 − 0.9189385 = −1.6433357;
        // dim 2: −0.5 − 0 − 0.9189385 = −1.4189385; sum −3.0622742.
        let lp = gaussian_log_prob(&[0.5, -1.0], &[0.0, 0.0], &[std::f32::consts::LN_2, 0.0]);
        assert!((lp + 3.062_274_2).abs() < 1e-5, "{lp}");
        // H = (0.5 + 0.9189385 + ln 2) + (0.5 + 0.9189385 + 0) = 3.5310242.
        assert!((gaussian_entropy(&[std::f32::consts::LN_2, 0.0]) - 3.531_024_2).abs() < 1e-5);
        // Gradients at dim 1: (a − μ)/σ² = 0.5/4 = 0.125; (a − μ)²/σ² − 1 = 0.0625 − 1.
        let (mut dm, mut ds) = ([0.0; 2], [0.0; 2]);
        gaussian_log_prob_grad(&[0.5, -1.0], &[0.0, 0.0], &[std::f32::consts::LN_2, 0.0], &mut dm, &mut ds);
        assert!((dm[0] - 0.125).abs() < 1e-6 && (ds[0] + 0.9375).abs() < 1e-6);
        assert!((dm[1] + 1.0).abs() < 1e-6 && (ds[1] - 0.0).abs() < 1e-6);
    }

    #[test]
    fn tanh_correction_is_exact_and_stable() {
        // u = 0.5: tanh = 0.46211716, 1 − tanh² = 0.78644773, log = −0.24022901.
        assert!((log_one_minus_tanh_sq(0.5) + 0.240_229_0).abs() < 1e-6);
        // Symmetric: log(1 − tanh²) is even.
        assert!((log_one_minus_tanh_sq(-0.5) + 0.240_229_0).abs() < 1e-6);
        // u = 20: naive log(1 − tanh²(20)) = log(0) = −∞ in f32; exact
        // 2 (log 2 − 20 − softplus(−40)) = 2 (0.6931472 − 20 − 4.2e−18) = −38.6137056.
        assert!((log_one_minus_tanh_sq(20.0) + 38.613_705_6).abs() < 1e-4);
        assert!((log_one_minus_tanh_sq(-20.0) + 38.613_705_6).abs() < 1e-4);
        assert!((softplus(0.0) - std::f32::consts::LN_2).abs() < 1e-7);
        assert!((softplus(100.0) - 100.0).abs() < 1e-5 && softplus(-100.0) < 1e-40);
    }

    #[test]
    fn squashed_sample_by_hand() {
        // μ = 0.2, log σ = ln 0.5, ε = 0.6: u = 0.2 + 0.3 = 0.5, a = tanh 0.5 = 0.46211716;
        // log π = −0.18 + 0.6931472 − 0.9189385 + 0.2402290 = −0.1655623.
        let mut a = [0.0];
        let lp = squashed_gaussian_sample(&[0.2], &[0.5f32.ln()], &[0.6], &mut a);
        assert!((a[0] - 0.462_117_16).abs() < 1e-6);
        assert!((lp + 0.165_562_3).abs() < 1e-5, "{lp}");
    }

    #[test]
    fn squashed_gradients_match_finite_differences() {
        // ℓ = c·a + k log π for fixed ε; compare analytic ∂ℓ/∂μ, ∂ℓ/∂log σ with differences.
        let (mean, log_std, eps) = ([0.3f32, -1.2], [-0.4f32, 0.3], [0.7f32, -1.1]);
        let (c, k) = ([0.8f32, -0.5], 0.3f32);
        let loss = |m: &[f32], s: &[f32]| {
            let mut a = [0.0; 2];
            let lp = squashed_gaussian_sample(m, s, &eps, &mut a);
            (c[0] * a[0] + c[1] * a[1] + k * lp) as f64
        };
        let mut a = [0.0; 2];
        squashed_gaussian_sample(&mean, &log_std, &eps, &mut a);
        let (mut dm, mut ds) = ([0.0; 2], [0.0; 2]);
        squashed_gaussian_backward(&log_std, &eps, &a, &c, k, &mut dm, &mut ds);
        let h = 1e-3;
        for i in 0..2 {
            let (mut mp, mut mm) = (mean, mean);
            mp[i] += h;
            mm[i] -= h;
            let fd = (loss(&mp, &log_std) - loss(&mm, &log_std)) / (2.0 * h as f64);
            assert!((fd - dm[i] as f64).abs() < 1e-3, "dμ{i}: fd {fd} vs {}", dm[i]);
            let (mut sp, mut sm) = (log_std, log_std);
            sp[i] += h;
            sm[i] -= h;
            let fd = (loss(&mean, &sp) - loss(&mean, &sm)) / (2.0 * h as f64);
            assert!((fd - ds[i] as f64).abs() < 1e-3, "dlogσ{i}: fd {fd} vs {}", ds[i]);
        }
    }
}
