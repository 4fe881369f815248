//! [`Sim`]: a Rapier world built from a `centaur_dynamics::Model`, so that the simulator and
//! the controller share one description of the robot.
//!
//! Each body of the model (links merged across fixed joints) becomes one link of a Rapier
//! reduced-coordinate multibody, with the model's mass, centre of mass and inertia; each
//! revolute or prismatic joint becomes a multibody joint with the same placement and axis;
//! a free-flyer root becomes the multibody's free root, a fixed base a fixed anchor body.
//! Collision geometry comes from the model's `<collision>` shapes; loop closures (the
//! Minitaur's legs) are impulse joints between two links of the multibody.
//!
//! State is read and written in the dynamics crate's convention ([`RobotState`]), joint
//! torques are applied as equal and opposite body torques (forces for prismatic joints)
//! on the child and parent links, because Rapier has no generalized-force input.
//!
//! Rapier's pitfalls handled here (see `notes/dependencies.md`): bodies never sleep, the
//! default 0.1 N·m·s/rad multibody damping is replaced by the model's damping, gravity is
//! set along −z, motors are not used (torques are computed by the actuator models), and the
//! free root's frame is placed at its centre of mass (Rapier integrates the root origin with
//! the centre-of-mass velocity, which is only consistent when the two coincide).

use centaur_dynamics::nalgebra::{self as na, Matrix3, UnitQuaternion, Vector3};
use centaur_dynamics::{GeometryRole, JointKind, Model, RobotState, Se3, Shape};
use rapier3d::prelude::{
    BroadPhaseBvh, CCDSolver, CoefficientCombineRule, ColliderBuilder, ColliderHandle, ColliderSet,
    GenericJointBuilder, Group, ImpulseJointHandle, ImpulseJointSet, IntegrationParameters,
    InteractionGroups, InteractionTestMode, IslandManager, JointAxesMask, MassProperties,
    MultibodyJointHandle, MultibodyJointSet, NarrowPhase, PhysicsPipeline, Pose, RigidBodyBuilder,
    RigidBodyHandle, RigidBodySet, Rotation, SoftBodySet, SpringCoefficients, Vector,
};

/// Physics settings of a [`Sim`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SimConfig {
    /// Physics time step (s) (default: 0.002).
    pub dt: f64,
    /// Rapier substeps per step, `num_solver_iterations` (default: 1).
    pub substeps: usize,
    /// Projected Gauss–Seidel iterations per substep (default: 8).
    pub pgs_iterations: usize,
    /// Stabilisation (unbiased) iterations per substep (default: 1).
    pub stabilization_iterations: usize,
    /// Natural frequency (Hz) of contacts against the ground (Rapier's static contact
    /// softness; default: 120, Rapier's own default of 60 lets light feet sink ~4 mm).
    pub ground_contact_frequency: f64,
    /// Damping ratio of ground contacts (default: 10, Rapier's default).
    pub ground_contact_damping_ratio: f64,
    /// Penetration Rapier tolerates before correcting contacts (m) (default: 0.001; Rapier's
    /// own 0.005 lets the robot sit several millimetres into the ground).
    pub allowed_penetration: f64,
    /// Distance (m) within which Rapier creates contacts ahead of time (default: 0.02,
    /// Rapier's; fast bodies at large time steps need more).
    pub prediction_distance: f64,
    /// Gravity in the world, z up (default: (0, 0, −9.81)).
    pub gravity: [f64; 3],
    /// Friction coefficient of the ground (default: 1.0).
    pub ground_friction: f64,
    /// Whether links of the robot collide with each other (default: false).
    pub self_collision: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            dt: 0.002,
            substeps: 1,
            pgs_iterations: 8,
            stabilization_iterations: 1,
            ground_contact_frequency: 120.0,
            ground_contact_damping_ratio: 10.0,
            allowed_penetration: 0.001,
            prediction_distance: 0.02,
            gravity: [0.0, 0.0, -9.81],
            ground_friction: 1.0,
            self_collision: false,
        }
    }
}

/// A point on one frame kept on a point of another frame: a loop-closing joint.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopClosure {
    /// Frame (link) name of the first point.
    pub frame_a: String,
    /// The point in `frame_a`.
    pub point_a: [f64; 3],
    /// Frame (link) name of the second point.
    pub frame_b: String,
    /// The point in `frame_b`.
    pub point_b: [f64; 3],
    /// A direction of `frame_a` left free (for planar linkages, the hinge axis: locking it
    /// too over-constrains the loop); `None` locks all three directions.
    pub free_axis: Option<[f64; 3]>,
}

/// Which collision shapes of the model become colliders, and with what friction.
#[derive(Clone, Debug, PartialEq)]
pub struct ColliderSpec {
    /// Names of the links whose `<collision>` shapes take part (empty: every link).
    pub links: Vec<String>,
    /// Friction coefficient per link (links not listed use `default_friction`).
    pub friction: Vec<(String, f64)>,
    /// Friction of the robot's colliders (default: 1.0). Rapier combines the two
    /// coefficients of a contact with `Max`, as MuJoCo does.
    pub default_friction: f64,
    /// Links whose box shapes are replaced by capsules along the box's longest side, of the
    /// same length and with the radius of half the next side: long thin links (legs) touch
    /// the ground through one or two points instead of four (default: none).
    pub capsule_boxes: Vec<String>,
}

