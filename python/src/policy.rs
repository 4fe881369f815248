//! `Policy`: a trained policy loaded from a checkpoint directory, acting deterministically.

use std::path::Path;
use std::sync::Mutex;

use centaur_rl::Policy as RustPolicy;
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::{check_len, error, lock};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Policy>()
}

/// The deterministic policy of a checkpoint (`centaur train` writes `RUN/checkpoint`): the
/// actor and its observation normalisation, acting as `centaur eval` does.
#[pyclass(module = "centaur._native", frozen)]
pub struct Policy {
    inner: Mutex<RustPolicy>,
    obs_dim: usize,
    act_dim: usize,
}

#[pymethods]
impl Policy {
    /// Loads the policy of the checkpoint directory `path`.
    #[staticmethod]
    fn load(path: &str) -> PyResult<Policy> {
        let p = RustPolicy::load(Path::new(path)).map_err(error)?;
        let (obs_dim, act_dim) = (p.obs_dim(), p.act_dim());
        Ok(Policy { inner: Mutex::new(p), obs_dim, act_dim })
    }

    #[getter]
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }
    #[getter]
    fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// The action for one observation (float32 `(obs_dim,)` → `(act_dim,)`).
    fn act<'py>(
        &self,
        py: Python<'py>,
        obs: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let obs = obs.as_slice().map_err(error)?;
        check_len("obs", obs.len(), self.obs_dim)?;
        let mut out = vec![0.0; self.act_dim];
        lock(&self.inner, "policy")?.act(obs, &mut out);
        Ok(PyArray1::from_vec(py, out))
    }

    /// The actions for a batch of observations (`(n, obs_dim)` → `(n, act_dim)`).
    fn act_batch<'py>(
        &self,
        py: Python<'py>,
        obs: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let shape = obs.shape();
        let (n, d) = (shape[0], shape[1]);
        check_len("each observation", d, self.obs_dim)?;
        let obs = obs.as_slice().map_err(error)?;
        let mut out = vec![0.0; n * self.act_dim];
        let mut p = lock(&self.inner, "policy")?;
        for (o, a) in obs.chunks(d.max(1)).zip(out.chunks_mut(self.act_dim.max(1))) {
            p.act(o, a);
        }
        PyArray1::from_vec(py, out).reshape([n, self.act_dim])
    }
}
