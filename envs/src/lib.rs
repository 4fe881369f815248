//! # centaur-envs
//!
//! Benchmark environments simulated with Rapier: PyBullet's Minitaur and Gymnasium's Ant,
//! Walker2d, Hopper, HalfCheetah and Humanoid, built from the same URDF the controller uses.
//!
//! Status: not yet implemented (issue 3). This crate holds only its documentation so far.
