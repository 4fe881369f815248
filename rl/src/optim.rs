//! Optimisers and learning-rate schedules over flat `f32` parameter vectors.
//!
//! * [`Adam`] (Kingma & Ba 2015, Algorithm 1) with bias correction, as `torch.optim.Adam`.
//! * [`RmsProp`] (Tieleman & Hinton 2012), as `torch.optim.RMSprop` (what
//!   Stable-Baselines3's A2C uses).
//! * [`clip_grad_norm`]: global ℓ₂ clipping over several gradient vectors, as
//!   `torch.nn.utils.clip_grad_norm_`.
//! * [`linear_decay`]: the linear learning-rate annealing of PPO (Schulman et al. 2017).

use serde::{Deserialize, Serialize};

/// Adam: with `g` the gradient at step `t`,
///
/// ```text
/// m ← β₁ m + (1 − β₁) g,   v ← β₂ v + (1 − β₂) g²,
/// θ ← θ − lr · (m / (1 − β₁ᵗ)) / (√(v / (1 − β₂ᵗ)) + ε)
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Adam {
    /// First-moment decay β₁.
    pub beta1: f32,
    /// Second-moment decay β₂.
    pub beta2: f32,
    /// ε added to the denominator.
    pub eps: f32,
    m: Vec<f32>,
    v: Vec<f32>,
    t: u64,
}

/// The state of an [`Adam`] optimiser (for checkpoints).
#[derive(Clone, Debug, PartialEq)]
pub struct AdamState {
    /// First moments.
    pub m: Vec<f32>,
    /// Second moments.
    pub v: Vec<f32>,
    /// Steps taken.
    pub t: u64,
}

impl Adam {
    /// An optimiser for `n` parameters (PyTorch defaults: β₁ = 0.9, β₂ = 0.999).
    pub fn new(n: usize, eps: f32) -> Adam {
        Adam { beta1: 0.9, beta2: 0.999, eps, m: vec![0.0; n], v: vec![0.0; n], t: 0 }
    }

    /// One update of `params` with `grads` at learning rate `lr`.
    #[track_caller]
    pub fn step(&mut self, params: &mut [f32], grads: &[f32], lr: f32) {
        assert!(
            params.len() == self.m.len() && grads.len() == self.m.len(),
            "Adam::step: optimiser has {} entries, params {}, grads {}",
            self.m.len(),
            params.len(),
            grads.len()
        );
        self.t += 1;
        let (b1, b2) = (self.beta1, self.beta2);
        let bc1 = 1.0 - (b1 as f64).powi(self.t.min(i32::MAX as u64) as i32);
        let bc2 = 1.0 - (b2 as f64).powi(self.t.min(i32::MAX as u64) as i32);
        // torch's form: θ −= (lr / bc1) · m / (√v / √bc2 + ε)
        let step_size = (lr as f64 / bc1) as f32;
        let inv_sqrt_bc2 = (1.0 / bc2.sqrt()) as f32;
        let eps = self.eps;
        let (ms, vs) = (&mut self.m, &mut self.v);
        // Compiled for AVX2/FMA when available (runtime dispatch); same arithmetic either way.
        pulp::Arch::new().dispatch(
            #[inline(always)]
            || {
                for ((p, g), (m, v)) in params.iter_mut().zip(grads).zip(ms.iter_mut().zip(vs.iter_mut())) {
                    *m = b1 * *m + (1.0 - b1) * g;
                    *v = b2 * *v + (1.0 - b2) * g * g;
                    *p -= step_size * *m / (v.sqrt() * inv_sqrt_bc2 + eps);
                }
            },
        );
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.m.len()
    }

    /// Whether it has no parameters.
    pub fn is_empty(&self) -> bool {
        self.m.is_empty()
    }

    /// A copy of the state.
    pub fn state(&self) -> AdamState {
        AdamState { m: self.m.clone(), v: self.v.clone(), t: self.t }
    }

    /// Moments as slices `(m, v)` and the step count.
    pub fn moments(&self) -> (&[f32], &[f32], u64) {
        (&self.m, &self.v, self.t)
    }

    /// Restores moments and step count; `false` if the sizes do not match.
    pub fn restore(&mut self, m: &[f32], v: &[f32], t: u64) -> bool {
        if m.len() != self.m.len() || v.len() != self.v.len() {
            return false;
        }
        self.m.copy_from_slice(m);
        self.v.copy_from_slice(v);
        self.t = t;
        true
    }
}

/// RMSprop as `torch.optim.RMSprop` (no momentum, not centred):
///
/// ```text
/// s ← α s + (1 − α) g²,   θ ← θ − lr · g / (√s + ε)
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct RmsProp {
    /// Smoothing constant α.
    pub alpha: f32,
    /// ε added to the denominator.
    pub eps: f32,
    s: Vec<f32>,
}

impl RmsProp {
    /// An optimiser for `n` parameters.
    pub fn new(n: usize, alpha: f32, eps: f32) -> RmsProp {
        RmsProp { alpha, eps, s: vec![0.0; n] }
    }

    /// One update.
    #[track_caller]
    pub fn step(&mut self, params: &mut [f32], grads: &[f32], lr: f32) {
        assert!(
            params.len() == self.s.len() && grads.len() == self.s.len(),
            "RmsProp::step: optimiser has {} entries, params {}, grads {}",
            self.s.len(),
            params.len(),
            grads.len()
        );
        let (a, eps) = (self.alpha, self.eps);
        for ((p, g), s) in params.iter_mut().zip(grads).zip(self.s.iter_mut()) {
            *s = a * *s + (1.0 - a) * g * g;
            *p -= lr * g / (s.sqrt() + eps);
        }
    }

