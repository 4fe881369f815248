//! `centaur sweep`: a grid (or a list) of run-file settings × seeds, run in parallel over the
//! machine's cores, resumable, summarised per point as the interquartile mean over seeds
//! with its 95 % stratified-bootstrap confidence interval (Agarwal et al. 2021) and as
//! learning curves with bands. Any environment `centaur train` takes (no controller needed).
//!
//! ## The grid file
//!
//! ```toml
//! env = "walker2d"          # what every run trains on
//! algo = "ppo"
//! steps = 200000
//! envs = 1                  # optional: environments per run (default 1)
//! eval_episodes = 10        # optional (default 10)
//! checkpoint_every = 100000 # optional (default: `centaur train`'s)
//!
//! [base]                    # optional: run-file keys shared by every point
//! n_steps = 2048
//! [base.env]
//! healthy_reward = 1.0
//!
//! [grid]                    # every combination of these values (keys in sorted order);
//! learning_rate = [3e-4, 1e-4]
//! "env.ctrl_cost_weight" = [1e-3, 0.0]   # `env.KEY`: a key of the [env] table
//!
//! # …or, instead of [grid], a list of points:
//! # [[points]]
//! # learning_rate = 3e-4
//! ```
//!
//! ## The output directory
//!
//! | file | content |
//! |---|---|
//! | `sweep.toml` | the grid file as given (a rerun with another grid is refused) |
//! | `pNNN/config.toml` | the point's run file (base + its values) |
//! | `pNNN/seed_K/` | a `centaur train` run directory |
//! | `sweep.json` | per point: its values, every seed's final return, IQM with 95 % CI, mean and std |
//! | `sweep_curves.png`, `.svg` | the training return per point: mean over seeds ± one std |
//!
//! A rerun of the same grid keeps every finished run (its `summary.json`), resumes every
//! interrupted one from its last checkpoint and starts the rest.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use centaur_rl::{AlgoKind, MetricsCsv};
use serde::{Deserialize, Serialize};

use crate::compare::band;
use crate::plot::{PlotError, PlotLabels, plot_curves};
use crate::registry::EnvSource;
use crate::rundir::write_atomic;
use crate::stats::{Interval, iqm_with_ci};
use crate::train::{
    DEFAULT_CHECKPOINT_EVERY, Summary, TrainError, TrainOptions, parse_run_config, read_config_file, resume,
    train,
};

/// The most runs (points × seeds) one sweep may hold.
pub const MAX_RUNS: usize = 100_000;

/// The grid file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// Environment of every run.
    pub env: String,
    /// Algorithm of every run.
    pub algo: String,
    /// Environment steps per run.
    pub steps: u64,
    /// Environments per run.
    #[serde(default = "one")]
    pub envs: usize,
    /// Deterministic evaluation episodes at the end of each run.
    #[serde(default = "ten")]
    pub eval_episodes: usize,
    /// Checkpoint period of each run (steps).
    #[serde(default)]
    pub checkpoint_every: Option<u64>,
    /// Run-file keys shared by every point.
    #[serde(default)]
    pub base: toml::Table,
    /// Values per key; the points are every combination.
    #[serde(default)]
    pub grid: BTreeMap<String, Vec<toml::Value>>,
    /// Or the points, listed.
    #[serde(default)]
    pub points: Vec<toml::Table>,
}

fn one() -> usize {
    1
}

fn ten() -> usize {
    10
}

/// One point of the grid: its name, its values and its run file.
#[derive(Clone, Debug)]
pub struct Point {
    /// `pNNN`.
    pub name: String,
    /// The values that make it a point (`key = value`, TOML).
    pub values: Vec<(String, String)>,
    /// Its run file.
    pub config: toml::Table,
}

/// What to sweep.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// The grid file.
    pub grid: PathBuf,
    /// Seeds per point (0..seeds).
    pub seeds: u64,
    /// Output directory.
    pub out: PathBuf,
    /// Runs at once (each on one thread).
    pub jobs: usize,
    /// Replace a sweep of another grid already in `out`.
    pub overwrite: bool,
}

