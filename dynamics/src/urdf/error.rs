//! What the loader refuses ([`UrdfError`]) and what it accepts with a remark
//! ([`UrdfWarning`]).

use std::fmt;

/// A URDF file that cannot become a [`crate::Model`]: each variant names the file (`file`), the
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
    /// In the default (non-strict) mode: a body the dynamics uses (links merged across fixed
    /// joints) whose rotational inertia clearly violates what a rigid body can have, and
    /// whose mass is not negligible. [`crate::UrdfOptions::accept_nonphysical_inertia`] loads it
    /// anyway, as given (Pinocchio's behaviour), with a warning.
    #[error(
        "{file}: the body moved by joint '{joint}' (links {links:?}, mass {mass} kg): non-physical inertia: \
         {reason}; fix the file's <inertia>, or load it as given with \
         UrdfOptions {{ accept_nonphysical_inertia: true, .. }}"
    )]
    NonPhysicalBody {
        /// File path or label.
        file: String,
        /// The joint that moves the body.
        joint: String,
        /// The links merged into it.
        links: Vec<String>,
        /// The body's mass (kg).
        mass: f64,
        /// Which condition fails, with the numbers.
        reason: String,
    },
}

/// Something the loader repaired, ignored or dropped, or a property of the loaded model
/// that its user should know about. Kept on the model ([`crate::Model::load_warnings`]),
/// never printed by the library; `dyn_eval` prints them on stderr. Each names the element,
/// says what is unusual and what the loader did.
#[derive(Clone, Debug, PartialEq)]
pub enum UrdfWarning {
    /// urdf-rs could not read the file as written; the loader read it again keeping only
    /// the elements the dynamics uses (each element it dropped has its own warning).
    Reread {
        /// What urdf-rs said about the original text.
        message: String,
    },
    /// An element the dynamics does not need (a visual or collision shape, a material)
    /// could not be read or is degenerate, and was dropped.
    Dropped {
        /// The element, e.g. `link 'toeFR' <visual> 0`.
        element: String,
        /// What is wrong with it.
        reason: String,
    },
    /// Elements the loader does not read (`<gazebo>`, `<transmission>`, vendor tags…),
    /// counted by tag: `robot/gazebo`, `link/contact`, `joint/safety_controller`.
    Ignored {
        /// Where the element sits and its tag.
        tag: String,
        /// How many there are.
        count: usize,
    },
    /// A `<mimic>` coupling is not modelled: the joint is an independent degree of freedom
    /// (Pinocchio's default reading too).
    MimicIgnored {
        /// The mimicking joint.
        joint: String,
        /// The joint it would follow.
        leader: String,
    },
    /// A link with `<mass value="0">` and a non-zero rotational inertia: kept as given
    /// (a massless frame with a flywheel-like inertia, as Pinocchio keeps it).
    ZeroMassWithInertia {
        /// The link.
        link: String,
    },
    /// A link whose own inertia no rigid body can have, merged across fixed joints into a
    /// body whose inertia is physical (the body is what the dynamics uses): accepted.
    NonPhysicalLinkMerged {
        /// The link.
        link: String,
        /// The joint whose body it joined.
        joint: String,
        /// Which condition the link fails, with the numbers.
        reason: String,
    },
    /// A body whose inertia violates a rigid body's conditions, kept as given: beyond
    /// rounding, but on a body of negligible mass, or because the caller asked for it
    /// ([`crate::UrdfOptions::accept_nonphysical_inertia`]).
    NonPhysicalBodyKept {
        /// The joint that moves the body.
        joint: String,
        /// The links merged into it.
        links: Vec<String>,
        /// Which condition fails, with the numbers.
        reason: String,
        /// Why it was kept.
        kept_because: String,
    },
    /// A degree of freedom that moves no inertia at the neutral configuration (a massless
    /// leaf, or point masses on the joint axis): the mass matrix is singular there, so
    /// forward dynamics (ABA) and `M⁻¹` are undefined for this model, as in Pinocchio.
    /// Inverse dynamics, kinematics and Jacobians are unaffected.
    SingularMassMatrix {
        /// The joint that owns the degree of freedom.
        joint: String,
        /// The pivot `D` of `M = U D Uᵀ` at that degree of freedom.
        pivot: f64,
        /// The largest diagonal entry of `M`, for scale.
        scale: f64,
    },
}

impl fmt::Display for UrdfWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            UrdfWarning::Reread { message } => write!(
                f,
                "urdf-rs could not read the file as written ({message}); read it again keeping only \
                 the elements the dynamics uses"
            ),
            UrdfWarning::Dropped { element, reason } => write!(f, "{element}: {reason}; dropped"),
            UrdfWarning::Ignored { tag, count } => {
                write!(f, "{count} <{tag}> element(s) ignored (the dynamics does not use them)")
            }
            UrdfWarning::MimicIgnored { joint, leader } => write!(
                f,
                "joint '{joint}': <mimic joint=\"{leader}\"> ignored; the joint moves independently"
            ),
            UrdfWarning::ZeroMassWithInertia { link } => {
                write!(f, "link '{link}': <mass value=\"0\"> with a non-zero <inertia>; kept as given")
            }
            UrdfWarning::NonPhysicalLinkMerged { link, joint, reason } => write!(
                f,
                "link '{link}': non-physical <inertia> ({reason}); merged across fixed joints into \
                 the body of joint '{joint}', whose inertia is physical: accepted"
            ),
            UrdfWarning::NonPhysicalBodyKept { joint, links, reason, kept_because } => write!(
                f,
                "the body moved by joint '{joint}' (links {links:?}): non-physical inertia ({reason}); \
                 kept as given: {kept_because}"
            ),
            UrdfWarning::SingularMassMatrix { joint, pivot, scale } => write!(
                f,
                "joint '{joint}' moves no inertia at the neutral configuration (pivot {pivot:e} \
                 against {scale:e}): the mass matrix is singular, forward dynamics (ABA) is undefined"
            ),
        }
    }
}