impl Default for ColliderSpec {
    fn default() -> Self {
        ColliderSpec {
            links: Vec::new(),
            friction: Vec::new(),
            default_friction: 1.0,
            capsule_boxes: Vec::new(),
        }
    }
}

/// A model the simulator cannot build.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A frame named in the configuration does not exist.
    #[error("unknown frame '{0}'")]
    UnknownFrame(String),
    /// Rapier refused a joint.
    #[error("Rapier refused the joint '{0}' (does it close a loop? use a LoopClosure)")]
    JointRejected(String),
    /// A model joint kind the simulator does not support at this place.
    #[error("joint '{0}': a free-flyer is only supported as the root")]
    Unsupported(String),
    /// A joint parametrised by `(cos θ, sin θ)` (`JointKind::RevoluteUnbounded`).
    #[error(
        "joint '{0}' is parametrised by (cos θ, sin θ), but the simulator works with joint angles: \
         load the URDF with the default UrdfOptions"
    )]
    CosSinJoint(String),
    /// A non-physical setting.
    #[error("invalid simulation setting: {0}")]
    InvalidConfig(String),
}

const GROUND: Group = Group::GROUP_1;
const ROBOT: Group = Group::GROUP_2;

fn v3(x: &Vector3<f64>) -> Vector {
    Vector::new(x.x as f32, x.y as f32, x.z as f32)
}

fn quat(r: &Matrix3<f64>) -> Rotation {
    let q = UnitQuaternion::from_rotation_matrix(&na::Rotation3::from_matrix_unchecked(*r));
    let q = q.quaternion();
    Rotation::from_xyzw(q.i as f32, q.j as f32, q.k as f32, q.w as f32).normalize()
}

fn pose(m: &Se3) -> Pose {
    Pose::from_parts(v3(&m.translation), quat(&m.rotation))
}

fn to_f64(v: Vector) -> Vector3<f64> {
    Vector3::new(v.x as f64, v.y as f64, v.z as f64)
}

/// A rotation taking the x axis to the unit vector `a` (Rapier's joints move along their
/// frame's x axis).
fn x_to(a: &Vector3<f64>) -> Rotation {
    Rotation::from_rotation_arc(Vector::X, v3(a).normalize())
}

/// The joint-frame axis a 1-dof joint moves along (0: x, 1: y, 2: z) and the rotation of the
/// joint frame that takes that axis to the unit vector `a`. When `exact` and `a` is ±x, ±y or
/// ±z, the axis is `a`'s own and the rotation is the identity or a half turn, both exact in
/// `f32`; otherwise the axis is x and the rotation [`x_to`].
///
/// Why exactness matters: on a fixed-base robot (the planar Walker2d, Hopper, HalfCheetah)
/// no joint moves the feet along y, so the contact's y tangent has zero effective mass.
/// Rapier inverts that effective mass unless it is below 1e-20; built with [`x_to`], the
/// frames of y-axis hinges leave a rounding residue of ~3e-15, whose inverse is a huge
/// impulse along y that fills the friction disc and scales the real x friction down to a few
/// percent (measured by the `planar_friction_probe` example). Exact frames keep that
/// effective mass exactly zero, which Rapier skips.
fn joint_axis_frame(a: &Vector3<f64>, exact: bool) -> (usize, Rotation) {
    if exact {
        for k in 0..3 {
            if a[k].abs() == 1.0 && a[(k + 1) % 3] == 0.0 && a[(k + 2) % 3] == 0.0 {
                if a[k] > 0.0 {
                    return (k, Rotation::IDENTITY);
                }
                // Half a turn about the next axis: its quaternion has one unit component.
                let about = [Vector::X, Vector::Y, Vector::Z][(k + 1) % 3];
                return (k, Rotation::from_xyzw(about.x, about.y, about.z, 0.0));
            }
        }
    }
    (0, x_to(a))
}

/// How one model joint appears in the multibody.
#[derive(Clone, Copy, Debug)]
struct JointMap {
    /// Rigid body of the child link.
    body: RigidBodyHandle,
    /// Rigid body of the parent link.
    parent_body: RigidBodyHandle,
    /// Multibody link id of the child.
    link: usize,
    /// Index of the joint's first dof in Rapier's generalized vectors.
    dof: usize,
    /// Index into `MultibodyJoint::coords()` of the joint coordinate (0–2: LinX–LinZ, 3–5:
    /// AngX–AngZ).
    coord: usize,
    /// Joint axis in the child frame (model convention).
    axis: Vector3<f64>,
    revolute: bool,
}

