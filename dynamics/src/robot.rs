//! [`Robot`]: a model with its workspace, for a first program.

use std::path::Path;

use nalgebra::{DMatrix, DVector, Vector3};

use crate::data::Data;
use crate::model::Model;
use crate::spatial::Se3;
use crate::state::RobotState;
use crate::urdf::{BaseKind, UrdfError};

/// A [`Model`] that owns its [`Data`]: the convenience layer over the free functions.
///
/// ```
/// # fn main() -> Result<(), centaur_dynamics::UrdfError> {
/// let urdf = r#"<robot name="pendulum">
///   <link name="base"/>
///   <link name="arm"><inertial><mass value="2"/><origin xyz="0 0 -0.5"/>
///     <inertia ixx="0.01" iyy="0.01" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
///   <joint name="hinge" type="continuous"><parent link="base"/><child link="arm"/>
///     <axis xyz="0 1 0"/></joint>
/// </robot>"#;
/// let mut robot = centaur_dynamics::Robot::from_urdf_str(urdf, centaur_dynamics::BaseKind::Fixed)?;
/// let mut state = robot.neutral_state();
/// state.q[0] = 0.3;
/// // Holding the arm still at 0.3 rad takes m g l sin(0.3) = 2 · 9.81 · 0.5 · sin 0.3.
/// let tau = robot.inverse_dynamics(&state, &[0.0])[0];
/// assert!((tau - 2.0 * 9.81 * 0.5 * 0.3f64.sin()).abs() < 1e-12);
/// # Ok(()) }
/// ```
#[derive(Clone, Debug)]
pub struct Robot {
    /// The model.
    pub model: Model,
    /// Its workspace.
    pub data: Data,
}

impl Robot {
    /// Loads a legged robot from a URDF file, with a floating base.
    pub fn from_urdf(path: impl AsRef<Path>) -> Result<Robot, UrdfError> {
        Ok(Robot::from_model(Model::from_urdf_file(path, BaseKind::Floating)?))
    }

    /// Loads a URDF file with the given base.
    pub fn from_urdf_with_base(path: impl AsRef<Path>, base: BaseKind) -> Result<Robot, UrdfError> {
        Ok(Robot::from_model(Model::from_urdf_file(path, base)?))
    }

    /// Builds from URDF text.
    pub fn from_urdf_str(text: &str, base: BaseKind) -> Result<Robot, UrdfError> {
        Ok(Robot::from_model(Model::from_urdf_str(text, "<string>", base)?))
    }

    /// Wraps an existing model.
    pub fn from_model(model: Model) -> Robot {
        let data = Data::new(&model);
        Robot { model, data }
    }

    /// The neutral configuration at rest.
    pub fn neutral_state(&self) -> RobotState {
        RobotState::new(&self.model)
    }

    /// Total mass moved by the joints.
    pub fn total_mass(&self) -> f64 {
        self.model.total_mass()
    }

    /// Joint torques (and base wrench) that produce accelerations `a` from `state`.
    #[track_caller]
    pub fn inverse_dynamics(&mut self, state: &RobotState, a: &[f64]) -> &DVector<f64> {
        crate::rnea(&self.model, &mut self.data, state.q.as_slice(), state.v.as_slice(), a)
    }

    /// Accelerations produced by generalized forces `tau` from `state`.
    #[track_caller]
    pub fn forward_dynamics(&mut self, state: &RobotState, tau: &[f64]) -> &DVector<f64> {
        crate::aba(&self.model, &mut self.data, state.q.as_slice(), state.v.as_slice(), tau)
    }

    /// Joint-space inertia matrix at `state`.
    pub fn mass_matrix(&mut self, state: &RobotState) -> &DMatrix<f64> {
        crate::crba(&self.model, &mut self.data, state.q.as_slice())
    }

    /// Centre of mass in the world at `state`.
    pub fn center_of_mass(&mut self, state: &RobotState) -> Vector3<f64> {
        crate::center_of_mass(&self.model, &mut self.data, state.q.as_slice())
    }

    /// World placement of the frame (link) called `name` at `state`, if it exists.
    pub fn frame_placement(&mut self, state: &RobotState, name: &str) -> Option<Se3> {
        let f = self.model.frame_index(name)?;
        crate::forward_kinematics(&self.model, &mut self.data, state.q.as_slice());
        Some(crate::frame_placement(&self.model, &self.data, f))
    }
}
