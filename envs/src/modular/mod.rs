//! Modular robots in the style of Revolve2: a core, bricks and active hinges put together
//! into a tree, turned into a URDF that `centaur-dynamics` loads and [`Sim`](crate::Sim) simulates.
//!
//! A [`Body`] starts with its core. [`Body::attach`] adds a module at a free face of a
//! module already in the body:
//!
//! | module | faces children attach to | what it is |
//! |---|---|---|
//! | core | front, back, left, right | the central box, 0.089 × 0.089 × 0.0603 m, 250 g |
//! | brick | front, left, right | a passive box, 0.0629 × 0.0629 × 0.0603 m, 30 g |
//! | active hinge | attachment | a servo: a frame fixed to the parent, a servo body behind a revolute joint about the hinge's local y axis, ±60°, 0.948 N·m |
//!
//! Each module is attached with a rotation about the direction it points in (its local x
//! axis, Revolve2's `rotation` argument): a hinge at rotation 0 swings in the vertical plane
//! (a leg lifting), at π/2 in the horizontal plane (a spine bending). The geometry, masses,
//! servo limits, armature and PD gains are those of Revolve2's V1 modules
//! (`revolve2.modular_robot.body.v1`, read from its source; only the numbers are used
//! here) and are all in [`ModuleSpecs`]. [`Body::gecko`], [`Body::ant`]
//! and [`Body::spider`] build the robots of the same names in `revolve2.standards`.
//!
//! **From a body to a robot.** [`Body::to_urdf`] writes one URDF link per module part
//! (core, brick, hinge frame, servo, servo horn), fixed joints between rigidly connected
//! parts and a revolute joint per hinge, with the boxes as visual and collision shapes and
//! solid-box inertias. `centaur-dynamics` merges the fixed joints, so the model has one body
//! per rigid group and one degree of freedom per hinge, after the free-flyer of the core.
//! Rotations that are multiples of 90° are composed exactly (no rounding residue in the
//! URDF's `xyz`; the `rpy` angles are exact multiples of π/2). [`Body::attach`] rejects a
//! face the module does not have, a face that is taken, a second core, a non-finite
//! rotation and a module that would overlap another one. The overlap test compares the
//! modules' main boxes (core, brick, servo body) at zero hinge angles as boxes aligned with
//! the core's axes, each shrunk by 4 mm per side: exact for quarter turns up to that
//! tolerance (touching neighbours may interpenetrate by up to 8 mm, as on Revolve2's grid),
//! conservative for other rotations (a valid body can be refused), and blind to the thin
//! hinge frames and horn plates.
//!
//! **The environment.** [`ModularEnv`] (Gymnasium semantics, `centaur train --env gecko`,
//! `modular-ant` or `spider`) drives each hinge like Revolve2's MuJoCo servo: the action
//! `a ∈ [−1, 1]ⁿ` sets the target angle `a · 60°`, and every physics step applies
//! `τ = kp (q* − q) − kd q̇` with kp 5 and kd 0.05 (Revolve2's position and velocity
//! actuators), limited to the servo's torque–speed envelope ([`servo_torque`]: 0.948 N·m at
//! rest, falling to zero at the rated 6.34 rad/s). Revolve2's MuJoCo scenes do not limit the
//! servos' speed; with only a ±0.948 N·m clip, PPO learned to whip the hinges at 38 rad/s,
//! six times the servo's rated speed, and bounce the gecko 24 m in 30 s. The control
//! period is Revolve2's standard 20 Hz; an episode lasts its standard 30 s (600 steps) and
//! never terminates early (a modular robot cannot fall in a way that ends its run), except
//! when the simulation blows up: then `terminated` is set with `info.unstable`. The default reward is the change of the core's horizontal distance from its
//! start, so that an episode's return is Revolve2's `xy_displacement` fitness exactly;
//! [`ModularReward::ForwardX`] rewards progress along x instead.
//!
//! Differences from Revolve2's MuJoCo scenes: Rapier's rigid contacts and PGS solver with
//! 5 ms steps instead of MuJoCo's soft contacts and 1 ms steps (2 ms steps make the env
//! about 2.2× slower; the gecko's PPO gait travels 17.2–17.8 m in 30 s at 5, 2 and 1 ms
//! alike); modules collide with the ground only, not with each other; the servos have a
//! torque–speed envelope.

mod body;
mod env;
mod json;

pub use body::{Body, Face, MAX_MODULES, ModularError, ModuleId, ModuleKind, ModuleSpecs};
pub use env::{ModularConfig, ModularEnv, ModularObservation, ModularReward, servo_torque};
