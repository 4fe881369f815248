//! `Controller`: the convex-MPC + whole-body-QP locomotion controller on numpy states.

use std::sync::Mutex;

use centaur_dynamics::RobotState;
use centaur_mpc::{
    Command, ControllerConfig, GAIT_RATE_RANGE, Gait, LocomotionController, MAX_DUTY_SHIFT,
    MAX_FOOTHOLD_OFFSET, SWING_SCALE_RANGE, duty_shift_in_range,
};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::dynamics::Model;
use crate::{check_len, error, lock};

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Controller>()
}

/// A `LocomotionController` for a model with a controller preset (`"minitaur"`, `"ant"`,
/// `"walker2d"`, `"humanoid"`, `"solo12"`). `tick(q, v, t, …)` returns `(torques, targets,
/// status)`: the torques the command applies at this state (`τ_ff + kp (q_des − q) + kd
/// (q̇_des − q̇)`, one per controlled joint in `joint_names` order), the command's parts,
/// and a dict of the tick's status.
#[pyclass(module = "centaur._native", frozen)]
pub struct Controller {
    inner: Mutex<State>,
    /// `(idx_q, idx_v)` of each controlled joint, in the controller's order.
    joints: Vec<(usize, usize)>,
    names: Vec<String>,
    contacts: usize,
    nq: usize,
    nv: usize,
}

struct State {
    controller: LocomotionController,
    state: RobotState,
    torques: Vec<f64>,
    q: Vec<f64>,
    qd: Vec<f64>,
}

/// What `tick` returns: torques, targets and status.
type Tick<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyDict>, Bound<'py, PyDict>);

#[pymethods]
impl Controller {
    /// The controller of `preset` for `model` (e.g. `Model.for_robot("minitaur")`).
    #[new]
    fn new(model: &Model, preset: &str) -> PyResult<Controller> {
        let model = &model.model;
        let config = ControllerConfig::preset(preset).ok_or_else(|| {
            error(format!(
                "unknown controller preset `{preset}` (presets: ant, humanoid, minitaur, solo12, walker2d)"
            ))
        })?;
        let controller = LocomotionController::new(model, config).map_err(error)?;
        let names = controller.joint_names().to_vec();
        let mut joints = Vec::with_capacity(names.len());
        for name in &names {
            let j = model.joint_index(name).map(|j| &model.joints[j]).filter(|j| j.nq() == 1 && j.nv() == 1);
            let j = j.ok_or_else(|| {
                error(format!("controlled joint `{name}` is not a one-coordinate joint of the model"))
            })?;
            joints.push((j.idx_q, j.idx_v));
        }
        let n = names.len();
        let contacts = controller.contact_frames().len();
        let state = RobotState::new(model);
        Ok(Controller {
            inner: Mutex::new(State {
                controller,
                state,
                torques: vec![0.0; n],
                q: vec![0.0; n],
                qd: vec![0.0; n],
            }),
            joints,
            names,
            contacts,
            nq: model.nq,
            nv: model.nv,
        })
    }

