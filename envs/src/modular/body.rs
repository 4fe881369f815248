//! The body: modules ([`ModuleKind`], [`ModuleSpecs`]) attached face to face into a tree
//! ([`Body`]), its checks ([`ModularError`]) and its URDF.

use centaur_dynamics::nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use centaur_dynamics::{BaseKind, Model};

/// The kinds of module.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum ModuleKind {
    /// The central box; every body has exactly one, as its root.
    Core,
    /// A passive box.
    Brick,
    /// A servo with one revolute joint.
    ActiveHinge,
}

impl ModuleKind {
    /// The faces children can be attached to.
    pub fn faces(&self) -> &'static [Face] {
        match self {
            ModuleKind::Core => &[Face::Front, Face::Back, Face::Left, Face::Right],
            ModuleKind::Brick => &[Face::Front, Face::Left, Face::Right],
            ModuleKind::ActiveHinge => &[Face::Attachment],
        }
    }

    pub(super) fn name(&self) -> &'static str {
        match self {
            ModuleKind::Core => "core",
            ModuleKind::Brick => "brick",
            ModuleKind::ActiveHinge => "hinge",
        }
    }
}

/// Where a child is attached to its parent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Face {
    /// Along the parent's +x.
    Front,
    /// Along the parent's −x (core only).
    Back,
    /// Along the parent's +y.
    Left,
    /// Along the parent's −y.
    Right,
    /// The end of an active hinge.
    Attachment,
}

impl Face {
    pub(super) fn index(&self) -> usize {
        match self {
            Face::Front => 0,
            Face::Back => 1,
            Face::Left => 2,
            Face::Right => 3,
            Face::Attachment => 4,
        }
    }

    /// Turn about z from the parent's x axis to the face's outward direction.
    fn yaw(&self) -> f64 {
        match self {
            Face::Front | Face::Attachment => 0.0,
            Face::Back => std::f64::consts::PI,
            Face::Left => std::f64::consts::FRAC_PI_2,
            Face::Right => 3.0 * std::f64::consts::FRAC_PI_2,
        }
    }

    pub(super) fn name(&self) -> &'static str {
        match self {
            Face::Front => "front",
            Face::Back => "back",
            Face::Left => "left",
            Face::Right => "right",
            Face::Attachment => "attachment",
        }
    }
}

/// A module of a [`Body`] (an index into it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct ModuleId(pub usize);

/// Most modules a body may have, the core included: the report's robots have 10–20; a
/// body of thousands simulates at a few steps per second (reliability probe: 1,833).
pub const MAX_MODULES: usize = 256;

/// Why a body could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModularError {
    /// One module more than [`MAX_MODULES`].
    #[error("a body has at most {MAX_MODULES} modules, the core included")]
    TooManyModules,
    /// The parent is not a module of this body.
    #[error("module {0} does not exist in this body")]
    NoSuchModule(usize),
    /// The parent has no such face.
    #[error("a {kind} has no {face} face (it has: {faces})")]
    NoSuchFace {
        /// The parent's kind.
        kind: &'static str,
        /// The face asked for.
        face: &'static str,
        /// The faces it has.
        faces: String,
    },
    /// The face already holds a module.
    #[error("the {face} face of {path} is already taken")]
    FaceTaken {
        /// The parent's path from the core.
        path: String,
        /// The face.
        face: &'static str,
    },
    /// A second core.
    #[error("a body has exactly one core, its root")]
    SecondCore,
    /// A rotation that is not a finite number.
    #[error("rotation {0} is not finite")]
    BadRotation(f64),
    /// The new module would overlap a module already in the body.
    #[error("{new} would overlap {existing}")]
    Overlap {
        /// Path of the new module.
        new: String,
        /// Path of the module it would overlap.
        existing: String,
    },
    /// A module property that is not physical.
    #[error("module property {field} = {value} is not physical")]
    BadSpec {
        /// The field of `ModuleSpecs`.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A body description that is not valid JSON of the expected shape.
    #[error("body description: {0}")]
    Parse(String),
    /// The generated URDF did not load (a bug if it happens; reported, not hidden).
    #[error("the body's URDF does not load: {0}")]
    Model(String),
}

