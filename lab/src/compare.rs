//! `centaur compare`: pure RL against the hybrid over several seeds, reported as the
//! interquartile mean over seeds with its 95 % stratified-bootstrap confidence interval
//! (Agarwal et al. 2021, [`crate::stats`]) and as mean ± std, with learning curves and
//! bands — several seeds and their variance, not the best run.
//!
//! Each seed `k` runs a full [`run_experiment`] in `DIR/seed_k/` (the MCAP recordings only
//! for seed 0). The output directory also gets:
//!
//! | file | content |
//! |---|---|
//! | `compare.json` | per agent: the across-seed IQM (with its 95 % CI), mean and std of the evaluation return, speed, falls and cost of transport, and every seed's numbers; both learners at every budget; the head-to-head read off them ([`HeadToHead`]: budgets at or above pure RL, the samples to reach its final return, equal wall-clock), which the command also prints |
//! | `learning_curves.png`, `.svg` | mean training return across seeds against steps, with a band of ± one standard deviation across seeds |
//! | `eval_curves.png`, `.svg`; `eval_curves_wall.png`, `.svg` | the deterministic evaluations at each budget (`--eval-every`): IQM over seeds with its 95 % CI, against steps and against training wall-clock seconds |

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use centaur_rl::{AlgoConfig, UpdateMetrics};
use serde::Serialize;

use crate::experiment::{
    AgentStats, BudgetEval, Curve, ExperimentError, ExperimentOptions, ExperimentSummary, Phase,
    check_resumable, finished_experiment, run_experiment,
};
use crate::hybrid::ResidualConfig;
use crate::plot::{PlotError, PlotLabels, Series, plot_curves};
use crate::settings::EnvSettings;
use crate::spec::ResolvedSpec;
use crate::stats::{Interval, iqm_with_ci};

/// What to compare.
#[derive(Clone, Debug)]
pub struct CompareOptions {
    /// Robot environment.
    pub env: String,
    /// Algorithm and hyperparameters of both agents (the seed is each run's), the hybrid's
    /// unless `hybrid_algo` is set.
    pub algo: AlgoConfig,
    /// The hybrid's own hyperparameters (see [`ExperimentOptions::hybrid_algo`]; `None`:
    /// `algo`'s).
    pub hybrid_algo: Option<AlgoConfig>,
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
    /// Seeds run at once, each on its own `threads` (results unchanged: every seed's run
    /// depends on its seed alone).
    pub jobs: usize,
    /// Evaluation episodes per agent and seed.
    pub eval_episodes: usize,
    /// The hybrid's residual setup.
    pub residual: ResidualConfig,
    /// Deterministic evaluations during training every this many steps (see
    /// [`ExperimentOptions::eval_every`]).
    pub eval_every: Option<u64>,
    /// Keep the seeds already finished in `out` with the same options (their
    /// `experiment.json` identity), run the others (replacing a seed's partial run of
    /// these options); a seed's directory holding a run of other options is refused before
    /// anything trains ([`crate::experiment::check_resumable`]).
    pub resume: bool,
    /// Replace a comparison already in `out` (its files only) instead of refusing.
    pub overwrite: bool,
    /// `[env]` settings over the robot's preset for both agents and the controller (empty:
    /// the preset).
    pub env_settings: EnvSettings,
    /// A finished comparison whose pure-RL agents are reused, seed by seed, instead of
    /// trained again (see [`ExperimentOptions::pure_from`]): an ablation of the hybrid then
    /// costs the hybrid's training alone. Its seeds must have been run with the same options
    /// but for the hybrid's setup.
    pub pure_from: Option<PathBuf>,
    /// The resolved run spec these options came from, written as `spec.json` into `out`
    /// (`None`: none is written).
    pub spec: Option<ResolvedSpec>,
    /// The command line that asked for the comparison, for the header of `results.md`.
    pub command: Option<String>,
}

impl CompareOptions {
    /// The comparison a resolved spec describes, into `out`, one seed at a time on one
    /// thread, neither resumed nor replacing; refused for a spec without a hybrid (one
    /// resolved for `train` on pure RL).
    pub fn from_spec(spec: &ResolvedSpec, out: PathBuf) -> Result<CompareOptions, crate::spec::SpecError> {
        let residual = spec.hybrid.clone().ok_or_else(|| crate::spec::SpecError::NotAHybrid {
            table: "hybrid",
            reason: format!("the spec of `{}` has no hybrid to compare", spec.robot),
        })?;
        Ok(CompareOptions {
            env: spec.robot.clone(),
            algo: spec.learner_config(),
            hybrid_algo: spec.hybrid_learner_config(),
            seeds: spec.seeds,
            steps: spec.steps,
            out,
            n_envs: spec.envs,
            threads: 1,
            jobs: 1,
            eval_episodes: spec.eval_episodes,
            residual,
            eval_every: (spec.eval_every > 0).then_some(spec.eval_every),
            resume: false,
            overwrite: false,
            env_settings: spec.env.clone(),
            pure_from: None,
            spec: Some(spec.clone()),
            command: None,
        })
    }
}

