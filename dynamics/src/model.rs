//! The kinematic tree: joints in depth-first order, body inertias, frames and geometry.

use nalgebra::{DVector, Matrix3, UnitQuaternion, Vector3};

use crate::spatial::{Inertia, Motion, Se3};

/// The kind of a joint, with its motion subspace `S` in the joint (child) frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointKind {
    /// Index 0 of every model: the world. No degrees of freedom.
    Universe,
    /// A 6-dof free-flyer (floating base). `q = [x, y, z, qx, qy, qz, qw]` (placement of the
    /// child frame in the parent frame, scalar-last unit quaternion); `v = [v, ω]` is the
    /// child's twist expressed in the child frame; `S = 𝟙₆`.
    FreeFlyer,
    /// Rotation by `q` about the unit `axis`: `S = (0, axis)`.
    Revolute {
        /// Unit rotation axis in the joint frame.
        axis: Vector3<f64>,
    },
    /// Rotation by the angle `θ` about the unit `axis`, parametrised as Pinocchio
    /// parametrises unbounded (continuous) joints: `q = (cos θ, sin θ)`, a unit vector
    /// (the algorithms assume it without checking; [`crate::normalize`] restores it), so
    /// the joint has no angle to wrap and no sine or cosine to evaluate; `v = θ̇`;
    /// `S = (0, axis)`. Two `q` entries, one degree of freedom. The URDF loader makes
    /// continuous joints this kind when asked ([`crate::UrdfOptions`]); by default they are
    /// [`JointKind::Revolute`] with unlimited angles.
    RevoluteUnbounded {
        /// Unit rotation axis in the joint frame.
        axis: Vector3<f64>,
    },
    /// Translation by `q` along the unit `axis`: `S = (axis, 0)`.
    Prismatic {
        /// Unit translation axis in the joint frame.
        axis: Vector3<f64>,
    },
}

impl JointKind {
    /// Dimension of the joint's configuration.
    #[inline]
    pub fn nq(&self) -> usize {
        match self {
            JointKind::Universe => 0,
            JointKind::FreeFlyer => 7,
            JointKind::RevoluteUnbounded { .. } => 2,
            JointKind::Revolute { .. } | JointKind::Prismatic { .. } => 1,
        }
    }

    /// Dimension of the joint's velocity (degrees of freedom).
    #[inline]
    pub fn nv(&self) -> usize {
        match self {
            JointKind::Universe => 0,
            JointKind::FreeFlyer => 6,
            JointKind::Revolute { .. }
            | JointKind::RevoluteUnbounded { .. }
            | JointKind::Prismatic { .. } => 1,
        }
    }

    /// The joint transform `M_J(q)` (child frame in the frame the joint is placed in).
    #[inline]
    pub fn transform(&self, q: &[f64]) -> Se3 {
        match self {
            JointKind::Universe => Se3::identity(),
            JointKind::FreeFlyer => {
                let quat = nalgebra::Quaternion::new(q[6], q[3], q[4], q[5]);
                let unit = UnitQuaternion::from_quaternion(quat);
                Se3::from_quaternion(&unit, Vector3::new(q[0], q[1], q[2]))
            }
            JointKind::Revolute { axis } => {
                Se3 { rotation: axis_rotation(axis, q[0]), translation: Vector3::zeros() }
            }
            JointKind::RevoluteUnbounded { axis } => {
                Se3 { rotation: rotation_from_sin_cos(axis, q[1], q[0]), translation: Vector3::zeros() }
            }
            JointKind::Prismatic { axis } => Se3::from_translation(axis * q[0]),
        }
    }

    /// Column `k` of the motion subspace `S` (for 1-dof joints, `k = 0`).
    #[inline]
    pub fn subspace_column(&self, k: usize) -> Motion {
        match self {
            JointKind::Universe => Motion::zero(),
            JointKind::FreeFlyer => {
                let mut m = Motion::zero();
                if k < 3 {
                    m.linear[k] = 1.0;
                } else {
                    m.angular[k - 3] = 1.0;
                }
                m
            }
            JointKind::Revolute { axis } | JointKind::RevoluteUnbounded { axis } => {
                Motion::new(Vector3::zeros(), *axis)
            }
            JointKind::Prismatic { axis } => Motion::new(*axis, Vector3::zeros()),
        }
    }

