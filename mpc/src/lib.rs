//! # centaur-mpc (work in progress)
#![allow(missing_docs)]
pub mod config;
pub mod controller;
pub mod convex_mpc;
pub mod friction;
pub mod gait;
pub mod minitaur;
pub mod qp;
pub mod robot;
pub mod swing;
pub mod wbc;

pub use config::{Command, ConfigError, ControlMode, ControllerConfig};
pub use controller::{ControllerStatus, Fallback, JointCommand, LocomotionController};
pub use convex_mpc::{ConvexMpc, HardConstraints, MpcConfig};
pub use friction::FrictionModel;
pub use gait::{Gait, GaitPattern, GaitScheduler};
pub use qp::{DenseQp, DenseQpData, QpStatus};
pub use robot::{BaseSpec, ContactSpec, LeggedRobot, LoopClosureSpec, RobotSpec};
pub use wbc::{QpBackend, WbcConfig, WholeBodyQp};

/// Largest number of contact points.
pub const MAX_CONTACTS: usize = 8;
