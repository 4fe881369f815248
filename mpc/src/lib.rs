//! # centaur-mpc (work in progress)
#![allow(missing_docs)]
pub mod convex_mpc;
pub mod friction;
pub mod gait;
pub mod qp;

/// Largest number of contact points.
pub const MAX_CONTACTS: usize = 8;

/// A configuration that cannot be used.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum ConfigError {
    #[error("{field} = {value} is out of range ({range})")]
    OutOfRange { field: &'static str, value: f64, range: &'static str },
    #[error("solver setup failed: {0}")]
    Solver(String),
}