/// One point's results.
#[derive(Clone, Debug, Serialize)]
pub struct PointSummary {
    /// `pNNN`.
    pub name: String,
    /// Its values.
    pub values: BTreeMap<String, String>,
    /// Every seed's final (deterministic evaluation) return, seed order.
    pub final_returns: Vec<f64>,
    /// Interquartile mean over seeds.
    pub return_iqm: f64,
    /// Its 95 % stratified-bootstrap confidence interval.
    pub return_iqm_ci95: Option<Interval>,
    /// Mean over seeds.
    pub return_mean: f64,
    /// Standard deviation over seeds.
    pub return_std: f64,
}

/// The `sweep.json` record.
#[derive(Clone, Debug, Serialize)]
pub struct SweepSummary {
    /// Environment.
    pub env: String,
    /// Algorithm.
    pub algo: String,
    /// Steps per run.
    pub steps: u64,
    /// Seeds per point.
    pub seeds: u64,
    /// The points.
    pub points: Vec<PointSummary>,
    /// Runs found finished in the directory and kept (this invocation).
    #[serde(skip)]
    pub kept_runs: usize,
}

/// Why a sweep failed.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The grid file is invalid.
    #[error("grid {path}: {message}")]
    Grid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The output directory holds a sweep of another grid.
    #[error("{dir} holds a sweep of another grid (sweep.toml); use --overwrite or another --out")]
    OtherGrid {
        /// The directory.
        dir: PathBuf,
    },
    /// A run failed (the others were finished or stopped; rerun to resume).
    #[error("{point} seed {seed}: {source}")]
    Run {
        /// The point.
        point: String,
        /// The seed.
        seed: u64,
        /// The failure.
        source: TrainError,
    },
    /// Files.
    #[error(transparent)]
    Train(#[from] TrainError),
    /// The plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// Sets `key` (dotted: `env.KEY` reaches into the `[env]` table) in `table`.
fn set_key(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    match key.split_once('.') {
        None => {
            table.insert(key.to_string(), value);
            Ok(())
        }
        Some((head, rest)) => {
            let inner =
                table.entry(head.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
            match inner {
                toml::Value::Table(t) => set_key(t, rest, value),
                _ => Err(format!("`{key}`: `{head}` is not a table")),
            }
        }
    }
}

/// The points of a grid (at least one; `[grid]` and `[[points]]` are exclusive).
pub fn points(grid: &Grid) -> Result<Vec<Point>, String> {
    let combos: Vec<Vec<(String, toml::Value)>> = match (grid.grid.is_empty(), grid.points.is_empty()) {
        (false, false) => return Err("give [grid] or [[points]], not both".into()),
        (true, true) => vec![Vec::new()],
        (true, false) => {
            grid.points.iter().map(|t| t.iter().map(|(k, v)| (k.clone(), v.clone())).collect()).collect()
        }
        (false, true) => {
            let mut total = 1usize;
            for (key, values) in &grid.grid {
                if values.is_empty() {
                    return Err(format!("[grid] {key} has no values"));
                }
                total = total
                    .checked_mul(values.len())
                    .filter(|&t| t <= MAX_RUNS)
                    .ok_or("more than 100000 points")?;
            }
            let mut combos = vec![Vec::new()];
            for (key, values) in &grid.grid {
                combos = combos
                    .into_iter()
                    .flat_map(|c: Vec<(String, toml::Value)>| {
                        values.iter().map(move |v| {
                            let mut c = c.clone();
                            c.push((key.clone(), v.clone()));
                            c
                        })
                    })
                    .collect();
            }
            debug_assert_eq!(combos.len(), total);
            combos
        }
    };
    combos
        .into_iter()
        .enumerate()
        .map(|(i, values)| {
            let mut config = grid.base.clone();
            for (k, v) in &values {
                set_key(&mut config, k, v.clone())?;
            }
            Ok(Point {
                name: format!("p{i:03}"),
                values: values.into_iter().map(|(k, v)| (k, v.to_string())).collect(),
                config,
            })
        })
        .collect()
}

/// Runs (or resumes) the sweep; `report` sees each run as it finishes (point, seed, summary).
pub fn run_sweep(
    opts: &SweepOptions,
    report: &(dyn Fn(&str, u64, &Summary) + Sync),
) -> Result<SweepSummary, SweepError> {
    let grid_err = |message: String| SweepError::Grid { path: opts.grid.clone(), message };
    let text = read_config_file(&opts.grid)?;
    let grid: Grid = toml::from_str(&text).map_err(|e| grid_err(e.to_string()))?;
    let kind =
        AlgoKind::from_name(&grid.algo).ok_or_else(|| grid_err(format!("unknown algo `{}`", grid.algo)))?;
    if opts.seeds == 0 || opts.jobs == 0 {
        return Err(grid_err("--seeds and --jobs must be at least 1".into()));
    }
    let points = points(&grid).map_err(grid_err)?;
    let runs = points.len().checked_mul(opts.seeds as usize).filter(|&n| n <= MAX_RUNS);
    let runs = runs.ok_or_else(|| {
        grid_err(format!("{} points × {} seeds exceed {MAX_RUNS} runs", points.len(), opts.seeds))
    })?;
    // Every point's settings are checked before anything runs.
    let source = EnvSource::read(&grid.env).map_err(TrainError::from)?;
    let texts: Vec<String> = points.iter().map(|p| toml::to_string(&p.config).unwrap_or_default()).collect();
    for (p, t) in points.iter().zip(&texts) {
        let (_, settings) = parse_run_config(kind, t, Path::new(&p.name))
            .map_err(|e| grid_err(format!("{} ({:?}): {e}", p.name, p.values)))?;
        source
            .clone()
            .with_settings(settings)
            .map_err(|e| grid_err(format!("{} ({:?}): {e}", p.name, p.values)))?;
    }
    // The directory: this grid's sweep, or a new one.
    let recorded = opts.out.join("sweep.toml");
    if let Ok(previous) = std::fs::read_to_string(&recorded)
        && previous != text
    {
        if !opts.overwrite {
            return Err(SweepError::OtherGrid { dir: opts.out.clone() });
        }
        remove_sweep(&opts.out).map_err(|(path, source)| TrainError::Io { path, source })?;
    }
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| TrainError::Io { path, source }
    };
    std::fs::create_dir_all(&opts.out).map_err(io(&opts.out))?;
    write_atomic(&recorded, &text).map_err(io(&recorded))?;
    let mut tasks = Vec::with_capacity(runs);
    for (p, t) in points.iter().zip(&texts) {
        let dir = opts.out.join(&p.name);
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let config = dir.join("config.toml");
        write_atomic(&config, t).map_err(io(&config))?;
        tasks.extend(
            (0..opts.seeds)
                .map(|seed| (p.name.clone(), seed, config.clone(), dir.join(format!("seed_{seed}")))),
        );
    }
    // Finished runs are kept as they are.
    let before = tasks.len();
    tasks.retain(|(_, _, _, dir)| !dir.join("summary.json").exists());
    let kept = before - tasks.len();

    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let failure: Mutex<Option<SweepError>> = Mutex::new(None);
    let run_one = |(_, seed, config, dir): &(String, u64, PathBuf, PathBuf)| -> Result<Summary, TrainError> {
        if dir.join("run.json").exists() {
            return resume(dir, 1, &mut |_| {});
        }
        let opts = TrainOptions {
            env: grid.env.clone(),
            algo: kind,
            steps: grid.steps,
            seed: Some(*seed),
            out: dir.clone(),
            config: Some(config.clone()),
            threads: 1,
            n_envs: grid.envs,
            eval_episodes: grid.eval_episodes,
            checkpoint_every: grid.checkpoint_every.unwrap_or(DEFAULT_CHECKPOINT_EVERY),
            overwrite: false,
        };
        train(&opts, &mut |_| {})
    };
    std::thread::scope(|s| {
        for _ in 0..opts.jobs.min(tasks.len()) {
            s.spawn(|| {
                while !stop.load(Ordering::Relaxed) {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(task) = tasks.get(i) else { break };
                    match run_one(task) {
                        Ok(summary) => report(&task.0, task.1, &summary),
                        Err(source) => {
                            stop.store(true, Ordering::Relaxed);
                            let mut f = failure.lock().unwrap_or_else(|e| e.into_inner());
                            f.get_or_insert(SweepError::Run { point: task.0.clone(), seed: task.1, source });
                        }
                    }
                }
            });
        }
    });
    if let Some(e) = failure.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e);
    }
    let mut summary = summarise(&grid, &points, opts)?;
    summary.kept_runs = kept;
    Ok(summary)
}

