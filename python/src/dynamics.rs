//! `Model`: a rigid-body model (from a URDF, or the one a robot environment simulates)
//! with its `Data`, and the dynamics algorithms on numpy `float64` arrays.

use std::sync::Mutex;

use centaur::registry::make_robot_env_with;
use centaur::settings::EnvSettings;
use centaur_dynamics::nalgebra::{DMatrix, DVector, Dim, Matrix, Matrix6xX, RawStorage};
use centaur_dynamics::{
    BaseKind, Data, Model as RustModel, ReferenceFrame, Se3, aba, center_of_mass, compute_joint_jacobians,
    crba, difference, forward_kinematics, frame_jacobian, frame_placement, gravity_torques, integrate,
    kinetic_energy, nonlinear_effects, potential_energy, rnea, update_frame_placements,
};
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;

use crate::{check_len, error, lock};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Model>()
}

/// A model and its workspace (`Data`), like Pinocchio's `model`/`data` pair in one object.
/// Configurations `q` have `nq` entries (a floating base first: position, then the
/// quaternion `x y z w`), velocities `v` and torques `nv`; all `float64`.
#[pyclass(module = "centaur._native", frozen)]
pub struct Model {
    pub(crate) model: RustModel,
    data: Mutex<Data>,
}

impl Model {
    pub(crate) fn from_rust(model: RustModel) -> Model {
        let data = Mutex::new(Data::new(&model));
        Model { model, data }
    }
}

/// A `(len,)` float64 argument as a slice, checked against `expected`.
fn vector<'a>(name: &str, a: &'a PyReadonlyArray1<'_, f64>, expected: usize) -> PyResult<&'a [f64]> {
    let s = a.as_slice().map_err(error)?;
    check_len(name, s.len(), expected)?;
    if let Some(i) = s.iter().position(|x| !x.is_finite()) {
        return Err(error(format!("{name}[{i}] is {}, expected a finite number", s[i])));
    }
    Ok(s)
}

/// A matrix as a numpy array of its shape (row-major, numpy's default; nalgebra's storage
/// is column-major).
fn matrix<'py, R: Dim, C: Dim, S: RawStorage<f64, R, C>>(
    py: Python<'py>,
    m: &Matrix<f64, R, C, S>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (r, c) = m.shape();
    PyArray1::from_iter(py, (0..r).flat_map(|i| (0..c).map(move |j| m[(i, j)]))).reshape([r, c])
}

/// A placement as the 4 × 4 homogeneous matrix `[R p; 0 1]`.
fn homogeneous<'py>(py: Python<'py>, m: &Se3) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let mut h = DMatrix::<f64>::identity(4, 4);
    h.view_mut((0, 0), (3, 3)).copy_from(&m.rotation);
    h.view_mut((0, 3), (3, 1)).copy_from(&m.translation);
    matrix(py, &h)
}

fn reference_frame(name: &str) -> PyResult<ReferenceFrame> {
    match name {
        "world" => Ok(ReferenceFrame::World),
        "local_world_aligned" => Ok(ReferenceFrame::LocalWorldAligned),
        "local" => Ok(ReferenceFrame::Local),
        _ => Err(error(format!(
            "unknown reference frame `{name}` (expected \"world\", \"local_world_aligned\" or \"local\")"
        ))),
    }
}

#[pymethods]
impl Model {
    /// Loads a URDF file; `floating_base` adds a free-flyer root joint.
    #[staticmethod]
    #[pyo3(signature = (path, floating_base=true))]
    fn from_urdf(path: &str, floating_base: bool) -> PyResult<Model> {
        let base = if floating_base { BaseKind::Floating } else { BaseKind::Fixed };
        RustModel::from_urdf_file(path, base).map(Model::from_rust).map_err(error)
    }

    /// Loads a URDF from its text (`source` names it in error messages).
    #[staticmethod]
    #[pyo3(signature = (text, floating_base=true, source="<string>"))]
    fn from_urdf_string(text: &str, floating_base: bool, source: &str) -> PyResult<Model> {
        let base = if floating_base { BaseKind::Floating } else { BaseKind::Fixed };
        RustModel::from_urdf_str(text, source, base).map(Model::from_rust).map_err(error)
    }

