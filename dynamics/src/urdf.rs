//! URDF → [`Model`], with a validation pass of our own.
//!
//! urdf-rs parses the XML structure but accepts files that are not robots (a missing parent
//! link, duplicate names, cycles, non-URDF XML); every check below is ours, and every error
//! names the file and the element at fault.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

use crate::model::{Frame, Geometry, GeometryRole, JointKind, Model, Shape};
use crate::spatial::{Inertia, Se3};

/// How the root link is attached to the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaseKind {
    /// The root link is welded to the world (arms, and planar robots whose URDF already
    /// contains their root joints).
    Fixed,
    /// A 6-dof free-flyer joint (`root_joint`) connects the world to the root link.
    Floating,
}

/// A URDF file that cannot become a [`Model`]: each variant names the file (`file`), the
/// element at fault and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum UrdfError {
    /// The file could not be read.
    #[error("{file}: cannot read the file: {source}")]
    Io {
        /// File path.
        file: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The text is not well-formed XML, or urdf-rs rejected its structure.
    #[error("{file}: not a readable URDF: {message}")]
    Parse {
        /// File path or label.
        file: String,
        /// What the parser said.
        message: String,
    },
    /// Well-formed XML whose root element is not `<robot>`.
    #[error("{file}: not a URDF: the root element is <{root}>, expected <robot>")]
    NotUrdf {
        /// File path or label.
        file: String,
        /// The root element found.
        root: String,
    },
    /// No `<link>` at all.
    #[error("{file}: the robot has no links")]
    NoLinks {
        /// File path or label.
        file: String,
    },
    /// Two links share a name.
    #[error("{file}: duplicate link name '{link}'")]
    DuplicateLink {
        /// File path or label.
        file: String,
        /// The repeated name.
        link: String,
    },
    /// Two joints share a name.
    #[error("{file}: duplicate joint name '{joint}'")]
    DuplicateJoint {
        /// File path or label.
        file: String,
        /// The repeated name.
        joint: String,
    },
    /// A joint refers to a link that does not exist.
    #[error("{file}: joint '{joint}': its {role} link '{link}' does not exist")]
    MissingLink {
        /// File path or label.
        file: String,
        /// The joint.
        joint: String,
        /// `"parent"` or `"child"`.
        role: &'static str,
        /// The missing link name.
        link: String,
    },
    /// A link is the child of two joints.
    #[error("{file}: link '{link}' is the child of two joints, '{first}' and '{second}'")]
    SeveralParents {
        /// File path or label.
        file: String,
        /// The link.
        link: String,
        /// First joint.
        first: String,
        /// Second joint.
        second: String,
    },
    /// More than one link is nobody's child.
    #[error("{file}: several root links (links that are no joint's child): {roots:?}")]
    SeveralRoots {
        /// File path or label.
        file: String,
        /// The root links.
        roots: Vec<String>,
    },
    /// The joints form a cycle.
    #[error("{file}: the joints form a cycle through links {links:?}")]
    Cycle {
        /// File path or label.
        file: String,
        /// Links on the cycle.
        links: Vec<String>,
    },
    /// A link's mass is negative, or zero while its rotational inertia is not.
    #[error("{file}: link '{link}': <mass value=\"{mass}\"> is not positive")]
    NonPositiveMass {
        /// File path or label.
        file: String,
        /// The link.
        link: String,
        /// The mass read.
        mass: f64,
    },
    /// A rotational inertia that no rigid body can have.
    #[error("{file}: link '{link}': non-physical <inertia>: {reason}")]
    NonPhysicalInertia {
        /// File path or label.
        file: String,
        /// The link.
        link: String,
        /// Which condition fails, with the numbers.
        reason: String,
    },
    /// A revolute or prismatic joint without `<limit>` (required by the URDF spec).
    #[error("{file}: joint '{joint}': a {kind} joint needs a <limit> element")]
    MissingLimit {
        /// File path or label.
        file: String,
        /// The joint.
        joint: String,
        /// `"revolute"` or `"prismatic"`.
        kind: &'static str,
    },
    /// A joint's lower position limit is above its upper limit.
    #[error("{file}: joint '{joint}': lower limit {lower} is above upper limit {upper}")]
    InvertedLimits {
        /// File path or label.
        file: String,
        /// The joint.
        joint: String,
        /// Lower limit.
        lower: f64,
        /// Upper limit.
        upper: f64,
    },
    /// A NaN or infinite number where a finite one is required.
    #[error("{file}: {element}: {field} is {value}, expected a finite number")]
    NonFinite {
        /// File path or label.
        file: String,
        /// The element, e.g. `link 'foot' <inertial>`.
        element: String,
        /// The attribute.
        field: String,
        /// The value read.
        value: f64,
    },
    /// A negative number where only non-negative ones make sense.
    #[error("{file}: {element}: {field} is {value}, expected a non-negative number")]
    Negative {
        /// File path or label.
        file: String,
        /// The element.
        element: String,
        /// The attribute.
        field: String,
        /// The value read.
        value: f64,
    },
    /// A joint axis of zero length.
    #[error("{file}: joint '{joint}': <axis xyz> has zero length")]
    ZeroAxis {
        /// File path or label.
        file: String,
        /// The joint.
        joint: String,
    },
    /// A joint type Centaur does not support.
    #[error(
        "{file}: joint '{joint}': unsupported joint type '{kind}' (supported: revolute, continuous, prismatic, fixed)"
    )]
    UnsupportedJoint {
        /// File path or label.
        file: String,
        /// The joint.
        joint: String,
        /// The type found.
        kind: String,
    },
    /// A geometry with a non-positive size.
    #[error("{file}: link '{link}': {what} has a non-positive size")]
    BadGeometry {
        /// File path or label.
        file: String,
        /// The link.
        link: String,
        /// Which geometry.
        what: String,
    },
}