    /// The joint velocity `v_J = S q̇` in the child frame.
    #[inline]
    pub fn motion(&self, qd: &[f64]) -> Motion {
        match self {
            JointKind::Universe => Motion::zero(),
            JointKind::FreeFlyer => {
                Motion::new(Vector3::new(qd[0], qd[1], qd[2]), Vector3::new(qd[3], qd[4], qd[5]))
            }
            JointKind::Revolute { axis } | JointKind::RevoluteUnbounded { axis } => {
                Motion::new(Vector3::zeros(), axis * qd[0])
            }
            JointKind::Prismatic { axis } => Motion::new(axis * qd[0], Vector3::zeros()),
        }
    }
}

/// Rotation by `angle` about the unit `axis` (Rodrigues), with exact matrices for the
/// coordinate axes.
#[inline]
pub(crate) fn axis_rotation(axis: &Vector3<f64>, angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    rotation_from_sin_cos(axis, s, c)
}

/// [`axis_rotation`] given the angle's sine and cosine.
#[inline]
fn rotation_from_sin_cos(axis: &Vector3<f64>, s: f64, c: f64) -> Matrix3<f64> {
    let (x, y, z) = (axis.x, axis.y, axis.z);
    let t = 1.0 - c;
    Matrix3::new(
        t * x * x + c,
        t * x * y - s * z,
        t * x * z + s * y,
        t * x * y + s * z,
        t * y * y + c,
        t * y * z - s * x,
        t * x * z - s * y,
        t * y * z + s * x,
        t * z * z + c,
    )
}

/// How the joint transforms turn a revolute joint's placement rotation: about a signed
/// coordinate axis only two of its columns mix (12 products instead of a 3 × 3 matrix
/// product); other axes take the full product. Classified once per joint by
/// [`Model::finalize`], as Pinocchio specialises its revolute joints by axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum AxisPlane {
    /// `±x` (the sign is the axis's x component): columns y and z turn.
    X(f64),
    /// `±y`: columns z and x turn.
    Y(f64),
    /// `±z`: columns x and y turn.
    Z(f64),
    /// Any other axis (and every non-revolute joint, which never asks).
    General,
}

impl AxisPlane {
    /// `Some((k, sign))` when the axis is `sign · e_k`, `None` for a general axis. Products
    /// with such an axis are a component pick, which equals the full product exactly (the
    /// zero terms add nothing but, at most, the sign of a zero result).
    #[inline(always)]
    pub(crate) fn unit(self) -> Option<(usize, f64)> {
        match self {
            AxisPlane::X(s) => Some((0, s)),
            AxisPlane::Y(s) => Some((1, s)),
            AxisPlane::Z(s) => Some((2, s)),
            AxisPlane::General => None,
        }
    }

    /// The plane of a joint kind's axis.
    pub(crate) fn of(kind: &JointKind) -> Self {
        let (JointKind::Revolute { axis } | JointKind::RevoluteUnbounded { axis }) = kind else {
            return AxisPlane::General;
        };
        let unit = |v: f64, o1: f64, o2: f64| (v == 1.0 || v == -1.0) && o1 == 0.0 && o2 == 0.0;
        if unit(axis.x, axis.y, axis.z) {
            AxisPlane::X(axis.x)
        } else if unit(axis.y, axis.z, axis.x) {
            AxisPlane::Y(axis.y)
        } else if unit(axis.z, axis.x, axis.y) {
            AxisPlane::Z(axis.z)
        } else {
            AxisPlane::General
        }
    }
}