    /// The controlled joints, in the order of `tick`'s arrays.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.names.clone()
    }

    /// The frames of the contact points, in the order of `contacts` and the status.
    #[getter]
    fn contact_frames(&self) -> PyResult<Vec<String>> {
        Ok(lock(&self.inner, "controller")?.controller.contact_frames().to_vec())
    }

    /// The gaits this preset offers (others are refused).
    #[getter]
    fn gaits(&self) -> PyResult<Vec<&'static str>> {
        let s = lock(&self.inner, "controller")?;
        Ok(Gait::ALL
            .iter()
            .filter(|g| s.controller.config().find_offer(**g).is_some())
            .map(|g| g.name())
            .collect())
    }

    /// The nominal standing configuration (`nq`).
    fn nominal<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(PyArray1::from_slice(py, lock(&self.inner, "controller")?.controller.nominal_state().q.as_slice()))
    }

    /// Forgets the gait phase, command ramps and plan (at an episode start).
    fn reset(&self) -> PyResult<()> {
        lock(&self.inner, "controller")?.controller.reset();
        Ok(())
    }

    /// Sets the rate of the gait clock: 1 runs every gait at its own period, 1.5 steps
    /// every cycle in 1/1.5 of it; the clock follows at a bounded slew and the phase
    /// carries on (a reset goes back to 1). A rate outside [0.25, 4] (or not finite) is an
    /// error.
    fn set_gait_rate(&self, rate: f64) -> PyResult<()> {
        check_range("gait rate", "a rate", rate, GAIT_RATE_RANGE)?;
        lock(&self.inner, "controller")?.controller.set_gait_rate(rate);
        Ok(())
    }

    /// The rate the gait clock runs at now (`set_gait_rate`).
    #[getter]
    fn gait_rate(&self) -> PyResult<f64> {
        Ok(lock(&self.inner, "controller")?.controller.gait_rate())
    }

    /// Moves every stepping gait's stance fractions by `shift` from their own (below 0 the
    /// feet lift off sooner: a trot with flight phases); followed at a bounded slew, each
    /// leg's phase carrying on (a reset goes back to 0). A shift outside [-0.3, 0.3] (or not
    /// finite) is an error.
    fn set_gait_duty_shift(&self, shift: f64) -> PyResult<()> {
        if !duty_shift_in_range(shift) {
            return Err(error(format!(
                "duty shift {shift}, expected a fraction in [-{MAX_DUTY_SHIFT}, {MAX_DUTY_SHIFT}]"
            )));
        }
        lock(&self.inner, "controller")?.controller.set_gait_duty_shift(shift);
        Ok(())
    }

    /// The shift of the stance fractions in force now (`set_gait_duty_shift`).
    #[getter]
    fn gait_duty_shift(&self) -> PyResult<f64> {
        Ok(lock(&self.inner, "controller")?.controller.gait_duty_shift())
    }

    /// Scales the swing feet's apex height by `scale` for every swing that lifts off from
    /// now on (a swing under way keeps its curve; a reset goes back to 1). A scale outside
    /// [0.25, 1.75] (or not finite) is an error.
    fn set_swing_height_scale(&self, scale: f64) -> PyResult<()> {
        check_range("swing height scale", "a scale", scale, SWING_SCALE_RANGE)?;
        lock(&self.inner, "controller")?.controller.set_swing_height_scale(scale);
        Ok(())
    }

    /// The scale the next swings' apex takes (`set_swing_height_scale`).
    #[getter]
    fn swing_height_scale(&self) -> PyResult<f64> {
        Ok(lock(&self.inner, "controller")?.controller.swing_height_scale())
    }

    /// Moves the footholds of every swing that lifts off from now on `offset` metres forward
    /// along the heading (negative: behind; a swing under way keeps its foothold; a reset
    /// goes back to 0). An offset outside [-0.1, 0.1] m (or not finite) is an error.
    fn set_foothold_offset(&self, offset: f64) -> PyResult<()> {
        check_range("foothold offset", "metres", offset, (-MAX_FOOTHOLD_OFFSET, MAX_FOOTHOLD_OFFSET))?;
        lock(&self.inner, "controller")?.controller.set_foothold_offset(offset);
        Ok(())
    }

    /// The foothold offset the next swings take (`set_foothold_offset`).
    #[getter]
    fn foothold_offset(&self) -> PyResult<f64> {
        Ok(lock(&self.inner, "controller")?.controller.foothold_offset())
    }

    /// One control step at time `t` (s) from state `(q, v)`, following the command (speeds in
    /// m/s and rad/s in the heading frame; `gait` one of `gaits`; a speed or yaw rate outside
    /// the gait's rating is clamped to it and counted in the status's `clamped_commands`);
    /// `contacts`: measured foot contacts, one per contact frame, or `None` to trust the
    /// schedule.
    #[pyo3(signature = (q, v, t, forward_velocity=0.0, lateral_velocity=0.0, yaw_rate=0.0, gait="trot", body_height=None, contacts=None))]
    fn tick<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
        v: PyReadonlyArray1<'py, f64>,
        t: f64,
        forward_velocity: f64,
        lateral_velocity: f64,
        yaw_rate: f64,
        gait: &str,
        body_height: Option<f64>,
        contacts: Option<Vec<bool>>,
    ) -> PyResult<Tick<'py>> {
        let (q, v) = (q.as_slice().map_err(error)?, v.as_slice().map_err(error)?);
        check_len("q", q.len(), self.nq)?;
        check_len("v", v.len(), self.nv)?;
        for (what, x) in [
            ("t", t),
            ("forward_velocity", forward_velocity),
            ("lateral_velocity", lateral_velocity),
            ("yaw_rate", yaw_rate),
        ]
        .into_iter()
        .chain(body_height.map(|h| ("body_height", h)))
        {
            if !x.is_finite() {
                return Err(error(format!("{what} is {x}, expected a finite number")));
            }
        }
        let gait = Gait::from_name(gait).ok_or_else(|| error(format!("unknown gait `{gait}`")))?;
        let mut s = lock(&self.inner, "controller")?;
        s.controller.config().offer(gait).map_err(error)?;
        if let Some(c) = &contacts {
            check_len("contacts", c.len(), self.contacts)?;
        }
        let command = Command { forward_velocity, lateral_velocity, yaw_rate, body_height, gait };
        let State { controller, state, torques, q: qj, qd: qdj } = &mut *s;
        state.q.as_mut_slice().copy_from_slice(q);
        state.v.as_mut_slice().copy_from_slice(v);
        // A non-finite state is the controller's to handle (posture PD, said in the status).
        let cmd = match &contacts {
            Some(c) => controller.tick_with_contacts(state, &command, t, c),
            None => controller.tick(state, &command, t),
        };
        for (k, &(iq, iv)) in self.joints.iter().enumerate() {
            qj[k] = q[iq];
            qdj[k] = v[iv];
        }
        cmd.torque(qj, qdj, torques);
        let targets = PyDict::new(py);
        targets.set_item("tau_ff", PyArray1::from_slice(py, &cmd.tau))?;
        targets.set_item("q_des", PyArray1::from_slice(py, &cmd.q_des))?;
        targets.set_item("qd_des", PyArray1::from_slice(py, &cmd.qd_des))?;
        targets.set_item("kp", PyArray1::from_slice(py, &cmd.kp))?;
        targets.set_item("kd", PyArray1::from_slice(py, &cmd.kd))?;
        let st = controller.status();
        let status = PyDict::new(py);
        status.set_item("t", st.t)?;
        status.set_item("gait", st.gait.name())?;
        status.set_item("phase", st.phase)?;
        status.set_item("contact", st.contact.clone())?;
        status.set_item("mpc_ran", st.mpc_ran)?;
        status.set_item("mpc_status", format!("{:?}", st.mpc_status))?;
        status.set_item("mpc_solve_us", st.mpc_solve_us)?;
        status.set_item("mpc_iterations", st.mpc_iterations)?;
        status.set_item("wbc_status", format!("{:?}", st.wbc_status))?;
        status.set_item("wbc_solve_us", st.wbc_solve_us)?;
        status.set_item("fallback", format!("{:?}", st.fallback))?;
        status.set_item("clamped_commands", st.clamped_commands)?;
        status.set_item("invalid_states", st.invalid_states)?;
        status.set_item("forces", st.forces.clone())?;
        status.set_item("foot_positions", st.foot_positions.clone())?;
        status.set_item("footholds", st.footholds.clone())?;
        Ok((PyArray1::from_slice(py, torques), targets, status))
    }
}

/// `value` (named `what`, a `noun`) finite and within `[low, high]`, or an error naming both.
fn check_range(what: &str, noun: &str, value: f64, (low, high): (f64, f64)) -> PyResult<()> {
    if value.is_finite() && (low..=high).contains(&value) {
        Ok(())
    } else {
        Err(error(format!("{what} {value}, expected {noun} in [{low}, {high}]")))
    }
}
