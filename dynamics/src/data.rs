//! [`Data`]: every buffer the algorithms write, allocated once by [`Data::new`].

use nalgebra::{DMatrix, DVector, Matrix3xX, Matrix6, Matrix6xX, Vector3};

use crate::model::Model;
use crate::spatial::{Force, Motion, OriginInertia, Se3};

/// Workspace and results of the algorithms for one [`Model`].
///
/// Build it once with [`Data::new`]; no algorithm allocates afterwards. Fields hold the
/// results of the last call that computes them (documented on each algorithm).
#[derive(Clone, Debug)]
pub struct Data {
    /// Placement of each joint frame relative to its parent joint frame, `ⁱ⁻¹Mᵢ(q)`.
    pub li_m_i: Vec<Se3>,
    /// Placement of each joint frame in the world, `⁰Mᵢ(q)`.
    pub o_m_i: Vec<Se3>,
    /// Placement of each frame in the world, `⁰M_f(q)`.
    pub o_m_f: Vec<Se3>,
    /// Spatial velocity of each body in its joint frame.
    pub v: Vec<Motion>,
    /// Spatial acceleration of each body in its joint frame (gravity not included).
    pub a: Vec<Motion>,
    /// Spatial acceleration including the fictitious upward gravity acceleration (RNEA).
    pub a_gf: Vec<Motion>,
    /// Spatial force transmitted by each joint, in its joint frame (RNEA).
    pub f: Vec<Force>,
    /// Generalized forces from [`crate::rnea`].
    pub tau: DVector<f64>,
    /// Nonlinear effects `C(q, v) v + g(q)` from [`crate::nonlinear_effects`].
    pub nle: DVector<f64>,
    /// Gravity torques `g(q)` from [`crate::gravity_torques`].
    pub g: DVector<f64>,
    /// Joint-space inertia matrix `M(q)` from [`crate::crba`] (both triangles).
    pub mass_matrix: DMatrix<f64>,
    /// Generalized accelerations from [`crate::aba`].
    pub ddq: DVector<f64>,
    /// Joint Jacobians in the world frame (6 × nv), column `k` = motion subspace of dof `k`
    /// expressed at the world origin, from [`crate::compute_joint_jacobians`].
    pub jacobians: Matrix6xX<f64>,
    /// World-frame composite rigid-body inertia of each subtree, at the world origin.
    pub o_ycrb: Vec<OriginInertia>,
    /// Centroidal momentum matrix `A_g(q)` (6 × nv, `[linear; angular about the CoM]`).
    pub centroidal_map: Matrix6xX<f64>,
    /// Centroidal momentum `h_g = A_g v` (linear momentum, angular momentum about the CoM).
    pub centroidal_momentum: Force,
    /// Centre of mass of each subtree in the world (index 0: the whole robot).
    pub com: Vec<Vector3<f64>>,
    /// Mass of each subtree (index 0: everything moved by joints).
    pub mass: Vec<f64>,
    /// Jacobian of the centre of mass (3 × nv).
    pub jacobian_com: Matrix3xX<f64>,
    /// Kinetic energy from [`crate::kinetic_energy`].
    pub kinetic_energy: f64,
    /// Potential energy from [`crate::potential_energy`].
    pub potential_energy: f64,
    // CRBA workspace: composite inertia of each subtree in its joint frame, and composite
    // inertia times each subspace column (moved up the tree as the pass goes).
    pub(crate) ycrb: Vec<OriginInertia>,
    pub(crate) f_crb: Vec<Force>,
    // ABA workspace.
    pub(crate) y_aba: Vec<Matrix6<f64>>,
    pub(crate) p_aba: Vec<Force>,
    pub(crate) c_aba: Vec<Motion>,
    pub(crate) u_aba: Matrix6xX<f64>,
    pub(crate) d_inv: DVector<f64>,
    pub(crate) uu: DVector<f64>,
    // Cholesky factor M = U D Uᵀ (U unit upper triangular, stored in full).
    pub(crate) chol_u: DMatrix<f64>,
    pub(crate) chol_d: DVector<f64>,
    pub(crate) chol_tmp: DVector<f64>,
    pub(crate) chol_ready: bool,
}

impl Data {
    /// Allocates every buffer for `model`.
    pub fn new(model: &Model) -> Data {
        let n = model.njoints();
        let nv = model.nv;
        let nf = model.frames.len();
        Data {
            li_m_i: vec![Se3::identity(); n],
            o_m_i: vec![Se3::identity(); n],
            o_m_f: vec![Se3::identity(); nf],
            v: vec![Motion::zero(); n],
            a: vec![Motion::zero(); n],
            a_gf: vec![Motion::zero(); n],
            f: vec![Force::zero(); n],
            tau: DVector::zeros(nv),
            nle: DVector::zeros(nv),
            g: DVector::zeros(nv),
            mass_matrix: DMatrix::zeros(nv, nv),
            ddq: DVector::zeros(nv),
            jacobians: Matrix6xX::zeros(nv),
            o_ycrb: vec![OriginInertia::zero(); n],
            centroidal_map: Matrix6xX::zeros(nv),
            centroidal_momentum: Force::zero(),
            com: vec![Vector3::zeros(); n],
            mass: vec![0.0; n],
            jacobian_com: Matrix3xX::zeros(nv),
            kinetic_energy: 0.0,
            potential_energy: 0.0,
            ycrb: vec![OriginInertia::zero(); n],
            f_crb: vec![Force::zero(); nv],
            y_aba: vec![Matrix6::zeros(); n],
            p_aba: vec![Force::zero(); n],
            c_aba: vec![Motion::zero(); n],
            u_aba: Matrix6xX::zeros(nv),
            d_inv: DVector::zeros(nv),
            uu: DVector::zeros(nv),
            chol_u: DMatrix::zeros(nv, nv),
            chol_d: DVector::zeros(nv),
            chol_tmp: DVector::zeros(nv),
            chol_ready: false,
        }
    }
}

/// Asserts a vector length with a message naming both sizes (a caller's programming error).
#[track_caller]
#[inline]
pub(crate) fn check_len(name: &str, got: usize, expected: usize) {
    assert!(got == expected, "{name} has length {got}, but the model expects {expected}");
}
