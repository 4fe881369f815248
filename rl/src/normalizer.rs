//! Running statistics: observation normalisation and reward scaling (the "37 details"
//! 5.4 and 5.5 of Huang et al. 2022, as gym's `NormalizeObservation` and
//! `NormalizeReward` wrappers).
//!
//! Moments are merged with the parallel formula of Chan, Golub & LeVeque (1979): for two
//! samples with means `μ_a, μ_b`, (population) variances `σ²_a, σ²_b` and counts `n_a, n_b`,
//!
//! ```text
//! n = n_a + n_b,   δ = μ_b − μ_a,   μ = μ_a + δ n_b / n,
//! σ² = (n_a σ²_a + n_b σ²_b + δ² n_a n_b / n) / n
//! ```

/// Merges two sets of moments `(mean, var, count)` (Chan et al. 1979); see the module doc.
pub fn merge_moments(
    mean_a: f64,
    var_a: f64,
    n_a: f64,
    mean_b: f64,
    var_b: f64,
    n_b: f64,
) -> (f64, f64, f64) {
    let n = n_a + n_b;
    let delta = mean_b - mean_a;
    let mean = mean_a + delta * n_b / n;
    let m2 = var_a * n_a + var_b * n_b + delta * delta * n_a * n_b / n;
    (mean, m2 / n, n)
}

/// Per-dimension running mean and variance in `f64`, started (as gym's `RunningMeanStd`)
/// at mean 0, variance 1 and a pseudo-count of 10⁻⁴.
#[derive(Clone, Debug, PartialEq)]
pub struct RunningMeanStd {
    /// Means.
    pub mean: Vec<f64>,
    /// Population variances.
    pub var: Vec<f64>,
    /// Number of samples seen (plus the initial 10⁻⁴).
    pub count: f64,
    /// Scratch for a batch's moments.
    batch_mean: Vec<f64>,
    batch_var: Vec<f64>,
}