/// `r · Rot(axis, angle)`, given `(sin angle, cos angle)` and the axis's [`AxisPlane`].
#[inline(always)]
pub(crate) fn rotate_about_axis(
    r: &Matrix3<f64>,
    axis: &Vector3<f64>,
    plane: AxisPlane,
    (s, c): (f64, f64),
) -> Matrix3<f64> {
    // Columns (a, b) of `r` rotated in their plane: (c a + s b, c b − s a).
    let turn = |a: usize, b: usize, s: f64| {
        let (ca, cb) = (r.column(a), r.column(b));
        let (na, nb) = (ca * c + cb * s, cb * c - ca * s);
        let mut out = *r;
        out.set_column(a, &na);
        out.set_column(b, &nb);
        out
    };
    match plane {
        AxisPlane::X(sign) => turn(1, 2, s * sign),
        AxisPlane::Y(sign) => turn(2, 0, s * sign),
        AxisPlane::Z(sign) => turn(0, 1, s * sign),
        AxisPlane::General => r * rotation_from_sin_cos(axis, s, c),
    }
}

/// One joint of the tree and the body it moves.
#[derive(Clone, Debug)]
pub struct Joint {
    /// Joint name (from the URDF; `"universe"` for index 0, `"root_joint"` for a free-flyer
    /// added by the loader).
    pub name: String,
    /// Kind and axis.
    pub kind: JointKind,
    /// Index of the parent joint (`0` for joints attached to the world; `parent < index`).
    pub parent: usize,
    /// Placement of the joint frame in the parent joint's frame at the neutral
    /// configuration (joint angle or displacement 0).
    pub placement: Se3,
    /// First index of this joint in `q`.
    pub idx_q: usize,
    /// First index of this joint in `v`.
    pub idx_v: usize,
}

impl Joint {
    /// Dimension of the joint's configuration.
    #[inline]
    pub fn nq(&self) -> usize {
        self.kind.nq()
    }
    /// Degrees of freedom.
    #[inline]
    pub fn nv(&self) -> usize {
        self.kind.nv()
    }
}

/// A named frame rigidly attached to a joint (every URDF link becomes one).
#[derive(Clone, Debug)]
pub struct Frame {
    /// Frame name (the URDF link name for link frames).
    pub name: String,
    /// Joint whose body the frame moves with.
    pub parent_joint: usize,
    /// Placement of the frame in the joint frame.
    pub placement: Se3,
    /// Inertia of the link this frame stands for, in the frame's own coordinates (zero for
    /// massless links and for frames that are not links).
    pub link_inertia: Inertia,
    /// Whether the frame is a URDF link (as opposed to an operational frame added later).
    pub is_link: bool,
}

/// A geometric primitive, in the frame of its [`Geometry`].
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Box with the given full side lengths (m).
    Box {
        /// Side lengths along x, y, z.
        size: Vector3<f64>,
    },
    /// Cylinder along the local z axis.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Full length (m).
        length: f64,
    },
    /// Capsule along the local z axis: a cylinder of `length` capped by two hemispheres.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Length of the cylindrical part (m).
        length: f64,
    },
    /// Sphere.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A mesh file; dynamics never reads it (resolution is the renderer's concern).
    Mesh {
        /// The filename as written in the URDF.
        filename: String,
        /// Scale factors.
        scale: Vector3<f64>,
    },
}

/// What a geometry is used for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeometryRole {
    /// A `<collision>` element.
    Collision,
    /// A `<visual>` element.
    Visual,
}

/// A collision or visual shape attached to a link.
#[derive(Clone, Debug)]
pub struct Geometry {
    /// Name (the URDF element's name, or `<link>_collision_<k>` / `<link>_visual_<k>`).
    pub name: String,
    /// Index of the link's frame in [`Model::frames`].
    pub frame: usize,
    /// Joint whose body the shape moves with.
    pub parent_joint: usize,
    /// Placement of the shape in the joint frame.
    pub placement: Se3,
    /// The primitive.
    pub shape: Shape,
    /// Collision or visual.
    pub role: GeometryRole,
    /// RGBA colour from the URDF material, if any.
    pub rgba: Option<[f64; 4]>,
}

