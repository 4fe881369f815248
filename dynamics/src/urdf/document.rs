//! The loader's own walk over the XML: facts urdf-rs's structs cannot tell (which joints
//! have a `<limit>`), the elements nobody reads, and — when urdf-rs cannot read a file as
//! written — a reduced document holding only what the dynamics uses.

use std::collections::BTreeMap;

use ::xml::{Element, Xml};

use super::error::{UrdfError, UrdfWarning};

/// Children of `<robot>` the loader reads.
const ROBOT_READ: &[&str] = &["link", "joint", "material"];
/// Children of `<link>` the loader reads.
const LINK_READ: &[&str] = &["inertial", "visual", "collision"];
/// Children of `<joint>` the loader reads (`mimic` gets its own warning).
const JOINT_READ: &[&str] = &["origin", "parent", "child", "axis", "limit", "dynamics", "mimic"];

/// The parsed document and what the walk learnt from it.
pub(super) struct Document {
    root: Element,
    /// Joints (by name) that have a `<limit>` child.
    joints_with_limit: Vec<String>,
    /// Unread elements, by `parent/tag`.
    ignored: BTreeMap<String, usize>,
    /// `(joint, leader)` of every `<mimic>`.
    mimics: Vec<(String, String)>,
}

/// Parses the XML, checks that it is a `<robot>` and takes stock of its elements.
pub(super) fn prescan(text: &str, file: &str) -> Result<Document, UrdfError> {
    let root: Element =
        text.parse().map_err(|e| UrdfError::Parse { file: file.to_string(), message: format!("{e:?}") })?;
    if root.name != "robot" {
        return Err(UrdfError::NotUrdf { file: file.to_string(), root: root.name.clone() });
    }
    let mut joints_with_limit = Vec::new();
    let mut ignored = BTreeMap::new();
    let mut mimics = Vec::new();
    let mut count = |parent: &str, e: &Element| {
        let tag = match &e.ns {
            Some(ns) if !ns.is_empty() => format!("{parent}/{{{ns}}}{}", e.name),
            _ => format!("{parent}/{}", e.name),
        };
        *ignored.entry(tag).or_insert(0) += 1;
    };
    for e in elements(&root) {
        let read = e.ns.is_none() && ROBOT_READ.contains(&e.name.as_str());
        if !read {
            count("robot", e);
            continue;
        }
        let (parent, wanted) = match e.name.as_str() {
            "link" => ("link", LINK_READ),
            "joint" => ("joint", JOINT_READ),
            _ => continue,
        };
        for c in elements(e) {
            if c.ns.is_some() || !wanted.contains(&c.name.as_str()) {
                count(parent, c);
            }
        }
        if parent == "joint" {
            let name = e.get_attribute("name", None).unwrap_or("").to_string();
            if e.get_child("limit", None).is_some() {
                joints_with_limit.push(name.clone());
            }
            if let Some(m) = e.get_child("mimic", None) {
                mimics.push((name, m.get_attribute("joint", None).unwrap_or("").to_string()));
            }
        }
    }
    Ok(Document { root, joints_with_limit, ignored, mimics })
}

/// The element children of `e`, in document order.
fn elements(e: &Element) -> impl Iterator<Item = &Element> {
    e.children.iter().filter_map(|c| if let Xml::ElementNode(el) = c { Some(el) } else { None })
}

impl Document {
    /// Whether the joint named `name` has a `<limit>` child.
    pub(super) fn has_limit(&self, name: &str) -> bool {
        self.joints_with_limit.iter().any(|n| n == name)
    }

    /// Warnings for the elements nobody reads and the `<mimic>` couplings.
    pub(super) fn ignored_warnings(&self) -> Vec<UrdfWarning> {
        let mut out: Vec<UrdfWarning> = self
            .ignored
            .iter()
            .map(|(tag, &count)| UrdfWarning::Ignored { tag: tag.clone(), count })
            .collect();
        out.extend(self.mimics.iter().map(|(joint, leader)| UrdfWarning::MimicIgnored {
            joint: joint.clone(),
            leader: leader.clone(),
        }));
        out
    }

    /// The document reduced to what the dynamics uses: links with their inertial and the
    /// visual and collision shapes whose geometry is readable, joints with their origin,
    /// parent, child, axis, limit and dynamics, and material colours. Every shape dropped
    /// is reported in `dropped`. Attribute values are copied verbatim, so urdf-rs reads the
    /// same numbers from it as from the original.
    pub(super) fn reduced_text(&self, dropped: &mut Vec<UrdfWarning>) -> String {
        let mut robot = Element::new("robot".into(), None, vec![]);
        copy_attr(&self.root, &mut robot, "name");
        for e in elements(&self.root).filter(|e| e.ns.is_none()) {
            match e.name.as_str() {
                "link" => {
                    robot.tag_stay(reduced_link(e, dropped));
                }
                "joint" => {
                    let mut j = Element::new("joint".into(), None, vec![]);
                    copy_attr(e, &mut j, "name");
                    copy_attr(e, &mut j, "type");
                    for c in elements(e) {
                        if c.ns.is_none() && JOINT_READ.contains(&c.name.as_str()) && c.name != "mimic" {
                            j.tag_stay(plain(c));
                        }
                    }
                    robot.tag_stay(j);
                }
                "material" => {
                    robot.tag_stay(reduced_material(e));
                }
                _ => {}
            }
        }
        robot.to_string()
    }
}

