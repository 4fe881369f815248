//! A body as a JSON document: [`Body::from_json`] and [`Body::to_json`].

use super::body::{Body, Face, ModularError, ModuleId, ModuleKind};

/// A body as a JSON document (see [`Body::from_json`]): a module, its rotation, and the
/// module at each of its faces. Nesting is bounded by `serde_json`'s recursion limit (128),
/// so attaching depth first by recursion cannot overflow the stack.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ModuleDoc {
    /// `"core"`, `"brick"` or `"hinge"`.
    kind: String,
    #[serde(default, skip_serializing_if = "is_zero")]
    rotation: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    front: Option<Box<ModuleDoc>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    back: Option<Box<ModuleDoc>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    left: Option<Box<ModuleDoc>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    right: Option<Box<ModuleDoc>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    attachment: Option<Box<ModuleDoc>>,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl ModuleDoc {
    /// The children in the order they are attached: left, right, front, back, attachment
    /// (the order in which the presets are built).
    fn children(&self) -> [(Face, &Option<Box<ModuleDoc>>); 5] {
        [
            (Face::Left, &self.left),
            (Face::Right, &self.right),
            (Face::Front, &self.front),
            (Face::Back, &self.back),
            (Face::Attachment, &self.attachment),
        ]
    }

    /// Attaches this document's children to `id`, depth first.
    fn attach_children(&self, body: &mut Body, id: ModuleId) -> Result<(), ModularError> {
        for (face, child) in self.children() {
            let Some(child) = child else { continue };
            let kind = match child.kind.as_str() {
                "brick" => ModuleKind::Brick,
                "hinge" => ModuleKind::ActiveHinge,
                "core" => return Err(ModularError::SecondCore),
                other => {
                    // A long name is shown by its start and length, not echoed whole.
                    let shown: String = other.chars().take(40).collect();
                    let shown = if shown.len() < other.len() {
                        format!("`{shown}…` ({} bytes)", other.len())
                    } else {
                        format!("`{shown}`")
                    };
                    return Err(ModularError::Parse(format!(
                        "unknown module kind {shown} at the {} face of {} (core, brick, hinge)",
                        face.name(),
                        body.path_of(id)
                    )));
                }
            };
            let cid = body.attach(id, face, kind, child.rotation)?;
            child.attach_children(body, cid)?;
        }
        Ok(())
    }
}

impl Body {
    /// A body from a JSON document, modules attached depth first, faces in the order left,
    /// right, front, back, attachment (which sets the hinge and action order; the presets
    /// read back from [`Body::to_json`] in their own order). Each module is an
    /// object with `kind` (`"core"` at the root, then `"brick"` or `"hinge"`), an optional
    /// `rotation` (rad, default 0) and an object per occupied face:
    ///
    /// ```text
    /// {"kind": "core",
    ///  "left":  {"kind": "hinge", "attachment": {"kind": "brick"}},
    ///  "right": {"kind": "hinge", "attachment": {"kind": "brick"}}}
    /// ```
    ///
    /// Malformed JSON, unknown fields or kinds, and every error [`Body::attach`] reports
    /// come back as a [`ModularError`]. Modules use Revolve2's V1 properties.
    pub fn from_json(text: &str) -> Result<Body, ModularError> {
        let doc: ModuleDoc = serde_json::from_str(text).map_err(|e| ModularError::Parse(e.to_string()))?;
        if doc.kind != "core" || doc.rotation != 0.0 {
            return Err(ModularError::Parse(
                "the root must be {\"kind\": \"core\"} without a rotation".into(),
            ));
        }
        let mut body = Body::new();
        let core = body.core();
        doc.attach_children(&mut body, core)?;
        Ok(body)
    }

    /// The body as a JSON document that [`Body::from_json`] reads back (module properties
    /// are not included), as long as no chain of modules is deeper than `serde_json`'s
    /// nesting limit of 128 objects (about 120 modules in a row).
    pub fn to_json(&self) -> String {
        let doc = self.doc(self.core());
        serde_json::to_string_pretty(&doc).unwrap_or_default()
    }

    fn doc(&self, id: ModuleId) -> ModuleDoc {
        let node = &self.nodes[id.0];
        let child = |face: Face| node.children[face.index()].map(|c| Box::new(self.doc(c)));
        ModuleDoc {
            kind: match node.kind {
                ModuleKind::Core => "core",
                ModuleKind::Brick => "brick",
                ModuleKind::ActiveHinge => "hinge",
            }
            .to_string(),
            rotation: node.rotation,
            front: child(Face::Front),
            back: child(Face::Back),
            left: child(Face::Left),
            right: child(Face::Right),
            attachment: child(Face::Attachment),
        }
    }
}