/// A robot simulated by Rapier, built from a [`Model`].
pub struct Sim {
    model: Model,
    config: SimConfig,
    pipeline: PhysicsPipeline,
    params: IntegrationParameters,
    gravity: Vector,
    islands: IslandManager,
    broad_phase: BroadPhaseBvh,
    narrow_phase: NarrowPhase,
    bodies: RigidBodySet,
    colliders: ColliderSet,
    impulse_joints: ImpulseJointSet,
    multibody_joints: MultibodyJointSet,
    soft_bodies: SoftBodySet,
    ccd: CCDSolver,
    /// Rigid body of each model joint (index 0: the fixed anchor, if any).
    bodies_of_joint: Vec<Option<RigidBodyHandle>>,
    joints: Vec<Option<JointMap>>,
    /// The multibody (absent for a robot that is a single free body).
    root_handle: Option<MultibodyJointHandle>,
    /// Centre of mass of the free root body in its model frame (the Rapier frame sits there).
    root_com: Vector3<f64>,
    floating: bool,
    /// Collider of each model geometry that became one.
    geometry_colliders: Vec<Option<ColliderHandle>>,
    closures: Vec<ImpulseJointHandle>,
    closure_specs: Vec<(RigidBodyHandle, Vector3<f64>, RigidBodyHandle, Vector3<f64>)>,
    /// Generalized forces applied at every step until changed (model `v` layout).
    tau: Vec<f64>,
    external: Option<(usize, Vector3<f64>)>,
    disp: Vec<f32>,
    time: f64,
}

