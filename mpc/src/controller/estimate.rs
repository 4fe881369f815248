//! Stage 1, the estimate: kinematics of the measured state, everything later stages read
//! about the robot as it is (centre of mass and its velocity, body orientation and rates,
//! contact points with their Jacobians, and the whole-body QP's dynamics and task
//! Jacobians). The controller sees the robot only through this.

use centaur_dynamics::nalgebra::{
    DMatrix, DVector, Matrix3, Matrix3xX, Matrix6xX, Rotation3, Vector3, Vector6,
};
use centaur_dynamics::{
    Data, ReferenceFrame, center_of_mass_velocity, crba, forward_kinematics, forward_kinematics_acceleration,
    frame_acceleration, frame_classical_acceleration, frame_jacobian, frame_velocity, nonlinear_effects,
    update_frame_placements,
};

use crate::robot::LeggedRobot;

/// The robot as measured this tick (world axes unless said otherwise).
pub(crate) struct Estimate {
    /// Configuration (base quaternion normalised).
    pub q: DVector<f64>,
    /// Velocity.
    pub v: DVector<f64>,
    zeros_v: DVector<f64>,
    jac6: Matrix6xX<f64>,
    /// Centre of mass.
    pub com: Vector3<f64>,
    /// Centre-of-mass velocity.
    pub com_vel: Vector3<f64>,
    /// Body orientation.
    pub rot: Matrix3<f64>,
    /// Body angular velocity.
    pub omega: Vector3<f64>,
    /// Roll, pitch, yaw of the body.
    pub rpy: Vector3<f64>,
    /// Position of each contact point.
    pub p_contact: Vec<Vector3<f64>>,
    /// Velocity of each contact point.
    pub v_contact: Vec<Vector3<f64>>,
    /// Linear Jacobian of each contact point.
    pub j_contact: Vec<Matrix3xX<f64>>,
    /// Origin of the body frame.
    pub body_origin: Vector3<f64>,
    /// The dynamics and task Jacobians the whole-body QP needs.
    pub dynamics: Dynamics,
}

/// `M`, `h` and the Jacobians of the whole-body QP's tasks at the measured state
/// (the kinematic half of [`crate::wbc::WbcInput`], which the torque stage copies in).
pub(crate) struct Dynamics {
    /// `M(q)` plus the armature on its diagonal.
    pub mass_matrix: DMatrix<f64>,
    /// `h = C q̇ + g + D q̇` (joint viscous damping included).
    pub nle: DVector<f64>,
    /// Body task: rows 0–2 `J_com`, rows 3–5 the body frame's angular rows.
    pub j_body: Matrix6xX<f64>,
    /// `J̇ q̇` of the body task.
    pub jdqd_body: Vector6<f64>,
    /// `J̇ q̇` of each contact point.
    pub jdqd_contact: Vec<Vector3<f64>>,
    /// Loop-closure rows `dᵀ(J_a − J_b)`.
    pub j_closure: DMatrix<f64>,
    /// Right-hand side of the closure rows (with the closure PD stabilisation).
    pub closure_rhs: DVector<f64>,
}

impl Estimate {
    pub(crate) fn new(robot: &LeggedRobot) -> Self {
        let (nq, nv, nc, nl) = (robot.model.nq, robot.model.nv, robot.n_contacts(), robot.n_closure_rows);
        Estimate {
            q: DVector::zeros(nq),
            v: DVector::zeros(nv),
            zeros_v: DVector::zeros(nv),
            jac6: Matrix6xX::zeros(nv),
            com: Vector3::zeros(),
            com_vel: Vector3::zeros(),
            rot: Matrix3::identity(),
            omega: Vector3::zeros(),
            rpy: Vector3::zeros(),
            p_contact: vec![Vector3::zeros(); nc],
            v_contact: vec![Vector3::zeros(); nc],
            j_contact: vec![Matrix3xX::zeros(nv); nc],
            body_origin: Vector3::zeros(),
            dynamics: Dynamics {
                mass_matrix: DMatrix::zeros(nv, nv),
                nle: DVector::zeros(nv),
                j_body: Matrix6xX::zeros(nv),
                jdqd_body: Vector6::zeros(),
                jdqd_contact: vec![Vector3::zeros(); nc],
                j_closure: DMatrix::zeros(nl, nv),
                closure_rhs: DVector::zeros(nl),
            },
        }
    }