/// Choices the URDF loader leaves to the caller; the default is what
/// [`Model::from_urdf_file`] and [`Model::from_urdf_str`] use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UrdfOptions {
    /// Load `continuous` joints as [`JointKind::RevoluteUnbounded`] (`q = (cos θ, sin θ)`,
    /// two entries per joint, as Pinocchio loads them) instead of as
    /// [`JointKind::Revolute`] with an unlimited angle (one entry, the default, and what
    /// the simulator and the controller expect).
    pub continuous_as_cos_sin: bool,
}

impl Model {
    /// Loads a URDF file. See [`Model::from_urdf_str`] for what is read.
    pub fn from_urdf_file(path: impl AsRef<Path>, base: BaseKind) -> Result<Model, UrdfError> {
        Model::from_urdf_file_with(path, base, UrdfOptions::default())
    }

    /// [`Model::from_urdf_file`] with loader options.
    pub fn from_urdf_file_with(
        path: impl AsRef<Path>,
        base: BaseKind,
        options: UrdfOptions,
    ) -> Result<Model, UrdfError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| UrdfError::Io { file: file.clone(), source })?;
        let text = String::from_utf8(bytes)
            .map_err(|e| UrdfError::Parse { file: file.clone(), message: format!("not UTF-8 text ({e})") })?;
        Model::from_urdf_str_with(&text, &file, base, options)
    }

    /// Builds a model from URDF text; `source` names it in errors (a path or a label).
    ///
    /// Reads links (inertials, visual and collision geometry), and revolute, continuous,
    /// prismatic and fixed joints with their origin, axis, `<limit>` (position, effort,
    /// velocity) and `<dynamics>` (damping, friction). Links behind fixed joints are merged
    /// into their moving parent's body but keep their frames. Ignored: `<mimic>`,
    /// `<calibration>`, `<safety_controller>`, `<transmission>`, `<gazebo>` and mesh contents.
    /// A revolute joint whose `<limit>` gives neither `lower` nor `upper` (both read as 0) is
    /// treated as position-unlimited, as PyBullet does.
    pub fn from_urdf_str(text: &str, source: &str, base: BaseKind) -> Result<Model, UrdfError> {
        Model::from_urdf_str_with(text, source, base, UrdfOptions::default())
    }

    /// [`Model::from_urdf_str`] with loader options.
    pub fn from_urdf_str_with(
        text: &str,
        source: &str,
        base: BaseKind,
        options: UrdfOptions,
    ) -> Result<Model, UrdfError> {
        let file = source.to_string();
        let scan = prescan(text, &file)?;
        let robot = urdf_rs::read_from_string(text)
            .map_err(|e| UrdfError::Parse { file: file.clone(), message: e.to_string() })?;
        build(&robot, &scan, &file, base, options)
    }
}