/// A copy of `e` without namespaced attributes or elements: a prefix declared on an ancestor
/// would not be bound in the reduced document (and the dynamics reads none of them).
fn plain(e: &Element) -> Element {
    let attrs = e
        .attributes
        .iter()
        .filter(|((_, ns), _)| ns.is_none())
        .map(|((k, _), v)| (k.clone(), None, v.clone()));
    let mut out = Element::new(e.name.clone(), None, attrs.collect::<Vec<_>>());
    for child in &e.children {
        match child {
            Xml::ElementNode(c) if c.ns.is_none() => {
                out.tag_stay(plain(c));
            }
            Xml::ElementNode(_) => {}
            Xml::CharacterNode(t) => {
                out.text(t.clone());
            }
            _ => {}
        }
    }
    out
}

fn copy_attr(from: &Element, to: &mut Element, name: &str) {
    if let Some(v) = from.get_attribute(name, None) {
        to.set_attribute(name.into(), None, v.into());
    }
}

/// A `<material>` with its name and colour only (a `<texture>` needs a file urdf-rs insists
/// on, and the dynamics never reads it).
fn reduced_material(e: &Element) -> Element {
    let mut m = Element::new("material".into(), None, vec![]);
    copy_attr(e, &mut m, "name");
    if let Some(c) = e.get_child("color", None) {
        let mut color = Element::new("color".into(), None, vec![]);
        copy_attr(c, &mut color, "rgba");
        m.tag_stay(color);
    }
    m
}

fn reduced_link(e: &Element, dropped: &mut Vec<UrdfWarning>) -> Element {
    let name = e.get_attribute("name", None).unwrap_or("");
    let mut link = Element::new("link".into(), None, vec![]);
    copy_attr(e, &mut link, "name");
    let mut counts = [0usize; 2];
    for c in elements(e).filter(|c| c.ns.is_none()) {
        let k = match c.name.as_str() {
            "inertial" => {
                link.tag_stay(plain(c));
                continue;
            }
            "visual" => 0,
            "collision" => 1,
            _ => continue,
        };
        let index = counts[k];
        counts[k] += 1;
        match reduced_shape(c) {
            Ok(shape) => {
                link.tag_stay(shape);
            }
            Err(reason) => dropped.push(UrdfWarning::Dropped {
                element: format!("link '{name}' <{}> {index}", c.name),
                reason,
            }),
        }
    }
    link
}

/// A `<visual>` or `<collision>` with its name, origin, one readable geometry and (visuals)
/// its material colour; `Err` says why the geometry cannot be read.
fn reduced_shape(e: &Element) -> Result<Element, String> {
    let mut out = Element::new(e.name.clone(), None, vec![]);
    copy_attr(e, &mut out, "name");
    if let Some(origin) = e.get_child("origin", None) {
        out.tag_stay(plain(origin));
    }
    let geometry = e.get_child("geometry", None).ok_or_else(|| "no <geometry>".to_string())?;
    let shape = elements(geometry)
        .find(|s| {
            s.ns.is_none() && ["box", "cylinder", "sphere", "capsule", "mesh"].contains(&s.name.as_str())
        })
        .ok_or_else(|| "<geometry> holds no box, cylinder, sphere, capsule or mesh".to_string())?;
    let required: &[&str] = match shape.name.as_str() {
        "box" => &["size"],
        "cylinder" | "capsule" => &["radius", "length"],
        "sphere" => &["radius"],
        _ => &["filename"],
    };
    let mut s = Element::new(shape.name.clone(), None, vec![]);
    for attr in required {
        if shape.get_attribute(attr, None).is_none() {
            return Err(format!("<{}> has no '{attr}'", shape.name));
        }
        copy_attr(shape, &mut s, attr);
    }
    if shape.name == "mesh"
        && let Some(scale) = shape.get_attribute("scale", None)
    {
        let parts: Vec<&str> = scale.split_whitespace().collect();
        if parts.len() != 3 || parts.iter().any(|p| p.parse::<f64>().is_err()) {
            return Err(format!("<mesh scale=\"{scale}\"> is not three numbers"));
        }
        copy_attr(shape, &mut s, "scale");
    }
    let mut g = Element::new("geometry".into(), None, vec![]);
    g.tag_stay(s);
    out.tag_stay(g);
    if let Some(m) = e.get_child("material", None) {
        out.tag_stay(reduced_material(m));
    }
    Ok(out)
}
