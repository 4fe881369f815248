//! Stage 5, torques: the whole-body QP (or the cheap path when it fails, or when
//! configured) turns the plan's forces and the motion targets into feed-forward joint
//! torques, and a damped-least-squares IK gives the joint PD targets that go with them.

use std::time::Instant;

use centaur_dynamics::nalgebra::{Matrix3, Matrix3xX, Rotation3, Vector3};

use super::status::{ControllerStatus, Fallback, JointCommand};
use super::targets::{LocomotionTargets, TickContext};
use crate::config::{ControlMode, ControllerConfig, while_turning};
use crate::error::ConfigError;
use crate::gait::Gait;
use crate::qp::{cholesky_in_place, cholesky_solve};
use crate::robot::LeggedRobot;
use crate::wbc::WholeBodyQp;

/// The torque stage's solver and buffers.
pub(crate) struct Torques {
    pub(crate) wbc: WholeBodyQp,
    ik_a: Vec<f64>,
    ik_b: Vec<f64>,
    tau_full: Vec<f64>,
    lam_a: Vec<f64>,
    lam_b: Vec<f64>,
    passive_joint_v: Vec<usize>,
}

impl Torques {
    pub(crate) fn new(cfg: &ControllerConfig, robot: &LeggedRobot) -> Result<Self, ConfigError> {
        let wbc = WholeBodyQp::new(robot, &cfg.wbc)?;
        let passive_joint_v: Vec<usize> =
            robot.unactuated_v.iter().copied().filter(|k| !robot.base_v.contains(k)).collect();
        let (nv, nc, nl, nj) =
            (robot.model.nv, robot.n_contacts(), robot.n_closure_rows, robot.joint_v.len());
        let n_rows_ik = 3 * nc + nl;
        Ok(Torques {
            wbc,
            ik_a: vec![0.0; nj * nj.max(n_rows_ik)],
            ik_b: vec![0.0; nj.max(n_rows_ik)],
            tau_full: vec![0.0; nv],
            lam_a: vec![0.0; nl * nl],
            lam_b: vec![0.0; nl],
            passive_joint_v,
        })
    }

    /// Feed-forward torques into `command.tau` (the QP's forces into `targets.force`),
    /// then the PD targets and gains.
    pub(crate) fn update(
        &mut self,
        cx: &TickContext<'_>,
        targets: &mut LocomotionTargets,
        command: &mut JointCommand,
        status: &mut ControllerStatus,
    ) {
        match cx.cfg.mode {
            ControlMode::WholeBody => {
                if !self.whole_body(cx, targets, command, status) {
                    status.fallback = Fallback::CheapPath;
                    self.cheap_path(cx, targets, command);
                }
            }
            ControlMode::Cheap => self.cheap_path(cx, targets, command),
        }
        self.joint_targets(cx, targets, command);
    }

