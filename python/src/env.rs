//! `Env` and `VecEnv`: one environment, and N stepped together in Rust threads.

use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use centaur::registry::{EnvSource, env_names};
use centaur::settings::EnvSettings;
use centaur_gym::{BoxSpace, Env as RustEnv, MAX_REWARD_TERMS, StepInfo, VecEnv as RustVecEnv, VecStep};
use centaur_lab::eval::trained_source;
use centaur_rl::{AlgoKind, Checkpoint};
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::{check_len, error, lock};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Env>()?;
    m.add_class::<VecEnv>()?;
    m.add_function(wrap_pyfunction!(names, m)?)?;
    m.add_function(wrap_pyfunction!(bench_vec_env, m)?)?;
    Ok(())
}

/// The environment of `name` with `settings` (the `[env]` table as JSON, `None`: the preset)
/// for `learner` (a `centaur train --algo` name; a hybrid takes that learner's residual
/// preset; `None`: PPO's).
fn source(name: &str, settings: Option<&str>, learner: Option<&str>) -> PyResult<EnvSource> {
    let settings: EnvSettings = match settings {
        Some(json) => serde_json::from_str(json).map_err(|e| error(format!("env options: {e}")))?,
        None => EnvSettings::default(),
    };
    let kind = match learner {
        Some(name) => AlgoKind::from_name(name).ok_or_else(|| {
            let names: Vec<_> = AlgoKind::ALL.iter().map(|k| k.name()).collect();
            error(format!("learner `{name}`: expected one of {}", names.join(", ")))
        })?,
        None => AlgoKind::Ppo,
    };
    EnvSource::read(name).and_then(|s| s.for_learner(kind)?.with_settings(settings)).map_err(error)
}

/// The names `Env` and `VecEnv` take (`modular:FILE.json` for a body file).
#[pyfunction]
fn names() -> Vec<String> {
    env_names()
}

/// The spaces and timing every environment reports, as Python values.
fn describe<'py>(py: Python<'py>, e: &dyn RustEnv) -> PyResult<Bound<'py, PyTuple>> {
    let space = |s: &BoxSpace| (PyArray1::from_slice(py, &s.low), PyArray1::from_slice(py, &s.high));
    (
        e.name().to_string(),
        space(e.observation_space()),
        space(e.action_space()),
        e.max_episode_steps(),
        e.dt(),
        e.reward_term_names().to_vec(),
    )
        .into_pyobject(py)
}

/// One environment with Gymnasium's semantics (`centaur.make` wraps it as a
/// `gymnasium.Env`): `reset(seed) -> obs`, `step(action) -> (obs, reward, terminated,
/// truncated, info)` with `info = (reward_terms, forward_velocity, energy, foot_contacts,
/// unstable)`.
#[pyclass(module = "centaur._native", frozen)]
pub struct Env {
    inner: Mutex<EnvState>,
}

struct EnvState {
    env: Box<dyn RustEnv>,
    obs: Vec<f32>,
}

#[pymethods]
impl Env {
    /// `name` as `centaur train --env` takes it; `settings`: the `[env]` table as JSON;
    /// `learner`: the learner a hybrid is for (`"sac"`, …: its residual preset; PPO's by
    /// default).
    #[new]
    #[pyo3(signature = (name, settings=None, learner=None))]
    fn new(name: &str, settings: Option<&str>, learner: Option<&str>) -> PyResult<Env> {
        let env = source(name, settings, learner)?.make().map_err(error)?;
        let obs = vec![0.0; env.observation_space().dim()];
        Ok(Env { inner: Mutex::new(EnvState { env, obs }) })
    }

    /// The environment the checkpoint at `path` (a run directory or its `checkpoint` file)
    /// was trained on, from what the checkpoint records alone: its environment, `[env]`
    /// settings and, for a hybrid, the whole setup it trained with.
    #[staticmethod]
    fn from_checkpoint(path: &str) -> PyResult<Env> {
        let path = Path::new(path);
        let file = if path.is_dir() { path.join("checkpoint") } else { path.to_path_buf() };
        let checkpoint = Checkpoint::read(&file).map_err(error)?;
        let env = trained_source(&checkpoint, &file).map_err(error)?.make().map_err(error)?;
        let obs = vec![0.0; env.observation_space().dim()];
        Ok(Env { inner: Mutex::new(EnvState { env, obs }) })
    }