/// Geometry, masses and servo properties of the modules (defaults: Revolve2's V1 modules).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ModuleSpecs {
    /// Core box side lengths (m).
    pub core_size: [f64; 3],
    /// Core mass (kg).
    pub core_mass: f64,
    /// Brick box side lengths (m).
    pub brick_size: [f64; 3],
    /// Brick mass (kg).
    pub brick_mass: f64,
    /// Hinge frame box (fixed to the parent) side lengths (m).
    pub frame_size: [f64; 3],
    /// Hinge frame mass (kg).
    pub frame_mass: f64,
    /// Distance from the attachment face to the frame's reference point, doubled (m)
    /// (Revolve2's `frame_offset`).
    pub frame_offset: f64,
    /// Servo body box side lengths (m).
    pub servo1_size: [f64; 3],
    /// Servo body mass (kg).
    pub servo1_mass: f64,
    /// Servo horn plate side lengths (m), at the far end of the servo body.
    pub servo2_size: [f64; 3],
    /// Servo horn plate mass (kg).
    pub servo2_mass: f64,
    /// Servo body centre from the frame's reference point (m).
    pub servo_offset: f64,
    /// Joint axis from the frame's reference point (m).
    pub joint_offset: f64,
    /// Child attachment point from the servo body centre (m).
    pub child_offset: f64,
    /// Joint range, symmetric (rad).
    pub range: f64,
    /// Torque limit (N·m).
    pub effort: f64,
    /// Rated no-load speed (rad/s): the servo's torque falls to zero at this speed
    /// ([`servo_torque`](super::servo_torque); `f64::INFINITY` removes the limit).
    pub velocity: f64,
    /// Reflected rotor inertia (kg·m²).
    pub armature: f64,
    /// Servo position gain (N·m/rad).
    pub kp: f64,
    /// Servo velocity gain (N·m·s/rad).
    pub kd: f64,
    /// Friction coefficient of every module.
    pub friction: f64,
}

impl Default for ModuleSpecs {
    /// Revolve2's `CoreV1`, `BrickV1` and `ActiveHingeV1`.
    fn default() -> Self {
        ModuleSpecs {
            core_size: [0.089, 0.089, 0.0603],
            core_mass: 0.250,
            brick_size: [0.06288625, 0.06288625, 0.0603],
            brick_mass: 0.030,
            frame_size: [0.018, 0.053, 0.0165891],
            frame_mass: 0.011,
            frame_offset: 0.04525,
            servo1_size: [0.0583, 0.0512, 0.020],
            servo1_mass: 0.058,
            servo2_size: [0.002, 0.053, 0.053],
            servo2_mass: 0.02,
            servo_offset: 0.0299,
            joint_offset: 0.0119,
            child_offset: 0.0583 / 2.0 + 0.002,
            // 60°, Revolve2's 1.047197551.
            range: std::f64::consts::FRAC_PI_3,
            effort: 0.948013269,
            velocity: 6.338968228,
            armature: 0.002,
            kp: 5.0,
            kd: 0.05,
            friction: 1.0,
        }
    }
}

impl ModuleSpecs {
    /// Checks that every number is physical: sizes, masses, offsets and gains finite and
    /// positive (`kd`, `armature`, `friction` may be zero; `velocity` may be infinite), the
    /// range in (0, π].
    pub fn validate(&self) -> Result<(), ModularError> {
        let positive = [
            ("core_mass", self.core_mass),
            ("brick_mass", self.brick_mass),
            ("frame_mass", self.frame_mass),
            ("servo1_mass", self.servo1_mass),
            ("servo2_mass", self.servo2_mass),
            ("frame_offset", self.frame_offset),
            ("servo_offset", self.servo_offset),
            ("joint_offset", self.joint_offset),
            ("child_offset", self.child_offset),
            ("effort", self.effort),
            ("kp", self.kp),
        ];
        let sizes = [
            ("core_size", self.core_size),
            ("brick_size", self.brick_size),
            ("frame_size", self.frame_size),
            ("servo1_size", self.servo1_size),
            ("servo2_size", self.servo2_size),
        ];
        let non_negative = [("kd", self.kd), ("armature", self.armature), ("friction", self.friction)];
        let bad = |field: &'static str, value: f64| Err(ModularError::BadSpec { field, value });
        for (field, value) in positive {
            if !(value > 0.0 && value.is_finite()) {
                return bad(field, value);
            }
        }
        for (field, size) in sizes {
            if let Some(&value) = size.iter().find(|v| !(**v > 0.0 && v.is_finite())) {
                return bad(field, value);
            }
        }
        for (field, value) in non_negative {
            if !(value >= 0.0 && value.is_finite()) {
                return bad(field, value);
            }
        }
        if self.velocity.is_nan() || self.velocity <= 0.0 {
            return bad("velocity", self.velocity);
        }
        if !(self.range > 0.0 && self.range <= std::f64::consts::PI) {
            return bad("range", self.range);
        }
        Ok(())
    }