impl Sim {
    /// Builds the world: the robot at its neutral configuration and a ground plane at z = 0.
    pub fn new(
        model: &Model,
        config: &SimConfig,
        colliders: &ColliderSpec,
        closures: &[LoopClosure],
    ) -> Result<Sim, SimError> {
        if !(config.dt > 0.0 && config.dt.is_finite()) || config.substeps == 0 || config.pgs_iterations == 0 {
            return Err(SimError::InvalidConfig(format!(
                "dt = {}, substeps = {}, pgs_iterations = {}",
                config.dt, config.substeps, config.pgs_iterations
            )));
        }
        let mut params = IntegrationParameters { dt: config.dt as f32, ..Default::default() };
        params.num_solver_iterations = config.substeps;
        params.num_internal_pgs_iterations = config.pgs_iterations;
        params.num_internal_stabilization_iterations = config.stabilization_iterations;
        params.static_contact_softness = SpringCoefficients::new(
            config.ground_contact_frequency as f32,
            config.ground_contact_damping_ratio as f32,
        );
        params.max_ccd_substeps = 0;
        params.normalized_allowed_linear_error = config.allowed_penetration as f32;
        params.normalized_prediction_distance = config.prediction_distance as f32;
        let mut bodies = RigidBodySet::new();
        let mut collider_set = ColliderSet::new();
        let mut multibody_joints = MultibodyJointSet::new();
        let mut impulse_joints = ImpulseJointSet::new();

        // Ground.
        let ground = bodies.insert(RigidBodyBuilder::fixed());
        collider_set.insert_with_parent(
            ColliderBuilder::halfspace(rapier3d::na::Unit::new_unchecked(Vector::Z))
                .friction(config.ground_friction as f32)
                .collision_groups(InteractionGroups::new(GROUND, Group::ALL, InteractionTestMode::And)),
            ground,
            &mut bodies,
        );

        let floating = model.has_floating_base();
        let n = model.njoints();
        let root_com = if floating { model.inertias[1].lever } else { Vector3::zeros() };
        // Rapier frame of each body relative to its model joint frame: the identity, except
        // the free root, shifted to its centre of mass.
        let shift = |j: usize| -> Se3 {
            if floating && j == 1 { Se3::from_translation(root_com) } else { Se3::identity() }
        };
        let mut bodies_of_joint: Vec<Option<RigidBodyHandle>> = vec![None; n];
        let mut joints: Vec<Option<JointMap>> = vec![None; n];
        let mass_props = |j: usize| -> MassProperties {
            let y = &model.inertias[j];
            let s = shift(j);
            let com = y.lever - s.translation;
            let r = &y.rotational;
            let m = rapier3d::math::Matrix::from_cols(
                Vector::new(r[(0, 0)] as f32, r[(1, 0)] as f32, r[(2, 0)] as f32),
                Vector::new(r[(0, 1)] as f32, r[(1, 1)] as f32, r[(2, 1)] as f32),
                Vector::new(r[(0, 2)] as f32, r[(1, 2)] as f32, r[(2, 2)] as f32),
            );
            MassProperties::with_inertia_matrix(v3(&com), y.mass as f32, m)
        };
        // Root of the multibody.
        if floating {
            let h = bodies.insert(
                RigidBodyBuilder::dynamic()
                    .can_sleep(false)
                    .additional_mass_properties(mass_props(1))
                    .pose(pose(&shift(1))),
            );
            bodies_of_joint[1] = Some(h);
        } else {
            let h = bodies.insert(RigidBodyBuilder::fixed());
            bodies_of_joint[0] = Some(h);
        }
        let first_moving = if floating { 2 } else { 1 };
        let mut root_handle = None;
        for j in first_moving..n {
            let joint = &model.joints[j];
            let parent = joint.parent;
            let parent_body =
                bodies_of_joint[parent].ok_or_else(|| SimError::Unsupported(joint.name.clone()))?;
            let (axis, revolute) = match joint.kind {
                JointKind::Revolute { axis } => (axis, true),
                JointKind::Prismatic { axis } => (axis, false),
                JointKind::FreeFlyer | JointKind::Universe => {
                    return Err(SimError::Unsupported(joint.name.clone()));
                }
                JointKind::RevoluteUnbounded { .. } => return Err(SimError::CosSinJoint(joint.name.clone())),
            };
            // Exact frames only on fixed-base robots, where they matter (see
            // `joint_axis_frame`); floating-base robots keep the frames their measured
            // results were obtained with.
            let (k, r) = joint_axis_frame(&axis, !floating);
            let coord = if revolute { 3 + k } else { k };
            let mask = JointAxesMask::LOCKED_FIXED_AXES - JointAxesMask::from_bits_truncate(1 << coord);
            let h = bodies.insert(
                RigidBodyBuilder::dynamic().can_sleep(false).additional_mass_properties(mass_props(j)),
            );
            bodies_of_joint[j] = Some(h);
            // Joint frame in the parent's Rapier frame, and in the child's (the child frame is
            // the joint frame: URDF convention).
            let in_parent = shift(parent).inverse().mul(&joint.placement);
            let mut builder = GenericJointBuilder::new(mask)
                .local_frame1(pose(&in_parent) * Pose::from_rotation(r))
                .local_frame2(Pose::from_rotation(r))
                .contacts_enabled(config.self_collision);
            // Position limits become Rapier joint limits (solved as constraints).
            let (lo, hi) = (model.lower_position_limit[joint.idx_q], model.upper_position_limit[joint.idx_q]);
            if lo.is_finite() && hi.is_finite() {
                use rapier3d::prelude::JointAxis;
                let axis = [
                    JointAxis::LinX,
                    JointAxis::LinY,
                    JointAxis::LinZ,
                    JointAxis::AngX,
                    JointAxis::AngY,
                    JointAxis::AngZ,
                ][coord];
                builder = builder.limits(axis, [lo as f32, hi as f32]);
            }
            let g = builder.build();
            let handle = multibody_joints
                .insert(parent_body, h, g, true)
                .ok_or_else(|| SimError::JointRejected(joint.name.clone()))?;
            root_handle.get_or_insert(handle);
            joints[j] = Some(JointMap { body: h, parent_body, link: 0, dof: 0, coord, axis, revolute });
        }

        // Colliders.
        let robot_groups = if config.self_collision {
            InteractionGroups::new(ROBOT, GROUND | ROBOT, InteractionTestMode::And)
        } else {
            InteractionGroups::new(ROBOT, GROUND, InteractionTestMode::And)
        };
        let mut geometry_colliders = vec![None; model.geometries.len()];
        for (k, g) in model.geometries.iter().enumerate() {
            if g.role != GeometryRole::Collision {
                continue;
            }
            let link = &model.frames[g.frame].name;
            if !colliders.links.is_empty() && !colliders.links.iter().any(|l| l == link) {
                continue;
            }
            let Some(body) = bodies_of_joint[g.parent_joint] else { continue };
            let local = shift(g.parent_joint).inverse().mul(&g.placement);
            let builder = match &g.shape {
                Shape::Box { size } if colliders.capsule_boxes.iter().any(|l| l == link) => {
                    // Longest side → capsule axis (z of a turned frame).
                    let mut idx = [0usize, 1, 2];
                    idx.sort_by(|a, b| size[*b].total_cmp(&size[*a]));
                    let (long, mid) = (size[idx[0]], size[idx[1]]);
                    let radius = mid / 2.0;
                    let axis = Vector3::ith(idx[0], 1.0);
                    let turn = na::Rotation3::rotation_between(&Vector3::z(), &axis)
                        .unwrap_or_else(na::Rotation3::identity);
                    let frame = local.mul(&Se3::new(*turn.matrix(), Vector3::zeros()));
                    ColliderBuilder::capsule_z(((long / 2.0) - radius).max(0.0) as f32, radius as f32)
                        .position(pose(&frame))
                }
                Shape::Box { size } => {
                    ColliderBuilder::cuboid(size.x as f32 / 2.0, size.y as f32 / 2.0, size.z as f32 / 2.0)
                        .position(pose(&local))
                }
                Shape::Sphere { radius } => ColliderBuilder::ball(*radius as f32).position(pose(&local)),
                Shape::Capsule { radius, length } => {
                    ColliderBuilder::capsule_z(*length as f32 / 2.0, *radius as f32).position(pose(&local))
                }
                Shape::Cylinder { radius, length } => {
                    // Rapier's cylinders run along y, URDF's along z.
                    let turn = Se3::new(
                        *na::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2)
                            .matrix(),
                        Vector3::zeros(),
                    );
                    ColliderBuilder::cylinder(*length as f32 / 2.0, *radius as f32)
                        .position(pose(&local.mul(&turn)))
                }
                Shape::Mesh { .. } => continue,
            };
            let mu = colliders
                .friction
                .iter()
                .find(|(l, _)| l == link)
                .map_or(colliders.default_friction, |(_, m)| *m);
            let c = collider_set.insert_with_parent(
                builder
                    .density(0.0)
                    .friction(mu as f32)
                    .friction_combine_rule(CoefficientCombineRule::Max)
                    .collision_groups(robot_groups),
                body,
                &mut bodies,
            );
            geometry_colliders[k] = Some(c);
        }