    /// `(name, (obs_low, obs_high), (act_low, act_high), max_episode_steps, dt, reward_term_names)`.
    fn describe<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        describe(py, lock(&self.inner, "environment")?.env.as_ref())
    }

    /// Tells the environment the learner's training samples so far (a hybrid's rising
    /// residual bound follows them; an environment never told acts as fully trained).
    fn set_training_samples(&self, samples: u64) -> PyResult<()> {
        lock(&self.inner, "environment")?.env.set_training_samples(samples);
        Ok(())
    }

    /// Starts an episode (`seed`: reseed, `None`: continue the generator's stream).
    #[pyo3(signature = (seed=None))]
    fn reset<'py>(&self, py: Python<'py>, seed: Option<u64>) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let mut s = lock(&self.inner, "environment")?;
        let EnvState { env, obs } = &mut *s;
        env.reset(seed, obs).map_err(error)?;
        Ok(PyArray1::from_slice(py, obs))
    }

    /// One control period with `action` (float32, the action space's length).
    fn step<'py>(
        &self,
        py: Python<'py>,
        action: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let action = action.as_slice().map_err(error)?;
        let mut s = lock(&self.inner, "environment")?;
        let EnvState { env, obs } = &mut *s;
        let step = env.step(action, obs).map_err(error)?;
        let n_terms = env.reward_term_names().len().min(MAX_REWARD_TERMS);
        let i = step.info;
        (
            PyArray1::from_slice(py, obs),
            step.reward,
            step.terminated,
            step.truncated,
            (
                PyArray1::from_slice(py, &i.reward_terms[..n_terms]),
                i.forward_velocity,
                i.energy,
                i.foot_contacts,
                i.unstable,
            ),
        )
            .into_pyobject(py)
    }
}

/// N copies of an environment stepped together on Rust threads with same-step auto-reset
/// (`centaur.make_vec` wraps it as a `gymnasium.vector.VectorEnv`). Environment `i` is
/// reset with seed `seed + i`; results do not depend on the number of threads.
#[pyclass(module = "centaur._native", frozen)]
pub struct VecEnv {
    inner: Mutex<VecState>,
}

struct VecState {
    envs: RustVecEnv,
    out: VecStep,
    obs: Vec<f32>,
    /// The actions, copied while the GIL is held (Python may write the array meanwhile).
    actions: Vec<f32>,
}

/// One `VecStep`'s per-environment information as arrays.
fn info_arrays<'py>(py: Python<'py>, infos: &[StepInfo], n_terms: usize) -> PyResult<Bound<'py, PyTuple>> {
    let n = infos.len();
    let mut terms = Vec::with_capacity(n * n_terms);
    for i in infos {
        terms.extend_from_slice(&i.reward_terms[..n_terms]);
    }
    let column = |f: fn(&StepInfo) -> f64| PyArray1::from_iter(py, infos.iter().map(f));
    (
        PyArray1::from_vec(py, terms).reshape([n, n_terms])?,
        column(|i| i.forward_velocity),
        column(|i| i.energy),
        PyArray1::from_iter(py, infos.iter().map(|i| i.foot_contacts)),
        PyArray1::from_iter(py, infos.iter().map(|i| i.unstable)),
    )
        .into_pyobject(py)
}

#[pymethods]
impl VecEnv {
    /// `num_envs` copies of `name` on `threads` threads (at most one per environment);
    /// `settings` and `learner` as for `Env`.
    #[new]
    #[pyo3(signature = (name, num_envs, threads, settings=None, learner=None))]
    fn new(
        name: &str,
        num_envs: usize,
        threads: usize,
        settings: Option<&str>,
        learner: Option<&str>,
    ) -> PyResult<VecEnv> {
        if num_envs == 0 {
            return Err(error("num_envs must be at least 1"));
        }
        if threads == 0 {
            return Err(error("threads must be at least 1"));
        }
        let envs = source(name, settings, learner)?.make_vec(num_envs, threads).map_err(error)?;
        let out = envs.make_step_buffers();
        let obs = vec![0.0; num_envs * envs.observation_space().dim()];
        let actions = vec![0.0; num_envs * envs.action_space().dim()];
        Ok(VecEnv { inner: Mutex::new(VecState { envs, out, obs, actions }) })
    }

