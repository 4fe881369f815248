//! [`RobotState`]: the one currency between simulator, estimator and controller.

use nalgebra::{DVector, Quaternion, UnitQuaternion, Vector3};

use crate::model::Model;

/// The state of a robot in its model's layout: configuration `q` and velocity `v`.
///
/// For a floating-base model (`Model::has_floating_base`):
/// `q = [x, y, z, qx, qy, qz, qw, joint positions…]` — base position in the world and the
/// base orientation as a scalar-last unit quaternion (world ← base);
/// `v = [v_base, ω_base, joint velocities…]` — the base twist **expressed in the base frame**
/// (linear velocity of the base origin, then angular velocity). Helper methods convert to
/// world axes. For a fixed-base model `q` and `v` hold only joints, and the base accessors
/// return the identity pose and zero twist.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotState {
    /// Configuration, length `model.nq`.
    pub q: DVector<f64>,
    /// Velocity, length `model.nv`.
    pub v: DVector<f64>,
    floating: bool,
}

impl RobotState {
    /// The neutral configuration at rest.
    pub fn new(model: &Model) -> Self {
        Self {
            q: model.neutral_configuration(),
            v: DVector::zeros(model.nv),
            floating: model.has_floating_base(),
        }
    }

    /// Wraps `q` and `v`, checking their lengths.
    #[track_caller]
    pub fn from_qv(model: &Model, q: DVector<f64>, v: DVector<f64>) -> Self {
        assert!(q.len() == model.nq, "q has length {}, but the model expects {}", q.len(), model.nq);
        assert!(v.len() == model.nv, "v has length {}, but the model expects {}", v.len(), model.nv);
        Self { q, v, floating: model.has_floating_base() }
    }

    /// Whether the first 7/6 entries of `q`/`v` are a floating base.
    pub fn has_floating_base(&self) -> bool {
        self.floating
    }

    fn base_dims(&self) -> (usize, usize) {
        if self.floating { (7, 6) } else { (0, 0) }
    }

    /// Base position in the world.
    pub fn base_position(&self) -> Vector3<f64> {
        if self.floating { Vector3::new(self.q[0], self.q[1], self.q[2]) } else { Vector3::zeros() }
    }

    /// Base orientation (world ← base).
    pub fn base_orientation(&self) -> UnitQuaternion<f64> {
        if self.floating {
            UnitQuaternion::from_quaternion(Quaternion::new(self.q[6], self.q[3], self.q[4], self.q[5]))
        } else {
            UnitQuaternion::identity()
        }
    }

    /// Base linear velocity in the base frame.
    pub fn base_linear_velocity(&self) -> Vector3<f64> {
        if self.floating { Vector3::new(self.v[0], self.v[1], self.v[2]) } else { Vector3::zeros() }
    }

    /// Base angular velocity in the base frame.
    pub fn base_angular_velocity(&self) -> Vector3<f64> {
        if self.floating { Vector3::new(self.v[3], self.v[4], self.v[5]) } else { Vector3::zeros() }
    }

    /// Base linear velocity in world axes.
    pub fn base_linear_velocity_world(&self) -> Vector3<f64> {
        self.base_orientation() * self.base_linear_velocity()
    }

    /// Base angular velocity in world axes.
    pub fn base_angular_velocity_world(&self) -> Vector3<f64> {
        self.base_orientation() * self.base_angular_velocity()
    }

    /// Sets the base pose (ignored for a fixed base).
    pub fn set_base_pose(&mut self, position: Vector3<f64>, orientation: UnitQuaternion<f64>) {
        if self.floating {
            let q = orientation.quaternion();
            self.q.as_mut_slice()[..7]
                .copy_from_slice(&[position.x, position.y, position.z, q.i, q.j, q.k, q.w]);
        }
    }

    /// Sets the base twist from world-axes linear and angular velocities (ignored for a
    /// fixed base).
    pub fn set_base_twist_world(&mut self, linear: Vector3<f64>, angular: Vector3<f64>) {
        if self.floating {
            let r = self.base_orientation();
            let (l, a) = (r.inverse_transform_vector(&linear), r.inverse_transform_vector(&angular));
            self.v.as_mut_slice()[..6].copy_from_slice(&[l.x, l.y, l.z, a.x, a.y, a.z]);
        }
    }

    /// Joint positions (everything after the base). With
    /// [`crate::JointKind::RevoluteUnbounded`] joints this holds their `(cos θ, sin θ)`
    /// pairs and is longer than [`RobotState::joint_velocities`].
    pub fn joint_positions(&self) -> &[f64] {
        &self.q.as_slice()[self.base_dims().0..]
    }

    /// Joint positions, mutable.
    pub fn joint_positions_mut(&mut self) -> &mut [f64] {
        let s = self.base_dims().0;
        &mut self.q.as_mut_slice()[s..]
    }

    /// Joint velocities (everything after the base).
    pub fn joint_velocities(&self) -> &[f64] {
        &self.v.as_slice()[self.base_dims().1..]
    }

    /// Joint velocities, mutable.
    pub fn joint_velocities_mut(&mut self) -> &mut [f64] {
        let s = self.base_dims().1;
        &mut self.v.as_mut_slice()[s..]
    }

    /// Whether every number is finite.
    pub fn is_finite(&self) -> bool {
        self.q.iter().chain(self.v.iter()).all(|x| x.is_finite())
    }
}