/// A rigid-body tree: the description every algorithm reads and never changes.
///
/// Joints are stored in depth-first order (`parent < child`, and every subtree occupies a
/// contiguous range of joints and of `v`); index 0 is the world (`universe`). Each joint
/// moves one body, whose inertia (links merged across fixed joints) is `inertias[i]`,
/// expressed in the joint frame. See the crate documentation for the `q`/`v` conventions.
#[derive(Clone, Debug)]
pub struct Model {
    /// Robot name.
    pub name: String,
    /// Where the model came from (file path or a label), used in error messages.
    pub source: String,
    /// Joints, index 0 being the universe. After editing them, call [`Model::finalize`].
    pub joints: Vec<Joint>,
    /// Body inertias, one per joint, in the joint frame (index 0: what is welded to the world).
    pub inertias: Vec<Inertia>,
    /// Frames: every link, plus any frame added with [`Model::add_frame`].
    pub frames: Vec<Frame>,
    /// Collision and visual geometry.
    pub geometries: Vec<Geometry>,
    /// Gravity in the world frame (default `(0, 0, −9.81)` m/s²).
    pub gravity: Vector3<f64>,
    /// Configuration dimension.
    pub nq: usize,
    /// Velocity dimension (degrees of freedom).
    pub nv: usize,
    /// Lower position limit per `q` entry (`−∞` where unlimited).
    pub lower_position_limit: DVector<f64>,
    /// Upper position limit per `q` entry (`+∞` where unlimited).
    pub upper_position_limit: DVector<f64>,
    /// Velocity limit per `v` entry (`+∞` where none is given).
    pub velocity_limit: DVector<f64>,
    /// Effort limit per `v` entry (`+∞` where none is given).
    pub effort_limit: DVector<f64>,
    /// Viscous damping per `v` entry (N·m·s/rad or N·s/m), from `<dynamics damping>`.
    pub damping: DVector<f64>,
    /// Coulomb friction per `v` entry (N·m or N), from `<dynamics friction>`.
    pub friction: DVector<f64>,
    /// Rotor inertia reflected to each `v` entry (armature; 0 unless set by the user).
    pub armature: DVector<f64>,
    /// What the URDF loader repaired, ignored or dropped, and properties of the model a
    /// user should know about (a singular mass matrix); empty for a model built by hand.
    pub load_warnings: Vec<crate::urdf::error::UrdfWarning>,
    // Derived tree structure, filled by `finalize`.
    pub(crate) parent_v: Vec<Option<usize>>,
    pub(crate) nv_subtree_from_row: Vec<usize>,
    pub(crate) supports: Vec<Vec<usize>>,
    pub(crate) joint_of_v: Vec<usize>,
    /// Flattened ancestor lists: `dof_support(k)` = `dof_supports[starts[k]..starts[k + 1]]`.
    pub(crate) dof_supports: Vec<usize>,
    pub(crate) dof_support_starts: Vec<usize>,
    /// Per joint: the plane its revolute axis turns ([`AxisPlane`]).
    pub(crate) axis_planes: Vec<AxisPlane>,
}

impl Model {
    /// An empty model: just the universe.
    pub fn new(name: impl Into<String>) -> Self {
        let mut m = Model {
            name: name.into(),
            source: String::new(),
            joints: vec![Joint {
                name: "universe".into(),
                kind: JointKind::Universe,
                parent: 0,
                placement: Se3::identity(),
                idx_q: 0,
                idx_v: 0,
            }],
            inertias: vec![Inertia::zero()],
            frames: Vec::new(),
            geometries: Vec::new(),
            gravity: Vector3::new(0.0, 0.0, -9.81),
            nq: 0,
            nv: 0,
            lower_position_limit: DVector::zeros(0),
            upper_position_limit: DVector::zeros(0),
            velocity_limit: DVector::zeros(0),
            effort_limit: DVector::zeros(0),
            damping: DVector::zeros(0),
            friction: DVector::zeros(0),
            armature: DVector::zeros(0),
            load_warnings: Vec::new(),
            parent_v: Vec::new(),
            nv_subtree_from_row: Vec::new(),
            supports: vec![vec![0]],
            joint_of_v: Vec::new(),
            dof_supports: Vec::new(),
            dof_support_starts: vec![0],
            axis_planes: Vec::new(),
        };
        m.finalize();
        m
    }