    /// As `Env.describe`, for one environment.
    fn describe<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        describe(py, lock(&self.inner, "vector env")?.envs.env(0))
    }

    /// As `Env.set_training_samples`, for every environment.
    fn set_training_samples(&self, samples: u64) -> PyResult<()> {
        lock(&self.inner, "vector env")?.envs.set_training_samples(samples);
        Ok(())
    }

    /// Resets every environment (environment `i` with seed `seed + i`): obs `(n, obs_dim)`.
    fn reset<'py>(&self, py: Python<'py>, seed: u64) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let mut s = lock(&self.inner, "vector env")?;
        let VecState { envs, obs, .. } = &mut *s;
        py.detach(|| envs.reset(seed, obs)).map_err(error)?;
        PyArray1::from_slice(py, obs).reshape([envs.len(), envs.observation_space().dim()])
    }

    /// Steps every environment with `actions` `(n, act_dim)` float32; finished episodes
    /// restart in the same step. Returns `(obs, rewards, terminated, truncated, final_obs,
    /// (reward_terms, forward_velocity, energy, foot_contacts, unstable), episodes)`,
    /// `final_obs` holding the last observation of each environment whose episode just
    /// ended and `episodes` a list of `(env, return, length)` of those episodes.
    fn step<'py>(
        &self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let mut s = lock(&self.inner, "vector env")?;
        let VecState { envs, out, actions: a, .. } = &mut *s;
        let actions = actions.as_slice().map_err(error)?;
        check_len("actions", actions.len(), a.len())?;
        a.copy_from_slice(actions);
        py.detach(|| envs.step(a, out)).map_err(error)?;
        let (n, d) = (envs.len(), envs.observation_space().dim());
        let n_terms = envs.env(0).reward_term_names().len().min(MAX_REWARD_TERMS);
        (
            PyArray1::from_slice(py, &out.obs).reshape([n, d])?,
            PyArray1::from_slice(py, &out.rewards),
            PyArray1::from_slice(py, &out.terminated),
            PyArray1::from_slice(py, &out.truncated),
            PyArray1::from_slice(py, &out.final_obs).reshape([n, d])?,
            info_arrays(py, &out.infos, n_terms)?,
            out.episodes.iter().map(|e| (e.env, e.ret, e.length)).collect::<Vec<_>>(),
        )
            .into_pyobject(py)
    }
}

/// Steps/s of the Rust `VecEnv` alone: `num_envs` copies of `name` on `threads` threads
/// reset with `seed`, then stepped with `actions` (`(steps, num_envs, act_dim)` float32,
/// copied before the clock starts), no Python in the loop. The bench gives the Python
/// vector env the same actions, so both run the same episodes.
#[pyfunction]
#[pyo3(signature = (name, num_envs, threads, actions, seed=0, settings=None))]
fn bench_vec_env(
    py: Python<'_>,
    name: &str,
    num_envs: usize,
    threads: usize,
    actions: PyReadonlyArray3<'_, f32>,
    seed: u64,
    settings: Option<&str>,
) -> PyResult<f64> {
    if num_envs == 0 || threads == 0 {
        return Err(error("num_envs and threads must be at least 1"));
    }
    let mut envs = source(name, settings, None)?.make_vec(num_envs, threads).map_err(error)?;
    let (n, a) = (envs.len(), envs.action_space().dim());
    let shape = actions.shape();
    if shape[1] != n || shape[2] != a || shape[0] == 0 {
        return Err(error(format!("actions have shape {shape:?}, expected (steps ≥ 1, {n}, {a})")));
    }
    let steps = shape[0];
    let actions = actions.as_slice().map_err(error)?.to_vec();
    py.detach(|| {
        let mut obs = vec![0.0; n * envs.observation_space().dim()];
        envs.reset(seed, &mut obs).map_err(error)?;
        let mut out = envs.make_step_buffers();
        let start = Instant::now();
        for batch in actions.chunks(n * a) {
            envs.step(batch, &mut out).map_err(error)?;
        }
        Ok((n * steps) as f64 / start.elapsed().as_secs_f64())
    })
}
