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