/// Across-seed statistics of one agent.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Aggregate {
    /// Interquartile mean over seeds of the mean evaluation return ([`crate::stats::iqm`]).
    pub return_iqm: f64,
    /// Its 95 % stratified-bootstrap confidence interval (2,000 resamples of the seeds).
    pub return_iqm_ci95: Option<Interval>,
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
    /// Both learners' deterministic evaluations at each training budget, across seeds.
    pub budgets: Vec<BudgetRow>,
    /// The comparison whose pure-RL agents were reused ([`CompareOptions::pure_from`]): the
    /// pure-RL wall times are then that run's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pure_from: Option<PathBuf>,
    /// The hybrid's own hyperparameters ([`CompareOptions::hybrid_algo`]), as Rust's `Debug`
    /// writes them; absent where the hybrid learnt with the pure-RL agent's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hybrid_learner: Option<String>,
    /// The hybrid against pure RL, read off `budgets` and the final evaluations: at every
    /// budget, the samples it takes to reach pure RL's final return, at equal wall-clock.
    pub head_to_head: HeadToHead,
}

/// The hybrid against pure RL, read off the evaluations the way issue 23 puts its bars: at
/// every evaluated budget, the samples the hybrid needs to reach pure RL's final return,
/// and at equal training wall-clock. Every figure is an IQM over seeds (the budgets' and the
/// final evaluations'); [`HeadToHead::from_budgets`] computes it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct HeadToHead {
    /// Budgets evaluated during training (`--eval-every`; the rows of
    /// [`CompareSummary::budgets`]).
    pub budgets: usize,
    /// Budgets where the hybrid's IQM is at least pure RL's.
    pub hybrid_at_or_above: usize,
    /// The budgets (training samples) where the hybrid's IQM is below pure RL's.
    pub hybrid_below_at: Vec<u64>,
    /// Budgets where the hybrid fell in fewer evaluation episodes than pure RL.
    pub fewer_falls: usize,
    /// Budgets where both fell in as many episodes.
    pub as_many_falls: usize,
    /// Pure RL's final return (IQM over seeds of its final evaluation): the return to reach.
    pub pure_final_iqm: f64,
    /// Pure RL's training samples per seed.
    pub pure_samples: u64,
    /// The hybrid's samples at its first budget whose IQM reaches `pure_final_iqm` (its
    /// final evaluation counting after its last budget); `None` where none does.
    pub hybrid_reaches_pure_final_at: Option<u64>,
    /// `hybrid_reaches_pure_final_at` as a fraction of `pure_samples` (issue 23's bar: ≤ ¼).
    pub fraction_of_pure_samples: Option<f64>,
    /// The hybrid at each of pure RL's evaluation times.
    pub equal_wall_clock: EqualWallClock,
}

/// The hybrid at each of pure RL's evaluation times: its latest evaluation by then.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct EqualWallClock {
    /// One point per pure-RL evaluation of the budget rows, in order.
    pub points: Vec<WallClockPoint>,
    /// Points where the hybrid's latest IQM is at least pure RL's.
    pub hybrid_at_or_above: usize,
    /// Pure RL's times were measured in another run (`--pure-from`), under another load, so
    /// they compare less surely with the hybrid's.
    pub pure_times_from_another_run: bool,
}

/// Pure RL's evaluation at one budget and the hybrid's latest evaluation by that time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct WallClockPoint {
    /// Pure RL's training wall-clock seconds to this budget (mean over seeds).
    pub seconds: f64,
    /// Pure RL's samples at this budget.
    pub pure_env_steps: u64,
    /// Pure RL's IQM at this budget.
    pub pure_iqm: f64,
    /// The hybrid's samples at its latest budget whose training time (the mean over seeds)
    /// is within `seconds`; 0 before its first, where the hybrid is still the controller
    /// alone (the untrained deterministic hybrid acts exactly as its controller) and
    /// `hybrid_iqm` is the controller's.
    pub hybrid_env_steps: u64,
    /// The hybrid's IQM there.
    pub hybrid_iqm: f64,
}

