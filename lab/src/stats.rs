//! Statistics over seeds as the field reports them (Agarwal et al., NeurIPS 2021, "Deep
//! reinforcement learning at the edge of the statistical precipice"): the interquartile
//! mean of per-run scores and its percentile confidence interval from a stratified
//! bootstrap (runs resampled with replacement within each task).

use centaur_gym::Rng;

/// The interquartile mean: the mean of the scores left after cutting `⌊n/4⌋` from each
/// end of the sorted scores (`scipy.stats.trim_mean(x, 0.25)`, what rliable computes).
/// `NaN` for no scores.
pub fn iqm(scores: &[f64]) -> f64 {
    if scores.is_empty() {
        return f64::NAN;
    }
    let mut s = scores.to_vec();
    s.sort_by(f64::total_cmp);
    let cut = s.len() / 4;
    let kept = &s[cut..s.len() - cut];
    kept.iter().sum::<f64>() / kept.len() as f64
}

/// A two-sided percentile confidence interval.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Interval {
    /// Lower bound.
    pub low: f64,
    /// Upper bound.
    pub high: f64,
}

/// The `level` (e.g. 0.95) percentile bootstrap interval of `statistic` over `tasks`
/// (each a list of per-run scores), resampling runs with replacement within each task
/// `resamples` times; the statistic sees the resampled runs of every task concatenated.
/// Deterministic for a given `seed`. `None` when a task has no runs.
pub fn stratified_bootstrap(
    tasks: &[&[f64]],
    statistic: impl Fn(&[f64]) -> f64,
    resamples: usize,
    level: f64,
    seed: u64,
) -> Option<Interval> {
    if tasks.is_empty() || tasks.iter().any(|t| t.is_empty()) || resamples == 0 {
        return None;
    }
    let mut rng = Rng::seed_from_u64(seed);
    let mut sample = Vec::with_capacity(tasks.iter().map(|t| t.len()).sum());
    let mut stats: Vec<f64> = (0..resamples)
        .map(|_| {
            sample.clear();
            for task in tasks {
                sample.extend((0..task.len()).map(|_| task[rng.below(task.len())]));
            }
            statistic(&sample)
        })
        .collect();
    stats.sort_by(f64::total_cmp);
    let tail = (1.0 - level.clamp(0.0, 1.0)) / 2.0;
    let at = |q: f64| {
        let pos = q * (stats.len() - 1) as f64;
        let (i, f) = (pos.floor() as usize, pos - pos.floor());
        let j = (i + 1).min(stats.len() - 1);
        stats[i] + f * (stats[j] - stats[i])
    };
    Some(Interval { low: at(tail), high: at(1.0 - tail) })
}

/// IQM and its 95 % stratified-bootstrap interval (2,000 resamples, fixed seed) of one
/// task's per-run scores.
pub fn iqm_with_ci(scores: &[f64]) -> (f64, Option<Interval>) {
    (iqm(scores), stratified_bootstrap(&[scores], iqm, 2000, 0.95, 0x5eed))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_iqm_cuts_a_quarter_from_each_end_like_scipy() {
        // scipy.stats.trim_mean([1, 2, 3, 4, 100], 0.25) = mean(2, 3, 4) = 3.
        assert_eq!(iqm(&[100.0, 2.0, 1.0, 4.0, 3.0]), 3.0);
        // n = 8: cuts 2 from each end.
        assert_eq!(iqm(&[-50.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 90.0]), 3.5);
        // n < 4: the plain mean.
        assert_eq!(iqm(&[1.0, 2.0, 6.0]), 3.0);
        assert!(iqm(&[]).is_nan());
    }

    #[test]
    fn the_bootstrap_interval_brackets_the_statistic_and_shrinks_with_more_runs() {
        let few = [10.0, 12.0, 9.0, 11.0, 13.0];
        let (m, ci) = iqm_with_ci(&few);
        let ci = ci.unwrap();
        assert!(ci.low <= m && m <= ci.high, "{ci:?} around {m}");
        assert!(ci.low >= 9.0 && ci.high <= 13.0);
        // The same spread over 40 runs: a narrower interval.
        let many: Vec<f64> = (0..40).map(|k| few[k % 5]).collect();
        let wide = stratified_bootstrap(&[&many], iqm, 2000, 0.95, 1).unwrap();
        assert!(wide.high - wide.low < ci.high - ci.low);
        // Identical runs: a point.
        let same = stratified_bootstrap(&[&[4.0; 5]], iqm, 100, 0.95, 1).unwrap();
        assert_eq!((same.low, same.high), (4.0, 4.0));
        // Deterministic for a seed; nothing to resample is None.
        assert_eq!(
            stratified_bootstrap(&[&few], iqm, 500, 0.95, 7),
            stratified_bootstrap(&[&few], iqm, 500, 0.95, 7)
        );
        assert!(stratified_bootstrap(&[&[]], iqm, 10, 0.95, 1).is_none());
    }
}