    /// Fills and solves the whole-body QP; writes torques on success.
    fn whole_body(
        &mut self,
        cx: &TickContext<'_>,
        targets: &mut LocomotionTargets,
        command: &mut JointCommand,
        status: &mut ControllerStatus,
    ) -> bool {
        let (cfg, robot, est, reference, height) = (cx.cfg, cx.robot, cx.est, cx.reference, cx.height);
        let staggered = cx.gait.pattern().stagger != 0.0;
        self.wbc.set_body_axis_weight(
            5,
            while_turning(staggered, cfg.turn_yaw_weight, cfg.wbc.body_axis_weights[5]),
        );
        self.wbc.set_posture_weight(while_turning(staggered, cfg.turn_posture_weight, cfg.wbc.w_posture));
        self.wbc.set_body_angular_weight(cfg.body_angular_weight(cx.gait.pattern().gait));
        let nc = robot.n_contacts();
        let m = robot.mass;
        let gvec = robot.model.gravity;
        let inp = &mut self.wbc.input;
        // The state's dynamics and task Jacobians, from the estimate.
        let d = &est.dynamics;
        inp.mass_matrix.copy_from(&d.mass_matrix);
        inp.nle.copy_from(&d.nle);
        inp.j_body.copy_from(&d.j_body);
        inp.jdqd_body = d.jdqd_body;
        inp.j_closure.copy_from(&d.j_closure);
        inp.closure_rhs.copy_from(&d.closure_rhs);
        let mut f_sum = Vector3::zeros();
        let mut tau_sum = Vector3::zeros();
        for c in 0..nc {
            inp.j_contact[c].copy_from(&est.j_contact[c]);
            inp.jdqd_contact[c] = d.jdqd_contact[c];
            inp.stance[c] = targets.stance[c];
            inp.f_ref[c] = targets.force[c];
            f_sum += targets.force[c];
            tau_sum += (est.p_contact[c] - est.com).cross(&targets.force[c]);
            let tg = &targets.motion[c];
            let (kp, kd) = cfg.swing_gains;
            inp.a_swing[c] = tg.a + (tg.p - est.p_contact[c]) * kp + (tg.v - est.v_contact[c]) * kd;
            inp.swing_free_direction[c] = free_direction(&est.j_contact[c], &robot.joint_v);
        }
        // Body task: MPC wrench feed-forward + PD.
        let (p_ref, v_cmd) = (reference.p_ref, reference.v_cmd);
        let pos_err = Vector3::new(
            p_ref.x - est.com.x,
            if cfg.mpc.planar { 0.0 } else { p_ref.y - est.com.y },
            height - est.com.z,
        );
        let vel_err = Vector3::new(v_cmd.x - est.com_vel.x, v_cmd.y - est.com_vel.y, -est.com_vel.z);
        let a_lin = f_sum / m
            + gvec
            + pos_err.component_mul(&Vector3::from(cfg.body_kp_pos))
            + vel_err.component_mul(&Vector3::from(cfg.body_kd_vel));
        let r_des = Rotation3::from_axis_angle(&Vector3::z_axis(), reference.yaw_ref);
        let r_err = r_des.matrix() * est.rot.transpose();
        let ori_err = Rotation3::from_matrix_unchecked(r_err).scaled_axis();
        let w_des = Vector3::new(0.0, 0.0, reference.yaw_rate_cmd);
        let iw = est.rot * robot.inertia_body * est.rot.transpose();
        let ff = iw.try_inverse().map_or(Vector3::zeros(), |i| i * tau_sum);
        let mut a_ang = ff
            + ori_err.component_mul(&Vector3::from(cfg.body_kp_ori))
            + (w_des - est.omega).component_mul(&Vector3::from(cfg.body_kd_ang));
        if cfg.mpc.planar {
            a_ang.x = 0.0;
            a_ang.z = 0.0;
        }
        for d in 0..3 {
            inp.a_body[d] = a_lin[d];
            inp.a_body[3 + d] = a_ang[d];
        }
        let (kp, kd) = cfg.posture_gains;
        for (k, (&iq, &iv)) in robot.joint_q.iter().zip(&robot.joint_v).enumerate() {
            inp.qdd_posture[k] = kp * (robot.q_nominal[iq] - est.q[iq]) - kd * est.v[iv];
        }
        inp.weight = m * gvec.z.abs();
        self.wbc.set_joint_limit_bounds(est.q.as_slice(), est.v.as_slice());
        let t0 = Instant::now();
        let st = self.wbc.solve();
        status.wbc_solve_us = t0.elapsed().as_secs_f64() * 1e6;
        status.wbc_status = st;
        status.wbc_iterations = self.wbc.iterations();
        if self.wbc.limits_relaxed() {
            status.wbc_limit_relaxations += 1;
        }
        if !st.is_ok() {
            status.wbc_failures += 1;
            return false;
        }
        command.tau.copy_from_slice(&self.wbc.output.tau);
        for c in 0..nc {
            targets.force[c] = self.wbc.output.forces[c];
        }
        let inp = &self.wbc.input;
        for d in 0..6 {
            let mut a = inp.jdqd_body[d];
            for k in 0..robot.model.nv {
                a += inp.j_body[(d, k)] * self.wbc.output.qdd[k];
            }
            status.body_acceleration_target[d] = inp.a_body[d];
            status.body_acceleration_planned[d] = a;
        }
        true
    }