    /// Mass of one module of a kind (kg).
    pub fn mass(&self, kind: ModuleKind) -> f64 {
        match kind {
            ModuleKind::Core => self.core_mass,
            ModuleKind::Brick => self.brick_mass,
            ModuleKind::ActiveHinge => self.frame_mass + self.servo1_mass + self.servo2_mass,
        }
    }

    /// Servo body centre from the joint axis, along the hinge (m).
    fn servo_from_joint(&self) -> f64 {
        self.servo_offset - self.joint_offset
    }

    /// Joint axis from the attachment face, along the hinge (m).
    fn joint_from_face(&self) -> f64 {
        self.frame_offset / 2.0 + self.joint_offset
    }
}

#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub(super) struct Node {
    pub(super) kind: ModuleKind,
    pub(super) rotation: f64,
    parent: Option<(ModuleId, Face)>,
    pub(super) children: [Option<ModuleId>; 5],
}

/// A modular robot's body: a tree of modules rooted at the core (see the module docs).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Body {
    specs: ModuleSpecs,
    pub(super) nodes: Vec<Node>,
}

impl Default for Body {
    fn default() -> Self {
        Body::new()
    }
}

/// A rotation by `angle` about `axis` (0 = x, 2 = z), exact for multiples of 90°.
fn axis_rotation(axis: usize, angle: f64) -> Rotation3<f64> {
    let quarter = angle / std::f64::consts::FRAC_PI_2;
    let (s, c) = if (quarter - quarter.round()).abs() < 1e-12 {
        match (quarter.round() as i64).rem_euclid(4) {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        }
    } else {
        angle.sin_cos()
    };
    let m = if axis == 0 {
        Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
    } else {
        Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
    };
    Rotation3::from_matrix_unchecked(m)
}

fn iso(t: Vector3<f64>, r: Rotation3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_rotation_matrix(&r))
}

/// A module's main box in the core's frame (all hinges at zero).
struct ModuleBox {
    module: ModuleId,
    centre: Vector3<f64>,
    rotation: Matrix3<f64>,
    half: Vector3<f64>,
}

/// One box of the body: the link it belongs to, its centre pose in that link's frame.
#[derive(Clone, Debug)]
struct Part {
    link: String,
    parent_link: String,
    /// Pose of this link in the parent link (for fixed and revolute joints).
    joint_origin: (Vector3<f64>, Rotation3<f64>),
    hinge: bool,
    size: [f64; 3],
    mass: f64,
    /// Box centre in the link frame (along x).
    offset: f64,
    module: ModuleId,
}

impl Body {
    /// A body holding only the core, with Revolve2's V1 modules.
    pub fn new() -> Body {
        Body {
            specs: ModuleSpecs::default(),
            nodes: vec![Node { kind: ModuleKind::Core, rotation: 0.0, parent: None, children: [None; 5] }],
        }
    }

    /// A body holding only the core, with the given module properties (checked by
    /// [`ModuleSpecs::validate`]).
    pub fn with_specs(specs: ModuleSpecs) -> Result<Body, ModularError> {
        specs.validate()?;
        Ok(Body {
            specs,
            nodes: vec![Node { kind: ModuleKind::Core, rotation: 0.0, parent: None, children: [None; 5] }],
        })
    }

    /// The module properties.
    pub fn specs(&self) -> &ModuleSpecs {
        &self.specs
    }

