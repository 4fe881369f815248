//! # centaur-mpc
//!
//! Model-predictive locomotion control: gait schedules, a convex MPC on the single-rigid-body
//! model (Di Carlo et al. 2018) and a whole-body QP, both solved with Clarabel, plus
//! swing-foot planning, behind one `LocomotionController`.
//!
//! Status: not yet implemented (issue 5). This crate holds only its documentation so far.
