//! What the controller needs to know about a robot beyond its [`Model`]: contact points,
//! the body frame, which joints are actuated, loop closures, and the nominal stance.
//! [`RobotSpec`] names them (typed, with presets in [`crate::ControllerConfig`]);
//! [`LeggedRobot::new`] resolves the names against a model once.

use centaur_dynamics::nalgebra::{DVector, Matrix3, Vector3};
use centaur_dynamics::{
    Data, JointKind, Model, Se3, center_of_mass, forward_kinematics, frame_placement, update_frame_placements,
};

use crate::error::ConfigError;

/// Largest number of contact points.
pub const MAX_CONTACTS: usize = 8;

/// A contact: a point rigidly attached to a model frame, or a sphere (a round foot, a
/// capsule's end) whose contact point is its lowest point, `c − r e_z`, recomputed from the
/// link's orientation every tick (flat ground). The contact constraints then act on the
/// material point of the link that touches the ground.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ContactSpec {
    /// Frame (link) the point moves with.
    pub frame: String,
    /// Position of the point (or the sphere's centre) in that frame (m).
    pub offset: [f64; 3],
    /// Sphere radius `r` (m); 0 for a point.
    pub radius: f64,
    /// Gait leg the point belongs to (several points may share a leg, e.g. heel and toe).
    pub leg: usize,
}

/// A loop closure: point `a` on `frame_a` and point `b` on `frame_b` coincide along the
/// given directions (unit vectors in `frame_a`'s axes). The whole-body QP keeps
/// `dᵀ(J_a − J_b) q̈ + dᵀ(J̇_a − J̇_b) q̇ = −k_p dᵀ(p_a − p_b) − k_d dᵀ(ṗ_a − ṗ_b)` with a
/// constraint force `λ` along each direction.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LoopClosureSpec {
    /// First frame.
    pub frame_a: String,
    /// Point in the first frame.
    pub point_a: [f64; 3],
    /// Second frame.
    pub frame_b: String,
    /// Point in the second frame.
    pub point_b: [f64; 3],
    /// Constrained directions in `frame_a`'s axes.
    pub directions: Vec<[f64; 3]>,
}

/// How the body moves relative to the world.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub enum BaseSpec {
    /// A free-flyer (`q[0..7]`, `v[0..6]`).
    Floating,
    /// A fixed-base model whose first joints move the body in the x–z plane
    /// (Walker2d's `rootx`, `rootz`, `rooty`).
    Planar {
        /// Prismatic joint along world x.
        x_joint: String,
        /// Prismatic joint along world z.
        z_joint: String,
        /// Revolute joint about world y.
        pitch_joint: String,
    },
}

/// The robot-specific part of the controller configuration.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RobotSpec {
    /// Base kind.
    pub base: BaseSpec,
    /// The frame whose pose is "the body" (the root link for floating robots).
    pub body_frame: String,
    /// Contact points in contact order (the order of forces in the MPC and status).
    pub contacts: Vec<ContactSpec>,
    /// Number of gait legs (2 or 4).
    pub n_legs: usize,
    /// Unactuated non-base joints (τ = 0), e.g. the Minitaur's knees. Joints with a zero
    /// effort limit are unactuated too.
    pub passive_joints: Vec<String>,
    /// Effort limit applied to every actuated joint instead of the URDF's (N·m or N).
    pub effort_limit: Option<f64>,
    /// Standing joint positions (joints not listed stay at 0).
    pub nominal_joints: Vec<(String, f64)>,
    /// Loop closures.
    pub loop_closures: Vec<LoopClosureSpec>,
}

/// A resolved loop closure.
#[derive(Clone, Debug)]
pub struct LoopClosure {
    /// Frame index of point a (an added frame at the point).
    pub frame_a: usize,
    /// Frame index of point b.
    pub frame_b: usize,
    /// Directions in frame a's axes.
    pub directions: Vec<Vector3<f64>>,
}