impl HeadToHead {
    /// Reads the head-to-head off the budget rows and the three agents' final evaluations;
    /// `pure_reused`: pure RL's agents (and so their wall times) come from another run.
    pub fn from_budgets(
        budgets: &[BudgetRow],
        hybrid: &Aggregate,
        pure: &Aggregate,
        controller: &Aggregate,
        pure_reused: bool,
    ) -> Self {
        let below: Vec<u64> = budgets
            .iter()
            .filter(|b| !at_or_above(b.hybrid_iqm, b.pure_iqm))
            .map(|b| b.hybrid_env_steps)
            .collect();
        let target = pure.return_iqm;
        let hybrid_final_steps = hybrid.per_seed.first().map_or(0, |s| s.env_steps);
        let pure_samples = pure.per_seed.first().map_or(0, |s| s.env_steps);
        let reached = budgets
            .iter()
            .map(|b| (b.hybrid_env_steps, b.hybrid_iqm))
            .chain(std::iter::once((hybrid_final_steps, hybrid.return_iqm)))
            .find(|&(_, r)| at_or_above(r, target))
            .map(|(steps, _)| steps);
        // A row whose pure-RL evaluation is the row before's (the last row pairs the hybrid's
        // final evaluation with pure RL's last when their rollouts end apart) is one time.
        let points: Vec<WallClockPoint> = budgets
            .iter()
            .enumerate()
            .filter(|&(k, p)| k == 0 || budgets[k - 1].pure_env_steps != p.pure_env_steps)
            .map(|(_, p)| {
                let (hybrid_env_steps, hybrid_iqm) = budgets
                    .iter()
                    .rev()
                    .find(|h| h.hybrid_wall_seconds <= p.pure_wall_seconds)
                    .map_or((0, controller.return_iqm), |h| (h.hybrid_env_steps, h.hybrid_iqm));
                WallClockPoint {
                    seconds: p.pure_wall_seconds,
                    pure_env_steps: p.pure_env_steps,
                    pure_iqm: p.pure_iqm,
                    hybrid_env_steps,
                    hybrid_iqm,
                }
            })
            .collect();
        HeadToHead {
            budgets: budgets.len(),
            hybrid_at_or_above: budgets.len() - below.len(),
            hybrid_below_at: below,
            fewer_falls: budgets.iter().filter(|b| b.hybrid_falls.0 < b.pure_falls.0).count(),
            as_many_falls: budgets.iter().filter(|b| b.hybrid_falls.0 == b.pure_falls.0).count(),
            pure_final_iqm: target,
            pure_samples,
            hybrid_reaches_pure_final_at: reached,
            fraction_of_pure_samples: reached
                .filter(|_| pure_samples > 0)
                .map(|s| s as f64 / pure_samples as f64),
            equal_wall_clock: EqualWallClock {
                hybrid_at_or_above: points.iter().filter(|p| at_or_above(p.hybrid_iqm, p.pure_iqm)).count(),
                points,
                pure_times_from_another_run: pure_reused,
            },
        }
    }

    /// The head-to-head in a few lines of text (what `centaur compare` prints).
    pub fn text(&self) -> String {
        let mut t = String::new();
        if self.budgets == 0 {
            t += "- no evaluations during training (`--eval-every`): no budgets to compare\n";
        } else {
            t += &format!(
                "- by budget: the hybrid's IQM at or above pure RL's at {} of {} budgets{}; fewer falls at {}, as many at {}\n",
                self.hybrid_at_or_above,
                self.budgets,
                if self.hybrid_below_at.is_empty() {
                    String::new()
                } else {
                    format!(" (below at {})", join(self.hybrid_below_at.iter().map(|s| s.to_string())))
                },
                self.fewer_falls,
                self.as_many_falls
            );
        }
        t += &match (self.hybrid_reaches_pure_final_at, self.fraction_of_pure_samples) {
            (Some(at), Some(f)) => format!(
                "- pure RL's final return ({:.2}) reached by the hybrid at {at} samples: {f:.3} of pure RL's {}\n",
                self.pure_final_iqm, self.pure_samples
            ),
            (Some(at), None) => {
                format!(
                    "- pure RL's final return ({:.2}) reached by the hybrid at {at} samples\n",
                    self.pure_final_iqm
                )
            }
            (None, _) => format!(
                "- pure RL's final return ({:.2}) not reached by the hybrid at any budget\n",
                self.pure_final_iqm
            ),
        };
        let w = &self.equal_wall_clock;
        if !w.points.is_empty() {
            let below = w.points.iter().filter(|p| !at_or_above(p.hybrid_iqm, p.pure_iqm));
            let below: Vec<String> =
                below.map(|p| format!("{:.0} s by {:.2}", p.seconds, p.pure_iqm - p.hybrid_iqm)).collect();
            t += &format!(
                "- at equal wall-clock (the hybrid's latest evaluation at each of pure RL's evaluation times; the controller alone before its first): at or above pure RL at {} of {}{}{}\n",
                w.hybrid_at_or_above,
                w.points.len(),
                if below.is_empty() {
                    String::new()
                } else {
                    format!(" (below at {})", join(below.into_iter()))
                },
                if w.pure_times_from_another_run {
                    "; pure RL's times are those of the run its agents were reused from, under another load"
                } else {
                    ""
                }
            );
        }
        t
    }
}

/// `hybrid ≥ pure`; false where either is NaN, so a NaN budget counts as below, never above.
fn at_or_above(hybrid: f64, pure: f64) -> bool {
    hybrid >= pure
}

