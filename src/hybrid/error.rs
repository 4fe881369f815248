//! [`HybridError`]: what the hybrid's pieces refuse.

use centaur_mpc::ConfigError;

/// What the hybrid's pieces refuse.
#[derive(Debug, thiserror::Error)]
pub enum HybridError {
    /// A robot actuator whose joint the controller does not drive.
    #[error("the controller does not drive the robot's actuated joint '{joint}'")]
    NotDriven {
        /// The joint.
        joint: String,
    },
    /// An actuated joint with more than one coordinate (a `(cos θ, sin θ)` pair).
    #[error(
        "the actuated joint '{joint}' is not a one-coordinate joint (load the URDF with angles: the default UrdfOptions)"
    )]
    NotOneCoordinate {
        /// The joint.
        joint: String,
    },
    /// A residual scale of the wrong length.
    #[error("the residual scale has {entries} entries; give 1 or the action dimension {action_dim}")]
    ScaleLength {
        /// Entries given.
        entries: usize,
        /// The action dimension.
        action_dim: usize,
    },
    /// A residual scale that is negative or not finite.
    #[error("residual scale {value:?} is not a finite, non-negative number")]
    BadScale {
        /// The value.
        value: f64,
    },
    /// A policy whose dimensions do not fit the robot and residual setup.
    #[error("the policy maps {} observations to {} actions; this robot and residual setup need {} → {}", policy.0, policy.1, needed.0, needed.1)]
    PolicyShape {
        /// The policy's observation and action dimensions.
        policy: (usize, usize),
        /// What the robot and residual need.
        needed: (usize, usize),
    },
    /// A steering span or exploration σ out of range.
    #[error("{part} = {value:?}: expected {expected}")]
    BadSetting {
        /// Which setting.
        part: &'static str,
        /// The value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// Neither a joint residual nor any steering: the policy would have no action.
    #[error("the hybrid's policy has nothing to act on: turn on the joint residual or a steering span")]
    NothingToLearn,
    /// The controller's configuration.
    #[error("controller: {0}")]
    Controller(#[from] ConfigError),
}