/// A [`RobotSpec`] resolved against a [`Model`].
#[derive(Clone, Debug)]
pub struct LeggedRobot {
    /// The model, with one added frame per contact point and closure point.
    pub model: Model,
    /// Frame of each contact point.
    pub contact_frames: Vec<usize>,
    /// Sphere radius of each contact (0 for points).
    pub contact_radius: Vec<f64>,
    /// Sphere centre of each contact in its parent joint's frame.
    pub contact_centre: Vec<Vector3<f64>>,
    /// Gait leg of each contact point.
    pub contact_leg: Vec<usize>,
    /// Number of gait legs.
    pub n_legs: usize,
    /// Body frame.
    pub body_frame: usize,
    /// `v` indices of the base (6 floating, 3 planar).
    pub base_v: Vec<usize>,
    /// For a planar base, the `q` indices of x, z and pitch.
    pub planar_q: Option<[usize; 3]>,
    /// `v` indices of the actuated joints, in model order: the order of every per-joint
    /// output of the controller.
    pub actuated_v: Vec<usize>,
    /// `q` indices of the actuated joints.
    pub actuated_q: Vec<usize>,
    /// Names of the actuated joints.
    pub actuated_names: Vec<String>,
    /// `v` indices of the unactuated dofs (base and passive joints).
    pub unactuated_v: Vec<usize>,
    /// `v` indices of all non-base joints (actuated and passive).
    pub joint_v: Vec<usize>,
    /// `q` index of each entry of `joint_v`.
    pub joint_q: Vec<usize>,
    /// Effort limit of each actuated joint.
    pub effort: Vec<f64>,
    /// Loop closures.
    pub closures: Vec<LoopClosure>,
    /// Number of closure rows (sum of directions).
    pub n_closure_rows: usize,
    /// Standing configuration, lowest contact point at z = 0.
    pub q_nominal: DVector<f64>,
    /// Total mass.
    pub mass: f64,
    /// Composite inertia about the CoM in body axes at the nominal pose.
    pub inertia_body: Matrix3<f64>,
    /// CoM height at the nominal pose.
    pub nominal_com_height: f64,
    /// Body-frame height at the nominal pose.
    pub nominal_body_height: f64,
    /// Contact positions relative to the body frame origin, in body axes, at the nominal
    /// pose (the "hip" references of the foothold planner).
    pub nominal_contacts_body: Vec<Vector3<f64>>,
    /// Centre of mass relative to the body frame origin, in body axes, at the nominal pose.
    pub nominal_com_body: Vector3<f64>,
}