    /// The core.
    pub fn core(&self) -> ModuleId {
        ModuleId(0)
    }

    /// Number of modules, the core included.
    pub fn num_modules(&self) -> usize {
        self.nodes.len()
    }

    /// The kind of a module.
    pub fn kind(&self, id: ModuleId) -> Option<ModuleKind> {
        self.nodes.get(id.0).map(|n| n.kind)
    }

    /// The hinges, in the order they were attached: the order of [`ModularEnv`](crate::ModularEnv)'s actions.
    /// Hinge `h` is the model joint named `hinge{h.0}`; the model numbers its joints in
    /// depth-first order, which can differ ([`RobotEnv::actuated_joints`](crate::RobotEnv::actuated_joints) maps one to the
    /// other).
    pub fn hinges(&self) -> Vec<ModuleId> {
        (0..self.nodes.len())
            .filter(|&k| self.nodes[k].kind == ModuleKind::ActiveHinge)
            .map(ModuleId)
            .collect()
    }

    /// Total mass (kg).
    pub fn mass(&self) -> f64 {
        self.nodes.iter().map(|n| self.specs.mass(n.kind)).sum()
    }

    /// Revolve2-style path of a module, e.g. `core.back.attachment.front` (`None` for a
    /// module not in this body).
    pub fn path(&self, id: ModuleId) -> Option<String> {
        self.nodes.get(id.0)?;
        Some(self.path_of(id))
    }

    pub(super) fn path_of(&self, id: ModuleId) -> String {
        let mut faces = Vec::new();
        let mut cur = id;
        while let Some((p, f)) = self.nodes.get(cur.0).and_then(|n| n.parent) {
            faces.push(f.name());
            cur = p;
        }
        faces.push("core");
        faces.reverse();
        faces.join(".")
    }

    /// The module attached at `face` of `parent`, if any.
    pub fn child(&self, parent: ModuleId, face: Face) -> Option<ModuleId> {
        self.nodes.get(parent.0).and_then(|n| n.children[face.index()])
    }

    /// Attaches a new module of `kind` at `face` of `parent`, turned by `rotation` (rad)
    /// about the direction it points in, and returns it.
    pub fn attach(
        &mut self,
        parent: ModuleId,
        face: Face,
        kind: ModuleKind,
        rotation: f64,
    ) -> Result<ModuleId, ModularError> {
        let node = self.nodes.get(parent.0).ok_or(ModularError::NoSuchModule(parent.0))?;
        if kind == ModuleKind::Core {
            return Err(ModularError::SecondCore);
        }
        if !rotation.is_finite() {
            return Err(ModularError::BadRotation(rotation));
        }
        if !node.kind.faces().contains(&face) {
            return Err(ModularError::NoSuchFace {
                kind: node.kind.name(),
                face: face.name(),
                faces: node.kind.faces().iter().map(|f| f.name()).collect::<Vec<_>>().join(", "),
            });
        }
        if node.children[face.index()].is_some() {
            return Err(ModularError::FaceTaken { path: self.path_of(parent), face: face.name() });
        }
        if self.nodes.len() >= MAX_MODULES {
            return Err(ModularError::TooManyModules);
        }
        let id = ModuleId(self.nodes.len());
        self.nodes.push(Node { kind, rotation, parent: Some((parent, face)), children: [None; 5] });
        self.nodes[parent.0].children[face.index()] = Some(id);
        if let Some(other) = self.overlapping(id) {
            let (new, existing) = (self.path_of(id), self.path_of(other));
            self.nodes.pop();
            self.nodes[parent.0].children[face.index()] = None;
            return Err(ModularError::Overlap { new, existing });
        }
        Ok(id)
    }

    /// [`Body::attach`] of an active hinge.
    pub fn hinge(&mut self, parent: ModuleId, face: Face, rotation: f64) -> Result<ModuleId, ModularError> {
        self.attach(parent, face, ModuleKind::ActiveHinge, rotation)
    }

    /// [`Body::attach`] of a brick.
    pub fn brick(&mut self, parent: ModuleId, face: Face, rotation: f64) -> Result<ModuleId, ModularError> {
        self.attach(parent, face, ModuleKind::Brick, rotation)
    }

