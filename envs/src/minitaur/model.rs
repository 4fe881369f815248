//! The robot: the URDF, PyBullet's motor order and directions, its initial pose and
//! loop-closure pivots, and the box inertias PyBullet gives the links.

use centaur_dynamics::nalgebra::Vector3;
use centaur_dynamics::{BaseKind, Inertia, Model, Shape, UrdfError};

/// The Minitaur URDF from pybullet_data, compiled into the crate.
pub const MINITAUR_URDF: &str = include_str!("../../../assets/minitaur/minitaur.urdf");

/// Motor joints in observation/action order (PyBullet's `MOTOR_NAMES`).
pub const MOTOR_NAMES: [&str; 8] = [
    "motor_front_leftL_joint",
    "motor_front_leftR_joint",
    "motor_back_leftL_joint",
    "motor_back_leftR_joint",
    "motor_front_rightL_joint",
    "motor_front_rightR_joint",
    "motor_back_rightL_joint",
    "motor_back_rightR_joint",
];

/// Legs in PyBullet's order (`LEG_POSITION`); leg `l` owns motors `2l` and `2l + 1`.
pub const LEG_NAMES: [&str; 4] = ["front_left", "back_left", "front_right", "back_right"];

/// Motor frame = joint frame × direction (left motors are mounted mirrored).
pub const MOTOR_DIRECTION: [f64; 8] = [-1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0];

/// Knee angle of the initial pose (PyBullet's `knee_angle`, joint frame × direction).
pub(super) const KNEE_ANGLE: f64 = -2.1834;
/// Loop-closure pivots in the lower legs (PyBullet's `KNEE_CONSTRAINT_POINT_*`).
pub(super) const TOE_RIGHT: [f64; 3] = [0.0, 0.005, 0.2];
pub(super) const TOE_LEFT: [f64; 3] = [0.0, 0.01, 0.2];
/// PyBullet's energy term multiplies the power by its 2 ms simulation step; the reward keeps
/// that definition whatever physics step Rapier uses.
pub const ENERGY_TERM_DT: f64 = 0.002;

/// The Minitaur model both the simulator and a controller use: the URDF with PyBullet's
/// inertias (box inertia of each link's collision AABB, 1 mm margin per side, about the
/// `<inertial>` origin, no parallel-axis term — PyBullet's behaviour without
/// `URDF_USE_INERTIA_FROM_FILE`; it reproduces the base inertia (0.0241, 0.0289, 0.0504)
/// kg·m² that PyBullet reports).
pub fn minitaur_model() -> Result<Model, UrdfError> {
    let mut model = Model::from_urdf_str(MINITAUR_URDF, "assets/minitaur/minitaur.urdf", BaseKind::Floating)?;
    apply_box_inertias(&mut model, 0.001);
    Ok(model)
}

/// Replaces every link's rotational inertia by Bullet's AABB box inertia (see
/// [`minitaur_model`]) and recomputes the body inertias.
pub fn apply_box_inertias(model: &mut Model, margin: f64) {
    for f in 0..model.frames.len() {
        let frame = &model.frames[f];
        if !frame.is_link || frame.link_inertia.mass <= 0.0 {
            continue;
        }
        let link_from_joint = frame.placement.inverse();
        // The AABB in the inertial frame (link frame shifted to the <inertial> origin).
        let origin = frame.link_inertia.lever;
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for g in model
            .geometries
            .iter()
            .filter(|g| g.frame == f && g.role == centaur_dynamics::GeometryRole::Collision)
        {
            let in_link = link_from_joint.mul(&g.placement);
            let (c, r) = (in_link.translation - origin, in_link.rotation);
            let half: Vector3<f64> = match &g.shape {
                Shape::Box { size } => (r.abs() * size) / 2.0,
                Shape::Sphere { radius } => Vector3::repeat(*radius),
                Shape::Cylinder { radius, length } | Shape::Capsule { radius, length } => {
                    let extra = if matches!(g.shape, Shape::Capsule { .. }) { *radius } else { 0.0 };
                    let axis = r.column(2);
                    Vector3::from_fn(|i, _| {
                        axis[i].abs() * (length / 2.0 + extra)
                            + radius * (1.0 - axis[i] * axis[i]).max(0.0).sqrt()
                    })
                }
                Shape::Mesh { .. } => continue,
            };
            lo = lo.inf(&(c - half));
            hi = hi.sup(&(c + half));
        }
        let m = frame.link_inertia.mass;
        let rotational = if lo.x.is_finite() {
            let l = (hi - lo) + Vector3::repeat(2.0 * margin);
            let (lx, ly, lz) = (l.x * l.x, l.y * l.y, l.z * l.z);
            centaur_dynamics::nalgebra::Matrix3::from_diagonal(&Vector3::new(ly + lz, lx + lz, lx + ly))
                * (m / 12.0)
        } else {
            centaur_dynamics::nalgebra::Matrix3::zeros()
        };
        model.frames[f].link_inertia = Inertia::new(m, origin, rotational);
    }
    model.recompute_body_inertias();
}