fn join(items: impl Iterator<Item = String>) -> String {
    items.collect::<Vec<_>>().join(", ")
}

/// Both learners at one training budget, across seeds.
#[derive(Clone, Debug, Serialize)]
pub struct BudgetRow {
    /// Training environment steps (per agent and seed): the larger of the two agents' at
    /// this evaluation (each pauses at its own rollout boundary, so with the hybrid's own
    /// rollout length, [`CompareOptions::hybrid_algo`], they are up to a rollout apart; each
    /// agent's own count is `hybrid_env_steps` and `pure_env_steps`).
    pub env_steps: u64,
    /// The hybrid's training environment steps at this evaluation (per seed).
    pub hybrid_env_steps: u64,
    /// Pure RL's training environment steps at this evaluation (per seed).
    pub pure_env_steps: u64,
    /// The hybrid's IQM over seeds of the mean evaluation return, and its 95 % CI.
    pub hybrid_iqm: f64,
    /// See `hybrid_iqm`.
    pub hybrid_ci95: Option<Interval>,
    /// Pure RL's IQM and 95 % CI.
    pub pure_iqm: f64,
    /// See `pure_iqm`.
    pub pure_ci95: Option<Interval>,
    /// Mean over seeds of the hybrid's training wall-clock seconds to this budget.
    pub hybrid_wall_seconds: f64,
    /// Mean over seeds of pure RL's training wall-clock seconds to this budget.
    pub pure_wall_seconds: f64,
    /// The hybrid's falls / episodes over all seeds.
    pub hybrid_falls: (usize, usize),
    /// Pure RL's falls / episodes over all seeds.
    pub pure_falls: (usize, usize),
}

/// Across-seed statistics at every budget all seeds evaluated (seeds share `eval_every`).
fn budget_rows(runs: &[ExperimentSummary]) -> Vec<BudgetRow> {
    let n = runs.iter().map(|r| r.hybrid_budgets.len().min(r.pure_budgets.len())).min().unwrap_or(0);
    (0..n)
        .map(|k| {
            let h: Vec<&BudgetEval> = runs.iter().map(|r| &r.hybrid_budgets[k]).collect();
            let p: Vec<&BudgetEval> = runs.iter().map(|r| &r.pure_budgets[k]).collect();
            let (hybrid_iqm, hybrid_ci95) = iqm_with_ci(&h.iter().map(|b| b.return_mean).collect::<Vec<_>>());
            let (pure_iqm, pure_ci95) = iqm_with_ci(&p.iter().map(|b| b.return_mean).collect::<Vec<_>>());
            let wall = |v: &[&BudgetEval]| mean_std(&v.iter().map(|b| b.wall_seconds).collect::<Vec<_>>()).0;
            let falls =
                |v: &[&BudgetEval]| (v.iter().map(|b| b.falls).sum(), v.iter().map(|b| b.episodes).sum());
            BudgetRow {
                env_steps: h[0].env_steps.max(p[0].env_steps),
                hybrid_env_steps: h[0].env_steps,
                pure_env_steps: p[0].env_steps,
                hybrid_iqm,
                hybrid_ci95,
                pure_iqm,
                pure_ci95,
                hybrid_wall_seconds: wall(&h),
                pure_wall_seconds: wall(&p),
                hybrid_falls: falls(&h),
                pure_falls: falls(&p),
            }
        })
        .collect()
}

impl CompareSummary {
    /// The learners at each training budget in Markdown: return IQM [95 % CI] over seeds,
    /// falls and training wall time.
    pub fn budget_table(&self) -> String {
        let ci =
            |c: Option<Interval>| c.map_or("—".to_string(), |i| format!("[{:.2}, {:.2}]", i.low, i.high));
        let mut t = String::from(
            "| samples | hybrid IQM [95 % CI] | pure RL IQM [95 % CI] | hybrid falls | pure falls | hybrid / pure wall (s) |\n|---:|---:|---:|---:|---:|---:|\n",
        );
        for b in &self.budgets {
            let samples = if b.hybrid_env_steps == b.pure_env_steps {
                b.env_steps.to_string()
            } else {
                format!("{} (hybrid) / {} (pure)", b.hybrid_env_steps, b.pure_env_steps)
            };
            t += &format!(
                "| {} | {:.2} {} | {:.2} {} | {}/{} | {}/{} | {:.0} / {:.0} |\n",
                samples,
                b.hybrid_iqm,
                ci(b.hybrid_ci95),
                b.pure_iqm,
                ci(b.pure_ci95),
                b.hybrid_falls.0,
                b.hybrid_falls.1,
                b.pure_falls.0,
                b.pure_falls.1,
                b.hybrid_wall_seconds,
                b.pure_wall_seconds
            );
        }
        t
    }