/// What the XML pre-scan learns that urdf-rs's structs cannot tell.
struct Prescan {
    /// Joints (by name) that have a `<limit>` child.
    joints_with_limit: Vec<String>,
}

fn prescan(text: &str, file: &str) -> Result<Prescan, UrdfError> {
    let root: xml::Element =
        text.parse().map_err(|e| UrdfError::Parse { file: file.to_string(), message: format!("{e:?}") })?;
    if root.name != "robot" {
        return Err(UrdfError::NotUrdf { file: file.to_string(), root: root.name.clone() });
    }
    let mut joints_with_limit = Vec::new();
    for joint in root.get_children("joint", None) {
        if joint.get_child("limit", None).is_some() {
            joints_with_limit.push(joint.get_attribute("name", None).unwrap_or("").to_string());
        }
    }
    Ok(Prescan { joints_with_limit })
}

fn check_finite(file: &str, element: &str, field: &str, values: &[f64]) -> Result<(), UrdfError> {
    for &value in values {
        if !value.is_finite() {
            return Err(UrdfError::NonFinite {
                file: file.to_string(),
                element: element.to_string(),
                field: field.to_string(),
                value,
            });
        }
    }
    Ok(())
}

fn pose_to_se3(file: &str, element: &str, pose: &urdf_rs::Pose) -> Result<Se3, UrdfError> {
    check_finite(file, element, "origin xyz", &pose.xyz.0)?;
    check_finite(file, element, "origin rpy", &pose.rpy.0)?;
    Ok(Se3::from_xyz_rpy(pose.xyz.0, pose.rpy.0))
}

/// Checks a link's inertial and converts it to an [`Inertia`] in the link frame.
fn link_inertia(file: &str, link: &urdf_rs::Link) -> Result<Inertia, UrdfError> {
    let element = format!("link '{}' <inertial>", link.name);
    let inertial = &link.inertial;
    let mass = inertial.mass.value;
    let i = &inertial.inertia;
    check_finite(file, &element, "mass", &[mass])?;
    check_finite(file, &element, "inertia", &[i.ixx, i.ixy, i.ixz, i.iyy, i.iyz, i.izz])?;
    let origin = pose_to_se3(file, &element, &inertial.origin)?;
    let inertia = Matrix3::new(i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz);
    let scale = inertia.abs().max();
    if mass < 0.0 || (mass == 0.0 && scale > 0.0) {
        return Err(UrdfError::NonPositiveMass { file: file.into(), link: link.name.clone(), mass });
    }
    if scale > 0.0 {
        let eig = SymmetricEigen::new(inertia).eigenvalues;
        let mut p = [eig[0], eig[1], eig[2]];
        p.sort_by(|a, b| a.total_cmp(b));
        // A rigid body has principal moments λ₁ ≤ λ₂ ≤ λ₃ with λ₁ ≥ 0 and λ₁ + λ₂ ≥ λ₃.
        let tol = 1e-9 * (p[0].abs() + p[1].abs() + p[2].abs()) + 1e-15;
        if p[0] < -tol {
            return Err(UrdfError::NonPhysicalInertia {
                file: file.into(),
                link: link.name.clone(),
                reason: format!("principal moment {:.6e} is negative (moments {:?})", p[0], p),
            });
        }
        if p[0] + p[1] < p[2] - tol {
            return Err(UrdfError::NonPhysicalInertia {
                file: file.into(),
                link: link.name.clone(),
                reason: format!("principal moments {:?} violate the triangle inequality (λ₁ + λ₂ < λ₃)", p),
            });
        }
    }
    // <inertial><origin> places the centre of mass and the inertia axes in the link frame.
    let rot = origin.rotation * inertia * origin.rotation.transpose();
    Ok(Inertia::new(mass, origin.translation, rot))
}