    /// Slot pose of a child at `face` of a module, in the module's own frame (the core's
    /// centre; a brick's centre; a hinge's servo-link frame at the joint).
    fn child_slot(&self, parent: &Node, face: Face, child: &Node) -> Isometry3<f64> {
        let s = &self.specs;
        // Front and back faces sit half the length (x) away, left and right half the width (y).
        let axis = if matches!(face, Face::Left | Face::Right) { 1 } else { 0 };
        let along = match parent.kind {
            ModuleKind::Core => s.core_size[axis] / 2.0,
            ModuleKind::Brick => s.brick_size[axis] / 2.0,
            ModuleKind::ActiveHinge => s.servo_from_joint() + s.child_offset,
        };
        let yaw = axis_rotation(2, face.yaw());
        iso(yaw * Vector3::new(along, 0.0, 0.0), yaw * axis_rotation(0, child.rotation))
    }

    /// Every box of the body with its link and placement, in tree order.
    fn parts(&self) -> Vec<Part> {
        let s = &self.specs;
        let mut parts = vec![Part {
            link: "core".into(),
            parent_link: String::new(),
            joint_origin: (Vector3::zeros(), Rotation3::identity()),
            hinge: false,
            size: s.core_size,
            mass: s.core_mass,
            offset: 0.0,
            module: ModuleId(0),
        }];
        // (module, link holding its frame, the module's frame in that link)
        let mut stack = vec![(ModuleId(0), "core".to_string(), Isometry3::identity())];
        while let Some((id, link, frame)) = stack.pop() {
            let node = &self.nodes[id.0];
            for face in node.kind.faces().iter().rev() {
                let Some(cid) = node.children[face.index()] else { continue };
                let child = &self.nodes[cid.0];
                let slot = frame * self.child_slot(node, *face, child);
                let (t, r) = (slot.translation.vector, slot.rotation.to_rotation_matrix());
                let r = snap(r);
                match child.kind {
                    ModuleKind::Brick => {
                        let name = format!("brick{}", cid.0);
                        let centre = t + r * Vector3::new(s.brick_size[0] / 2.0, 0.0, 0.0);
                        parts.push(Part {
                            link: name.clone(),
                            parent_link: link.clone(),
                            joint_origin: (centre, r),
                            hinge: false,
                            size: s.brick_size,
                            mass: s.brick_mass,
                            offset: 0.0,
                            module: cid,
                        });
                        stack.push((cid, name, Isometry3::identity()));
                    }
                    ModuleKind::ActiveHinge => {
                        let frame_link = format!("hinge{}_frame", cid.0);
                        let servo = format!("hinge{}", cid.0);
                        parts.push(Part {
                            link: frame_link.clone(),
                            parent_link: link.clone(),
                            joint_origin: (t, r),
                            hinge: false,
                            size: s.frame_size,
                            mass: s.frame_mass,
                            offset: s.frame_size[0] / 2.0,
                            module: cid,
                        });
                        parts.push(Part {
                            link: servo.clone(),
                            parent_link: frame_link,
                            joint_origin: (
                                Vector3::new(s.joint_from_face(), 0.0, 0.0),
                                Rotation3::identity(),
                            ),
                            hinge: true,
                            size: s.servo1_size,
                            mass: s.servo1_mass,
                            offset: s.servo_from_joint(),
                            module: cid,
                        });
                        parts.push(Part {
                            link: format!("hinge{}_horn", cid.0),
                            parent_link: servo.clone(),
                            joint_origin: (Vector3::zeros(), Rotation3::identity()),
                            hinge: false,
                            size: s.servo2_size,
                            mass: s.servo2_mass,
                            offset: s.servo_from_joint() + (s.servo1_size[0] + s.servo2_size[0]) / 2.0,
                            module: cid,
                        });
                        stack.push((cid, servo, Isometry3::identity()));
                    }
                    ModuleKind::Core => {}
                }
            }
        }
        parts
    }