    /// Number of joints including the universe.
    #[inline]
    pub fn njoints(&self) -> usize {
        self.joints.len()
    }

    /// Whether joint 1 is a free-flyer attached to the world (a floating-base robot).
    pub fn has_floating_base(&self) -> bool {
        self.joints.len() > 1 && self.joints[1].kind == JointKind::FreeFlyer && self.joints[1].parent == 0
    }

    /// Index of the joint with the given name.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Index of the frame with the given name.
    pub fn frame_index(&self, name: &str) -> Option<usize> {
        self.frames.iter().position(|f| f.name == name)
    }

    /// Joints on the path from the world to `joint`, root first, `joint` last (0 excluded).
    #[inline]
    pub fn support(&self, joint: usize) -> &[usize] {
        &self.supports[joint][1..]
    }

    /// The `v` index of the parent degree of freedom of `v` index `k` (the previous dof of
    /// the same joint, or the last dof of the parent joint), `None` at a root.
    #[inline]
    pub fn parent_dof(&self, k: usize) -> Option<usize> {
        self.parent_v[k]
    }

    /// Number of degrees of freedom in the subtree that starts at `v` index `k` (inclusive),
    /// which occupy the contiguous range `k..k + n`.
    #[inline]
    pub fn nv_subtree(&self, k: usize) -> usize {
        self.nv_subtree_from_row[k]
    }

    /// The degrees of freedom that support dof `k`: `k` itself, then its parent dof, and so
    /// on to the root (the rows `r` with `M[r, k]` possibly non-zero and `r ≤ k`).
    #[inline]
    pub fn dof_support(&self, k: usize) -> &[usize] {
        &self.dof_supports[self.dof_support_starts[k]..self.dof_support_starts[k + 1]]
    }

    /// The joint that owns `v` index `k`.
    #[inline]
    pub fn joint_of_dof(&self, k: usize) -> usize {
        self.joint_of_v[k]
    }

    /// Total mass moved by the joints (what is welded to the world is excluded).
    pub fn total_mass(&self) -> f64 {
        self.inertias[1..].iter().map(|i| i.mass).sum()
    }

    /// The neutral configuration: zero joint angles and positions (`(1, 0)` for
    /// [`JointKind::RevoluteUnbounded`]), identity base orientation.
    pub fn neutral_configuration(&self) -> DVector<f64> {
        let mut q = DVector::zeros(self.nq);
        for j in &self.joints[1..] {
            match j.kind {
                JointKind::FreeFlyer => q[j.idx_q + 6] = 1.0,
                JointKind::RevoluteUnbounded { .. } => q[j.idx_q] = 1.0,
                _ => {}
            }
        }
        q
    }

    /// Adds a frame rigidly attached to the frame `parent_frame`, at `placement` in it.
    /// Returns its index.
    #[track_caller]
    pub fn add_frame(&mut self, name: impl Into<String>, parent_frame: usize, placement: Se3) -> usize {
        assert!(
            parent_frame < self.frames.len(),
            "add_frame: parent frame {parent_frame} out of range (model has {} frames)",
            self.frames.len()
        );
        let parent = &self.frames[parent_frame];
        self.frames.push(Frame {
            name: name.into(),
            parent_joint: parent.parent_joint,
            placement: parent.placement.mul(&placement),
            link_inertia: Inertia::zero(),
            is_link: false,
        });
        self.frames.len() - 1
    }

