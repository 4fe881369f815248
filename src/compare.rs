//! `centaur compare`: pure RL against the hybrid over several seeds, reported as mean ± std
//! across seeds with learning curves and confidence bands — several seeds and their
//! variance, not the best run.
//!
//! Each seed `k` runs a full [`run_experiment`] in `DIR/seed_k/` (the MCAP recordings only
//! for seed 0). The output directory also gets:
//!
//! | file | content |
//! |---|---|
//! | `compare.json` | per agent: the across-seed mean and std of the evaluation return, speed, falls and cost of transport, and every seed's numbers |
//! | `learning_curves.png`, `.svg` | mean training return across seeds against steps, with a band of ± one standard deviation across seeds |

use std::path::PathBuf;

use centaur_rl::{AlgoConfig, UpdateMetrics};
use serde::Serialize;

use crate::experiment::{
    AgentStats, Curve, ExperimentError, ExperimentOptions, ExperimentSummary, Phase, run_experiment,
};
use crate::hybrid::ResidualConfig;
use crate::plot::{PlotError, PlotLabels, Series, plot_curves};

/// What to compare.
#[derive(Clone, Debug)]
pub struct CompareOptions {
    /// Robot environment.
    pub env: String,
    /// Algorithm and hyperparameters of both agents (the seed is each run's).
    pub algo: AlgoConfig,
    /// Number of seeds (0..seeds).
    pub seeds: u64,
    /// Training steps per agent and seed.
    pub steps: u64,
    /// Output directory.
    pub out: PathBuf,
    /// Parallel environments per agent.
    pub n_envs: usize,
    /// Threads stepping each agent's environments; with more than one, a seed's two agents
    /// also train side by side (results unchanged).
    pub threads: usize,
    /// Evaluation episodes per agent and seed.
    pub eval_episodes: usize,
    /// The hybrid's residual setup.
    pub residual: ResidualConfig,
}

/// Across-seed statistics of one agent.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Aggregate {
    /// Mean over seeds of the mean evaluation return.
    pub return_mean: f64,
    /// Standard deviation over seeds of the mean evaluation return.
    pub return_std: f64,
    /// Mean over seeds of the mean forward speed (m/s).
    pub mean_speed: f64,
    /// Standard deviation over seeds of the mean forward speed.
    pub mean_speed_std: f64,
    /// Falls summed over seeds.
    pub falls: usize,
    /// Evaluation episodes summed over seeds.
    pub episodes: usize,
    /// Mean over seeds of the cost of transport (seeds that moved forward).
    pub cost_of_transport: Option<f64>,
    /// Every seed's evaluation.
    pub per_seed: Vec<AgentStats>,
}

/// The `compare.json` record.
#[derive(Clone, Debug, Serialize)]
pub struct CompareSummary {
    /// Environment.
    pub env: String,
    /// Algorithm.
    pub algo: String,
    /// Number of seeds.
    pub seeds: u64,
    /// Steps per agent and seed.
    pub steps: u64,
    /// Residual RL on the controller.
    pub hybrid: Aggregate,
    /// RL alone.
    pub pure_rl: Aggregate,
    /// The controller alone.
    pub controller: Aggregate,
}

impl CompareSummary {
    /// The across-seed table in Markdown: return (mean ± std over seeds), forward speed,
    /// falls over all evaluation episodes and cost of transport of the three agents.
    pub fn markdown_table(&self) -> String {
        let row = |name: &str, a: &Aggregate| {
            let cot = a.cost_of_transport.map_or("—".to_string(), |c| format!("{c:.2}"));
            format!(
                "| {name} | {:.2} ± {:.2} | {:.3} ± {:.3} | {}/{} | {cot} |\n",
                a.return_mean, a.return_std, a.mean_speed, a.mean_speed_std, a.falls, a.episodes
            )
        };
        let mut t = String::from(
            "| agent | return (mean ± std over seeds) | forward speed (m/s) | falls | cost of transport |\n|---|---:|---:|---:|---:|\n",
        );
        t += &row("hybrid (residual RL on the controller)", &self.hybrid);
        t += &row("pure RL", &self.pure_rl);
        t += &row("controller alone", &self.controller);
        t
    }
}

fn mean_std(xs: &[f64]) -> (f64, f64) {
    let n = xs.len().max(1) as f64;
    let m = xs.iter().sum::<f64>() / n;
    (m, (xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n).sqrt())
}

/// Across-seed statistics of `pick(summary)`.
fn aggregate(runs: &[ExperimentSummary], pick: impl Fn(&ExperimentSummary) -> &AgentStats) -> Aggregate {
    let stats: Vec<AgentStats> = runs.iter().map(|r| pick(r).clone()).collect();
    let (return_mean, return_std) = mean_std(&stats.iter().map(|s| s.return_mean).collect::<Vec<_>>());
    let (mean_speed, mean_speed_std) = mean_std(&stats.iter().map(|s| s.mean_speed).collect::<Vec<_>>());
    let cots: Vec<f64> = stats.iter().filter_map(|s| s.cost_of_transport).collect();
    Aggregate {
        return_mean,
        return_std,
        mean_speed,
        mean_speed_std,
        falls: stats.iter().map(|s| s.falls).sum(),
        episodes: stats.iter().map(|s| s.episodes).sum(),
        cost_of_transport: (!cots.is_empty()).then(|| mean_std(&cots).0),
        per_seed: stats,
    }
}

