//! [`BoxSpace`]: Gymnasium's `Box`, the one space of continuous control.

use crate::rng::Rng;

/// A box `[low, high]` of `f32` vectors (Gymnasium's `Box`). Bounds may be infinite.
#[derive(Clone, Debug, PartialEq)]
pub struct BoxSpace {
    /// Lower bounds.
    pub low: Vec<f32>,
    /// Upper bounds.
    pub high: Vec<f32>,
}

impl BoxSpace {
    /// A box with the given bounds.
    #[track_caller]
    pub fn new(low: Vec<f32>, high: Vec<f32>) -> Self {
        assert!(low.len() == high.len(), "BoxSpace: low has {} entries, high {}", low.len(), high.len());
        BoxSpace { low, high }
    }

    /// `[-bound, bound]^dim`.
    pub fn symmetric(dim: usize, bound: f32) -> Self {
        BoxSpace { low: vec![-bound; dim], high: vec![bound; dim] }
    }

    /// `(-∞, ∞)^dim`.
    pub fn unbounded(dim: usize) -> Self {
        Self::symmetric(dim, f32::INFINITY)
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.low.len()
    }

    /// Whether every bound is finite.
    pub fn is_bounded(&self) -> bool {
        self.low.iter().chain(&self.high).all(|b| b.is_finite())
    }

    /// Whether `x` lies in the box.
    pub fn contains(&self, x: &[f32]) -> bool {
        x.len() == self.dim()
            && x.iter().zip(self.low.iter().zip(&self.high)).all(|(v, (l, h))| *l <= *v && *v <= *h)
    }

    /// Clips `x` into the box in place.
    pub fn clip(&self, x: &mut [f32]) {
        for (v, (l, h)) in x.iter_mut().zip(self.low.iter().zip(&self.high)) {
            *v = v.clamp(*l, *h);
        }
    }

    /// A uniform sample (bounded boxes; unbounded coordinates get a standard normal).
    pub fn sample(&self, rng: &mut Rng, out: &mut [f32]) {
        for (o, (l, h)) in out.iter_mut().zip(self.low.iter().zip(&self.high)) {
            *o = if l.is_finite() && h.is_finite() {
                rng.range(*l as f64, *h as f64) as f32
            } else {
                rng.normal() as f32
            };
        }
    }
}