    /// Stance: `τ = −J_cᵀ f`; swing: `τ = J_cᵀ(K_p e + K_d ė)`; passive joints zeroed
    /// through the closure forces (least squares).
    fn cheap_path(&mut self, cx: &TickContext<'_>, targets: &LocomotionTargets, command: &mut JointCommand) {
        let (cfg, robot, est) = (cx.cfg, cx.robot, cx.est);
        let nv = robot.model.nv;
        let nc = robot.n_contacts();
        self.tau_full.fill(0.0);
        let (kp, kd) = cfg.cheap_swing_gains;
        for c in 0..nc {
            let f = if targets.stance[c] {
                -targets.force[c]
            } else {
                let tg = &targets.motion[c];
                (tg.p - est.p_contact[c]) * kp + (tg.v - est.v_contact[c]) * kd
            };
            for k in 0..nv {
                let j = &est.j_contact[c];
                self.tau_full[k] += j[(0, k)] * f.x + j[(1, k)] * f.y + j[(2, k)] * f.z;
            }
        }
        for &k in &robot.actuated_v {
            self.tau_full[k] += robot.model.damping[k] * est.v[k];
        }
        // Gravity compensation of the legs is left to the stance forces; passive joints:
        // find λ with (τ + J_lᵀ λ)_passive ≈ 0.
        let nl = robot.n_closure_rows;
        if nl > 0 && !self.passive_joint_v.is_empty() {
            let jl = &est.dynamics.j_closure;
            self.lam_a.fill(0.0);
            self.lam_b.fill(0.0);
            for &p in &self.passive_joint_v {
                for a in 0..nl {
                    self.lam_b[a] -= jl[(a, p)] * self.tau_full[p];
                    for b in 0..nl {
                        self.lam_a[b * nl + a] += jl[(a, p)] * jl[(b, p)];
                    }
                }
            }
            for a in 0..nl {
                self.lam_a[a * nl + a] += 1e-9;
            }
            if cholesky_in_place(&mut self.lam_a, nl) {
                cholesky_solve(&self.lam_a, nl, &mut self.lam_b);
                for k in 0..nv {
                    let mut s = 0.0;
                    for a in 0..nl {
                        s += jl[(a, k)] * self.lam_b[a];
                    }
                    self.tau_full[k] += s;
                }
            }
        }
        for (i, &iv) in robot.actuated_v.iter().enumerate() {
            let lim = robot.effort[i];
            command.tau[i] = self.tau_full[iv].clamp(-lim, lim);
        }
    }