fn convert_shape(file: &str, link: &str, what: &str, g: &urdf_rs::Geometry) -> Result<Shape, UrdfError> {
    let element = format!("link '{link}' {what}");
    let bad = || UrdfError::BadGeometry { file: file.into(), link: link.into(), what: what.into() };
    let shape = match g {
        urdf_rs::Geometry::Box { size } => {
            check_finite(file, &element, "box size", &size.0)?;
            if size.0.iter().any(|&s| s <= 0.0) {
                return Err(bad());
            }
            Shape::Box { size: Vector3::from(size.0) }
        }
        urdf_rs::Geometry::Cylinder { radius, length } => {
            check_finite(file, &element, "cylinder size", &[*radius, *length])?;
            if *radius <= 0.0 || *length <= 0.0 {
                return Err(bad());
            }
            Shape::Cylinder { radius: *radius, length: *length }
        }
        urdf_rs::Geometry::Capsule { radius, length } => {
            check_finite(file, &element, "capsule size", &[*radius, *length])?;
            if *radius <= 0.0 || *length < 0.0 {
                return Err(bad());
            }
            Shape::Capsule { radius: *radius, length: *length }
        }
        urdf_rs::Geometry::Sphere { radius } => {
            check_finite(file, &element, "sphere radius", &[*radius])?;
            if *radius <= 0.0 {
                return Err(bad());
            }
            Shape::Sphere { radius: *radius }
        }
        urdf_rs::Geometry::Mesh { filename, scale } => {
            let scale = scale.map(|s| s.0).unwrap_or([1.0; 3]);
            check_finite(file, &element, "mesh scale", &scale)?;
            Shape::Mesh { filename: filename.clone(), scale: Vector3::from(scale) }
        }
    };
    Ok(shape)
}