    /// Recomputes every body inertia from the frames' link inertias (merging links across
    /// fixed joints). Call after editing [`Frame::link_inertia`].
    pub fn recompute_body_inertias(&mut self) {
        for y in &mut self.inertias {
            *y = Inertia::zero();
        }
        for f in &self.frames {
            if f.link_inertia.mass > 0.0 || f.link_inertia.rotational != Matrix3::zeros() {
                let y = f.placement.act_inertia(&f.link_inertia);
                self.inertias[f.parent_joint] = self.inertias[f.parent_joint].add(&y);
            }
        }
    }

    /// Appends a joint under `parent` and returns its index. Joints must be added in
    /// depth-first order (each subtree complete before the next sibling starts), which
    /// [`Model::finalize`] checks.
    #[track_caller]
    pub fn add_joint(
        &mut self,
        name: impl Into<String>,
        kind: JointKind,
        parent: usize,
        placement: Se3,
    ) -> usize {
        assert!(
            parent < self.joints.len(),
            "add_joint: parent {parent} out of range (model has {} joints)",
            self.joints.len()
        );
        let idx_q = self.nq;
        let idx_v = self.nv;
        self.joints.push(Joint { name: name.into(), kind, parent, placement, idx_q, idx_v });
        self.inertias.push(Inertia::zero());
        self.nq += kind.nq();
        self.nv += kind.nv();
        let grow = |v: &mut DVector<f64>, n: usize, value: f64| {
            let old = v.len();
            *v = v.clone().resize_vertically(n, value);
            debug_assert!(v.len() >= old);
        };
        let (nq, nv) = (self.nq, self.nv);
        grow(&mut self.lower_position_limit, nq, f64::NEG_INFINITY);
        grow(&mut self.upper_position_limit, nq, f64::INFINITY);
        grow(&mut self.velocity_limit, nv, f64::INFINITY);
        grow(&mut self.effort_limit, nv, f64::INFINITY);
        grow(&mut self.damping, nv, 0.0);
        grow(&mut self.friction, nv, 0.0);
        grow(&mut self.armature, nv, 0.0);
        self.finalize();
        self.joints.len() - 1
    }

