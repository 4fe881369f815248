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
//! eval_every = 100000       # optional: deterministic evaluations during training
//!                           # (a multiple of checkpoint_every; evaluations.csv per run)
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
//!
//! [judges.no_penalty]       # optional: every final policy is also evaluated on the env
//! ctrl_cost_weight = 0.0    # with these [env] settings (in place of the run's)
//! ```
//!
//! ## A sweep over a run spec
//!
//! A grid file may instead name a run spec ([`crate::spec`]) that every point starts from,
//! `spec = "../configs/walker2d_ppo.toml"` (relative to the grid file), or `centaur sweep
//! --spec FILE [--set key=value …]` gives it for every grid. The spec then holds the robot,
//! the learner, the budget, the environments, the evaluation and every table (a hybrid's
//! too: `robot = "minitaur-residual"`), so the grid file has none of `env`, `algo`, `steps`,
//! `envs`, `eval_episodes`, `eval_every` or `[base]`, and its keys are the spec's table keys:
//!
//! ```toml
//! spec = "../configs/minitaur_residual.toml"
//! [grid]
//! "learner.learning_rate" = [3e-4, 1e-4]
//! "hybrid.residual_scale" = [0.3, 0.5]
//! ```
//!
//! Each point's `config.toml` is then its whole spec (`centaur train --spec pNNN/config.toml`
//! reruns one of its seeds), and every point is resolved and checked before anything runs.
//!
//! ## The output directory
//!
//! | file | content |
//! |---|---|
//! | `sweep.toml` | the grid file as given (a rerun with another grid is refused) |
//! | `pNNN/config.toml` | the point's run file (base + its values) |
//! | `pNNN/seed_K/` | a `centaur train` run directory |
//! | `judges/NAME.toml` | a judge's `[env]` table |
//! | `pNNN/seed_K/judge_NAME.json` | the run's final policy evaluated by judge `NAME` (`centaur eval`'s `eval.json`) |
//! | `sweep.json` | per point: its values, every seed's final return, IQM with 95 % CI, mean and std; per judge the same statistics of the judged returns |
//! | `sweep_curves.png`, `.svg` | the training return per point: mean over seeds ± one std |
//! | `results.md` | the generated results page: the grid, the table, every seed, host and wall time, the curves |
//!
//! A rerun of the same grid keeps every finished run (its `summary.json`), resumes every
//! interrupted one from its last checkpoint and starts the rest.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use centaur_rl::{AlgoKind, MetricsCsv};
use serde::{Deserialize, Serialize};

use crate::compare::band;
use crate::eval::{EvalOptions, run_eval};
use crate::experiment::AgentStats;
use crate::plot::{PlotError, PlotLabels, plot_curves};
use crate::registry::EnvSource;
use crate::rundir::write_atomic;
use crate::settings::split_run_toml;
use crate::spec::{Purpose, ResolvedSpec, RunSpec};
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
    /// A run spec every point starts from (relative to the grid file); the fields it gives
    /// are then filled from it (see the module docs).
    #[serde(default)]
    pub spec: Option<PathBuf>,
    /// Environment of every run.
    #[serde(default)]
    pub env: String,
    /// Algorithm of every run.
    #[serde(default)]
    pub algo: String,
    /// Environment steps per run.
    #[serde(default)]
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
    /// Steps between deterministic evaluations of each run (0: only the final one).
    #[serde(default)]
    pub eval_every: u64,
    /// Judges: named `[env]` tables; every final policy is evaluated on its env with each.
    #[serde(default)]
    pub judges: BTreeMap<String, toml::Table>,
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
    /// Its run file (over a spec: its whole spec).
    pub config: toml::Table,
}