    /// The across-seed table in Markdown: return (mean ± std over seeds), forward speed,
    /// falls over all evaluation episodes and cost of transport of the three agents.
    pub fn markdown_table(&self) -> String {
        let row = |name: &str, a: &Aggregate| {
            let cot = a.cost_of_transport.map_or("—".to_string(), |c| format!("{c:.2}"));
            let ci =
                a.return_iqm_ci95.map_or("—".to_string(), |i| format!("[{:.2}, {:.2}]", i.low, i.high));
            format!(
                "| {name} | {:.2} {ci} | {:.2} ± {:.2} | {:.3} ± {:.3} | {}/{} | {cot} |\n",
                a.return_iqm,
                a.return_mean,
                a.return_std,
                a.mean_speed,
                a.mean_speed_std,
                a.falls,
                a.episodes
            )
        };
        let mut t = String::from(
            "| agent | return IQM [95 % CI] over seeds | return (mean ± std over seeds) | forward speed (m/s) | falls | cost of transport |\n|---|---:|---:|---:|---:|---:|\n",
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
    let (return_iqm, return_iqm_ci95) = iqm_with_ci(&stats.iter().map(|s| s.return_mean).collect::<Vec<_>>());
    let cots: Vec<f64> = stats.iter().filter_map(|s| s.cost_of_transport).collect();
    Aggregate {
        return_iqm,
        return_iqm_ci95,
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

/// Resamples each seed's curve on a common grid (linear interpolation between its finite
/// points — records without a finished episode are NaN — held flat outside its range) and
/// returns the across-seed mean with a ± one-std band.
pub fn band(label: &str, curves: &[Curve], steps: u64, points: usize) -> Series {
    let curves: Vec<Curve> =
        curves.iter().map(|c| c.iter().copied().filter(|p| p.1.is_finite()).collect()).collect();
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
///
/// `progress` is called with the seed, the phase and the update's metrics; with
/// `jobs > 1` it is called from the seeds' threads (one at a time).
pub fn run_compare(
    opts: &CompareOptions,
    progress: &mut (dyn FnMut(u64, Phase, &UpdateMetrics) + Send),
) -> Result<CompareSummary, ExperimentError> {
    let started = std::time::Instant::now();
    crate::rundir::check_not_file(&opts.out)
        .map_err(|source| ExperimentError::Io { path: opts.out.clone(), source })?;
    if let Some(from) = &opts.pure_from {
        // Replacing or resuming this comparison would write over the runs to be reused.
        if crate::rundir::same_path(from, &opts.out) {
            return Err(ExperimentError::PureFromItself { dir: opts.out.clone() });
        }
        if !from.join("seed_0").join("experiment.json").is_file() {
            return Err(ExperimentError::NotAComparison { dir: from.clone() });
        }
    }
    if !opts.resume && !opts.overwrite {
        let taken = |f: &str| opts.out.join(f).exists();
        if let Some(file) = ["compare.json", "seed_0"].into_iter().find(|f| taken(f)) {
            return Err(ExperimentError::RunExists { dir: opts.out.clone(), file });
        }
    }
    let seeds = opts.seeds.max(1);
    let seed_options = |seed: u64| ExperimentOptions {
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
        eval_every: opts.eval_every,
        // A seed's partial run (killed before its summary) is replaced on resume.
        overwrite: opts.resume || opts.overwrite,
        env_settings: opts.env_settings.clone(),
        pure_from: opts.pure_from.as_ref().map(|dir| dir.join(format!("seed_{seed}"))),
        hybrid_algo: opts.hybrid_algo.clone(),
    };
    // Every seed's pure-RL agent to reuse, and on resume every seed's directory, is checked
    // before the first seed trains: a resume replaces only runs of these options killed
    // before their summary, never a run of other options (a mistyped flag once replaced two
    // finished seeds).
    for seed in 0..seeds {
        let exp = seed_options(seed);
        if let Some(from) = &exp.pure_from {
            crate::experiment::check_pure_source(from, &exp)?;
        }
        if opts.resume && !opts.overwrite {
            check_resumable(&exp)?;
        }
    }
    if let Some(spec) = &opts.spec {
        check_spec(&opts.out, spec)?;
    }
    let run_seed = |seed: u64, progress: &mut dyn FnMut(u64, Phase, &UpdateMetrics)| {
        let exp = seed_options(seed);
        match opts.resume.then(|| finished_experiment(&exp)).flatten() {
            Some(r) => {
                progress(seed, Phase::Evaluate, &UpdateMetrics::default());
                Ok(r)
            }
            None => run_experiment(&exp, &mut |phase, m| progress(seed, phase, m)),
        }
    };
    // Seeds run `jobs` at a time, each result kept at its seed: the summary is the same for
    // any number of jobs.
    let progress = Mutex::new(progress);
    let results = crate::jobs::run_indexed(seeds as usize, opts.jobs, |k| {
        run_seed(k as u64, &mut |seed, phase, m| {
            let mut p = progress.lock().unwrap_or_else(|e| e.into_inner());
            (*p)(seed, phase, m)
        })
    });
    let (mut runs, mut pure_curves, mut hybrid_curves) = (Vec::new(), Vec::new(), Vec::new());
    for result in results {
        match result {
            Some(Ok(r)) => {
                runs.push(r.summary);
                pure_curves.push(r.pure_curve);
                hybrid_curves.push(r.hybrid_curve);
            }
            Some(Err(e)) => return Err(e),
            // Not started because an earlier seed failed: that failure is returned first.
            None => {}
        }
    }
    let (hybrid, pure_rl, controller) = (
        aggregate(&runs, |r| &r.hybrid),
        aggregate(&runs, |r| &r.pure_rl),
        aggregate(&runs, |r| &r.controller),
    );
    let budgets = budget_rows(&runs);
    let head_to_head =
        HeadToHead::from_budgets(&budgets, &hybrid, &pure_rl, &controller, opts.pure_from.is_some());
    let summary = CompareSummary {
        env: opts.env.clone(),
        algo: opts.algo.kind().name().to_string(),
        seeds,
        steps: opts.steps,
        hybrid,
        pure_rl,
        controller,
        budgets,
        pure_from: opts.pure_from.as_deref().map(crate::rundir::recorded_path),
        hybrid_learner: opts.hybrid_algo.as_ref().map(|h| format!("{h:?}")),
        head_to_head,
    };
    if let Some(spec) = &opts.spec {
        let path = opts.out.join("spec.json");
        crate::rundir::write_atomic(&path, &spec.record_json())
            .map_err(|source| ExperimentError::Io { path: path.clone(), source })?;
    }
    let path = opts.out.join("compare.json");
    let text = serde_json::to_string_pretty(&summary)
        .map_err(|e| ExperimentError::Io { path: path.clone(), source: e.into() })?;
    crate::rundir::write_atomic(&path, &(text + "\n"))
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
    // The deterministic evaluations: IQM with its 95 % CI against samples and against
    // training wall-clock time.
    let eval_series = |x: &dyn Fn(&BudgetRow, bool) -> f64| {
        [true, false].map(|hybrid| {
            let pick = |b: &BudgetRow| {
                if hybrid { (b.hybrid_iqm, b.hybrid_ci95) } else { (b.pure_iqm, b.pure_ci95) }
            };
            let rows = &summary.budgets;
            Series {
                label: format!("{} (IQM, 95 % CI over seeds)", if hybrid { "hybrid" } else { "pure RL" }),
                x: rows.iter().map(|b| x(b, hybrid)).collect(),
                y: rows.iter().map(|b| pick(b).0).collect(),
                lower: Some(rows.iter().map(|b| pick(b).1.map_or(pick(b).0, |i| i.low)).collect()),
                upper: Some(rows.iter().map(|b| pick(b).1.map_or(pick(b).0, |i| i.high)).collect()),
            }
        })
    };
    let by_steps = eval_series(&|b, _| b.env_steps as f64);
    let by_wall = eval_series(&|b, hybrid| if hybrid { b.hybrid_wall_seconds } else { b.pure_wall_seconds });
    for (name, x, series) in [
        ("eval_curves", "environment steps", by_steps),
        ("eval_curves_wall", "training wall-clock seconds", by_wall),
    ] {
        let labels = PlotLabels {
            title: format!(
                "{} on {}: deterministic evaluation, {} seeds",
                opts.algo.kind().name(),
                opts.env,
                summary.seeds
            ),
            x: x.into(),
            y: "evaluation return".into(),
        };
        for ext in ["png", "svg"] {
            match plot_curves(&opts.out.join(format!("{name}.{ext}")), &labels, &series) {
                Ok(()) | Err(PlotError::Empty { .. }) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }
    let path = opts.out.join("results.md");
    crate::rundir::write_atomic(
        &path,
        &results_markdown(opts, &summary, &runs, started.elapsed().as_secs_f64()),
    )
    .map_err(|source| ExperimentError::Io { path: path.clone(), source })?;
    Ok(summary)
}

/// Refuses to resume or extend a comparison whose `spec.json` (written when it finished,
/// beside `compare.json`) records another identity: its seeds were run with other options.
fn check_spec(dir: &Path, spec: &ResolvedSpec) -> Result<(), ExperimentError> {
    let path = dir.join("spec.json");
    if let Ok(text) = crate::rundir::read_text_bounded(&path, crate::spec::MAX_SPEC_BYTES)
        && let Ok(recorded) = serde_json::from_str::<crate::spec::SpecRecord>(&text)
        && recorded.identity != spec.identity()
    {
        return Err(ExperimentError::SpecChanged {
            dir: dir.to_path_buf(),
            recorded: recorded.identity,
            given: spec.identity(),
        });
    }
    Ok(())
}

/// The machine a result was measured on: the CPU model and its logical cores.
pub fn host_description() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, m)| m.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{model}, {cores} logical cores, {}", std::env::consts::OS)
}

/// `results.md`: the command and the spec in its header, then the tables over seeds (IQM
/// with 95 % bootstrap CIs), the head-to-head, the host and the wall time, and the plots.
pub fn results_markdown(
    opts: &CompareOptions,
    s: &CompareSummary,
    runs: &[ExperimentSummary],
    elapsed: f64,
) -> String {
    use std::fmt::Write as _;
    let mut md = String::new();
    let learner = opts.algo.kind().name().to_uppercase();
    let _ = writeln!(md, "# {learner} on {}: pure RL, the hybrid and the controller alone\n", s.env);
    let _ = writeln!(md, "Generated by `centaur compare`; do not edit by hand (rerun the command).\n");
    if let Some(command) = &opts.command {
        let _ = writeln!(md, "```sh\n{command}\n```\n");
    }
    if let Some(spec) = &opts.spec {
        let _ = writeln!(
            md,
            "Spec identity `{}` (the resolved spec is `spec.json` beside this page).\n",
            spec.identity()
        );
    }
    let _ = writeln!(
        md,
        "{} seeds × {} steps per agent, {} deterministic evaluation episodes per agent and seed; IQM over seeds with 95 % stratified-bootstrap CIs.\n",
        s.seeds, s.steps, opts.eval_episodes
    );
    md.push_str(&s.markdown_table());
    if s.budgets.len() > 1 {
        md.push_str("\n## By training budget (deterministic evaluation)\n\n");
        md.push_str(&s.budget_table());
    }
    md.push_str("\n## The hybrid against pure RL\n\n");
    md.push_str(&s.head_to_head.text());
    md.push_str("\n## Seeds, host and wall time\n\n| seed | hybrid return | pure RL return | controller return | hybrid training wall (s) | pure RL training wall (s) |\n|---:|---:|---:|---:|---:|---:|\n");
    for (k, r) in runs.iter().enumerate() {
        let _ = writeln!(
            md,
            "| {k} | {:.2} ({} falls of {}) | {:.2} ({} falls of {}) | {:.2} | {:.0} | {:.0} |",
            r.hybrid.return_mean,
            r.hybrid.falls,
            r.hybrid.episodes,
            r.pure_rl.return_mean,
            r.pure_rl.falls,
            r.pure_rl.episodes,
            r.controller.return_mean,
            r.hybrid.wall_seconds,
            r.pure_rl.wall_seconds
        );
    }
    let _ = writeln!(
        md,
        "\nHost: {}; threads per agent {}, seeds at once {}. This invocation took {:.0} s (seeds kept by `--resume` cost nothing).\n",
        host_description(),
        opts.threads,
        opts.jobs,
        elapsed
    );
    md.push_str("![learning curves](learning_curves.png)\n\n![evaluation by budget](eval_curves.png)\n\n![evaluation by wall-clock](eval_curves_wall.png)\n");
    md
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

    #[test]
    fn each_budget_row_keeps_both_agents_sample_counts() {
        // The hybrid at its own rollout (512 samples) pauses before pure RL (1024) does.
        let eval = |env_steps, return_mean| BudgetEval {
            env_steps,
            return_mean,
            episodes: 10,
            ..Default::default()
        };
        let run = |h: f64, p: f64| ExperimentSummary {
            hybrid: AgentStats::default(),
            pure_rl: AgentStats::default(),
            controller: AgentStats::default(),
            hybrid_budgets: vec![eval(100_352, h), eval(200_704, h + 1.0)],
            pure_budgets: vec![eval(102_400, p), eval(200_704, p + 1.0)],
        };
        let rows = budget_rows(&[run(20.0, 5.0), run(22.0, 7.0)]);
        assert_eq!(rows.len(), 2);
        assert_eq!(
            (rows[0].env_steps, rows[0].hybrid_env_steps, rows[0].pure_env_steps),
            (102_400, 100_352, 102_400)
        );
        assert_eq!(
            (rows[1].env_steps, rows[1].hybrid_env_steps, rows[1].pure_env_steps),
            (200_704, 200_704, 200_704)
        );
        assert!((rows[0].hybrid_iqm - 21.0).abs() < 1e-12 && (rows[1].pure_iqm - 7.0).abs() < 1e-12);
        let summary = CompareSummary {
            env: "minitaur".into(),
            algo: "ppo".into(),
            seeds: 2,
            steps: 200_000,
            hybrid: Aggregate::default(),
            pure_rl: Aggregate::default(),
            controller: Aggregate::default(),
            budgets: rows,
            pure_from: None,
            hybrid_learner: None,
            head_to_head: HeadToHead::default(),
        };
        let table = summary.budget_table();
        assert!(table.contains("| 100352 (hybrid) / 102400 (pure) |"), "{table}");
        assert!(table.contains("| 200704 |"), "{table}");
    }

    #[test]
    fn the_head_to_head_reads_budgets_the_quarter_and_equal_wall_clock_as_issue_23_puts_them() {
        // Three budgets; the hybrid costs twice pure RL's time per sample.
        let row = |steps: u64, h: f64, p: f64, h_wall: f64, p_wall: f64, h_falls: usize, p_falls: usize| {
            BudgetRow {
                env_steps: steps,
                hybrid_env_steps: steps,
                pure_env_steps: steps,
                hybrid_iqm: h,
                hybrid_ci95: None,
                pure_iqm: p,
                pure_ci95: None,
                hybrid_wall_seconds: h_wall,
                pure_wall_seconds: p_wall,
                hybrid_falls: (h_falls, 50),
                pure_falls: (p_falls, 50),
            }
        };
        let budgets = [
            row(100, 20.0, 10.0, 20.0, 10.0, 1, 5),
            row(200, 25.0, 26.0, 40.0, 20.0, 2, 2),
            row(300, 31.0, 30.0, 60.0, 30.0, 0, 1),
        ];
        let agent = |iqm: f64, steps: u64| Aggregate {
            return_iqm: iqm,
            per_seed: vec![AgentStats { env_steps: steps, ..Default::default() }],
            ..Default::default()
        };
        let (hybrid, pure, controller) = (agent(31.5, 300), agent(30.5, 300), agent(12.0, 0));
        let h = HeadToHead::from_budgets(&budgets, &hybrid, &pure, &controller, false);
        // By budget: at or above at 100 and 300, below at 200; fewer falls at 100 and 300,
        // as many at 200.
        assert_eq!((h.budgets, h.hybrid_at_or_above, h.hybrid_below_at.clone()), (3, 2, vec![200]));
        assert_eq!((h.fewer_falls, h.as_many_falls), (2, 1));
        // Pure RL's final 30.5: the hybrid's 31.0 at 300 is the first to reach it, 300 / 300 = 1.
        assert_eq!((h.pure_final_iqm, h.pure_samples), (30.5, 300));
        assert_eq!((h.hybrid_reaches_pure_final_at, h.fraction_of_pure_samples), (Some(300), Some(1.0)));
        // Equal wall-clock: at pure RL's 10 s the hybrid has no evaluation yet (its first at
        // 20 s): the controller's 12 against 10, at or above; at 20 s its 100-sample 20
        // against 26, below by 6; at 30 s still its 100-sample 20 against 30, below by 10.
        let w = &h.equal_wall_clock;
        let seen: Vec<(f64, u64, f64)> =
            w.points.iter().map(|p| (p.seconds, p.hybrid_env_steps, p.hybrid_iqm)).collect();
        assert_eq!(seen, [(10.0, 0, 12.0), (20.0, 100, 20.0), (30.0, 100, 20.0)]);
        assert_eq!((w.hybrid_at_or_above, w.pure_times_from_another_run), (1, false));
        let text = h.text();
        assert!(text.contains("at 2 of 3 budgets (below at 200); fewer falls at 2, as many at 1"), "{text}");
        assert!(
            text.contains("(30.50) reached by the hybrid at 300 samples: 1.000 of pure RL's 300"),
            "{text}"
        );
        assert!(
            text.contains("at or above pure RL at 1 of 3 (below at 20 s by 6.00, 30 s by 10.00)"),
            "{text}"
        );
        // A last row pairing the hybrid's final evaluation with pure RL's last one again (their
        // rollouts end apart): a budget of its own, but not another of pure RL's times.
        let mut paired = budgets.to_vec();
        paired.push(BudgetRow {
            hybrid_env_steps: 310,
            hybrid_iqm: 31.5,
            hybrid_wall_seconds: 62.0,
            ..budgets[2]
        });
        let h = HeadToHead::from_budgets(&paired, &hybrid, &pure, &controller, false);
        assert_eq!((h.budgets, h.hybrid_at_or_above, h.equal_wall_clock.points.len()), (4, 3, 3));
        // A target never reached, pure RL's agents reused from another run, a NaN budget
        // counted below (never silently above).
        let mut nan = budgets.clone();
        nan[0].hybrid_iqm = f64::NAN;
        let h = HeadToHead::from_budgets(&nan, &hybrid, &agent(40.0, 1200), &controller, true);
        assert_eq!((h.hybrid_reaches_pure_final_at, h.fraction_of_pure_samples), (None, None));
        assert_eq!(h.hybrid_below_at, vec![100, 200]);
        assert!(h.text().contains("(40.00) not reached by the hybrid at any budget"), "{}", h.text());
        assert!(h.text().contains("under another load"), "{}", h.text());
        // No budgets: said so, and the final evaluations still answer the return question.
        let h = HeadToHead::from_budgets(&[], &hybrid, &pure, &controller, false);
        assert_eq!(h.hybrid_reaches_pure_final_at, Some(300));
        assert!(h.text().contains("no evaluations during training"), "{}", h.text());
    }
}
