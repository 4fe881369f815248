//! The one error of the crate's set-up: a [`ConfigError`] from `validate()` and the
//! constructors (`new`) of the controller and its solvers.

/// A configuration that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A number outside its documented range.
    #[error("{field} = {value} is out of range ({range})")]
    OutOfRange {
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range.
        range: &'static str,
    },
    /// A frame or joint name that the model does not have.
    #[error("the model has no {kind} named '{name}'")]
    UnknownName {
        /// "frame" or "joint".
        kind: &'static str,
        /// The name.
        name: String,
    },
    /// A gait the robot's configuration does not offer ([`crate::ControllerConfig::gaits`]).
    #[error("the gait '{gait}' is not offered for this robot; it offers {offered}")]
    GaitNotOffered {
        /// The gait asked for.
        gait: &'static str,
        /// The gaits it offers, with their speed ranges and turning (`"stand, trot (0–2.5
        /// m/s; straight only)"`).
        offered: String,
    },
    /// A speed above the gait's rated maximum ([`crate::GaitOffer::max_speed`]).
    #[error("{gait} at {speed} m/s is above this robot's rated {max_speed} m/s for that gait")]
    SpeedAboveRating {
        /// The gait.
        gait: &'static str,
        /// The speed asked for (m/s).
        speed: f64,
        /// The gait's rated speed (m/s).
        max_speed: f64,
    },
    /// A yaw rate above the gait's turning rating at the commanded speed
    /// ([`crate::GaitOffer::max_yaw_rate`], [`crate::GaitOffer::max_turning_speed`]).
    #[error(
        "{gait} turning at {yaw_rate} rad/s at {speed} m/s is outside this robot's rating for that gait: {rating}"
    )]
    YawRateAboveRating {
        /// The gait.
        gait: &'static str,
        /// The yaw rate asked for (rad/s).
        yaw_rate: f64,
        /// The planar speed asked for (m/s).
        speed: f64,
        /// The gait's turning rating in words (`"turns at up to 0.5 rad/s to 0.6 m/s"`).
        rating: String,
    },
    /// Fields that do not fit together.
    #[error("inconsistent configuration: {0}")]
    Inconsistent(String),
    /// Clarabel rejected the problem set-up (kept as the source).
    #[error("{problem}: Clarabel rejected the problem set-up: {source}")]
    Solver {
        /// Which problem: `"convex MPC"` or `"whole-body QP"`.
        problem: &'static str,
        /// Clarabel's error.
        #[source]
        source: clarabel::solver::SolverError,
    },
    /// The MPC's worker thread ([`crate::MpcExecution::Background`]) could not start.
    #[error("could not start the MPC thread: {0}")]
    Thread(#[source] std::io::Error),
}
