//! What the planning stages hand to the torque stage, in one typed struct (the MIT
//! Cheetah controller's `LocomotionCtrlData`): per contact point its effective stance, the
//! force the plan gives it and its motion target; for the body, the shaped reference
//! lives in [`super::reference::Reference`].

use centaur_dynamics::nalgebra::Vector3;

use super::estimate::Estimate;
use super::reference::Reference;
use crate::config::ControllerConfig;
use crate::gait::GaitScheduler;
use crate::robot::LeggedRobot;
use crate::swing::PointTarget;

/// What the stages after the reference read this tick: the configuration, the robot, the
/// estimate, the shaped reference and the gait schedule, and the tick's times.
pub(crate) struct TickContext<'a> {
    pub cfg: &'a ControllerConfig,
    pub robot: &'a LeggedRobot,
    pub est: &'a Estimate,
    pub reference: &'a Reference,
    pub gait: &'a GaitScheduler,
    /// Time of the tick (s).
    pub t: f64,
    /// Time since the last tick (s; 0 at the first).
    pub dt: f64,
    /// Body (CoM) height to hold.
    pub height: f64,
}

/// The planner's output for this tick, per contact point (contact order).
pub(crate) struct LocomotionTargets {
    /// Effective stance: the schedule, refined by measured touch-downs and early contacts.
    pub stance: Vec<bool>,
    /// Force of the plan (or its fallback) for this tick (world, N); the torque stage
    /// replaces it with the whole-body QP's.
    pub force: Vec<Vector3<f64>>,
    /// Target of the point: the swing curve, or for a planted foot where it should be seen
    /// from a body on its reference.
    pub motion: Vec<PointTarget>,
    /// Touch-down point of the current or coming swing.
    pub foothold: Vec<Vector3<f64>>,
    /// Where the MPC expects the point's next stance.
    pub next_foothold: Vec<Vector3<f64>>,
}

impl LocomotionTargets {
    pub(crate) fn new(nc: usize) -> Self {
        LocomotionTargets {
            stance: vec![true; nc],
            force: vec![Vector3::zeros(); nc],
            motion: vec![PointTarget::default(); nc],
            foothold: vec![Vector3::zeros(); nc],
            next_foothold: vec![Vector3::zeros(); nc],
        }
    }
}