/// Resamples each seed's curve on a common grid (linear interpolation, held flat outside
/// its range) and returns the across-seed mean with a ± one-std band.
pub fn band(label: &str, curves: &[Curve], steps: u64, points: usize) -> Series {
    let grid: Vec<f64> = (0..points).map(|k| steps as f64 * (k + 1) as f64 / points as f64).collect();
    let at = |c: &Curve, x: f64| -> Option<f64> {
        let first = c.first()?;
        if x <= first.0 as f64 {
            return Some(first.1);
        }
        for w in c.windows(2) {
            let (x0, y0, x1, y1) = (w[0].0 as f64, w[0].1, w[1].0 as f64, w[1].1);
            if x <= x1 {
                return Some(y0 + (y1 - y0) * (x - x0) / (x1 - x0).max(1e-9));
            }
        }
        c.last().map(|p| p.1)
    };
    let (mut y, mut lower, mut upper) = (Vec::new(), Vec::new(), Vec::new());
    let mut x = Vec::new();
    for &g in &grid {
        let vals: Vec<f64> = curves.iter().filter_map(|c| at(c, g)).filter(|v| v.is_finite()).collect();
        if vals.is_empty() {
            continue;
        }
        let (m, s) = mean_std(&vals);
        x.push(g);
        y.push(m);
        lower.push(m - s);
        upper.push(m + s);
    }
    Series { label: label.to_string(), x, y, lower: Some(lower), upper: Some(upper) }
}

/// Runs the comparison and writes the output directory.
pub fn run_compare(
    opts: &CompareOptions,
    progress: &mut dyn FnMut(u64, Phase, &UpdateMetrics),
) -> Result<CompareSummary, ExperimentError> {
    let (mut runs, mut pure_curves, mut hybrid_curves) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 0..opts.seeds.max(1) {
        let exp = ExperimentOptions {
            env: opts.env.clone(),
            algo: opts.algo.clone(),
            steps: opts.steps,
            seed,
            out: opts.out.join(format!("seed_{seed}")),
            n_envs: opts.n_envs,
            threads: opts.threads,
            eval_episodes: opts.eval_episodes,
            residual: opts.residual.clone(),
            record: seed == 0,
        };
        let r = run_experiment(&exp, &mut |phase, m| progress(seed, phase, m))?;
        runs.push(r.summary);
        pure_curves.push(r.pure_curve);
        hybrid_curves.push(r.hybrid_curve);
    }
    let summary = CompareSummary {
        env: opts.env.clone(),
        algo: opts.algo.kind().name().to_string(),
        seeds: opts.seeds.max(1),
        steps: opts.steps,
        hybrid: aggregate(&runs, |r| &r.hybrid),
        pure_rl: aggregate(&runs, |r| &r.pure_rl),
        controller: aggregate(&runs, |r| &r.controller),
    };
    let path = opts.out.join("compare.json");
    let text = serde_json::to_string_pretty(&summary)
        .map_err(|e| ExperimentError::Io { path: path.clone(), source: e.into() })?;
    std::fs::write(&path, text + "\n")
        .map_err(|source| ExperimentError::Io { path: path.clone(), source })?;
    let series = [
        band("pure RL (mean ± std over seeds)", &pure_curves, opts.steps, 60),
        band("hybrid (mean ± std over seeds)", &hybrid_curves, opts.steps, 60),
    ];
    let labels = PlotLabels {
        title: format!("{} on {}: {} seeds", opts.algo.kind().name(), opts.env, summary.seeds),
        x: "environment steps".into(),
        y: "training episode return".into(),
    };
    for ext in ["png", "svg"] {
        match plot_curves(&opts.out.join(format!("learning_curves.{ext}")), &labels, &series) {
            Ok(()) | Err(PlotError::Empty { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_is_the_across_seed_mean_and_std_on_a_common_grid() {
        // Two seeds logged at different steps: 0→0, 100→10 and 50→0, 100→20.
        let a: Curve = vec![(0, 0.0), (100, 10.0)];
        let b: Curve = vec![(50, 0.0), (100, 20.0)];
        let s = band("x", &[a, b], 100, 2);
        // At 50: a = 5 (interpolated), b = 0 → mean 2.5, std 2.5. At 100: 10 and 20 → 15 ± 5.
        assert_eq!(s.x, vec![50.0, 100.0]);
        assert!((s.y[0] - 2.5).abs() < 1e-12 && (s.y[1] - 15.0).abs() < 1e-12);
        let lower = s.lower.unwrap();
        assert!((lower[0] - 0.0).abs() < 1e-12 && (lower[1] - 10.0).abs() < 1e-12);
    }
}
