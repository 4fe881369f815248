//! Building the [`Model`]: the tree's structure checks, joints and frames in depth-first
//! order, the inertia policy on the merged bodies, and the mass matrix's pivots.

use std::collections::HashMap;

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

use super::document::Document;
use super::error::{UrdfError, UrdfWarning};
use super::inertia;
use super::options::{BaseKind, UrdfOptions};
use crate::data::Data;
use crate::model::{Frame, Geometry, GeometryRole, JointKind, Model, Shape};
use crate::spatial::{Inertia, Se3};

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

/// A link's `<inertial>`, read and checked for non-finite numbers and a negative mass (errors
/// in every mode): `(mass, inertia about the centre of mass in the inertial frame, the
/// inertial frame in the link frame)`.
fn read_inertial(file: &str, link: &urdf_rs::Link) -> Result<(f64, Matrix3<f64>, Se3), UrdfError> {
    let element = format!("link '{}' <inertial>", link.name);
    let inertial = &link.inertial;
    let mass = inertial.mass.value;
    let i = &inertial.inertia;
    check_finite(file, &element, "mass", &[mass])?;
    check_finite(file, &element, "inertia", &[i.ixx, i.ixy, i.ixz, i.iyy, i.iyz, i.izz])?;
    let origin = pose_to_se3(file, &element, &inertial.origin)?;
    if mass < 0.0 {
        return Err(UrdfError::NonPositiveMass { file: file.into(), link: link.name.clone(), mass });
    }
    Ok((mass, Matrix3::new(i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz), origin))
}

/// The inertia of the link in its own frame: `<inertial><origin>` places the centre of mass
/// and the inertia axes in the link frame.
fn in_link_frame(mass: f64, inertia: &Matrix3<f64>, origin: &Se3) -> Inertia {
    let rot = origin.rotation * inertia * origin.rotation.transpose();
    Inertia::new(mass, origin.translation, rot)
}

