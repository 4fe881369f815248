//! PyBullet's `MinitaurBulletEnv-v0` on Rapier.
//!
//! Read from `pybullet_envs/bullet/{minitaur_gym_env,minitaur,motor,minitaur_env_randomizer}.py`
//! (pybullet 3.2.7) and reproduced here:
//!
//! * **Robot**: `assets/minitaur/minitaur.urdf` (8 motors, 8 passive knees), the four 5-bar
//!   legs closed at the toes by loop-closing joints between the two lower legs of each leg
//!   (pivots `[0, 0.005, 0.2]` in `lower_leg_*R_link`, `[0, 0.01, 0.2]` in
//!   `lower_leg_*L_link`). Inertias follow PyBullet, which ignores the file's 1 kg·m²:
//!   each link gets the box inertia of the AABB of its collision shapes (+1 mm per side)
//!   about its `<inertial>` origin — see [`minitaur_model`].
//! * **Time**: physics step 2 ms, 5 physics steps per env step (100 Hz), 1000 steps.
//!   Gravity −10 m/s², as PyBullet's env sets it.
//! * **Motors**: PyBullet's DC motor model ([`MotorModel`]) recomputed before every physics
//!   step from the current motor angle and velocity (pwm = clip(−kp (q − q*) − kd q̇), back-EMF,
//!   the current→torque table, 50 V diode clipping), overheat protection (a motor above
//!   2.45 N·m for more than 1 s switches off until reset); or a plain PD option.
//! * **Action**: the leg model ([`leg_model_to_motor_angles`]) by default, motor angles or
//!   PWM as options. Actions are clipped to [−1, 1] (PyBullet raises beyond ±1.01).
//! * **Observation** (28): motor angles, velocities, observed torques (motor frame:
//!   left motors negated) and the base quaternion (x, y, z, w).
//! * **Reward**: `w_d Δx − w_e |τ_obs · q̇| · 0.002 − w_drift |Δy| − w_shake |Δz|`, weights
//!   1.0 / 0.005 / 0 / 0 by default, the energy term on the last physics step only, the first
//!   step measured from the origin (as PyBullet does).
//! * **Termination**: base z-axis · world z < 0.85, or base height < 0.13 m.
//! * **Randomisation** (on by default, as in v0; [`MinitaurRandomization`]): base mass and
//!   leg/motor masses ±20 % (inertias scale with mass), battery voltage 14.8–16.8 V, motor
//!   viscous damping 0–0.01, foot friction 0.8–1.5; plus the sim-to-real options of Tan et
//!   al. (2018): motor strength, control latency and observation noise.
//!
//! Differences from PyBullet: Rapier's solver instead of Bullet's (1 substep, 16 PGS
//! iterations, ground contact at 120 Hz natural frequency — standing height 0.158 m vs
//! PyBullet's 0.157 m), loop closures locking the two in-plane directions only (a full
//! point-to-point lock is unstable in Rapier: the out-of-plane row is redundant for a
//! planar linkage), no self-collision (PyBullet enables it; it changes random-action
//! statistics by a few percent), lower legs collide as capsules of the same length (option
//! `capsule_feet`), and the randomiser draws from the environment's seeded generator rather
//! than Python's global one.

mod env;
mod legs;
mod model;
mod motor;

pub use env::{
    MAX_LATENCY, MinitaurAction, MinitaurConfig, MinitaurEnv, MinitaurRandomization, MotorControl,
    MotorInverse,
};
pub use legs::{leg_model_to_motor_angles, motor_angles_to_leg_model};
pub use model::{
    ENERGY_TERM_DT, LEG_NAMES, MINITAUR_URDF, MOTOR_DIRECTION, MOTOR_NAMES, apply_box_inertias,
    minitaur_model,
};
pub use motor::{MotorModel, OBSERVED_TORQUE_LIMIT};