fn build(
    robot: &urdf_rs::Robot,
    scan: &Prescan,
    file: &str,
    base: BaseKind,
    options: UrdfOptions,
) -> Result<Model, UrdfError> {
    if robot.links.is_empty() {
        return Err(UrdfError::NoLinks { file: file.into() });
    }
    let mut link_index: HashMap<&str, usize> = HashMap::new();
    for (k, link) in robot.links.iter().enumerate() {
        if link_index.insert(link.name.as_str(), k).is_some() {
            return Err(UrdfError::DuplicateLink { file: file.into(), link: link.name.clone() });
        }
    }
    let mut joint_names: HashMap<&str, usize> = HashMap::new();
    // parent_joint[link] = index of the joint whose child it is.
    let mut parent_joint: Vec<Option<usize>> = vec![None; robot.links.len()];
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); robot.links.len()];
    for (k, joint) in robot.joints.iter().enumerate() {
        if joint_names.insert(joint.name.as_str(), k).is_some() {
            return Err(UrdfError::DuplicateJoint { file: file.into(), joint: joint.name.clone() });
        }
        let Some(&p) = link_index.get(joint.parent.link.as_str()) else {
            return Err(UrdfError::MissingLink {
                file: file.into(),
                joint: joint.name.clone(),
                role: "parent",
                link: joint.parent.link.clone(),
            });
        };
        let Some(&c) = link_index.get(joint.child.link.as_str()) else {
            return Err(UrdfError::MissingLink {
                file: file.into(),
                joint: joint.name.clone(),
                role: "child",
                link: joint.child.link.clone(),
            });
        };
        if let Some(first) = parent_joint[c] {
            return Err(UrdfError::SeveralParents {
                file: file.into(),
                link: joint.child.link.clone(),
                first: robot.joints[first].name.clone(),
                second: joint.name.clone(),
            });
        }
        parent_joint[c] = Some(k);
        children[p].push(k);
    }
    let roots: Vec<usize> = (0..robot.links.len()).filter(|&l| parent_joint[l].is_none()).collect();
    if roots.is_empty() {
        // Every link has a parent: the joints must contain a cycle.
        let links = find_cycle(robot, &link_index, &parent_joint);
        return Err(UrdfError::Cycle { file: file.into(), links });
    }
    if roots.len() > 1 {
        // Links on a cycle are unreachable from the true root: report the cycle if there is one.
        let reachable = reachable_from(roots[0], robot, &link_index, &children);
        let unreachable_has_cycle = (0..robot.links.len()).any(|l| {
            !reachable[l] && parent_joint[l].is_some() && on_cycle(l, robot, &link_index, &parent_joint)
        });
        if unreachable_has_cycle {
            let links = find_cycle(robot, &link_index, &parent_joint);
            return Err(UrdfError::Cycle { file: file.into(), links });
        }
        return Err(UrdfError::SeveralRoots {
            file: file.into(),
            roots: roots.iter().map(|&l| robot.links[l].name.clone()).collect(),
        });
    }
    let root = roots[0];
    let reachable = reachable_from(root, robot, &link_index, &children);
    if let Some(l) = (0..robot.links.len()).find(|&l| !reachable[l]) {
        let _ = l;
        let links = find_cycle(robot, &link_index, &parent_joint);
        return Err(UrdfError::Cycle { file: file.into(), links });
    }

    // Per-joint checks before building.
    let mut link_inertias = Vec::with_capacity(robot.links.len());
    for link in &robot.links {
        link_inertias.push(link_inertia(file, link)?);
    }

    let mut model = Model::new(robot.name.clone());
    model.source = file.to_string();

    // Root link.
    let root_joint = match base {
        BaseKind::Fixed => 0,
        BaseKind::Floating => model.add_joint("root_joint", JointKind::FreeFlyer, 0, Se3::identity()),
    };
    // Depth-first traversal: (link, joint it hangs from, placement of the link in that joint).
    let mut link_frame = vec![usize::MAX; robot.links.len()];
    add_link_frame(
        &mut model,
        robot,
        root,
        root_joint,
        Se3::identity(),
        &link_inertias,
        file,
        &mut link_frame,
    )?;
    let mut stack: Vec<usize> = children[root].iter().rev().copied().collect();
    while let Some(k) = stack.pop() {
        let joint = &robot.joints[k];
        let parent_link = link_index[joint.parent.link.as_str()];
        let child_link = link_index[joint.child.link.as_str()];
        let pf = &model.frames[link_frame[parent_link]];
        let (parent_jnt, parent_place) = (pf.parent_joint, pf.placement);
        let element = format!("joint '{}'", joint.name);
        let origin = pose_to_se3(file, &element, &joint.origin)?;
        let placement = parent_place.mul(&origin);
        let (attach_joint, link_place) = match joint.joint_type {
            urdf_rs::JointType::Fixed => (parent_jnt, placement),
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous | urdf_rs::JointType::Prismatic => {
                let axis = Vector3::from(joint.axis.xyz.0);
                check_finite(file, &element, "axis xyz", &joint.axis.xyz.0)?;
                let norm = axis.norm();
                if norm < 1e-12 {
                    return Err(UrdfError::ZeroAxis { file: file.into(), joint: joint.name.clone() });
                }
                let axis = axis / norm;
                let (kind, kind_name) = match joint.joint_type {
                    urdf_rs::JointType::Prismatic => (JointKind::Prismatic { axis }, "prismatic"),
                    urdf_rs::JointType::Continuous if options.continuous_as_cos_sin => {
                        (JointKind::RevoluteUnbounded { axis }, "continuous")
                    }
                    urdf_rs::JointType::Continuous => (JointKind::Revolute { axis }, "continuous"),
                    _ => (JointKind::Revolute { axis }, "revolute"),
                };
                let limited = kind_name != "continuous";
                if limited && !scan.joints_with_limit.iter().any(|n| n == &joint.name) {
                    return Err(UrdfError::MissingLimit {
                        file: file.into(),
                        joint: joint.name.clone(),
                        kind: if kind_name == "prismatic" { "prismatic" } else { "revolute" },
                    });
                }
                let j = model.add_joint(joint.name.clone(), kind, parent_jnt, placement);
                let iv = model.joints[j].idx_v;
                let iq = model.joints[j].idx_q;
                let lim = &joint.limit;
                let has_limit = scan.joints_with_limit.iter().any(|n| n == &joint.name);
                if has_limit {
                    for (field, v) in [("limit effort", lim.effort), ("limit velocity", lim.velocity)] {
                        if v.is_nan() {
                            check_finite(file, &element, field, &[v])?;
                        }
                        if v < 0.0 {
                            return Err(UrdfError::Negative {
                                file: file.into(),
                                element: element.clone(),
                                field: field.into(),
                                value: v,
                            });
                        }
                    }
                    if lim.lower.is_nan() || lim.upper.is_nan() {
                        check_finite(file, &element, "limit lower/upper", &[lim.lower, lim.upper])?;
                    }
                    if limited {
                        if lim.lower > lim.upper {
                            return Err(UrdfError::InvertedLimits {
                                file: file.into(),
                                joint: joint.name.clone(),
                                lower: lim.lower,
                                upper: lim.upper,
                            });
                        }
                        if lim.lower < lim.upper {
                            model.lower_position_limit[iq] = lim.lower;
                            model.upper_position_limit[iq] = lim.upper;
                        }
                    }
                    // URDF 1.0 writes 0 for "not given"; an effort or velocity limit of 0 would
                    // freeze the joint, so 0 means "none".
                    if lim.effort > 0.0 {
                        model.effort_limit[iv] = lim.effort;
                    }
                    if lim.velocity > 0.0 {
                        model.velocity_limit[iv] = lim.velocity;
                    }
                }
                if let Some(d) = &joint.dynamics {
                    check_finite(file, &element, "dynamics damping/friction", &[d.damping, d.friction])?;
                    for (field, v) in [("dynamics damping", d.damping), ("dynamics friction", d.friction)] {
                        if v < 0.0 {
                            return Err(UrdfError::Negative {
                                file: file.into(),
                                element: element.clone(),
                                field: field.into(),
                                value: v,
                            });
                        }
                    }
                    model.damping[iv] = d.damping;
                    model.friction[iv] = d.friction;
                }
                (j, Se3::identity())
            }
            ref other => {
                return Err(UrdfError::UnsupportedJoint {
                    file: file.into(),
                    joint: joint.name.clone(),
                    kind: format!("{other:?}").to_lowercase(),
                });
            }
        };
        add_link_frame(
            &mut model,
            robot,
            child_link,
            attach_joint,
            link_place,
            &link_inertias,
            file,
            &mut link_frame,
        )?;
        for &c in children[child_link].iter().rev() {
            stack.push(c);
        }
    }
    model.recompute_body_inertias();
    model.finalize();
    Ok(model)
}