impl RunningMeanStd {
    /// Statistics of `dim`-vectors.
    pub fn new(dim: usize) -> RunningMeanStd {
        RunningMeanStd {
            mean: vec![0.0; dim],
            var: vec![1.0; dim],
            count: 1e-4,
            batch_mean: vec![0.0; dim],
            batch_var: vec![0.0; dim],
        }
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Merges a batch of `xs.len() / dim` samples (row-major, sample after sample).
    #[track_caller]
    pub fn update(&mut self, xs: &[f32]) {
        let dim = self.dim();
        assert!(
            dim > 0 && xs.len().is_multiple_of(dim),
            "RunningMeanStd::update: {} values for dimension {dim}",
            xs.len()
        );
        let n = xs.len() / dim;
        if n == 0 {
            return;
        }
        self.batch_mean.fill(0.0);
        self.batch_var.fill(0.0);
        for x in xs.chunks_exact(dim) {
            self.batch_mean.iter_mut().zip(x).for_each(|(m, v)| *m += *v as f64);
        }
        self.batch_mean.iter_mut().for_each(|m| *m /= n as f64);
        for x in xs.chunks_exact(dim) {
            self.batch_var.iter_mut().zip(x.iter().zip(&self.batch_mean)).for_each(|(s, (v, m))| {
                *s += (*v as f64 - m).powi(2);
            });
        }
        self.batch_var.iter_mut().for_each(|s| *s /= n as f64);
        let mut count = self.count;
        for i in 0..dim {
            let (m, v, c) = merge_moments(
                self.mean[i],
                self.var[i],
                self.count,
                self.batch_mean[i],
                self.batch_var[i],
                n as f64,
            );
            self.mean[i] = m;
            self.var[i] = v;
            count = c;
        }
        self.count = count;
    }

    /// Merges a batch of `f64` scalars (dimension 1).
    #[track_caller]
    pub fn update_scalars(&mut self, xs: &[f64]) {
        assert!(self.dim() == 1, "RunningMeanStd::update_scalars on dimension {}", self.dim());
        if xs.is_empty() {
            return;
        }
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
        let (m, v, c) = merge_moments(self.mean[0], self.var[0], self.count, mean, var, n);
        self.mean[0] = m;
        self.var[0] = v;
        self.count = c;
    }

    /// Merges another set of statistics of the same dimension.
    #[track_caller]
    pub fn merge(&mut self, other: &RunningMeanStd) {
        assert!(
            self.dim() == other.dim(),
            "RunningMeanStd::merge: dimensions {} and {}",
            self.dim(),
            other.dim()
        );
        let mut count = self.count;
        for i in 0..self.dim() {
            let (m, v, c) = merge_moments(
                self.mean[i],
                self.var[i],
                self.count,
                other.mean[i],
                other.var[i],
                other.count,
            );
            self.mean[i] = m;
            self.var[i] = v;
            count = c;
        }
        self.count = count;
    }

    /// Replaces the statistics (from a checkpoint); `false` if the dimension differs.
    pub fn restore(&mut self, mean: &[f64], var: &[f64], count: f64) -> bool {
        if mean.len() != self.dim() || var.len() != self.dim() {
            return false;
        }
        self.mean.copy_from_slice(mean);
        self.var.copy_from_slice(var);
        self.count = count;
        true
    }
}

/// `ε` under the square root of the normalisers (gym's default).
pub const NORM_EPS: f64 = 1e-8;

/// Normalises `obs` into `out`: `clip((x − μ) / √(σ² + 10⁻⁸), −clip, clip)`, in `f64`,
/// the one function training and deployment ([`crate::Policy`]) share.
#[track_caller]
#[inline]
pub fn normalize_obs(mean: &[f64], var: &[f64], clip: f64, obs: &[f32], out: &mut [f32]) {
    assert!(
        obs.len() == out.len() && obs.len().is_multiple_of(mean.len().max(1)) && mean.len() == var.len(),
        "normalize_obs: {} observations into {} for dimension {}",
        obs.len(),
        out.len(),
        mean.len()
    );
    let dim = mean.len();
    for (o, x) in out.chunks_exact_mut(dim).zip(obs.chunks_exact(dim)) {
        for i in 0..dim {
            o[i] = ((x[i] as f64 - mean[i]) / (var[i] + NORM_EPS).sqrt()).clamp(-clip, clip) as f32;
        }
    }
}

/// Reward scaling by the running standard deviation of the discounted return
/// (Engstrom et al. 2020, "reward scaling"; gym's `NormalizeReward` of gym 0.21–0.26):
/// per environment `G ← γ G + r`, the running variance of `G` is updated with the batch of
/// `G`s, the reward is divided by `√(Var G + 10⁻⁸)` and clipped to `±clip`, and `G` is reset
/// to 0 when the episode ends (terminated or truncated).
#[derive(Clone, Debug, PartialEq)]
pub struct RewardScaler {
    /// Discount γ of the tracked return.
    pub gamma: f64,
    /// Clip of the scaled reward.
    pub clip: f64,
    /// Running statistics of `G`.
    pub stats: RunningMeanStd,
    /// Per-environment discounted returns `G`.
    pub returns: Vec<f64>,
}

impl RewardScaler {
    /// A scaler for `n_envs` environments.
    pub fn new(n_envs: usize, gamma: f64, clip: f64) -> RewardScaler {
        RewardScaler { gamma, clip, stats: RunningMeanStd::new(1), returns: vec![0.0; n_envs] }
    }