    /// Recomputes the derived tree structure (supports, dof parents, subtree sizes) and the
    /// per-joint axis planes the transforms use. Call it after editing `joints` (their
    /// parents, kinds or axes); inertias, placements and limits need no call. A kind may
    /// only be replaced by one with the same `nq` and `nv` (the `q`/`v` layout is fixed
    /// when joints are added).
    ///
    /// # Panics
    /// If the joints are not in depth-first order, or their `idx_q`/`idx_v` no longer
    /// follow from their kinds (programming errors of the caller).
    #[track_caller]
    pub fn finalize(&mut self) {
        let n = self.joints.len();
        let (mut nq, mut nv) = (0, 0);
        for j in &self.joints {
            assert!(
                j.idx_q == nq && j.idx_v == nv,
                "joint '{}' starts at q[{}]/v[{}] but the kinds before it end at q[{nq}]/v[{nv}]: \
                 a kind was replaced by one of another size",
                j.name,
                j.idx_q,
                j.idx_v
            );
            nq += j.nq();
            nv += j.nv();
        }
        assert!(
            nq == self.nq && nv == self.nv,
            "the joints' kinds no longer add up to nq {}, nv {}",
            self.nq,
            self.nv
        );
        self.supports = Vec::with_capacity(n);
        self.supports.push(vec![0]);
        for i in 1..n {
            let p = self.joints[i].parent;
            assert!(p < i, "joint {i} has parent {p}: parents must come first");
            let mut s = self.supports[p].clone();
            s.push(i);
            self.supports.push(s);
        }
        // Depth-first order: the subtree of each joint is the contiguous range that follows it.
        let mut subtree_end = vec![0usize; n];
        for i in (1..n).rev() {
            subtree_end[i] = subtree_end[i].max(i + 1);
            let p = self.joints[i].parent;
            subtree_end[p] = subtree_end[p].max(subtree_end[i]);
        }
        for i in 1..n {
            for k in (i + 1)..subtree_end[i] {
                assert!(
                    self.supports[k].contains(&i),
                    "joints are not in depth-first order: joint {k} ('{}') lies inside the \
                     subtree range of joint {i} ('{}') but is not its descendant",
                    self.joints[k].name,
                    self.joints[i].name
                );
            }
        }
        self.axis_planes = self.joints.iter().map(|j| AxisPlane::of(&j.kind)).collect();
        self.parent_v = vec![None; self.nv];
        self.nv_subtree_from_row = vec![0; self.nv];
        self.joint_of_v = vec![0; self.nv];
        for i in 1..n {
            let j = &self.joints[i];
            let nvj = j.nv();
            let end_v = if subtree_end[i] < n { self.joints[subtree_end[i]].idx_v } else { self.nv };
            for k in 0..nvj {
                let row = j.idx_v + k;
                self.joint_of_v[row] = i;
                self.nv_subtree_from_row[row] = end_v - row;
                self.parent_v[row] = if k > 0 {
                    Some(row - 1)
                } else {
                    // Last dof of the nearest ancestor that has dofs.
                    let mut p = j.parent;
                    loop {
                        if p == 0 {
                            break None;
                        }
                        let pj = &self.joints[p];
                        if pj.nv() > 0 {
                            break Some(pj.idx_v + pj.nv() - 1);
                        }
                        p = pj.parent;
                    }
                };
            }
        }
        self.dof_supports.clear();
        self.dof_support_starts = Vec::with_capacity(self.nv + 1);
        self.dof_support_starts.push(0);
        for k in 0..self.nv {
            let mut r = Some(k);
            while let Some(row) = r {
                self.dof_supports.push(row);
                r = self.parent_v[row];
            }
            self.dof_support_starts.push(self.dof_supports.len());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_planes_follow_the_joints_after_finalize() {
        let mut m = Model::new("planes");
        let z = m.add_joint("z", JointKind::Revolute { axis: -Vector3::z() }, 0, Se3::identity());
        let g =
            m.add_joint("g", JointKind::Revolute { axis: Vector3::new(0.6, 0.8, 0.0) }, z, Se3::identity());
        m.add_joint("p", JointKind::Prismatic { axis: Vector3::x() }, g, Se3::identity());
        assert_eq!(m.axis_planes[1..], [AxisPlane::Z(-1.0), AxisPlane::General, AxisPlane::General]);
        // An edited axis takes effect through `finalize`, as the docs say.
        m.joints[2].kind = JointKind::Revolute { axis: Vector3::y() };
        m.finalize();
        assert_eq!(m.axis_planes[2], AxisPlane::Y(1.0));
    }

    #[test]
    #[should_panic(expected = "a kind was replaced by one of another size")]
    fn finalize_refuses_a_kind_of_another_size() {
        let mut m = Model::new("sizes");
        let a = m.add_joint("a", JointKind::Revolute { axis: Vector3::z() }, 0, Se3::identity());
        m.add_joint("b", JointKind::Revolute { axis: Vector3::x() }, a, Se3::identity());
        // Two q entries instead of one: joint b's idx_q is now wrong.
        m.joints[a].kind = JointKind::RevoluteUnbounded { axis: Vector3::z() };
        m.finalize();
    }

    #[test]
    fn rotate_about_axis_matches_the_full_product() {
        let r = axis_rotation(&Vector3::new(0.3, -0.5, 0.8).normalize(), 0.9);
        let axes = [
            Vector3::x(),
            -Vector3::x(),
            Vector3::y(),
            -Vector3::y(),
            Vector3::z(),
            -Vector3::z(),
            Vector3::new(1.0, 2.0, -2.0) / 3.0,
        ];
        for axis in axes {
            for angle in [-2.5f64, -0.3, 0.0, 0.7, 3.0] {
                let plane = AxisPlane::of(&JointKind::Revolute { axis });
                let fast = rotate_about_axis(&r, &axis, plane, angle.sin_cos());
                let full = r * axis_rotation(&axis, angle);
                assert!((fast - full).abs().max() < 1e-15, "axis {axis:?}, angle {angle}");
            }
        }
    }
}