impl LeggedRobot {
    /// Resolves `spec` against `model`.
    pub fn new(model: &Model, spec: &RobotSpec) -> Result<Self, ConfigError> {
        let mut model = model.clone();
        let frame = |m: &Model, name: &str| {
            m.frame_index(name)
                .ok_or_else(|| ConfigError::UnknownName { kind: "frame", name: name.to_string() })
        };
        let joint = |m: &Model, name: &str| {
            m.joint_index(name)
                .ok_or_else(|| ConfigError::UnknownName { kind: "joint", name: name.to_string() })
        };
        if spec.n_legs != 2 && spec.n_legs != 4 {
            return Err(ConfigError::OutOfRange {
                field: "robot.n_legs",
                value: spec.n_legs as f64,
                range: "2 or 4",
            });
        }
        if spec.contacts.is_empty() || spec.contacts.len() > MAX_CONTACTS {
            return Err(ConfigError::OutOfRange {
                field: "robot.contacts",
                value: spec.contacts.len() as f64,
                range: "1..=8",
            });
        }
        let body_frame = frame(&model, &spec.body_frame)?;
        let (base_v, planar_q) = match &spec.base {
            BaseSpec::Floating => {
                if !model.has_floating_base() {
                    return Err(ConfigError::Inconsistent(
                        "BaseSpec::Floating needs a floating-base model".into(),
                    ));
                }
                ((0..6).collect::<Vec<_>>(), None)
            }
            BaseSpec::Planar { x_joint, z_joint, pitch_joint } => {
                let ids = [joint(&model, x_joint)?, joint(&model, z_joint)?, joint(&model, pitch_joint)?];
                let v: Vec<usize> = ids.iter().map(|&j| model.joints[j].idx_v).collect();
                let q = [model.joints[ids[0]].idx_q, model.joints[ids[1]].idx_q, model.joints[ids[2]].idx_q];
                (v, Some(q))
            }
        };
        let mut contact_frames = Vec::new();
        let mut contact_leg = Vec::new();
        let mut contact_radius = Vec::new();
        let mut contact_centre = Vec::new();
        for (k, c) in spec.contacts.iter().enumerate() {
            let f = frame(&model, &c.frame)?;
            if c.leg >= spec.n_legs {
                return Err(ConfigError::OutOfRange {
                    field: "robot.contacts.leg",
                    value: c.leg as f64,
                    range: "< n_legs",
                });
            }
            let o = c.offset;
            let id = model.add_frame(
                format!("contact_{k}"),
                f,
                Se3::from_translation(Vector3::new(o[0], o[1], o[2])),
            );
            if !(c.radius.is_finite() && c.radius >= 0.0) {
                return Err(ConfigError::OutOfRange {
                    field: "robot.contacts.radius",
                    value: c.radius,
                    range: "finite, >= 0",
                });
            }
            contact_centre.push(model.frames[id].placement.translation);
            contact_frames.push(id);
            contact_leg.push(c.leg);
            contact_radius.push(c.radius);
        }
        for leg in 0..spec.n_legs {
            if !contact_leg.contains(&leg) {
                return Err(ConfigError::Inconsistent(format!("leg {leg} has no contact point")));
            }
        }
        let mut closures = Vec::new();
        for (k, c) in spec.loop_closures.iter().enumerate() {
            let fa = frame(&model, &c.frame_a)?;
            let fb = frame(&model, &c.frame_b)?;
            let pa = Vector3::from(c.point_a);
            let pb = Vector3::from(c.point_b);
            let a = model.add_frame(format!("closure_{k}_a"), fa, Se3::from_translation(pa));
            let b = model.add_frame(format!("closure_{k}_b"), fb, Se3::from_translation(pb));
            let directions = c.directions.iter().map(|d| Vector3::from(*d).normalize()).collect();
            closures.push(LoopClosure { frame_a: a, frame_b: b, directions });
        }
        let n_closure_rows = closures.iter().map(|c| c.directions.len()).sum();
        let mut passive = Vec::new();
        for name in &spec.passive_joints {
            passive.push(joint(&model, name)?);
        }
        let mut actuated_v = Vec::new();
        let mut actuated_q = Vec::new();
        let mut actuated_names = Vec::new();
        let mut unactuated_v = base_v.clone();
        let mut joint_v = Vec::new();
        let mut joint_q = Vec::new();
        let mut effort = Vec::new();
        for (i, j) in model.joints.iter().enumerate().skip(1) {
            if matches!(j.kind, JointKind::RevoluteUnbounded { .. }) {
                return Err(ConfigError::Inconsistent(format!(
                    "joint '{}' is parametrised by (cos θ, sin θ), but the controller works with \
                     joint angles: load the URDF with the default UrdfOptions",
                    j.name
                )));
            }
            if j.kind == JointKind::FreeFlyer || base_v.contains(&j.idx_v) {
                continue;
            }
            if j.kind.nv() != 1 {
                continue;
            }
            joint_v.push(j.idx_v);
            joint_q.push(j.idx_q);
            let limit = model.effort_limit[j.idx_v];
            if passive.contains(&i) || limit <= 0.0 {
                unactuated_v.push(j.idx_v);
            } else {
                actuated_v.push(j.idx_v);
                actuated_q.push(j.idx_q);
                actuated_names.push(j.name.clone());
                effort.push(spec.effort_limit.unwrap_or(limit));
            }
        }
        if actuated_v.is_empty() {
            return Err(ConfigError::Inconsistent("no actuated joint".into()));
        }
        // Nominal configuration.
        let mut q = model.neutral_configuration();
        for (name, val) in &spec.nominal_joints {
            let j = joint(&model, name)?;
            q[model.joints[j].idx_q] = *val;
        }
        let mut data = Data::new(&model);
        forward_kinematics(&model, &mut data, q.as_slice());
        set_sphere_contacts(&mut model, &data, &contact_frames, &contact_radius, &contact_centre);
        update_frame_placements(&model, &mut data);
        let zmin = contact_frames
            .iter()
            .map(|&f| frame_placement(&model, &data, f).translation.z)
            .fold(f64::INFINITY, f64::min);
        match planar_q {
            None => q[2] -= zmin,
            Some([_, iz, _]) => q[iz] -= zmin,
        }
        forward_kinematics(&model, &mut data, q.as_slice());
        set_sphere_contacts(&mut model, &data, &contact_frames, &contact_radius, &contact_centre);
        update_frame_placements(&model, &mut data);
        let body = data.o_m_f[body_frame];
        let nominal_contacts_body =
            contact_frames.iter().map(|&f| body.act_inv_point(&data.o_m_f[f].translation)).collect();
        let com = center_of_mass(&model, &mut data, q.as_slice());
        let nominal_com_body = body.act_inv_point(&com);
        let whole = data.o_ycrb[0].to_inertia();
        // Inertia about the CoM in world axes, rotated to body axes.
        let r = body.rotation;
        let inertia_body = r.transpose() * whole.rotational * r;
        let mass = model.total_mass();
        Ok(LeggedRobot {
            contact_frames,
            contact_radius,
            contact_centre,
            contact_leg,
            n_legs: spec.n_legs,
            body_frame,
            base_v,
            planar_q,
            actuated_v,
            actuated_q,
            actuated_names,
            unactuated_v,
            joint_v,
            joint_q,
            effort,
            closures,
            n_closure_rows,
            mass,
            inertia_body,
            nominal_com_height: com.z,
            nominal_body_height: body.translation.z,
            nominal_contacts_body,
            nominal_com_body,
            q_nominal: q,
            model,
        })
    }

    /// Moves every sphere contact to the lowest point of its sphere for the joint
    /// orientations in `data.o_m_i` (after forward kinematics; call
    /// [`update_frame_placements`] afterwards).
    pub fn update_sphere_contacts(&mut self, data: &Data) {
        set_sphere_contacts(
            &mut self.model,
            data,
            &self.contact_frames,
            &self.contact_radius,
            &self.contact_centre,
        );
    }

    /// Number of contact points.
    pub fn n_contacts(&self) -> usize {
        self.contact_frames.len()
    }

    /// Number of actuated joints.
    pub fn n_actuated(&self) -> usize {
        self.actuated_v.len()
    }
}

/// Contact frame placements in their joints: `c + R_iᵀ (0, 0, −r)` for spheres.
fn set_sphere_contacts(
    model: &mut Model,
    data: &Data,
    frames: &[usize],
    radius: &[f64],
    centre: &[Vector3<f64>],
) {
    for (k, &f) in frames.iter().enumerate() {
        if radius[k] <= 0.0 {
            continue;
        }
        let j = model.frames[f].parent_joint;
        let down = data.o_m_i[j].rotation.transpose() * Vector3::new(0.0, 0.0, -radius[k]);
        model.frames[f].placement.translation = centre[k] + down;
    }
}