/// The per-link check of [`UrdfOptions::strict`] (the loader's behaviour before the policy).
fn link_inertia_strict(file: &str, link: &urdf_rs::Link) -> Result<Inertia, UrdfError> {
    let (mass, inertia, origin) = read_inertial(file, link)?;
    let scale = inertia.abs().max();
    if mass == 0.0 && scale > 0.0 {
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
    Ok(in_link_frame(mass, &inertia, &origin))
}

/// A link's inertia in its frame, refusing only what is undefined (non-finite numbers, a
/// negative mass); physicality is judged on the merged bodies ([`check_bodies`]).
fn link_inertia(
    file: &str,
    link: &urdf_rs::Link,
    warnings: &mut Vec<UrdfWarning>,
) -> Result<Inertia, UrdfError> {
    let (mass, inertia, origin) = read_inertial(file, link)?;
    if mass == 0.0 && inertia.abs().max() > 0.0 {
        warnings.push(UrdfWarning::ZeroMassWithInertia { link: link.name.clone() });
    }
    Ok(in_link_frame(mass, &inertia, &origin))
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

pub(super) fn build(
    robot: &urdf_rs::Robot,
    scan: &Document,
    file: &str,
    base: BaseKind,
    options: UrdfOptions,
    mut warnings: Vec<UrdfWarning>,
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
        link_inertias.push(if options.strict {
            link_inertia_strict(file, link)?
        } else {
            link_inertia(file, link, &mut warnings)?
        });
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
    let mut shapes = ShapePolicy { strict: options.strict, warnings: &mut warnings };
    add_link_frame(
        &mut model,
        robot,
        root,
        root_joint,
        Se3::identity(),
        &link_inertias,
        file,
        &mut link_frame,
        &mut shapes,
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
                if limited && !scan.has_limit(&joint.name) {
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
                let has_limit = scan.has_limit(&joint.name);
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
            &mut shapes,
        )?;
        for &c in children[child_link].iter().rev() {
            stack.push(c);
        }
    }
    model.recompute_body_inertias();
    model.finalize();
    if !options.strict {
        check_bodies(&model, file, options, &link_inertias, &link_frame, &mut warnings)?;
    }
    warnings.extend(singular_pivots(&model));
    model.load_warnings = warnings;
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
    shapes: &mut ShapePolicy<'_>,
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
    let mut push = |role: GeometryRole,
                    k: usize,
                    name: &Option<String>,
                    origin: &urdf_rs::Pose,
                    geometry: &urdf_rs::Geometry,
                    rgba: Option<[f64; 4]>|
     -> Result<(), UrdfError> {
        let tag = if role == GeometryRole::Collision { "collision" } else { "visual" };
        let what = format!("<{tag}> {k}");
        let origin = pose_to_se3(file, &format!("link '{}' {what}", l.name), origin)?;
        if let Some(shape) = shapes.convert(file, &l.name, &what, geometry)? {
            model.geometries.push(Geometry {
                name: name.clone().unwrap_or_else(|| format!("{}_{tag}_{k}", l.name)),
                frame,
                parent_joint: joint,
                placement: placement.mul(&origin),
                shape,
                role,
                rgba,
            });
        }
        Ok(())
    };
    for (k, c) in l.collision.iter().enumerate() {
        push(GeometryRole::Collision, k, &c.name, &c.origin, &c.geometry, None)?;
    }
    for (k, v) in l.visual.iter().enumerate() {
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
        push(GeometryRole::Visual, k, &v.name, &v.origin, &v.geometry, rgba)?;
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

/// What becomes of a shape [`convert_shape`] refuses for its size: an error in strict mode,
/// otherwise the shape is dropped with a warning (the dynamics never reads shapes; the
/// simulator cannot use a degenerate one). Non-finite numbers stay errors in both modes.
struct ShapePolicy<'a> {
    strict: bool,
    warnings: &'a mut Vec<UrdfWarning>,
}

impl ShapePolicy<'_> {
    fn convert(
        &mut self,
        file: &str,
        link: &str,
        what: &str,
        g: &urdf_rs::Geometry,
    ) -> Result<Option<Shape>, UrdfError> {
        match convert_shape(file, link, what, g) {
            Ok(shape) => Ok(Some(shape)),
            Err(UrdfError::BadGeometry { .. }) if !self.strict => {
                self.warnings.push(UrdfWarning::Dropped {
                    element: format!("link '{link}' {what}"),
                    reason: "a non-positive size".into(),
                });
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }
}

/// The inertia policy on the bodies the dynamics uses (links merged across fixed joints):
/// a violation within rounding passes; beyond it, a body of negligible mass without a
/// negative principal moment (or any body,
/// with [`UrdfOptions::accept_nonphysical_inertia`]) is kept with a warning and any other
/// body is refused. Links that violate on their own but sit in a physical body are reported.
fn check_bodies(
    model: &Model,
    file: &str,
    options: UrdfOptions,
    link_inertias: &[Inertia],
    link_frame: &[usize],
    warnings: &mut Vec<UrdfWarning>,
) -> Result<(), UrdfError> {
    let scale = inertia::robot_scale(model.inertias[1..].iter().map(|y| &y.rotational));
    let total_mass = model.total_mass();
    let links_of = |j: usize| -> Vec<String> {
        model.frames.iter().filter(|f| f.is_link && f.parent_joint == j).map(|f| f.name.clone()).collect()
    };
    let mut body_ok = vec![true; model.njoints()];
    for j in 1..model.njoints() {
        let y = &model.inertias[j];
        let p = inertia::principal_moments(&y.rotational);
        let v = inertia::violation(p);
        if inertia::is_rounding(p, v, scale) {
            continue;
        }
        body_ok[j] = false;
        let joint = model.joints[j].name.clone();
        // A clearly negative moment makes the mass matrix indefinite (the dynamics would be
        // wrong, not only unrealisable), whatever the body's mass.
        let kept_because =
            if y.mass <= inertia::NEGLIGIBLE_MASS * total_mass && !inertia::is_negative(p, scale) {
                format!(
                    "its mass {} kg is negligible (below {} of the robot's {total_mass} kg)",
                    y.mass,
                    inertia::NEGLIGIBLE_MASS
                )
            } else if options.accept_nonphysical_inertia {
                "UrdfOptions::accept_nonphysical_inertia".to_string()
            } else {
                return Err(UrdfError::NonPhysicalBody {
                    file: file.into(),
                    joint,
                    links: links_of(j),
                    mass: y.mass,
                    reason: inertia::describe(p),
                });
            };
        warnings.push(UrdfWarning::NonPhysicalBodyKept {
            joint,
            links: links_of(j),
            reason: inertia::describe(p),
            kept_because,
        });
    }
    // Links that break the conditions on their own, inside a body that does not.
    for (l, y) in link_inertias.iter().enumerate() {
        let frame = &model.frames[link_frame[l]];
        let j = frame.parent_joint;
        if j == 0 || !body_ok[j] {
            continue;
        }
        let p = inertia::principal_moments(&y.rotational);
        let v = inertia::violation(p);
        if !inertia::is_rounding(p, v, scale) {
            warnings.push(UrdfWarning::NonPhysicalLinkMerged {
                link: frame.name.clone(),
                joint: model.joints[j].name.clone(),
                reason: inertia::describe(p),
            });
        }
    }
    Ok(())
}

/// Degrees of freedom whose pivot in `M = U D Uᵀ` at the neutral configuration is zero
/// (not above [`inertia::SINGULAR_PIVOT`] of `M`'s largest diagonal entry). The sparse
/// factorisation of [`crate::cholesky_decompose`], except that a zero pivot removes its
/// row and column (the factor of the principal submatrix without them) instead of
/// dividing by zero, so that one massless leaf does not spoil its ancestors' pivots.
fn singular_pivots(model: &Model) -> Vec<UrdfWarning> {
    let nv = model.nv;
    if nv == 0 {
        return Vec::new();
    }
    let mut data = Data::new(model);
    let q = model.neutral_configuration();
    let m = crate::crba(model, &mut data, q.as_slice());
    let scale = (0..nv).map(|k| m[(k, k)]).fold(0.0, f64::max);
    let mut u = nalgebra::DMatrix::<f64>::zeros(nv, nv);
    let mut d = vec![0.0; nv];
    let mut dead = vec![false; nv];
    let mut out: Vec<UrdfWarning> = Vec::new();
    for j in (0..nv).rev() {
        let sub = (j + 1)..(j + model.nv_subtree(j));
        let mut dj = m[(j, j)];
        for k in sub.clone().filter(|&k| !dead[k]) {
            dj -= u[(j, k)] * u[(j, k)] * d[k];
        }
        // A NaN pivot counts as zero too.
        if dj.is_nan() || dj <= inertia::SINGULAR_PIVOT * scale {
            dead[j] = true;
            let joint = model.joints[model.joint_of_dof(j)].name.clone();
            if !out
                .iter()
                .any(|w| matches!(w, UrdfWarning::SingularMassMatrix { joint: n, .. } if *n == joint))
            {
                out.push(UrdfWarning::SingularMassMatrix { joint, pivot: dj, scale });
            }
            continue;
        }
        d[j] = dj;
        let mut ancestor = model.parent_dof(j);
        while let Some(r) = ancestor {
            let mut s = m[(r, j)];
            for k in sub.clone().filter(|&k| !dead[k]) {
                s -= u[(r, k)] * u[(j, k)] * d[k];
            }
            u[(r, j)] = s / dj;
            ancestor = model.parent_dof(r);
        }
    }
    // Reported root first, as the joints are listed.
    out.reverse();
    out
}
