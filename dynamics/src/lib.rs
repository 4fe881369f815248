//! # centaur-dynamics
//!
//! Rigid-body dynamics of robots described by URDF: a [`Model`] built once, a [`Data`]
//! workspace allocated once, and algorithms as free functions that allocate nothing:
//!
//! | function | computes |
//! |---|---|
//! | [`forward_kinematics`] (+ `_velocity`, `_acceleration`), [`update_frame_placements`] | `⁰Mᵢ(q)` of every joint and frame, body twists and accelerations |
//! | [`compute_joint_jacobians`], [`frame_jacobian`], [`joint_jacobian`] | `J(q)` with `v_frame = J q̇` in [`ReferenceFrame::World`], `LocalWorldAligned` or `Local` |
//! | [`rnea`], [`nonlinear_effects`], [`gravity_torques`] | `τ = M(q) q̈ + C(q, q̇) q̇ + g(q)`, `C q̇ + g`, `g` |
//! | [`crba`] | `M(q)` |
//! | [`aba`] | `q̈ = M⁻¹(τ − C q̇ − g)` |
//! | [`cholesky_decompose`], [`mass_matrix_solve`], [`mass_matrix_inverse`] | `M = U D Uᵀ`, `M⁻¹ b`, `M⁻¹` |
//! | [`center_of_mass`], [`jacobian_center_of_mass`] | `c(q)`, `J_c(q)` |
//! | [`centroidal_map`], [`centroidal_momentum`] | `A_g(q)`, `h_g = A_g q̇` |
//! | [`kinetic_energy`], [`potential_energy`] | `½ q̇ᵀ M q̇`, `−Σ mᵢ gᵀ cᵢ` |
//!
//! The algorithms follow Featherstone's *Rigid Body Dynamics Algorithms* (2008): RNEA §5.3,
//! CRBA §6.2 (in joint frames; the centre-of-mass and centroidal functions use world-frame
//! composites), ABA §7.3, the sparse `U D Uᵀ` factorisation of
//! Featherstone (2005), and the centroidal momentum matrix of Orin, Goswami & Lee (2013).
//!
//! ## Conventions (written once here, used by every Centaur crate)
//!
//! * **Units and axes**: SI; world z up; gravity `(0, 0, −9.81)` m/s² unless
//!   [`Model::gravity`] is changed.
//! * **Spatial vectors**: linear part first. A motion `(v, ω)` gives the velocity of the
//!   point at the frame origin and the angular velocity; a force `(f, n)` gives the force
//!   and the moment about the frame origin. `aMb = (R, p)` maps frame-*b* coordinates to
//!   frame *a*: `x_a = R x_b + p` (see [`spatial`]).
//! * **Joints and frames**: index 0 is the world (`universe`); joints are in depth-first
//!   order, so `parent < child` and every subtree is a contiguous range of joints and of
//!   `v`. A URDF joint's frame is its child link's frame. Links behind fixed joints are
//!   merged into the body of their moving parent; every link keeps a [`Frame`].
//! * **Floating base** ([`BaseKind::Floating`]): joint 1 is a free-flyer named `root_joint`;
//!   `q = [x, y, z, qx, qy, qz, qw, joints…]` is the root-link placement in the world with a
//!   scalar-last unit quaternion; `v = [v, ω, joint rates…]` is the root-link twist
//!   expressed **in the root-link frame**; the matching part of a generalized force is the
//!   wrench on the root link in the root-link frame. These are Pinocchio's conventions.
//! * **Joint coordinates**: revolute and continuous joints use their angle (one entry in
//!   `q`), prismatic joints their displacement, along the normalised URDF axis. Pinocchio
//!   parametrises continuous joints by `(cos θ, sin θ)` instead (two entries, no angle to
//!   wrap, no sine or cosine to evaluate); [`UrdfOptions::continuous_as_cos_sin`] loads
//!   them that way ([`JointKind::RevoluteUnbounded`]), for the dynamics algorithms only:
//!   the simulator and the controller take angles and refuse such models with a typed
//!   error.
//! * [`RobotState`] is `(q, v)` in this layout, with accessors for the base pose and twist
//!   in base or world axes.
//!
//! ## What the URDF loader reads, accepts and refuses
//!
//! Read: links (inertial, visual and collision geometry: box, cylinder, capsule, sphere,
//! mesh file names), joints of type revolute, continuous, prismatic and fixed (origin,
//! axis, `<limit>` position/effort/velocity, `<dynamics>` damping/friction), material
//! colours. A `<limit>` that gives neither `lower` nor `upper` leaves the joint
//! position-unlimited (PyBullet's reading). Mesh contents are never read (a mesh that
//! cannot be found is not an error).
//!
//! The policy matches the published robots (Pinocchio loads them; the corpus of 44 in
//! `assets/corpus/` loads and agrees with it): refuse only what makes the dynamics wrong or
//! undefined, and report everything repaired, ignored or dropped as a [`UrdfWarning`] in
//! [`Model::load_warnings`] (which link or joint, what, what was done).
//!
//! * **Refused** with a typed [`UrdfError`] naming the file and element: unreadable or
//!   non-URDF files, missing parent/child links, duplicate names, cycles, several roots,
//!   revolute/prismatic joints without `<limit>`, inverted limits, NaN or infinite numbers,
//!   zero-length axes, floating/planar/spherical joints, negative masses, and a body (links
//!   merged across fixed joints) that carries at least `1e−3` of the robot's mass and whose
//!   rotational inertia clearly violates a rigid body's conditions (a principal moment
//!   below zero, or `λ₁ + λ₂ < λ₃`, by more than `1e−6` of its moments plus `1e−9` of the
//!   largest body's: [`UrdfError::NonPhysicalBody`]).
//! * **Accepted with a warning**: a link whose own inertia is non-physical inside a body
//!   that is not (the dummy `base` links of Go1, B1, ANYmal, HyQ); a non-physical body of
//!   negligible mass; a link with zero mass and non-zero inertia (kept as given); shapes
//!   that are degenerate or that urdf-rs cannot read (dropped: when urdf-rs cannot read the
//!   file as written, the loader reads it again keeping only the elements the dynamics
//!   uses); `<mimic>` (the joint stays independent); `<gazebo>`, `<transmission>`,
//!   `<sensor>`, `<calibration>`, `<safety_controller>`, `ros2_control` and vendor tags
//!   (counted); a degree of freedom that moves no inertia (a massless moving leaf, as in
//!   Pinocchio a zero-inertia body: the mass matrix is singular and ABA undefined).
//! * [`UrdfOptions::accept_nonphysical_inertia`] keeps even clearly non-physical bodies as
//!   given, as Pinocchio does (needed for example-robot-data's `romeo_small` and
//!   `romeo_laas_small`, pybullet's `mini_cheetah` and `xarm6_robot`);
//!   [`UrdfOptions::strict`] restores the earlier, stricter behaviour (every link checked on
//!   its own, zero mass with inertia and degenerate shapes refused, no second reading).
//!
//! ## Not supported
//!
//! Closed kinematic loops (the simulator closes them with constraints), joint types other
//! than the above, and multi-dof joints other than the root free-flyer.
//!
//! ## Example
//!
//! ```
//! use centaur_dynamics::{BaseKind, Data, Model, aba, rnea};
//! # fn main() -> Result<(), centaur_dynamics::UrdfError> {
//! let urdf = r#"<robot name="two_link">
//!   <link name="base"/>
//!   <link name="upper"><inertial><mass value="1"/><origin xyz="0 0 -0.25"/>
//!     <inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
//!   <link name="lower"><inertial><mass value="0.5"/><origin xyz="0 0 -0.2"/>
//!     <inertia ixx="0.01" iyy="0.01" izz="0.0005" ixy="0" ixz="0" iyz="0"/></inertial></link>
//!   <joint name="hip" type="revolute"><parent link="base"/><child link="upper"/>
//!     <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="30" velocity="10"/></joint>
//!   <joint name="knee" type="revolute"><parent link="upper"/><child link="lower"/>
//!     <origin xyz="0 0 -0.5"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="0" effort="30" velocity="10"/></joint>
//! </robot>"#;
//! let model = Model::from_urdf_str(urdf, "two_link.urdf", BaseKind::Fixed)?;
//! let mut data = Data::new(&model);
//! let (q, v, a) = ([0.3, -0.6], [0.5, -1.0], [1.0, 2.0]);
//! let tau = rnea(&model, &mut data, &q, &v, &a).clone();
//! // Forward dynamics undoes inverse dynamics.
//! let ddq = aba(&model, &mut data, &q, &v, tau.as_slice());
//! assert!((ddq[0] - a[0]).abs() < 1e-12 && (ddq[1] - a[1]).abs() < 1e-12);
//! # Ok(()) }
//! ```