        // Loop closures.
        let mut closure_handles = Vec::new();
        let mut closure_specs = Vec::new();
        for lc in closures {
            let fa =
                model.frame_index(&lc.frame_a).ok_or_else(|| SimError::UnknownFrame(lc.frame_a.clone()))?;
            let fb =
                model.frame_index(&lc.frame_b).ok_or_else(|| SimError::UnknownFrame(lc.frame_b.clone()))?;
            let (ja, jb) = (model.frames[fa].parent_joint, model.frames[fb].parent_joint);
            let (ba, bb) = (
                bodies_of_joint[ja].ok_or_else(|| SimError::UnknownFrame(lc.frame_a.clone()))?,
                bodies_of_joint[jb].ok_or_else(|| SimError::UnknownFrame(lc.frame_b.clone()))?,
            );
            let pa =
                shift(ja).inverse().mul(&model.frames[fa].placement).act_point(&Vector3::from(lc.point_a));
            let pb =
                shift(jb).inverse().mul(&model.frames[fb].placement).act_point(&Vector3::from(lc.point_b));
            // The free direction is given in each frame's own coordinates (for a planar
            // linkage, the common hinge axis); Rapier frees the x axis of the joint frames.
            let in_body = |f: usize, a: [f64; 3]| model.frames[f].placement.rotation * Vector3::from(a);
            let (mask, rot_a, rot_b) = match lc.free_axis {
                Some(axis) => (
                    JointAxesMask::LIN_Y | JointAxesMask::LIN_Z,
                    x_to(&in_body(fa, axis)),
                    x_to(&in_body(fb, axis)),
                ),
                None => (JointAxesMask::LIN_AXES, Rotation::IDENTITY, Rotation::IDENTITY),
            };
            let g = GenericJointBuilder::new(mask)
                .local_frame1(Pose::from_parts(v3(&pa), rot_a))
                .local_frame2(Pose::from_parts(v3(&pb), rot_b))
                .contacts_enabled(false)
                .build();
            closure_handles.push(impulse_joints.insert(ba, bb, g, true));
            closure_specs.push((ba, pa, bb, pb));
        }