    /// The model a robot environment simulates (`"minitaur"`, `"ant"`, …; the one its
    /// controller preset is made for).
    #[staticmethod]
    fn for_robot(name: &str) -> PyResult<Model> {
        let env = make_robot_env_with(name, &EnvSettings::default()).map_err(error)?;
        Ok(Model::from_rust(env.model().clone()))
    }

    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }
    #[getter]
    fn nq(&self) -> usize {
        self.model.nq
    }
    #[getter]
    fn nv(&self) -> usize {
        self.model.nv
    }
    #[getter]
    fn total_mass(&self) -> f64 {
        self.model.total_mass()
    }
    /// Joint names in tree order (`"universe"` first).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.model.joints.iter().map(|j| j.name.clone()).collect()
    }
    /// Frame names (URDF links and added frames).
    #[getter]
    fn frame_names(&self) -> Vec<String> {
        self.model.frames.iter().map(|f| f.name.clone()).collect()
    }
    #[getter]
    fn has_floating_base(&self) -> bool {
        self.model.has_floating_base()
    }

    /// The neutral configuration (`nq`).
    fn neutral<'py>(&self, py: Python<'py>) -> Vector<'py> {
        PyArray1::from_slice(py, self.model.neutral_configuration().as_slice())
    }

    /// Inverse dynamics `τ = M(q) a + h(q, v)` (RNEA).
    fn rnea<'py>(&self, py: Python<'py>, q: Arg<'py>, v: Arg<'py>, a: Arg<'py>) -> PyResult<Vector<'py>> {
        self.qvx(py, (&q, &v, ("a", &a)), rnea)
    }

    /// Forward dynamics `a = M(q)⁻¹ (τ − h(q, v))` (ABA).
    fn aba<'py>(&self, py: Python<'py>, q: Arg<'py>, v: Arg<'py>, tau: Arg<'py>) -> PyResult<Vector<'py>> {
        self.qvx(py, (&q, &v, ("tau", &tau)), aba)
    }

    /// The joint-space inertia matrix `M(q)` (`nv × nv`, both triangles; CRBA).
    fn crba<'py>(&self, py: Python<'py>, q: Arg<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let q = vector("q", &q, self.model.nq)?;
        let mut d = lock(&self.data, "model")?;
        matrix(py, crba(&self.model, &mut d, q))
    }

    /// The bias forces `h(q, v)` (Coriolis, centrifugal and gravity).
    fn nonlinear_effects<'py>(&self, py: Python<'py>, q: Arg<'py>, v: Arg<'py>) -> PyResult<Vector<'py>> {
        let m = &self.model;
        let (q, v) = (vector("q", &q, m.nq)?, vector("v", &v, m.nv)?);
        let mut d = lock(&self.data, "model")?;
        Ok(PyArray1::from_slice(py, nonlinear_effects(m, &mut d, q, v).as_slice()))
    }

    /// The gravity torques `g(q)`.
    fn gravity_torques<'py>(&self, py: Python<'py>, q: Arg<'py>) -> PyResult<Vector<'py>> {
        let q = vector("q", &q, self.model.nq)?;
        let mut d = lock(&self.data, "model")?;
        Ok(PyArray1::from_slice(py, gravity_torques(&self.model, &mut d, q).as_slice()))
    }

    /// The centre of mass in the world (m).
    fn center_of_mass<'py>(&self, py: Python<'py>, q: Arg<'py>) -> PyResult<Vector<'py>> {
        let q = vector("q", &q, self.model.nq)?;
        let mut d = lock(&self.data, "model")?;
        Ok(PyArray1::from_slice(py, center_of_mass(&self.model, &mut d, q).as_slice()))
    }

    /// Kinetic and potential energy `(T, V)` (J).
    fn energy(&self, q: PyReadonlyArray1<'_, f64>, v: PyReadonlyArray1<'_, f64>) -> PyResult<(f64, f64)> {
        let m = &self.model;
        let (q, v) = (vector("q", &q, m.nq)?, vector("v", &v, m.nv)?);
        let mut d = lock(&self.data, "model")?;
        Ok((kinetic_energy(m, &mut d, q, v), potential_energy(m, &mut d, q)))
    }

    /// The world placement of frame `frame` as a 4 × 4 homogeneous matrix.
    fn frame_placement<'py>(
        &self,
        py: Python<'py>,
        q: Arg<'py>,
        frame: &str,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = &self.model;
        let q = vector("q", &q, m.nq)?;
        let f = self.frame(frame)?;
        let mut d = lock(&self.data, "model")?;
        forward_kinematics(m, &mut d, q);
        update_frame_placements(m, &mut d);
        homogeneous(py, &frame_placement(m, &d, f))
    }

    /// The Jacobian of frame `frame` (6 × nv, linear rows first) in `reference`:
    /// `"local_world_aligned"` (default), `"world"` or `"local"`.
    #[pyo3(signature = (q, frame, reference="local_world_aligned"))]
    fn frame_jacobian<'py>(
        &self,
        py: Python<'py>,
        q: Arg<'py>,
        frame: &str,
        reference: &str,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = &self.model;
        let q = vector("q", &q, m.nq)?;
        let (f, rf) = (self.frame(frame)?, reference_frame(reference)?);
        let mut d = lock(&self.data, "model")?;
        compute_joint_jacobians(m, &mut d, q);
        let mut j = Matrix6xX::zeros(m.nv);
        frame_jacobian(m, &d, f, rf, &mut j);
        matrix(py, &j)
    }

    /// `q ⊕ v`: the configuration reached from `q` with velocity `v` in unit time.
    fn integrate<'py>(&self, py: Python<'py>, q: Arg<'py>, v: Arg<'py>) -> PyResult<Vector<'py>> {
        let m = &self.model;
        let (q, v) = (vector("q", &q, m.nq)?, vector("v", &v, m.nv)?);
        let mut out = vec![0.0; m.nq];
        integrate(m, q, v, &mut out);
        Ok(PyArray1::from_vec(py, out))
    }

    /// `q1 ⊖ q0`: the velocity that takes `q0` to `q1` in unit time.
    fn difference<'py>(&self, py: Python<'py>, q0: Arg<'py>, q1: Arg<'py>) -> PyResult<Vector<'py>> {
        let m = &self.model;
        let (q0, q1) = (vector("q0", &q0, m.nq)?, vector("q1", &q1, m.nq)?);
        let mut out = vec![0.0; m.nv];
        difference(m, q0, q1, &mut out);
        Ok(PyArray1::from_vec(py, out))
    }
}