    /// PD targets: damped-least-squares IK of all contact points (swing: their targets;
    /// stance: where they are) and closure rows, over the non-base joints.
    fn joint_targets(
        &mut self,
        cx: &TickContext<'_>,
        targets: &LocomotionTargets,
        command: &mut JointCommand,
    ) {
        let (cfg, robot, est) = (cx.cfg, cx.robot, cx.est);
        // Standing (the gait in force is stand), the whole-body QP alone holds the robot.
        let standing = cx.gait.pattern().gait == Gait::Stand;
        let nj = robot.joint_v.len();
        let nc = robot.n_contacts();
        let nl = robot.n_closure_rows;
        let lam2 = cfg.ik_damping * cfg.ik_damping;
        // A = JᵀJ + λ²I, b = Jᵀe over joint columns; then the same for velocities.
        for pass in 0..2 {
            self.ik_a[..nj * nj].fill(0.0);
            self.ik_b[..nj].fill(0.0);
            for c in 0..nc {
                let tg = &targets.motion[c];
                let e = if pass == 0 { tg.p - est.p_contact[c] } else { tg.v };
                let j = &est.j_contact[c];
                for (a, &va) in robot.joint_v.iter().enumerate() {
                    self.ik_b[a] += j[(0, va)] * e.x + j[(1, va)] * e.y + j[(2, va)] * e.z;
                    for (b, &vb) in robot.joint_v.iter().enumerate() {
                        self.ik_a[b * nj + a] +=
                            j[(0, va)] * j[(0, vb)] + j[(1, va)] * j[(1, vb)] + j[(2, va)] * j[(2, vb)];
                    }
                }
            }
            let jl = &est.dynamics.j_closure;
            for l in 0..nl {
                for (a, &va) in robot.joint_v.iter().enumerate() {
                    for (b, &vb) in robot.joint_v.iter().enumerate() {
                        self.ik_a[b * nj + a] += jl[(l, va)] * jl[(l, vb)];
                    }
                }
            }
            for a in 0..nj {
                self.ik_a[a * nj + a] += lam2;
            }
            if !cholesky_in_place(&mut self.ik_a[..nj * nj], nj) {
                return;
            }
            cholesky_solve(&self.ik_a[..nj * nj], nj, &mut self.ik_b[..nj]);
            for (i, &iv) in robot.actuated_v.iter().enumerate() {
                let a = robot.joint_v.iter().position(|&x| x == iv).unwrap_or(0);
                let iq = robot.actuated_q[i];
                if pass == 0 {
                    // A target beyond a position limit only presses the joint into it
                    // (max/min rather than clamp: no panic on a model built with NaN limits).
                    let (lo, hi) =
                        (robot.model.lower_position_limit[iq], robot.model.upper_position_limit[iq]);
                    command.q_des[i] = (est.q[iq] + self.ik_b[a]).max(lo).min(hi);
                } else {
                    command.qd_des[i] = self.ik_b[a];
                }
            }
        }
        // Gains: swing legs vs stance legs (a joint is "swing" if it moves a swing contact).
        for (i, &iv) in robot.actuated_v.iter().enumerate() {
            let mut swing = false;
            for c in 0..nc {
                if !targets.stance[c] {
                    let j = &est.j_contact[c];
                    if j[(0, iv)] != 0.0 || j[(1, iv)] != 0.0 || j[(2, iv)] != 0.0 {
                        swing = true;
                    }
                }
            }
            // Standing, the whole-body QP alone holds the robot; the stance PD targets only
            // carry a walking body over its feet.
            let (kp, kd) = if swing {
                cfg.swing_joint_gains
            } else if standing {
                (0.0, 0.0)
            } else {
                cfg.stance_joint_gains
            };
            command.kp[i] = kp;
            command.kd[i] = kd;
        }
    }
}

/// The horizontal direction a two-dof leg cannot follow, from a contact's linear Jacobian
/// `j` and the `v` indices of the non-base joints: with `M = Σⱼ jⱼ jⱼᵀ` over those
/// columns, a rank-2 `M` (`λ_min < 10⁻⁶ λ_max`) has a null eigenvector `n`, the direction
/// the foot cannot move in; its horizontal part (normalised, if `n` is mostly horizontal)
/// is returned, otherwise zero. Ant legs give the radial direction, Minitaur and Walker2d
/// legs the lateral one.
fn free_direction(j: &Matrix3xX<f64>, joint_v: &[usize]) -> Vector3<f64> {
    let mut m = Matrix3::zeros();
    for &k in joint_v {
        let col = Vector3::new(j[(0, k)], j[(1, k)], j[(2, k)]);
        m += col * col.transpose();
    }
    let eig = m.symmetric_eigen();
    let (mut i_min, mut i_max) = (0, 0);
    for i in 1..3 {
        if eig.eigenvalues[i] < eig.eigenvalues[i_min] {
            i_min = i;
        }
        if eig.eigenvalues[i] > eig.eigenvalues[i_max] {
            i_max = i;
        }
    }
    // (False for NaN data, which then gives no free direction.)
    let rank_two = eig.eigenvalues[i_min] < 1e-6 * eig.eigenvalues[i_max];
    if !rank_two {
        return Vector3::zeros();
    }
    let n = eig.eigenvectors.column(i_min);
    let h = Vector3::new(n[0], n[1], 0.0);
    if h.norm() < 0.5 { Vector3::zeros() } else { h.normalize() }
}
