//! [`RobotEnvError`]: why a robot environment cannot be built, with the underlying error
//! (the URDF loader's, the simulator's, the modular builder's) kept as its source. Inside
//! the [`centaur_gym::Env`] API it travels as [`centaur_gym::EnvError::Env`].

use centaur_dynamics::UrdfError;

use crate::modular::ModularError;
use crate::sim::SimError;

/// A robot environment that cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum RobotEnvError {
    /// A configuration value out of its range.
    #[error("{config}: {message}")]
    InvalidConfig {
        /// The configuration type, e.g. `MinitaurConfig`.
        config: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The robot's URDF does not load.
    #[error("{robot}: {source}")]
    Urdf {
        /// The robot.
        robot: String,
        /// The loader's error (boxed: it is large).
        #[source]
        source: Box<UrdfError>,
    },
    /// The simulator cannot build the robot.
    #[error("{robot}: the simulator cannot build the robot: {source}")]
    Sim {
        /// The robot.
        robot: String,
        /// The simulator's error.
        #[source]
        source: SimError,
    },
    /// A modular body cannot become a robot.
    #[error("{robot}: {source}")]
    Modular {
        /// The robot.
        robot: String,
        /// The modular builder's error.
        #[source]
        source: ModularError,
    },
    /// A joint or link the environment needs is missing from the model.
    #[error("{robot}: the model has no {what} '{name}'")]
    Missing {
        /// The robot.
        robot: String,
        /// `"joint"` or `"link"`.
        what: &'static str,
        /// Its name.
        name: String,
    },
    /// The MuJoCo layout file that goes with a Gymnasium robot does not parse.
    #[error("{robot}: its MuJoCo layout (assets/mujoco/{robot}.mujoco.json) is not readable: {source}")]
    Layout {
        /// The robot.
        robot: String,
        /// The JSON error.
        #[source]
        source: serde_json::Error,
    },
}

impl RobotEnvError {
    /// An invalid configuration of the given type.
    pub(crate) fn config(config: &'static str, message: impl Into<String>) -> RobotEnvError {
        RobotEnvError::InvalidConfig { config, message: message.into() }
    }
}

impl From<RobotEnvError> for centaur_gym::EnvError {
    fn from(e: RobotEnvError) -> Self {
        centaur_gym::EnvError::env(e)
    }
}
