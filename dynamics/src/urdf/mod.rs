//! URDF → [`Model`], with a validation pass of our own and a loading policy that matches
//! the published robots.
//!
//! urdf-rs parses the XML structure but accepts files that are not robots (a missing parent
//! link, duplicate names, cycles, non-URDF XML); every check below is ours, and every error
//! names the file and the element at fault.
//!
//! # The policy (default options)
//!
//! Refused, with a typed [`UrdfError`]: what makes the dynamics wrong or undefined, and
//! what is not a robot: unreadable or non-URDF files, missing links, duplicate names,
//! cycles, several roots, revolute or prismatic joints without `<limit>`, inverted limits,
//! zero-length axes, unsupported joint types, NaN or infinite numbers, negative masses, and
//! a body (links merged across fixed joints) whose inertia clearly violates a rigid body's
//! conditions while carrying a non-negligible share of the robot's mass
//! ([`UrdfError::NonPhysicalBody`]).
//!
//! Accepted, with a [`UrdfWarning`] on [`Model::load_warnings`]:
//! * a link with `<mass value="0">` and zero inertia: a massless frame (merged into its
//!   parent's body across a fixed joint; on a moving joint it is a zero-inertia body, as in
//!   Pinocchio: no warning of its own, but see the singular mass matrix below);
//! * a link with zero mass and a non-zero inertia: kept as given;
//! * a link whose own inertia is not physical (Go1's, ANYmal's and HyQ's dummy `base` links
//!   with principal moments `[−2.2e−22, 0, 3e−6]`) when the body it is merged into is;
//! * a body whose inertia violates the conditions within rounding of its own scale or of
//!   the robot's (no warning), or beyond that on a body of negligible mass (kept, warned);
//! * a degree of freedom that moves no inertia (massless leaves, point masses on the joint
//!   axis): the mass matrix is singular, forward dynamics undefined, as in Pinocchio;
//! * elements the dynamics never reads (`<gazebo>`, `<transmission>`, `<sensor>`,
//!   `ros2_control`, vendor tags, `<mimic>`), counted and reported;
//! * visual and collision shapes that are degenerate (a non-positive size) or that urdf-rs
//!   cannot read (a `<texture>` without a file, a `<material>` inside `<geometry>`): if
//!   urdf-rs cannot read the file as written, the loader rebuilds the document keeping only
//!   the elements the dynamics uses, drops the shapes it cannot read, and reads it again.
//!
//! [`UrdfOptions::strict`] restores the earlier behaviour: every link checked on its own,
//! zero mass with non-zero inertia refused, degenerate shapes refused, no second reading.
//!
//! The thresholds, where they are used ([`inertia`]): a body's violation
//! `max(−λ₁, λ₃ − λ₁ − λ₂)` of its principal moments `λ₁ ≤ λ₂ ≤ λ₃` counts as rounding
//! below `1e−6 · (λ₁ + λ₂ + λ₃) + 1e−9 · I_robot` (`I_robot`: the largest trace of any body
//! of the model); a body's mass is negligible below `1e−3` of the robot's; a pivot of
//! `M = U D Uᵀ` is zero below `1e−12` of `M`'s largest diagonal entry.

mod build;
mod document;
pub(crate) mod error;
pub(crate) mod inertia;
mod options;

use std::path::Path;

pub use error::{UrdfError, UrdfWarning};
pub use options::{BaseKind, UrdfOptions};

use crate::model::Model;

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
    /// into their moving parent's body but keep their frames. Ignored (and listed in
    /// [`Model::load_warnings`]): `<mimic>`, `<calibration>`, `<safety_controller>`,
    /// `<transmission>`, `<gazebo>`, sensors, vendor tags, and mesh contents. A revolute
    /// joint whose `<limit>` gives neither `lower` nor `upper` (both read as 0) is treated
    /// as position-unlimited, as PyBullet does. The module docs give the full policy.
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
        let doc = document::prescan(text, &file)?;
        let mut warnings = doc.ignored_warnings();
        let robot = match urdf_rs::read_from_string(text) {
            Ok(robot) => robot,
            Err(e) if options.strict => {
                return Err(UrdfError::Parse { file, message: e.to_string() });
            }
            Err(e) => {
                // Read again from what the dynamics uses; the dropped shapes are reported.
                let mut dropped = Vec::new();
                let reduced = doc.reduced_text(&mut dropped);
                let robot = urdf_rs::read_from_string(&reduced)
                    .map_err(|_| UrdfError::Parse { file: file.clone(), message: e.to_string() })?;
                warnings.push(UrdfWarning::Reread { message: e.to_string() });
                warnings.extend(dropped);
                robot
            }
        };
        build::build(&robot, &doc, &file, base, options, warnings)
    }
}