    /// Scales one vectorised step's rewards into `out`.
    #[track_caller]
    pub fn scale(&mut self, rewards: &[f64], done: impl Fn(usize) -> bool, out: &mut [f64]) {
        assert!(
            rewards.len() == self.returns.len() && out.len() == rewards.len(),
            "RewardScaler::scale: {} rewards for {} environments",
            rewards.len(),
            self.returns.len()
        );
        for (g, r) in self.returns.iter_mut().zip(rewards) {
            *g = *g * self.gamma + r;
        }
        self.stats.update_scalars(&self.returns);
        let scale = 1.0 / (self.stats.var[0] + NORM_EPS).sqrt();
        for (i, (o, r)) in out.iter_mut().zip(rewards).enumerate() {
            *o = (r * scale).clamp(-self.clip, self.clip);
            if done(i) {
                self.returns[i] = 0.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merge_by_hand() {
        // {1, 2, 3}: mean 2, var 2/3; {5, 7}: mean 6, var 1. Together {1,2,3,5,7}:
        // mean 18/5 = 3.6, var = (6.76 + 2.56 + 0.36 + 1.96 + 11.56)/5 = 23.2/5 = 4.64.
        // Formula: δ = 4, μ = 2 + 4·2/5 = 3.6, M2 = 2 + 2 + 16·3·2/5 = 23.2, σ² = 4.64.
        let (m, v, n) = merge_moments(2.0, 2.0 / 3.0, 3.0, 6.0, 1.0, 2.0);
        assert!((m - 3.6).abs() < 1e-12 && (v - 4.64).abs() < 1e-12 && n == 5.0);
    }

    #[test]
    fn running_stats_equal_batch_stats() {
        // Two batches of 2-D samples merged one after the other equal the moments of all.
        let a = [1.0f32, 10.0, 2.0, 20.0, 3.0, 30.0];
        let b = [5.0f32, 50.0, 7.0, 70.0];
        let mut rms = RunningMeanStd::new(2);
        rms.update(&a);
        rms.update(&b);
        // Count 5 + 1e-4 (the initial pseudo-sample at mean 0, variance 1 weighs 1e-4).
        assert!((rms.count - 5.0001).abs() < 1e-12);
        assert!((rms.mean[0] - 3.6).abs() < 1e-3 && (rms.var[0] - 4.64).abs() < 1e-3);
        assert!((rms.mean[1] - 36.0).abs() < 1e-2 && (rms.var[1] - 464.0).abs() < 1e-1);
        // Merging two running statistics equals updating one with both batches.
        let mut x = RunningMeanStd::new(2);
        x.update(&a);
        let mut y = RunningMeanStd::new(2);
        y.update(&b);
        x.merge(&y);
        assert!((x.mean[0] - rms.mean[0]).abs() < 1e-3 && (x.var[1] - rms.var[1]).abs() < 1e-1);
    }

    #[test]
    fn obs_normalisation_clips() {
        let mut out = [0.0f32; 4];
        // (3 − 1)/√4 = 1; (−100 − 0)/1 → −10 (clipped).
        normalize_obs(&[1.0, 0.0], &[4.0, 1.0], 10.0, &[3.0, -100.0, 1.0, 0.5], &mut out);
        assert!(
            (out[0] - 1.0).abs() < 1e-6 && out[1] == -10.0 && out[2] == 0.0 && (out[3] - 0.5).abs() < 1e-6
        );
    }

    #[test]
    fn reward_scaler_by_hand() {
        // One env, γ = 0.5, rewards 2 then 2 (episode ends after the second).
        // Step 1: G = 2; stats merge (0, 1, 1e-4) with (2, 0, 1):
        //   μ = 2/1.0001 = 1.99980, σ² = (1e-4 + 4·1e-4/1.0001)/1.0001 = 4.99900e-4;
        //   r' = 2/√(4.99900e-4 + 1e-8) = 89.45 → clipped to 10.
        // Step 2: G = 1 + 2 = 3, reset after.
        let mut s = RewardScaler::new(1, 0.5, 10.0);
        let mut out = [0.0];
        s.scale(&[2.0], |_| false, &mut out);
        assert_eq!(out[0], 10.0);
        assert!((s.stats.var[0] - 4.999e-4).abs() < 1e-6);
        s.scale(&[2.0], |_| true, &mut out);
        assert_eq!(s.returns[0], 0.0);
        // After G = 2 and G = 3: μ ≈ 2.5, σ² ≈ 0.25 (pseudo-count negligible):
        // r' = 2/√0.25 ≈ 4.
        assert!((out[0] - 4.0).abs() < 1e-2, "{}", out[0]);
    }
}
