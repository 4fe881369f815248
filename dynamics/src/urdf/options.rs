//! What the caller chooses when loading a URDF: [`BaseKind`] and [`UrdfOptions`].

/// How the root link is attached to the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaseKind {
    /// The root link is welded to the world (arms, and planar robots whose URDF already
    /// contains their root joints).
    Fixed,
    /// A 6-dof free-flyer joint (`root_joint`) connects the world to the root link.
    Floating,
}

/// Choices the URDF loader leaves to the caller; the default is what
/// [`crate::Model::from_urdf_file`] and [`crate::Model::from_urdf_str`] use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UrdfOptions {
    /// Load `continuous` joints as [`crate::JointKind::RevoluteUnbounded`]
    /// (`q = (cos θ, sin θ)`, two entries per joint, as Pinocchio loads them) instead of as
    /// [`crate::JointKind::Revolute`] with an unlimited angle (one entry, the default, and
    /// what the simulator and the controller expect) (default: false).
    pub continuous_as_cos_sin: bool,
    /// Refuse what the default policy repairs or accepts with a warning (see the module
    /// docs): every link's inertia is checked on its own at a tolerance of `1e−9` of its
    /// moments, a zero mass with a non-zero inertia is an error, degenerate shapes are
    /// errors and a file urdf-rs cannot read as written is not read again. Centaur's
    /// behaviour before the policy (default: false).
    pub strict: bool,
    /// Keep a body whose inertia clearly violates a rigid body's conditions as given, with
    /// a warning, instead of refusing it: what Pinocchio does. Needed for a few published
    /// files (example-robot-data's `romeo_small`, pybullet_data's `mini_cheetah` and
    /// `xarm6_robot`). Negative masses and non-finite numbers stay errors. Ignored with
    /// [`UrdfOptions::strict`] (default: false).
    pub accept_nonphysical_inertia: bool,
}