    /// Copies the state, normalising the base quaternion; `false` if it cannot be (a zero
    /// quaternion).
    pub(crate) fn set_state(&mut self, robot: &LeggedRobot, q: &DVector<f64>, v: &DVector<f64>) -> bool {
        self.q.copy_from(q);
        self.v.copy_from(v);
        if robot.model.has_floating_base() {
            let s = &mut self.q.as_mut_slice()[3..7];
            let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3]).sqrt();
            if n < 1e-9 {
                return false;
            }
            s.iter_mut().for_each(|x| *x /= n);
        }
        true
    }

    /// Kinematics and dynamics of the state last set; `closure_gains` `(k_p, k_d)`
    /// stabilise the loop closures' acceleration rows.
    pub(crate) fn update(&mut self, robot: &mut LeggedRobot, data: &mut Data, closure_gains: (f64, f64)) {
        // Sphere contacts: the touching point depends on the link orientations.
        forward_kinematics(&robot.model, data, self.q.as_slice());
        robot.update_sphere_contacts(data);
        let model = &robot.model;
        let q = self.q.as_slice();
        let v = self.v.as_slice();
        let dyn_ = &mut self.dynamics;
        self.com_vel = center_of_mass_velocity(model, data, q, v);
        self.com = data.com[0];
        dyn_.j_body.fixed_rows_mut::<3>(0).copy_from(&data.jacobian_com);
        crba(model, data, q);
        dyn_.mass_matrix.copy_from(&data.mass_matrix);
        for k in 0..model.nv {
            dyn_.mass_matrix[(k, k)] += model.armature[k];
        }
        nonlinear_effects(model, data, q, v);
        dyn_.nle.copy_from(&data.nle);
        // Joint viscous damping (`<dynamics damping>`) is part of the bias forces:
        // M q̈ + C q̇ + g + D q̇ = Sᵀτ + Jᵀf.
        for k in 0..model.nv {
            dyn_.nle[k] += model.damping[k] * v[k];
        }
        forward_kinematics_acceleration(model, data, q, v, self.zeros_v.as_slice());
        update_frame_placements(model, data);
        // Body.
        let bf = robot.body_frame;
        let o = data.o_m_f[bf];
        self.body_origin = o.translation;
        self.rot = o.rotation;
        let r = Rotation3::from_matrix_unchecked(self.rot);
        let (roll, pitch, yaw) = r.euler_angles();
        self.rpy = Vector3::new(roll, pitch, yaw);
        let bv = frame_velocity(model, data, bf, ReferenceFrame::LocalWorldAligned);
        self.omega = bv.angular;
        frame_jacobian(model, data, bf, ReferenceFrame::LocalWorldAligned, &mut self.jac6);
        dyn_.j_body.fixed_rows_mut::<3>(3).copy_from(&self.jac6.fixed_rows::<3>(3));
        // CoM drift J̇_com q̇ = (1/m) Σᵢ mᵢ R_i (aᵢ + αᵢ × cᵢ + ωᵢ × (vᵢ + ωᵢ × cᵢ)) with the
        // body accelerations of q̈ = 0 (each body's CoM point, classical acceleration).
        let mut m_acc = Vector3::zeros();
        let mut m_tot = 0.0;
        for i in 1..model.njoints() {
            let inertia = &model.inertias[i];
            if inertia.mass <= 0.0 {
                continue;
            }
            let (vi, ai, c) = (&data.v[i], &data.a[i], &inertia.lever);
            let a_local =
                ai.linear + ai.angular.cross(c) + vi.angular.cross(&(vi.linear + vi.angular.cross(c)));
            m_acc += data.o_m_i[i].rotation * a_local * inertia.mass;
            m_tot += inertia.mass;
        }
        let lin = if m_tot > 0.0 { m_acc / m_tot } else { Vector3::zeros() };
        let ang = frame_acceleration(model, data, bf, ReferenceFrame::LocalWorldAligned).angular;
        for d in 0..3 {
            dyn_.jdqd_body[d] = lin[d];
            dyn_.jdqd_body[3 + d] = ang[d];
        }
        // Contacts.
        for (c, &f) in robot.contact_frames.iter().enumerate() {
            self.p_contact[c] = data.o_m_f[f].translation;
            self.v_contact[c] = frame_velocity(model, data, f, ReferenceFrame::LocalWorldAligned).linear;
            frame_jacobian(model, data, f, ReferenceFrame::LocalWorldAligned, &mut self.jac6);
            self.j_contact[c].copy_from(&self.jac6.fixed_rows::<3>(0));
            dyn_.jdqd_contact[c] = frame_classical_acceleration(model, data, f);
        }
        // Loop closures.
        let (kp, kd) = closure_gains;
        let mut row = 0;
        for cl in &robot.closures {
            let pa = data.o_m_f[cl.frame_a].translation;
            let pb = data.o_m_f[cl.frame_b].translation;
            let ra = data.o_m_f[cl.frame_a].rotation;
            let va = frame_velocity(model, data, cl.frame_a, ReferenceFrame::LocalWorldAligned).linear;
            let vb = frame_velocity(model, data, cl.frame_b, ReferenceFrame::LocalWorldAligned).linear;
            let aa = frame_classical_acceleration(model, data, cl.frame_a);
            let ab = frame_classical_acceleration(model, data, cl.frame_b);
            for dl in &cl.directions {
                let d = ra * dl;
                frame_jacobian(model, data, cl.frame_a, ReferenceFrame::LocalWorldAligned, &mut self.jac6);
                for k in 0..model.nv {
                    dyn_.j_closure[(row, k)] =
                        d.x * self.jac6[(0, k)] + d.y * self.jac6[(1, k)] + d.z * self.jac6[(2, k)];
                }
                frame_jacobian(model, data, cl.frame_b, ReferenceFrame::LocalWorldAligned, &mut self.jac6);
                for k in 0..model.nv {
                    dyn_.j_closure[(row, k)] -=
                        d.x * self.jac6[(0, k)] + d.y * self.jac6[(1, k)] + d.z * self.jac6[(2, k)];
                }
                dyn_.closure_rhs[row] = -d.dot(&(aa - ab)) - kp * d.dot(&(pa - pb)) - kd * d.dot(&(va - vb));
                row += 1;
            }
        }
    }
}