    /// The URDF of the body (see the module docs), with the robot named `name`.
    pub fn to_urdf(&self, name: &str) -> String {
        let s = &self.specs;
        let mut links = String::new();
        let mut joints = String::new();
        for p in self.parts() {
            let [x, y, z] = p.size;
            let m = p.mass;
            let (ixx, iyy, izz) =
                (m / 12.0 * (y * y + z * z), m / 12.0 * (x * x + z * z), m / 12.0 * (x * x + y * y));
            let o = format!("<origin xyz=\"{} 0 0\" rpy=\"0 0 0\"/>", p.offset);
            let geometry = format!("<geometry><box size=\"{x} {y} {z}\"/></geometry>");
            links += &format!(
                "  <link name=\"{l}\">\n    <inertial>{o}<mass value=\"{m}\"/>\
                 <inertia ixx=\"{ixx}\" ixy=\"0\" ixz=\"0\" iyy=\"{iyy}\" iyz=\"0\" izz=\"{izz}\"/></inertial>\n    \
                 <visual>{o}{geometry}</visual>\n    <collision>{o}{geometry}</collision>\n  </link>\n",
                l = p.link,
            );
            if p.parent_link.is_empty() {
                continue;
            }
            let (t, r) = p.joint_origin;
            let (roll, pitch, yaw) = r.euler_angles();
            let origin = format!(
                "<origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>",
                clean(t.x),
                clean(t.y),
                clean(t.z),
                clean(roll),
                clean(pitch),
                clean(yaw)
            );
            if p.hinge {
                joints += &format!(
                    "  <joint name=\"{l}\" type=\"revolute\">\n    <parent link=\"{pl}\"/><child link=\"{l}\"/>\
                     {origin}<axis xyz=\"0 1 0\"/>\n    <limit lower=\"{lo}\" upper=\"{hi}\" effort=\"{e}\" velocity=\"{v}\"/>\n  </joint>\n",
                    l = p.link,
                    pl = p.parent_link,
                    lo = -s.range,
                    hi = s.range,
                    e = s.effort,
                    v = s.velocity,
                );
            } else {
                joints += &format!(
                    "  <joint name=\"{l}_fixed\" type=\"fixed\">\n    <parent link=\"{pl}\"/><child link=\"{l}\"/>{origin}\n  </joint>\n",
                    l = p.link,
                    pl = p.parent_link,
                );
            }
        }
        let name: String = name
            .chars()
            .map(|c| match c {
                '&' => "&amp;".to_string(),
                '<' => "&lt;".to_string(),
                '>' => "&gt;".to_string(),
                '"' => "&quot;".to_string(),
                '\'' => "&apos;".to_string(),
                c => c.to_string(),
            })
            .collect();
        format!(
            "<?xml version=\"1.0\"?>\n<!-- Modular robot built by centaur-envs::modular -->\n<robot name=\"{name}\">\n{links}{joints}</robot>\n"
        )
    }

    /// The body as a floating-base `Model`.
    pub fn to_model(&self, name: &str) -> Result<Model, ModularError> {
        Model::from_urdf_str(&self.to_urdf(name), name, BaseKind::Floating)
            .map_err(|e| ModularError::Model(e.to_string()))
    }

    /// World boxes (centre, rotation, half extents) of each module's main part with the
    /// core at the origin and every hinge at zero.
    fn module_boxes(&self) -> Vec<ModuleBox> {
        let s = &self.specs;
        let mut world: Vec<(String, Isometry3<f64>)> = Vec::new();
        let mut out = Vec::new();
        for p in self.parts() {
            let parent =
                world.iter().find(|(l, _)| *l == p.parent_link).map_or(Isometry3::identity(), |(_, w)| *w);
            let pose = parent * iso(p.joint_origin.0, p.joint_origin.1);
            world.push((p.link.clone(), pose));
            let main = match self.nodes[p.module.0].kind {
                ModuleKind::ActiveHinge => p.hinge,
                _ => true,
            };
            if main {
                let r = pose.rotation.to_rotation_matrix().into_inner();
                let c = pose * centaur_dynamics::nalgebra::Point3::new(p.offset, 0.0, 0.0);
                let size = if p.hinge { s.servo1_size } else { p.size };
                out.push(ModuleBox {
                    module: p.module,
                    centre: c.coords,
                    rotation: r,
                    half: Vector3::new(size[0], size[1], size[2]) / 2.0,
                });
            }
        }
        out
    }