/// Re-exported so that users name the exact nalgebra version the API uses.
pub use nalgebra;

pub mod spatial;

mod aba;
mod cholesky;
mod crba;
mod data;
mod energy;
mod jacobian;
mod kinematics;
mod model;
mod rnea;
mod robot;
mod state;
mod urdf;

pub use aba::aba;
pub use cholesky::{cholesky_decompose, mass_matrix_inverse, mass_matrix_solve};
pub use crba::{
    center_of_mass, center_of_mass_velocity, centroidal_map, centroidal_momentum, crba,
    jacobian_center_of_mass,
};
pub use data::Data;
pub use energy::{kinetic_energy, potential_energy};
pub use jacobian::{compute_joint_jacobians, frame_jacobian, joint_jacobian};
pub use kinematics::{
    ReferenceFrame, difference, forward_kinematics, forward_kinematics_acceleration,
    forward_kinematics_velocity, frame_acceleration, frame_classical_acceleration, frame_placement,
    frame_velocity, integrate, normalize, update_frame_placements,
};
pub use model::{Frame, Geometry, GeometryRole, Joint, JointKind, Model, Shape};
pub use rnea::{gravity_torques, nonlinear_effects, rnea};
pub use robot::Robot;
pub use spatial::{Force, Inertia, Motion, OriginInertia, Se3};
pub use state::RobotState;
pub use urdf::{BaseKind, UrdfError, UrdfOptions, UrdfWarning};
