//! Sweeps from Python: a sweep's runs, some of them, or all with the summary (what
//! `centaur sweep` does), so that a scheduler such as Ray can spread the runs.

use std::path::{Path, PathBuf};

use centaur_lab::sweep::{SweepOptions, markdown, run_sweep, run_sweep_runs, sweep_runs};
use pyo3::prelude::*;

use crate::error;

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(sweep_run_ids, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_some, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    Ok(())
}

fn options(grid: &str, seeds: u64, out: &str, jobs: usize, overwrite: bool) -> SweepOptions {
    SweepOptions { grid: PathBuf::from(grid), seeds, out: PathBuf::from(out), jobs, overwrite, spec: None }
}

/// The runs of the sweep of `grid` with `seeds` seeds: `[(point, seed)]`.
#[pyfunction]
fn sweep_run_ids(grid: &str, seeds: u64) -> PyResult<Vec<(String, u64)>> {
    sweep_runs(Path::new(grid), seeds).map_err(error)
}

/// Runs (or resumes) the listed runs of the sweep into `out` on `jobs` threads, without the
/// summary; returns how many of them were finished before.
#[pyfunction]
#[pyo3(signature = (grid, seeds, out, runs, jobs=1))]
fn sweep_some(
    py: Python<'_>,
    grid: &str,
    seeds: u64,
    out: &str,
    runs: Vec<(String, u64)>,
    jobs: usize,
) -> PyResult<usize> {
    let opts = options(grid, seeds, out, jobs, false);
    py.detach(|| run_sweep_runs(&opts, &runs, &|_, _, _| {})).map_err(error)
}

/// Runs (or resumes) the whole sweep into `out` and writes its summary (`sweep.json`,
/// curves); returns the summary's markdown table.
#[pyfunction]
#[pyo3(signature = (grid, seeds, out, jobs=1, overwrite=false))]
fn sweep(
    py: Python<'_>,
    grid: &str,
    seeds: u64,
    out: &str,
    jobs: usize,
    overwrite: bool,
) -> PyResult<String> {
    let opts = options(grid, seeds, out, jobs, overwrite);
    py.detach(|| run_sweep(&opts, &|_, _, _| {})).map(|s| markdown(&s)).map_err(error)
}