        let mut sim = Sim {
            model: model.clone(),
            config: config.clone(),
            pipeline: PhysicsPipeline::new(),
            params,
            gravity: Vector::new(
                config.gravity[0] as f32,
                config.gravity[1] as f32,
                config.gravity[2] as f32,
            ),
            islands: IslandManager::new(),
            broad_phase: BroadPhaseBvh::new(),
            narrow_phase: NarrowPhase::new(),
            bodies,
            colliders: collider_set,
            impulse_joints,
            multibody_joints,
            soft_bodies: SoftBodySet::new(),
            ccd: CCDSolver::new(),
            bodies_of_joint,
            joints,
            root_handle,
            root_com,
            floating,
            geometry_colliders,
            closures: closure_handles,
            closure_specs,
            tau: vec![0.0; model.nv],
            external: None,
            disp: Vec::new(),
            time: 0.0,
        };
        sim.finish_build();
        Ok(sim)
    }

    fn multibody(&self) -> Option<&rapier3d::prelude::Multibody> {
        self.root_handle.and_then(|h| self.multibody_joints.get(h)).map(|(mb, _)| mb)
    }

    fn multibody_mut(&mut self) -> Option<&mut rapier3d::prelude::Multibody> {
        self.root_handle.and_then(|h| self.multibody_joints.get_mut(h)).map(|(mb, _)| mb)
    }

    /// Settles the multibody's root type, records link ids and dof indices, and replaces
    /// Rapier's default damping by the model's.
    fn finish_build(&mut self) {
        // Mass properties are otherwise only computed at the first step.
        for h in self.bodies_of_joint.iter().flatten() {
            if let Some(b) = self.bodies.get_mut(*h) {
                b.recompute_mass_properties_from_colliders(&self.colliders);
            }
        }
        let bodies = &self.bodies;
        if let Some(mb) = self.root_handle.and_then(|h| self.multibody_joints.get_mut(h)).map(|(mb, _)| mb) {
            mb.forward_kinematics(bodies, true);
        }
        for j in 0..self.joints.len() {
            let Some(body) = self.joints[j].map(|m| m.body) else { continue };
            let Some(link_id) = self.multibody_joints.rigid_body_link(body).map(|l| l.id) else { continue };
            let dof = self.multibody().and_then(|mb| mb.link(link_id)).map_or(0, |l| l.assembly_id());
            if let Some(map) = self.joints[j].as_mut() {
                map.link = link_id;
                map.dof = dof;
            }
        }
        let settings: Vec<(usize, f32, f32)> = self
            .joints
            .iter()
            .enumerate()
            .filter_map(|(j, m)| m.map(|m| (j, m)))
            .map(|(j, m)| {
                let iv = self.model.joints[j].idx_v;
                (m.dof, self.model.damping[iv] as f32, self.model.armature[iv] as f32)
            })
            .collect();
        let mut ndofs = 0;
        if let Some(mb) = self.multibody_mut() {
            ndofs = mb.ndofs();
            mb.damping_mut().fill(0.0);
            for (dof, damping, armature) in settings {
                mb.damping_mut()[dof] = damping;
                mb.armature_mut()[dof] = armature;
            }
        }
        self.disp = vec![0.0; ndofs];
    }

    /// The model this simulation was built from.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The physics settings.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// Total mass of the simulated robot bodies (kg), as Rapier sees it.
    pub fn total_mass(&self) -> f64 {
        self.bodies_of_joint
            .iter()
            .flatten()
            .map(|h| &self.bodies[*h])
            .filter(|b| b.is_dynamic())
            .map(|b| b.mass() as f64)
            .sum()
    }

    /// Simulated time since construction (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Sets an implicit joint spring `τ = −k (q − q_rest)` on joint `joint` (MuJoCo's joint
    /// stiffness; integrated implicitly by Rapier).
    #[track_caller]
    pub fn set_joint_spring(&mut self, joint: usize, stiffness: f64, rest: f64) {
        let Some(map) = self.joints[joint] else { return };
        if let Some(link) = self.multibody_mut().and_then(|mb| mb.link_mut(map.link)) {
            link.joint.set_spring(map.coord, stiffness as f32, rest as f32);
        }
    }

    /// Rapier dof of the model's `v` index, for 1-dof joints.
    fn rapier_dof(&self, v_index: usize) -> Option<usize> {
        let j = self.model.joint_of_dof(v_index);
        self.joints[j].map(|m| m.dof)
    }

    /// Sets the reflected rotor inertia (armature) of the dof `v_index` of the model
    /// (ignored for a floating base's dofs).
    pub fn set_armature(&mut self, v_index: usize, armature: f64) {
        if let Some(dof) = self.rapier_dof(v_index)
            && let Some(mb) = self.multibody_mut()
        {
            mb.armature_mut()[dof] = armature as f32;
            self.model.armature[v_index] = armature;
        }
    }

    /// Sets the viscous damping of the dof `v_index`, integrated implicitly by Rapier
    /// (ignored for a floating base's dofs).
    pub fn set_damping(&mut self, v_index: usize, damping: f64) {
        if let Some(dof) = self.rapier_dof(v_index)
            && let Some(mb) = self.multibody_mut()
        {
            mb.damping_mut()[dof] = damping as f32;
            self.model.damping[v_index] = damping;
        }
    }

    /// Position and velocity of one 1-dof model joint (cheaper than [`Sim::read_state`]).
    #[inline]
    pub fn joint_state(&self, joint: usize) -> (f64, f64) {
        let Some(map) = self.joints[joint] else { return (0.0, 0.0) };
        let Some(mb) = self.multibody() else { return (0.0, 0.0) };
        let q = mb.link(map.link).map_or(0.0, |l| l.joint().coords()[map.coord]);
        (q as f64, mb.generalized_velocity()[map.dof] as f64)
    }

    /// Applies a force (N, world frame) through the centre of mass of the body moved by
    /// `joint` at every step until changed (zero to stop).
    pub fn set_external_force(&mut self, joint: usize, force: Vector3<f64>) {
        self.external = Some((joint, force)).filter(|(_, f)| f.norm() > 0.0);
    }

    /// Sets the generalized forces applied from now on (model `v` layout; entries of a
    /// floating base are ignored). They persist across steps until changed.
    #[track_caller]
    pub fn set_joint_torques(&mut self, tau: &[f64]) {
        assert!(
            tau.len() == self.model.nv,
            "set_joint_torques: {} entries, model nv = {}",
            tau.len(),
            self.model.nv
        );
        self.tau.copy_from_slice(tau);
    }

    /// Sets one generalized force (model `v` index).
    pub fn set_joint_torque(&mut self, v_index: usize, tau: f64) {
        self.tau[v_index] = tau;
    }

    /// Advances the simulation by one time step.
    pub fn step(&mut self) {
        for (_, rb) in self.bodies.iter_mut() {
            rb.reset_forces(false);
            rb.reset_torques(false);
        }
        for j in 0..self.joints.len() {
            let Some(map) = self.joints[j] else { continue };
            let tau = self.tau[self.model.joints[j].idx_v];
            if tau == 0.0 {
                continue;
            }
            let child = &self.bodies[map.body];
            let axis_world = *child.rotation() * v3(&map.axis);
            if map.revolute {
                let t = axis_world * tau as f32;
                self.bodies[map.body].add_torque(t, false);
                if self.bodies[map.parent_body].is_dynamic() {
                    self.bodies[map.parent_body].add_torque(-t, false);
                }
            } else {
                // Equal and opposite forces through the child's centre of mass, so that no
                // moment reaches the ancestors.
                let f = axis_world * tau as f32;
                let at = self.bodies[map.body].mass_properties().world_com;
                self.bodies[map.body].add_force(f, false);
                if self.bodies[map.parent_body].is_dynamic() {
                    self.bodies[map.parent_body].add_force_at_point(-f, at, false);
                }
            }
        }
        if let Some((j, f)) = self.external
            && let Some(body) = self.bodies_of_joint[j]
        {
            self.bodies[body].add_force(v3(&f), false);
        }
        self.pipeline.step(
            self.gravity,
            &self.params,
            &mut self.islands,
            &mut self.broad_phase,
            &mut self.narrow_phase,
            &mut self.bodies,
            &mut self.colliders,
            &mut self.impulse_joints,
            &mut self.multibody_joints,
            &mut self.soft_bodies,
            &mut self.ccd,
            &(),
            &(),
        );
        self.time += self.config.dt;
    }

    /// Reads the robot's state into `state` (model layout, dynamics conventions).
    pub fn read_state(&self, state: &mut RobotState) {
        let mb = self.multibody();
        if let Some(mb) = mb {
            let gv = mb.generalized_velocity();
            for j in 0..self.joints.len() {
                let Some(map) = self.joints[j] else { continue };
                let mj = &self.model.joints[j];
                if let Some(link) = mb.link(map.link) {
                    state.q[mj.idx_q] = link.joint().coords()[map.coord] as f64;
                }
                state.v[mj.idx_v] = gv[map.dof] as f64;
            }
        }
        if self.floating
            && let Some(root) = self.bodies_of_joint[1]
        {
            let rb = &self.bodies[root];
            let p = rb.position();
            let rq = p.rotation;
            let rot = UnitQuaternion::from_quaternion(na::Quaternion::new(
                rq.w as f64,
                rq.x as f64,
                rq.y as f64,
                rq.z as f64,
            ));
            let r = rot.to_rotation_matrix();
            // The Rapier root frame sits at the centre of mass c: origin = p − R c. Its
            // velocity (the multibody's root dofs, or the lone body's) is the CoM's.
            let rc = r * self.root_com;
            let origin = to_f64(p.translation) - rc;
            let (v_com, w) = match mb {
                Some(mb) => {
                    let gv = mb.generalized_velocity();
                    (
                        Vector3::new(gv[0] as f64, gv[1] as f64, gv[2] as f64),
                        Vector3::new(gv[3] as f64, gv[4] as f64, gv[5] as f64),
                    )
                }
                None => (to_f64(rb.linvel()), to_f64(rb.angvel())),
            };
            let v_origin = v_com - w.cross(&rc);
            let (vl, wl) = (r.transpose() * v_origin, r.transpose() * w);
            let q = rot.quaternion();
            state.q.as_mut_slice()[..7].copy_from_slice(&[origin.x, origin.y, origin.z, q.i, q.j, q.k, q.w]);
            state.v.as_mut_slice()[..6].copy_from_slice(&[vl.x, vl.y, vl.z, wl.x, wl.y, wl.z]);
        }
    }

    /// Moves the robot to `state` (positions and velocities), in place.
    pub fn set_state(&mut self, state: &RobotState) {
        // Root twist, as Rapier wants it: centre-of-mass velocity and angular velocity, world axes.
        let mut root_twist = None;
        if self.floating
            && let Some(root) = self.bodies_of_joint[1]
        {
            let q = &state.q;
            let rot = UnitQuaternion::from_quaternion(na::Quaternion::new(q[6], q[3], q[4], q[5]));
            let r = rot.to_rotation_matrix();
            let rc = r * self.root_com;
            let p = Vector3::new(q[0], q[1], q[2]) + rc;
            self.bodies[root].set_position(Pose::from_parts(v3(&p), quat(r.matrix())), true);
            let vl = Vector3::new(state.v[0], state.v[1], state.v[2]);
            let wl = Vector3::new(state.v[3], state.v[4], state.v[5]);
            let (v_origin, w) = (r * vl, r * wl);
            let v_com = v_origin + w.cross(&rc);
            root_twist = Some((v_com, w));
            if self.root_handle.is_none() {
                self.bodies[root].set_linvel(v3(&v_com), true);
                self.bodies[root].set_angvel(v3(&w), true);
            }
        }
        let Some(handle) = self.root_handle else {
            self.bodies.propagate_modified_body_positions_to_colliders(&mut self.colliders);
            return;
        };
        let Some((mb, _)) = self.multibody_joints.get_mut(handle) else { return };
        self.disp.iter_mut().for_each(|d| *d = 0.0);
        for j in 0..self.joints.len() {
            let Some(map) = self.joints[j] else { continue };
            let mj = &self.model.joints[j];
            let current = mb.link(map.link).map_or(0.0, |l| l.joint().coords()[map.coord]);
            self.disp[map.dof] = state.q[mj.idx_q] as f32 - current;
        }
        mb.apply_displacements(&self.disp);
        {
            let mut gv = mb.generalized_velocity_mut();
            for j in 0..self.joints.len() {
                let Some(map) = self.joints[j] else { continue };
                gv[map.dof] = state.v[self.model.joints[j].idx_v] as f32;
            }
            if let Some((v_com, w)) = root_twist {
                for k in 0..3 {
                    gv[k] = v_com[k] as f32;
                    gv[3 + k] = w[k] as f32;
                }
            }
        }
        mb.forward_kinematics(&self.bodies, true);
        mb.update_rigid_bodies(&mut self.bodies, true);
        self.bodies.propagate_modified_body_positions_to_colliders(&mut self.colliders);
    }

    /// Generalized accelerations Rapier computed at the start of the last step, before
    /// contacts, limits and loop closures (model `v` layout; joints only — base entries are
    /// left untouched).
    pub fn unconstrained_joint_accelerations(&self, out: &mut [f64]) {
        let Some(mb) = self.multibody() else { return };
        let ga = mb.generalized_acceleration();
        for j in 0..self.joints.len() {
            if let Some(map) = self.joints[j] {
                out[self.model.joints[j].idx_v] = ga[map.dof] as f64;
            }
        }
    }

    /// World position of a point given in a model frame.
    pub fn frame_point(&self, frame: usize, point: &Vector3<f64>) -> Vector3<f64> {
        let f = &self.model.frames[frame];
        let j = f.parent_joint;
        let Some(body) = self.bodies_of_joint[j] else {
            return f.placement.act_point(point);
        };
        let shift = if self.floating && j == 1 { self.root_com } else { Vector3::zeros() };
        let local = f.placement.act_point(point) - shift;
        to_f64(self.bodies[body].position().transform_point(v3(&local)))
    }

    /// Gap of every loop closure: the distance between its two points (m).
    pub fn loop_closure_gaps(&self, out: &mut [f64]) {
        for (o, (ba, pa, bb, pb)) in out.iter_mut().zip(&self.closure_specs) {
            let wa = self.bodies[*ba].position().transform_point(v3(pa));
            let wb = self.bodies[*bb].position().transform_point(v3(pb));
            *o = (wa - wb).length() as f64;
        }
    }

    /// Number of loop closures.
    pub fn num_loop_closures(&self) -> usize {
        self.closures.len()
    }

    /// Collider of model geometry `k`, if it became one.
    pub fn geometry_collider(&self, k: usize) -> Option<ColliderHandle> {
        self.geometry_colliders[k]
    }

    /// The contact force (N, world frame) the ground exerts on a collider during the last
    /// step, and the point where its normal part acts (the impulse-weighted mean of the
    /// contact points), or `None` without contact.
    ///
    /// The tangential (friction) part is read for colliders on multibody links, i.e. every
    /// link of a robot with joints. A robot of a single link is a plain rigid body, whose
    /// contacts Rapier solves with one friction impulse per manifold that it does not store
    /// per point; for it the force has its normal part only. (Rapier's per-point Coulomb
    /// model would make it readable, but lets a free block slide down a slope with ~10 %
    /// less friction than μ, measured by the slope test.)
    pub fn contact_force(&self, collider: ColliderHandle) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let mut force = Vector::ZERO;
        let mut point = Vector::ZERO;
        let mut total = 0.0f32;
        for pair in self.narrow_phase.contact_pairs_with(collider) {
            let sign = if pair.collider1 == collider { 1.0 } else { -1.0 };
            for m in pair.solver_manifolds() {
                let n = m.data.normal;
                let d1 = -n;
                let (t1, t2) = friction_basis(d1);
                for sc in &m.data.solver_contacts {
                    let Some(p) = m.points.get(sc.contact_indices()[0] as usize) else { continue };
                    let on_1 =
                        -n * p.data.impulse + t1 * p.data.tangent_impulse.x + t2 * p.data.tangent_impulse.y;
                    force += on_1 * sign;
                    let w = p.data.impulse.abs();
                    let (p1, p2) = m.data.solver_contact_world_points(sc, &self.bodies);
                    point += (p1 + p2) * 0.5 * w;
                    total += w;
                }
            }
        }
        if total <= 0.0 {
            return None;
        }
        let dt = self.config.dt as f32;
        Some((to_f64(force / dt), to_f64(point / total)))
    }

    /// World pose of a model joint's body (its model frame, not Rapier's), for rendering.
    pub fn joint_placement(&self, joint: usize) -> Se3 {
        let Some(body) = self.bodies_of_joint[joint] else { return Se3::identity() };
        let p = self.bodies[body].position();
        let rq = p.rotation;
        let rot = UnitQuaternion::from_quaternion(na::Quaternion::new(
            rq.w as f64,
            rq.x as f64,
            rq.y as f64,
            rq.z as f64,
        ));
        let r = *rot.to_rotation_matrix().matrix();
        let t = to_f64(p.translation);
        let shift = if self.floating && joint == 1 { self.root_com } else { Vector3::zeros() };
        Se3::new(r, t - r * shift)
    }

    /// Sets the friction coefficient of the ground.
    pub fn set_ground_friction(&mut self, mu: f64) {
        for (_, c) in self.colliders.iter_mut() {
            if c.parent().is_some_and(|p| !self.bodies[p].is_dynamic()) && c.shape().as_halfspace().is_some()
            {
                c.set_friction(mu as f32);
            }
        }
    }
}

/// The friction directions of Rapier 0.36's contact constraints for a contact whose force on
/// body 1 points along `d1`: `t1` is the second vector of Pixar's branchless orthonormal
/// basis (Duff et al. 2017; Rapier's `orthonormal_vector`), `t2 = d1 × t1`. Tangent impulses
/// are stored in that basis (`generic_contact_constraint.rs`, `compute_tangent_contact_directions`).
fn friction_basis(d1: Vector) -> (Vector, Vector) {
    let sign = 1.0f32.copysign(d1.z);
    let a = -1.0 / (sign + d1.z);
    let b = d1.x * d1.y * a;
    let t1 = Vector::new(b, sign + d1.y * d1.y * a, -d1.y);
    (t1, d1.cross(t1))
}