    /// A module whose box overlaps `id`'s (other than its parent and children), if any.
    fn overlapping(&self, id: ModuleId) -> Option<ModuleId> {
        const SLACK: f64 = 0.004;
        let boxes = self.module_boxes();
        let b = boxes.iter().find(|b| b.module == id)?;
        let half = |b: &ModuleBox| b.rotation.abs() * b.half - Vector3::repeat(SLACK);
        let ha = half(b);
        let parent = self.nodes[id.0].parent.map(|p| p.0);
        boxes.iter().find_map(|o| {
            let adjacent = o.module == id || Some(o.module) == parent;
            let hb = half(o);
            let apart = (0..3).any(|k| (b.centre[k] - o.centre[k]).abs() >= ha[k] + hb[k]);
            let other = &o.module;
            (!adjacent && !apart).then_some(*other)
        })
    }

    /// Revolve2's `gecko_v1`: two front legs on the core, a two-hinge spine bending sideways,
    /// two hind legs (6 hinges, 0.964 kg).
    pub fn gecko() -> Body {
        Body::lizard(false).expect("the gecko is a valid body")
    }

    /// Revolve2's `ant_v1`: the gecko with a third pair of legs on the brick between the
    /// two spine hinges (8 hinges, 1.202 kg).
    pub fn ant() -> Body {
        Body::lizard(true).expect("the ant is a valid body")
    }

    /// The gecko, with or without middle legs.
    fn lizard(middle_legs: bool) -> Result<Body, ModularError> {
        use std::f64::consts::FRAC_PI_2 as H;
        // A leg: a hinge lifting in the vertical plane and a brick as its foot.
        let leg = |b: &mut Body, parent: ModuleId, face: Face| -> Result<(), ModularError> {
            let hinge = b.hinge(parent, face, 0.0)?;
            b.brick(hinge, Face::Attachment, 0.0).map(|_| ())
        };
        let mut b = Body::new();
        let c = b.core();
        leg(&mut b, c, Face::Left)?;
        leg(&mut b, c, Face::Right)?;
        let spine = b.hinge(c, Face::Back, H)?;
        let mid = b.brick(spine, Face::Attachment, -H)?;
        if middle_legs {
            leg(&mut b, mid, Face::Left)?;
            leg(&mut b, mid, Face::Right)?;
        }
        let spine2 = b.hinge(mid, Face::Front, H)?;
        let hip = b.brick(spine2, Face::Attachment, -H)?;
        leg(&mut b, hip, Face::Left)?;
        leg(&mut b, hip, Face::Right)?;
        Ok(b)
    }

    /// Revolve2's `spider_v1`: four two-hinge legs, hip swinging sideways, knee lifting
    /// (8 hinges).
    pub fn spider() -> Body {
        use std::f64::consts::FRAC_PI_2 as H;
        let mut b = Body::new();
        let c = b.core();
        let build = |b: &mut Body| -> Result<(), ModularError> {
            for face in [Face::Left, Face::Right, Face::Front, Face::Back] {
                let hip = b.hinge(c, face, H)?;
                let upper = b.brick(hip, Face::Attachment, -H)?;
                let knee = b.hinge(upper, Face::Front, 0.0)?;
                b.brick(knee, Face::Attachment, 0.0)?;
            }
            Ok(())
        };
        build(&mut b).expect("the spider is a valid body");
        b
    }
}

/// Rounds the entries of a rotation that are within 1e-15 of 0 or ±1 (turns composed of
/// exact quarter turns stay exact).
fn snap(r: Rotation3<f64>) -> Rotation3<f64> {
    let m = r.into_inner().map(|x| {
        if x.abs() < 1e-15 {
            0.0
        } else if (x.abs() - 1.0).abs() < 1e-15 {
            x.signum()
        } else {
            x
        }
    });
    Rotation3::from_matrix_unchecked(m)
}

/// Writes `x` with negative zero and rounding residue below 1e-15 as 0.
fn clean(x: f64) -> f64 {
    if x.abs() < 1e-15 { 0.0 } else { x }
}