/// A float64 vector argument.
type Arg<'py> = PyReadonlyArray1<'py, f64>;
/// A float64 vector result.
type Vector<'py> = Bound<'py, PyArray1<f64>>;
/// An algorithm of `(q, v, x)` with `x` of length `nv` (RNEA, ABA).
type QvxAlgorithm = for<'d> fn(&RustModel, &'d mut Data, &[f64], &[f64], &[f64]) -> &'d DVector<f64>;

impl Model {
    /// Checks `q`, `v` and the named `x`, then runs `f`.
    fn qvx<'py>(
        &self,
        py: Python<'py>,
        (q, v, (xn, x)): (&Arg<'py>, &Arg<'py>, (&str, &Arg<'py>)),
        f: QvxAlgorithm,
    ) -> PyResult<Vector<'py>> {
        let m = &self.model;
        let (q, v, x) = (vector("q", q, m.nq)?, vector("v", v, m.nv)?, vector(xn, x, m.nv)?);
        let mut d = lock(&self.data, "model")?;
        Ok(PyArray1::from_slice(py, f(m, &mut d, q, v, x).as_slice()))
    }

    fn frame(&self, name: &str) -> PyResult<usize> {
        self.model
            .frame_index(name)
            .ok_or_else(|| error(format!("the model `{}` has no frame `{name}`", self.model.name)))
    }
}