fn add_link_frame(
    model: &mut Model,
    robot: &urdf_rs::Robot,
    link: usize,
    joint: usize,
    placement: Se3,
    link_inertias: &[Inertia],
    file: &str,
    link_frame: &mut [usize],
) -> Result<(), UrdfError> {
    let l = &robot.links[link];
    model.frames.push(Frame {
        name: l.name.clone(),
        parent_joint: joint,
        placement,
        link_inertia: link_inertias[link],
        is_link: true,
    });
    let frame = model.frames.len() - 1;
    link_frame[link] = frame;
    for (k, c) in l.collision.iter().enumerate() {
        let what = format!("<collision> {k}");
        let origin = pose_to_se3(file, &format!("link '{}' {what}", l.name), &c.origin)?;
        model.geometries.push(Geometry {
            name: c.name.clone().unwrap_or_else(|| format!("{}_collision_{k}", l.name)),
            frame,
            parent_joint: joint,
            placement: placement.mul(&origin),
            shape: convert_shape(file, &l.name, &what, &c.geometry)?,
            role: GeometryRole::Collision,
            rgba: None,
        });
    }
    for (k, v) in l.visual.iter().enumerate() {
        let what = format!("<visual> {k}");
        let origin = pose_to_se3(file, &format!("link '{}' {what}", l.name), &v.origin)?;
        let rgba = v.material.as_ref().and_then(|m| {
            m.color.as_ref().map(|c| c.rgba.0).or_else(|| {
                robot
                    .materials
                    .iter()
                    .find(|g| g.name == m.name)
                    .and_then(|g| g.color.as_ref().map(|c| c.rgba.0))
            })
        });
        let rgba = rgba.filter(|c| c.iter().all(|x| x.is_finite()));
        model.geometries.push(Geometry {
            name: v.name.clone().unwrap_or_else(|| format!("{}_visual_{k}", l.name)),
            frame,
            parent_joint: joint,
            placement: placement.mul(&origin),
            shape: convert_shape(file, &l.name, &what, &v.geometry)?,
            role: GeometryRole::Visual,
            rgba,
        });
    }
    Ok(())
}

