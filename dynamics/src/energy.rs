//! Kinetic and potential energy.

use crate::data::{Data, check_len};
use crate::kinematics::forward_kinematics_velocity;
use crate::model::Model;

/// Kinetic energy `½ vᵀ M(q) v = Σᵢ ½ vᵢ · (Iᵢ vᵢ)`; result in `data.kinetic_energy`.
/// Also runs [`forward_kinematics_velocity`].
#[track_caller]
pub fn kinetic_energy(model: &Model, data: &mut Data, q: &[f64], v: &[f64]) -> f64 {
    forward_kinematics_velocity(model, data, q, v);
    let e: f64 = (1..model.njoints()).map(|i| model.inertias[i].kinetic_energy(&data.v[i])).sum();
    data.kinetic_energy = e;
    e
}

/// Potential energy in the model's gravity field, `−Σᵢ mᵢ gᵀ cᵢ` (zero at the world
/// origin's height); result in `data.potential_energy`. Also runs forward kinematics.
#[track_caller]
pub fn potential_energy(model: &Model, data: &mut Data, q: &[f64]) -> f64 {
    check_len("q", q.len(), model.nq);
    crate::kinematics::forward_kinematics(model, data, q);
    let e: f64 = (1..model.njoints())
        .map(|i| {
            let y = &model.inertias[i];
            -y.mass * model.gravity.dot(&data.o_m_i[i].act_point(&y.lever))
        })
        .sum();
    data.potential_energy = e;
    e
}