/// Removes a sweep's files from `dir`: `sweep.*`, `sweep_curves.*` and the `pNNN` point
/// directories (nothing else).
fn remove_sweep(dir: &Path) -> Result<(), (PathBuf, std::io::Error)> {
    let entries = std::fs::read_dir(dir).map_err(|e| (dir.to_path_buf(), e))?;
    for entry in entries {
        let entry = entry.map_err(|e| (dir.to_path_buf(), e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let point = name.len() >= 4 && name.starts_with('p') && name[1..].bytes().all(|b| b.is_ascii_digit());
        let path = entry.path();
        if point && path.is_dir() {
            std::fs::remove_dir_all(&path).map_err(|e| (path.clone(), e))?;
        } else if matches!(
            name.as_str(),
            "sweep.toml" | "sweep.json" | "sweep_curves.png" | "sweep_curves.svg"
        ) {
            std::fs::remove_file(&path).map_err(|e| (path.clone(), e))?;
        }
    }
    Ok(())
}

/// Reads every run's summary and curve and writes `sweep.json` and the curves.
fn summarise(grid: &Grid, points: &[Point], opts: &SweepOptions) -> Result<SweepSummary, SweepError> {
    let (mut rows, mut series) = (Vec::new(), Vec::new());
    for p in points {
        let (mut finals, mut curves) = (Vec::new(), Vec::new());
        for seed in 0..opts.seeds {
            let dir = opts.out.join(&p.name).join(format!("seed_{seed}"));
            let path = dir.join("summary.json");
            let text = std::fs::read_to_string(&path)
                .map_err(|source| TrainError::Io { path: path.clone(), source })?;
            let s: Summary = serde_json::from_str(&text)
                .map_err(|e| TrainError::Io { path: path.clone(), source: e.into() })?;
            finals.push(s.final_return_mean);
            let csv = dir.join("metrics.csv");
            let m = MetricsCsv::read(&csv).map_err(|source| TrainError::Io { path: csv, source })?;
            curves.push(m.iter().map(|r| (r.env_steps, r.episode_return_mean)).collect::<Vec<_>>());
        }
        let (iqm, ci) = iqm_with_ci(&finals);
        let n = finals.len() as f64;
        let mean = finals.iter().sum::<f64>() / n;
        let std = (finals.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        let label = if p.values.is_empty() {
            p.name.clone()
        } else {
            format!(
                "{}: {}",
                p.name,
                p.values.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(" ")
            )
        };
        series.push(band(&label, &curves, grid.steps, 60));
        rows.push(PointSummary {
            name: p.name.clone(),
            values: p.values.iter().cloned().collect(),
            final_returns: finals,
            return_iqm: iqm,
            return_iqm_ci95: ci,
            return_mean: mean,
            return_std: std,
        });
    }
    let summary = SweepSummary {
        env: grid.env.clone(),
        algo: grid.algo.clone(),
        steps: grid.steps,
        seeds: opts.seeds,
        points: rows,
        kept_runs: 0,
    };
    let path = opts.out.join("sweep.json");
    let json = serde_json::to_string_pretty(&summary).expect("the summary serialises") + "\n";
    write_atomic(&path, &json).map_err(|source| TrainError::Io { path: path.clone(), source })?;
    let labels = PlotLabels {
        title: format!("{} on {}: sweep, {} seeds per point", grid.algo, grid.env, opts.seeds),
        x: "environment steps".into(),
        y: "training episode return (mean ± std over seeds)".into(),
    };
    for ext in ["png", "svg"] {
        match plot_curves(&opts.out.join(format!("sweep_curves.{ext}")), &labels, &series) {
            Ok(()) | Err(PlotError::Empty { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(summary)
}

/// The summary as a Markdown table.
pub fn markdown(s: &SweepSummary) -> String {
    let mut out = String::from(
        "| point | values | final return IQM [95 % CI] | mean ± std | seeds |\n|---|---|---:|---:|---:|\n",
    );
    for p in &s.points {
        let values: Vec<String> = p.values.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        let ci = p.return_iqm_ci95.map_or("—".to_string(), |c| format!("[{:.2}, {:.2}]", c.low, c.high));
        out += &format!(
            "| {} | {} | {:.2} {ci} | {:.2} ± {:.2} | {} |\n",
            p.name,
            values.join(", "),
            p.return_iqm,
            p.return_mean,
            p.return_std,
            p.final_returns.len()
        );
    }
    out
}