fn reachable_from(
    root: usize,
    robot: &urdf_rs::Robot,
    link_index: &HashMap<&str, usize>,
    children: &[Vec<usize>],
) -> Vec<bool> {
    let mut seen = vec![false; robot.links.len()];
    let mut stack = vec![root];
    seen[root] = true;
    while let Some(l) = stack.pop() {
        for &j in &children[l] {
            let c = link_index[robot.joints[j].child.link.as_str()];
            if !seen[c] {
                seen[c] = true;
                stack.push(c);
            }
        }
    }
    seen
}

fn parent_link_of(
    l: usize,
    robot: &urdf_rs::Robot,
    link_index: &HashMap<&str, usize>,
    parent_joint: &[Option<usize>],
) -> Option<usize> {
    parent_joint[l].map(|j| link_index[robot.joints[j].parent.link.as_str()])
}

fn on_cycle(
    start: usize,
    robot: &urdf_rs::Robot,
    link_index: &HashMap<&str, usize>,
    parent_joint: &[Option<usize>],
) -> bool {
    let mut l = start;
    for _ in 0..robot.links.len() {
        match parent_link_of(l, robot, link_index, parent_joint) {
            Some(p) if p == start => return true,
            Some(p) => l = p,
            None => return false,
        }
    }
    false
}

/// Follows parent links from a link with a parent until a link repeats; returns that loop.
fn find_cycle(
    robot: &urdf_rs::Robot,
    link_index: &HashMap<&str, usize>,
    parent_joint: &[Option<usize>],
) -> Vec<String> {
    for start in 0..robot.links.len() {
        if on_cycle(start, robot, link_index, parent_joint) {
            let mut links = vec![robot.links[start].name.clone()];
            let mut l = start;
            while let Some(p) = parent_link_of(l, robot, link_index, parent_joint) {
                if p == start {
                    break;
                }
                links.push(robot.links[p].name.clone());
                l = p;
            }
            return links;
        }
    }
    Vec::new()
}