/// A run spec given to a sweep on the command line (`centaur sweep --spec FILE --set …`).
#[derive(Clone, Debug)]
pub struct SpecSource {
    /// The spec file.
    pub path: PathBuf,
    /// Its `--set key.path=value` overrides.
    pub sets: Vec<String>,
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
    /// A run spec every point starts from, for a grid file that names none.
    pub spec: Option<SpecSource>,
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
    /// Every seed's training wall time (s), seed order.
    pub wall_seconds: Vec<f64>,
    /// Interquartile mean over seeds.
    pub return_iqm: f64,
    /// Its 95 % stratified-bootstrap confidence interval.
    pub return_iqm_ci95: Option<Interval>,
    /// Mean over seeds.
    pub return_mean: f64,
    /// Standard deviation over seeds.
    pub return_std: f64,
    /// Per judge: every seed's judged return and their statistics.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub judged: BTreeMap<String, Judged>,
}

/// The final policies of a point's seeds, evaluated by one judge.
#[derive(Clone, Debug, Serialize)]
pub struct Judged {
    /// Every seed's mean return, seed order.
    pub returns: Vec<f64>,
    /// Interquartile mean over seeds.
    pub return_iqm: f64,
    /// Its 95 % stratified-bootstrap confidence interval.
    pub return_iqm_ci95: Option<Interval>,
    /// Episodes that ended by a fall, over all seeds.
    pub falls: usize,
    /// Episodes, over all seeds.
    pub episodes: usize,
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
    /// A judge's evaluation of a run failed.
    #[error("{point} seed {seed}, judge {judge}: {message}")]
    Judge {
        /// The point.
        point: String,
        /// The seed.
        seed: u64,
        /// The judge.
        judge: String,
        /// The failure.
        message: String,
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

/// A grid file read and checked: every point's run file and every judge's `[env]` table
/// fit the environment, the algorithm exists, the evaluation period fits the checkpoints.
pub struct CheckedGrid {
    /// The file's text.
    pub text: String,
    /// The grid.
    pub grid: Grid,
    /// Its algorithm.
    pub kind: AlgoKind,
    /// Its points.
    pub points: Vec<Point>,
    /// Each point's run file (TOML).
    pub texts: Vec<String>,
    /// Each judge's name and run file (an `[env]` table).
    pub judge_files: Vec<(String, String)>,
    /// The runs' checkpoint period.
    pub checkpoint_every: u64,
    /// Over a spec: each point's spec, resolved for `centaur train`.
    pub specs: Option<Vec<ResolvedSpec>>,
    /// Over a spec: its `seeds`, which `centaur sweep` runs when not given `--seeds`.
    pub spec_seeds: Option<u64>,
}

/// The keys a grid file over a spec leaves to the spec.
const GIVEN_BY_THE_SPEC: [&str; 7] = ["env", "algo", "steps", "envs", "eval_episodes", "eval_every", "base"];

/// A grid file over a spec (the file's `spec`, or `given`; not both): the spec's table with
/// its `--set` overrides as every point's base, and the grid's run fields filled from the
/// spec resolved. `None` for a grid without one.
fn spec_base(
    path: &Path,
    raw: &toml::Table,
    grid: &mut Grid,
    given: Option<&SpecSource>,
) -> Result<Option<(toml::Table, ResolvedSpec)>, String> {
    let (spec_path, sets) = match (&grid.spec, given) {
        (Some(_), Some(g)) => {
            return Err(format!(
                "it names its spec, and --spec {} gives another: give one",
                g.path.display()
            ));
        }
        (Some(p), None) => (path.parent().unwrap_or(Path::new("")).join(p), &[][..]),
        (None, Some(g)) => (g.path.clone(), &g.sets[..]),
        (None, None) => {
            for key in ["env", "algo", "steps"] {
                if !raw.contains_key(key) {
                    return Err(format!("missing field `{key}` (or name a run spec: `spec = \"FILE\"`)"));
                }
            }
            return Ok(None);
        }
    };
    if let Some(key) = GIVEN_BY_THE_SPEC.iter().find(|k| raw.contains_key(**k)) {
        return Err(format!("`{key}` is given by the spec {}: set it there", spec_path.display()));
    }
    let keys = grid.grid.keys().chain(grid.points.iter().flat_map(|p| p.keys()));
    if let Some(key) = keys.into_iter().find(|k| !k.contains('.')) {
        return Err(format!(
            "`{key}`: over a spec the grid's keys are its table keys (`learner.learning_rate`, `env.KEY`, `hybrid.residual_scale`, …); the robot, learner and budget are the spec's"
        ));
    }
    let text = crate::rundir::read_text_bounded(&spec_path, crate::spec::MAX_SPEC_BYTES)
        .map_err(|e| format!("spec {}: {e}", spec_path.display()))?;
    let mut table: toml::Table =
        toml::from_str(&text).map_err(|e| format!("spec {}: {e}", spec_path.display()))?;
    for set in sets {
        crate::spec::apply_set(&mut table, set).map_err(|e| e.to_string())?;
    }
    let resolved = RunSpec::from_table(table.clone(), &spec_path.display().to_string())
        .and_then(|s| s.resolve(Purpose::Train))
        .map_err(|e| e.to_string())?;
    grid.env = resolved.robot.clone();
    grid.algo = resolved.algo.clone();
    grid.steps = resolved.steps;
    grid.envs = resolved.envs;
    grid.eval_episodes = resolved.eval_episodes;
    grid.eval_every = resolved.eval_every;
    grid.base = table.clone();
    Ok(Some((table, resolved)))
}

/// Reads and checks the grid file at `path` without running anything (`centaur sweep
/// --check`; [`run_sweep`] starts with it).
pub fn check_grid(path: &Path) -> Result<CheckedGrid, SweepError> {
    check_grid_with(path, None)
}

/// [`check_grid`] with a run spec given for a grid file that names none
/// ([`SweepOptions::spec`]).
pub fn check_grid_with(path: &Path, spec: Option<&SpecSource>) -> Result<CheckedGrid, SweepError> {
    let grid_err = |message: String| SweepError::Grid { path: path.to_path_buf(), message };
    let mut text = read_config_file(path)?;
    let raw: toml::Table = toml::from_str(&text).map_err(|e| grid_err(e.to_string()))?;
    let mut grid: Grid = toml::from_str(&text).map_err(|e| grid_err(e.to_string()))?;
    let base = spec_base(path, &raw, &mut grid, spec).map_err(grid_err)?;
    let kind =
        AlgoKind::from_name(&grid.algo).ok_or_else(|| grid_err(format!("unknown algo `{}`", grid.algo)))?;
    let points = points(&grid).map_err(grid_err)?;
    // Every point's settings are checked before anything runs.
    let source = EnvSource::read(&grid.env).and_then(|s| s.for_learner(kind)).map_err(TrainError::from)?;
    let texts: Vec<String> = points.iter().map(|p| toml::to_string(&p.config).unwrap_or_default()).collect();
    let mut specs = Vec::new();
    for (p, t) in points.iter().zip(&texts) {
        let point_err = |e: &dyn std::fmt::Display| grid_err(format!("{} ({:?}): {e}", p.name, p.values));
        if base.is_some() {
            let resolved = RunSpec::from_table(p.config.clone(), &p.name)
                .and_then(|s| s.resolve(Purpose::Train))
                .map_err(|e| point_err(&e))?;
            specs.push(resolved);
            continue;
        }
        let (config, settings) = parse_run_config(kind, t, Path::new(&p.name)).map_err(|e| point_err(&e))?;
        config.validate().map_err(|e| point_err(&e))?;
        source.clone().with_settings(settings).map_err(|e| point_err(&e))?;
    }
    // A sweep over a spec is that spec's: its record holds the spec resolved, so a rerun
    // over an edited spec is another grid.
    let spec_seeds = base.as_ref().map(|(_, resolved)| resolved.seeds);
    if let Some((_, resolved)) = &base {
        text.push_str(&format!("\n# over the spec, resolved: {}\n", resolved.canonical_json()));
    }
    let checkpoint_every = grid.checkpoint_every.unwrap_or(DEFAULT_CHECKPOINT_EVERY);
    if grid.eval_every > 0 && (checkpoint_every == 0 || !grid.eval_every.is_multiple_of(checkpoint_every)) {
        return Err(grid_err(format!(
            "eval_every {} must be a multiple of checkpoint_every {checkpoint_every}",
            grid.eval_every
        )));
    }
    let mut judge_files = Vec::new();
    for (name, table) in &grid.judges {
        let ok_name =
            !name.is_empty() && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        if !ok_name {
            return Err(grid_err(format!("judge `{name}`: names are letters, digits, `_` and `-`")));
        }
        let env = toml::Table::from_iter([("env".to_string(), toml::Value::Table(table.clone()))]);
        let text = toml::to_string(&env).unwrap_or_default();
        let (settings, _) = split_run_toml(&text).map_err(|e| grid_err(format!("judge `{name}`: {e}")))?;
        source.clone().with_settings(settings).map_err(|e| grid_err(format!("judge `{name}`: {e}")))?;
        judge_files.push((name.clone(), text));
    }
    let specs = base.map(|_| specs);
    Ok(CheckedGrid { text, grid, kind, points, texts, judge_files, checkpoint_every, specs, spec_seeds })
}

/// Runs (or resumes) the sweep; `report` sees each run as it finishes (point, seed, summary).
pub fn run_sweep(
    opts: &SweepOptions,
    report: &(dyn Fn(&str, u64, &Summary) + Sync),
) -> Result<SweepSummary, SweepError> {
    let started = std::time::Instant::now();
    let (grid, points, kept) = execute(opts, None, report)?;
    let mut summary = summarise(&grid, &points, opts)?;
    summary.kept_runs = kept;
    let recorded = std::fs::read_to_string(opts.out.join("sweep.toml")).unwrap_or_default();
    let md = results_markdown(&summary, &recorded, started.elapsed().as_secs_f64());
    let path = opts.out.join("results.md");
    write_atomic(&path, &md).map_err(|source| TrainError::Io { path: path.clone(), source })?;
    Ok(summary)
}

/// The sweep's generated results page (`results.md`): the grid as recorded (over a spec,
/// with the spec resolved), the table of [`markdown`], every seed's final return, the runs'
/// training wall time, the host and this invocation's wall time, and the curves.
pub fn results_markdown(s: &SweepSummary, grid_text: &str, elapsed: f64) -> String {
    use std::fmt::Write as _;
    let mut md = String::new();
    let _ =
        writeln!(md, "# {} on {}: sweep of {} points × {} seeds\n", s.algo, s.env, s.points.len(), s.seeds);
    let _ = writeln!(md, "Generated by `centaur sweep`; do not edit by hand (rerun the command).\n");
    let _ = writeln!(md, "The grid (`sweep.toml`):\n\n```toml\n{}\n```\n", grid_text.trim_end());
    let _ = writeln!(
        md,
        "{} steps per run; final return: deterministic evaluation at the end of each run; IQM over seeds with its 95 % stratified-bootstrap CI.\n",
        s.steps
    );
    md.push_str(&markdown(s));
    let _ = writeln!(md, "\n| point | final return per seed | training wall per seed (s) |\n|---|---|---|");
    for p in &s.points {
        let show = |xs: &[f64], digits: usize| {
            xs.iter().map(|x| format!("{x:.digits$}")).collect::<Vec<_>>().join(", ")
        };
        let _ = writeln!(md, "| {} | {} | {} |", p.name, show(&p.final_returns, 2), show(&p.wall_seconds, 0));
    }
    let total: f64 = s.points.iter().flat_map(|p| &p.wall_seconds).sum();
    let _ = writeln!(
        md,
        "\nHost: {}. Training wall time summed over runs: {total:.0} s; this invocation: {elapsed:.0} s (runs kept from before not counted).\n",
        crate::compare::host_description()
    );
    let _ = writeln!(md, "![training return per point](sweep_curves.svg)");
    md
}

/// The output directory of each of a study's grid files under `out`: `out` itself for one
/// file, `out/<file stem>` for several (`centaur sweep --grid studies/d_*.toml`). Two files
/// with the same stem are refused, as one would overwrite the other, and so is a directory
/// holding a sweep of another grid (unless `overwrite`): all before the first grid runs.
pub fn study_dirs(
    grids: &[(PathBuf, CheckedGrid)],
    out: &Path,
    overwrite: bool,
) -> Result<Vec<PathBuf>, SweepError> {
    let dirs = study_dir_names(grids.iter().map(|(p, _)| p.as_path()), grids.len(), out)?;
    for ((_, grid), dir) in grids.iter().zip(&dirs) {
        let recorded = std::fs::read_to_string(dir.join("sweep.toml"));
        if !overwrite && recorded.is_ok_and(|text| text != grid.text) {
            return Err(SweepError::OtherGrid { dir: dir.clone() });
        }
    }
    Ok(dirs)
}

fn study_dir_names<'a>(
    grids: impl Iterator<Item = &'a Path>,
    n: usize,
    out: &Path,
) -> Result<Vec<PathBuf>, SweepError> {
    if n == 1 {
        return Ok(vec![out.to_path_buf()]);
    }
    let mut dirs: Vec<PathBuf> = Vec::with_capacity(n);
    for grid in grids {
        let stem = grid.file_stem().ok_or_else(|| SweepError::Grid {
            path: grid.to_path_buf(),
            message: "a grid file needs a file name".into(),
        })?;
        let dir = out.join(stem);
        if dirs.contains(&dir) {
            return Err(SweepError::Grid {
                path: grid.to_path_buf(),
                message: format!(
                    "another grid file given has the same name; both would write {}",
                    dir.display()
                ),
            });
        }
        dirs.push(dir);
    }
    Ok(dirs)
}

/// A sweep's runs, `(point, seed)` in the order [`run_sweep`] takes them: the unit that a
/// cluster scheduler hands to its machines ([`run_sweep_runs`]; the Python package's
/// `centaur.ray.sweep` does this with Ray tasks).
pub fn sweep_runs(grid: &Path, seeds: u64) -> Result<Vec<(String, u64)>, SweepError> {
    let points = check_grid(grid)?.points;
    Ok(points.iter().flat_map(|p| (0..seeds).map(|s| (p.name.clone(), s))).collect())
}

/// Runs (or resumes) only the listed runs of the sweep, writing its directory as
/// [`run_sweep`] does, without the summary; returns how many of them were already finished. Runs
/// of one sweep may go to several processes or machines sharing `opts.out` at once; when
/// all have finished, [`run_sweep`] keeps them and writes the summary.
pub fn run_sweep_runs(
    opts: &SweepOptions,
    runs: &[(String, u64)],
    report: &(dyn Fn(&str, u64, &Summary) + Sync),
) -> Result<usize, SweepError> {
    execute(opts, Some(runs), report).map(|(_, _, kept)| kept)
}

/// Sets up the sweep's directory and runs its unfinished runs (those in `only`, if given):
/// the grid, its points and the number of finished runs kept.
fn execute(
    opts: &SweepOptions,
    only: Option<&[(String, u64)]>,
    report: &(dyn Fn(&str, u64, &Summary) + Sync),
) -> Result<(Grid, Vec<Point>, usize), SweepError> {
    let grid_err = |message: String| SweepError::Grid { path: opts.grid.clone(), message };
    if opts.seeds == 0 || opts.jobs == 0 {
        return Err(grid_err("--seeds and --jobs must be at least 1".into()));
    }
    let CheckedGrid { text, grid, kind, points, texts, judge_files, checkpoint_every, specs, .. } =
        check_grid_with(&opts.grid, opts.spec.as_ref())?;
    let runs = points.len().checked_mul(opts.seeds as usize).filter(|&n| n <= MAX_RUNS);
    let runs = runs.ok_or_else(|| {
        grid_err(format!("{} points × {} seeds exceed {MAX_RUNS} runs", points.len(), opts.seeds))
    })?;
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
    if !judge_files.is_empty() {
        let judges = opts.out.join("judges");
        std::fs::create_dir_all(&judges).map_err(io(&judges))?;
        for (name, text) in &judge_files {
            let path = judges.join(format!("{name}.toml"));
            write_atomic(&path, text).map_err(io(&path))?;
        }
    }
    let mut tasks = Vec::with_capacity(runs);
    for (i, (p, t)) in points.iter().zip(&texts).enumerate() {
        let dir = opts.out.join(&p.name);
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let config = dir.join("config.toml");
        write_atomic(&config, t).map_err(io(&config))?;
        tasks.extend(
            (0..opts.seeds)
                .map(|seed| (p.name.clone(), seed, config.clone(), dir.join(format!("seed_{seed}")), i)),
        );
    }
    let judges_dir = opts.out.join("judges");
    let judged = |dir: &Path| grid.judges.keys().all(|name| dir.join(format!("judge_{name}.json")).exists());
    if let Some(only) = only {
        if let Some((p, seed)) =
            only.iter().find(|(p, seed)| !tasks.iter().any(|t| t.0 == *p && t.1 == *seed))
        {
            return Err(grid_err(format!("the sweep has no run {p}/seed_{seed}")));
        }
        tasks.retain(|t| only.iter().any(|(p, seed)| t.0 == *p && t.1 == *seed));
    }
    // Finished (and judged) runs are kept as they are.
    let before = tasks.len();
    tasks.retain(|(_, _, _, dir, _)| !dir.join("summary.json").exists() || !judged(dir));
    let kept = before - tasks.len();

    type Task = (String, u64, PathBuf, PathBuf, usize);
    let run_one = |(_, seed, config, dir, point): &Task| -> Result<Summary, TrainError> {
        if dir.join("run.json").exists() {
            return resume(dir, 1, &mut |_| {});
        }
        // Over a spec, the point's spec resolved gives everything but the seed; else its run file.
        let spec = specs.as_ref().map(|s| s[*point].clone());
        let opts = TrainOptions {
            env: grid.env.clone(),
            algo: kind,
            steps: grid.steps,
            seed: Some(*seed),
            out: dir.clone(),
            config: spec.is_none().then(|| config.clone()),
            threads: 1,
            n_envs: grid.envs,
            eval_episodes: grid.eval_episodes,
            checkpoint_every,
            eval_every: grid.eval_every,
            overwrite: false,
            spec,
        };
        train(&opts, &mut |_| {})
    };
    let run_and_judge = |task: &Task| -> Result<Summary, SweepError> {
        let run = |source| SweepError::Run { point: task.0.clone(), seed: task.1, source };
        let summary = run_one(task).map_err(run)?;
        for name in grid.judges.keys() {
            let out = task.3.join(format!("judge_{name}.json"));
            if out.exists() {
                continue;
            }
            let eval = EvalOptions {
                checkpoint: task.3.clone(),
                config: Some(judges_dir.join(format!("{name}.toml"))),
                env: None,
                episodes: grid.eval_episodes.max(10),
                seed: 1_000_000 + task.1,
                record: None,
                out: Some(out),
                allow_env_change: false,
                fade: None,
            };
            run_eval(&eval).map_err(|e| SweepError::Judge {
                point: task.0.clone(),
                seed: task.1,
                judge: name.clone(),
                message: e.to_string(),
            })?;
        }
        Ok(summary)
    };
    let results = crate::jobs::run_indexed(tasks.len(), opts.jobs, |i| {
        let task = &tasks[i];
        let summary = run_and_judge(task)?;
        report(&task.0, task.1, &summary);
        Ok(())
    });
    if let Some(e) = results.into_iter().flatten().find_map(Result::err) {
        return Err(e);
    }
    Ok((grid, points, kept))
}

/// Removes a sweep's files from `dir`: `sweep.*`, `sweep_curves.*`, `judges/` and the
/// `pNNN` point directories (nothing else).
fn remove_sweep(dir: &Path) -> Result<(), (PathBuf, std::io::Error)> {
    let entries = std::fs::read_dir(dir).map_err(|e| (dir.to_path_buf(), e))?;
    for entry in entries {
        let entry = entry.map_err(|e| (dir.to_path_buf(), e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let point = name.len() >= 4 && name.starts_with('p') && name[1..].bytes().all(|b| b.is_ascii_digit());
        let path = entry.path();
        if (point || name == "judges") && path.is_dir() {
            std::fs::remove_dir_all(&path).map_err(|e| (path.clone(), e))?;
        } else if matches!(
            name.as_str(),
            "sweep.toml" | "sweep.json" | "sweep_curves.png" | "sweep_curves.svg" | "results.md"
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
        let (mut finals, mut curves, mut walls) = (Vec::new(), Vec::new(), Vec::new());
        let mut judged: BTreeMap<String, (Vec<f64>, usize, usize)> = BTreeMap::new();
        for seed in 0..opts.seeds {
            let dir = opts.out.join(&p.name).join(format!("seed_{seed}"));
            let path = dir.join("summary.json");
            let text = std::fs::read_to_string(&path)
                .map_err(|source| TrainError::Io { path: path.clone(), source })?;
            let s: Summary = serde_json::from_str(&text)
                .map_err(|e| TrainError::Io { path: path.clone(), source: e.into() })?;
            finals.push(s.final_return_mean);
            walls.push(s.wall_seconds);
            let csv = dir.join("metrics.csv");
            let m = MetricsCsv::read(&csv).map_err(|source| TrainError::Io { path: csv, source })?;
            curves.push(m.iter().map(|r| (r.env_steps, r.episode_return_mean)).collect::<Vec<_>>());
            for name in grid.judges.keys() {
                let path = dir.join(format!("judge_{name}.json"));
                let text = std::fs::read_to_string(&path)
                    .map_err(|source| TrainError::Io { path: path.clone(), source })?;
                let stats: JudgeFile = serde_json::from_str(&text)
                    .map_err(|e| TrainError::Io { path: path.clone(), source: e.into() })?;
                let entry = judged.entry(name.clone()).or_default();
                entry.0.push(stats.stats.return_mean);
                entry.1 += stats.stats.falls;
                entry.2 += stats.stats.episodes;
            }
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
            wall_seconds: walls,
            return_iqm: iqm,
            return_iqm_ci95: ci,
            return_mean: mean,
            return_std: std,
            judged: judged
                .into_iter()
                .map(|(name, (returns, falls, episodes))| {
                    let (iqm, ci) = iqm_with_ci(&returns);
                    (name, Judged { returns, return_iqm: iqm, return_iqm_ci95: ci, falls, episodes })
                })
                .collect(),
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

/// What `summarise` reads of a judge's `eval.json` ([`crate::eval::EvalReport`]).
#[derive(Deserialize)]
struct JudgeFile {
    stats: AgentStats,
}

/// The summary as a Markdown table (a column per judge after the final return's).
pub fn markdown(s: &SweepSummary) -> String {
    let judges: Vec<&String> = s.points.first().map(|p| p.judged.keys().collect()).unwrap_or_default();
    let interval =
        |c: Option<Interval>| c.map_or("—".to_string(), |c| format!("[{:.2}, {:.2}]", c.low, c.high));
    let mut out = String::from("| point | values | final return IQM [95 % CI] | mean ± std |");
    for j in &judges {
        out += &format!(" judge {j}: IQM [95 % CI], falls |");
    }
    out += " seeds |\n|---|---|---:|---:|";
    out += &"---:|".repeat(judges.len());
    out += "---:|\n";
    for p in &s.points {
        let values: Vec<String> = p.values.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        out += &format!(
            "| {} | {} | {:.2} {} | {:.2} ± {:.2} |",
            p.name,
            values.join(", "),
            p.return_iqm,
            interval(p.return_iqm_ci95),
            p.return_mean,
            p.return_std,
        );
        for j in &judges {
            match p.judged.get(*j) {
                Some(d) => {
                    out += &format!(
                        " {:.2} {}, {}/{} |",
                        d.return_iqm,
                        interval(d.return_iqm_ci95),
                        d.falls,
                        d.episodes
                    )
                }
                None => out += " — |",
            }
        }
        out += &format!(" {} |\n", p.final_returns.len());
    }
    out
}