    /// The squared-gradient averages.
    pub fn square_avg(&self) -> &[f32] {
        &self.s
    }

    /// Restores the squared-gradient averages; `false` if the size does not match.
    pub fn restore(&mut self, s: &[f32]) -> bool {
        if s.len() != self.s.len() {
            return false;
        }
        self.s.copy_from_slice(s);
        true
    }
}

/// Which optimiser an algorithm uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OptimizerKind {
    /// [`Adam`].
    Adam,
    /// [`RmsProp`].
    Rmsprop,
}

/// Global ℓ₂ norm `‖(g₁, …, g_k)‖₂` of several gradient vectors.
pub fn grad_norm(grads: &[&[f32]]) -> f32 {
    grads.iter().flat_map(|g| g.iter()).map(|g| (*g as f64) * (*g as f64)).sum::<f64>().sqrt() as f32
}

/// Scales all gradients by `max_norm / (‖g‖ + 10⁻⁶)` when the global norm `‖g‖` exceeds
/// `max_norm` (as `torch.nn.utils.clip_grad_norm_`); returns the norm before clipping.
pub fn clip_grad_norm(grads: &mut [&mut [f32]], max_norm: f32) -> f32 {
    // Compiled for AVX2 where present (see `nn::BiasActivation` for why a `WithSimd` struct
    // and not a closure); the sum's order, and so its value, is the same on every path.
    pulp::Arch::new().dispatch(ClipGradNorm { grads, max_norm })
}

struct ClipGradNorm<'a, 'b> {
    grads: &'a mut [&'b mut [f32]],
    max_norm: f32,
}

impl pulp::WithSimd for ClipGradNorm<'_, '_> {
    type Output = f32;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> f32 {
        let grads = self.grads;
        let norm =
            grads.iter().flat_map(|g| g.iter()).map(|g| (*g as f64) * (*g as f64)).sum::<f64>().sqrt() as f32;
        let coef = self.max_norm / (norm + 1e-6);
        if coef < 1.0 {
            for g in grads.iter_mut() {
                g.iter_mut().for_each(|x| *x *= coef);
            }
        }
        norm
    }
}

/// Linear decay from `initial` to 0: `initial · (1 − done / total)`, clamped at 0
/// (CleanRL's `frac = 1 − (update − 1) / num_updates`, with `done` the steps before the
/// current update).
pub fn linear_decay(initial: f64, done: u64, total: u64) -> f64 {
    if total == 0 {
        return initial;
    }
    initial * (1.0 - done as f64 / total as f64).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adam_first_steps_by_hand() {
        // Step 1, g = 2: m = 0.2, v = 0.004; m̂ = 0.2/0.1 = 2, v̂ = 0.004/0.001 = 4;
        // θ = 1 − 0.1 · 2 / (2 + 1e-8) = 0.9.
        let mut adam = Adam::new(1, 1e-8);
        let mut p = [1.0f32];
        adam.step(&mut p, &[2.0], 0.1);
        assert!((p[0] - 0.9).abs() < 1e-6, "{}", p[0]);
        // Step 2, g = −1: m = 0.18 − 0.1 = 0.08, v = 0.003996 + 0.001 = 0.004996;
        // m̂ = 0.08/0.19 = 0.421053, v̂ = 0.004996/0.001999 = 2.499250, √ = 1.580902;
        // θ = 0.9 − 0.1 · 0.421053/1.580902 = 0.9 − 0.026634 = 0.873366.
        adam.step(&mut p, &[-1.0], 0.1);
        assert!((p[0] - 0.873366).abs() < 1e-5, "{}", p[0]);
        let (m, v, t) = adam.moments();
        assert_eq!(t, 2);
        assert!((m[0] - 0.08).abs() < 1e-6 && (v[0] - 0.004996).abs() < 1e-7);
    }

    #[test]
    fn rmsprop_first_step_by_hand() {
        // s = 0.01 · 4 = 0.04, θ = 1 − 0.1 · 2 / (0.2 + 1e-5) = 1 − 0.99995 = 0.00005.
        let mut opt = RmsProp::new(1, 0.99, 1e-5);
        let mut p = [1.0f32];
        opt.step(&mut p, &[2.0], 0.1);
        assert!((p[0] - 5e-5).abs() < 1e-6, "{}", p[0]);
    }

    #[test]
    fn clipping_by_hand() {
        // ‖(3, 4)‖ = 5 > 1: scaled by 1/(5 + 1e-6) → (0.6, 0.8).
        let mut a = [3.0f32];
        let mut b = [4.0f32];
        let n = clip_grad_norm(&mut [&mut a, &mut b], 1.0);
        assert!((n - 5.0).abs() < 1e-6);
        assert!((a[0] - 0.6).abs() < 1e-6 && (b[0] - 0.8).abs() < 1e-6);
        // Below the bound: unchanged.
        let n = clip_grad_norm(&mut [&mut a, &mut b], 10.0);
        assert!((n - 1.0).abs() < 1e-5 && (a[0] - 0.6).abs() < 1e-6);
        assert!((grad_norm(&[&[3.0], &[4.0]]) - 5.0).abs() < 1e-6);
    }

    #[test]
    fn linear_decay_by_hand() {
        assert_eq!(linear_decay(3e-4, 0, 100), 3e-4);
        assert!((linear_decay(3e-4, 25, 100) - 2.25e-4).abs() < 1e-12);
        assert_eq!(linear_decay(3e-4, 200, 100), 0.0);
    }
}
