//! Stage 4, the plan: the convex MPC over the horizon (solved in the tick, or on the
//! controller's worker thread), and the contact forces it gives for this tick, with the
//! fallbacks when it fails.

use centaur_dynamics::nalgebra::Vector3;

use super::reference::wrap_pi;
use super::status::{ControllerStatus, Fallback};
use super::targets::{LocomotionTargets, TickContext};
use crate::background::{BackgroundMpc, MpcPlan, Poll};
use crate::config::{ControllerConfig, MpcExecution, while_turning};
use crate::convex_mpc::{ConvexMpc, NX};
use crate::error::ConfigError;
use crate::gait::MAX_LEGS;
use crate::qp::QpStatus;
use crate::robot::LeggedRobot;

/// The convex MPC, solved in `tick` or on a worker thread.
#[allow(clippy::large_enum_variant)] // one per controller, never moved in a hot path
enum MpcRunner {
    Inline { mpc: ConvexMpc, plan: MpcPlan },
    Background(BackgroundMpc),
}

/// The MPC and the plan in use.
pub(crate) struct Planner {
    mpc: MpcRunner,
    /// Forces of the plan in use, `horizon × contacts` (world, N).
    plan_forces: Vec<Vector3<f64>>,
    plan_valid: bool,
    /// Time of the state the plan in use starts from.
    plan_t: f64,
    last_mpc_t: Option<f64>,
    consecutive_failures: u32,
    /// Stance per leg over the horizon (row 0: now).
    pub schedule: Vec<[bool; MAX_LEGS]>,
}

impl Planner {
    pub(crate) fn new(cfg: &ControllerConfig, robot: &LeggedRobot) -> Result<Self, ConfigError> {
        let nc = robot.n_contacts();
        let h = cfg.mpc.horizon;
        let mpc = ConvexMpc::new(&cfg.mpc, nc, robot.mass, robot.inertia_body)?;
        let mpc = match cfg.mpc_execution {
            MpcExecution::Inline => MpcRunner::Inline { mpc, plan: MpcPlan::new(h, nc) },
            MpcExecution::Background => MpcRunner::Background(BackgroundMpc::start(mpc, h, nc)?),
        };
        Ok(Planner {
            mpc,
            plan_forces: vec![Vector3::zeros(); h * nc],
            plan_valid: false,
            plan_t: 0.0,
            last_mpc_t: None,
            consecutive_failures: 0,
            schedule: vec![[false; MAX_LEGS]; h + 1],
        })
    }

    /// The MPC when it is solved in the tick.
    pub(crate) fn mpc(&self) -> Option<&ConvexMpc> {
        match &self.mpc {
            MpcRunner::Inline { mpc, .. } => Some(mpc),
            MpcRunner::Background(_) => None,
        }
    }

    /// Drops the plan (an episode reset), and any plan the worker solves for the old state.
    pub(crate) fn reset(&mut self) {
        self.plan_valid = false;
        self.last_mpc_t = None;
        self.consecutive_failures = 0;
        if let MpcRunner::Background(bg) = &mut self.mpc {
            bg.reset();
        }
    }

    /// Adopts a plan the worker finished, solves the MPC if one is due (every
    /// `mpc_period`, at a gait change, or without a plan), and writes this tick's forces
    /// into `out.force`.
    pub(crate) fn update(
        &mut self,
        cx: &TickContext<'_>,
        gait_changed: bool,
        out: &mut LocomotionTargets,
        status: &mut ControllerStatus,
    ) {
        let (cfg, t) = (cx.cfg, cx.t);
        // (A plan whose state is later than now, from before time went back, is dropped.)
        if let MpcRunner::Background(bg) = &mut self.mpc
            && bg.poll(false) == Poll::Plan
            && bg.latest.t <= t
        {
            self.adopt_plan(status);
        }
        let due = self.last_mpc_t.is_none_or(|t0| t - t0 >= cfg.mpc_period - 1e-9 || t < t0);
        if due || gait_changed || !self.plan_valid {
            self.run_mpc(cx, out, status);
        }
        self.current_forces(cx, out, status);
    }

    fn run_mpc(&mut self, cx: &TickContext<'_>, targets: &LocomotionTargets, status: &mut ControllerStatus) {
        let (cfg, robot, est, reference, gait) = (cx.cfg, cx.robot, cx.est, cx.reference, cx.gait);
        let (t, height) = (cx.t, cx.height);
        let h = cfg.mpc.horizon;
        let dt = cfg.mpc.dt;
        let nc = robot.n_contacts();
        let planar = cfg.mpc.planar;
        gait.contact_schedule(dt, &mut self.schedule);
        let inp = match &mut self.mpc {
            MpcRunner::Inline { mpc, .. } => &mut mpc.input,
            MpcRunner::Background(bg) => &mut bg.staging,
        };
        let (yaw_ref, yaw_rate_cmd, p_ref, v_cmd) =
            (reference.yaw_ref, reference.yaw_rate_cmd, reference.p_ref, reference.v_cmd);
        let mut x0 = [0.0; NX];
        let yaw = yaw_ref + wrap_pi(est.rpy.z - yaw_ref);
        x0[0] = est.rpy.x;
        x0[1] = est.rpy.y;
        x0[2] = yaw;
        x0[3..6].copy_from_slice(est.com.as_slice());
        x0[6..9].copy_from_slice(est.omega.as_slice());
        x0[9..12].copy_from_slice(est.com_vel.as_slice());
        x0[12] = robot.model.gravity.z;
        if planar {
            x0[0] = 0.0;
            x0[2] = 0.0;
            x0[6] = 0.0;
            x0[8] = 0.0;
            x0[10] = 0.0;
        }
        inp.x0 = x0;
        inp.state_weights = cfg.mpc_state_weights(gait.pattern().gait);
        inp.state_weights[8] =
            while_turning(gait.pattern().stagger != 0.0, cfg.turn_yaw_rate_weight, inp.state_weights[8]);
        for k in 0..h {
            let tk = (k + 1) as f64 * dt;
            let r = &mut inp.x_ref[k];
            r.fill(0.0);
            r[2] = if planar { 0.0 } else { yaw_ref + yaw_rate_cmd * tk };
            r[3] = p_ref.x + v_cmd.x * tk;
            r[4] = if planar { x0[4] } else { p_ref.y + v_cmd.y * tk };
            r[5] = height;
            r[8] = yaw_rate_cmd;
            r[9] = v_cmd.x;
            r[10] = v_cmd.y;
            r[12] = x0[12];
        }
        for k in 0..h {
            for ci in 0..nc {
                let leg = robot.contact_leg[ci];
                // Now: the effective contact; later: the schedule.
                let on_at = |j: usize| if j == 0 { targets.stance[ci] } else { self.schedule[j][leg] };
                let on = on_at(k);
                inp.contact[k][ci] = on;
                // Current position while the stance that holds now lasts; afterwards the
                // planned foothold (shifted by the commanded motion for later stances).
                let continuous = (0..=k).all(on_at);
                inp.foot[k][ci] = if continuous { est.p_contact[ci] } else { targets.next_foothold[ci] };
                if planar {
                    inp.foot[k][ci].y = x0[4];
                }
            }
        }
        self.last_mpc_t = Some(t);
        match &mut self.mpc {
            MpcRunner::Inline { mpc, plan } => {
                status.mpc_blocked = true;
                plan.solve(mpc, t, h, nc);
            }
            MpcRunner::Background(bg) => {
                if bg.gone() {
                    self.solver_gone(status);
                    return;
                }
                bg.submit(t);
                if self.plan_valid {
                    return; // follow the current plan until this one is ready
                }
                // Never had a feasible plan: wait for one.
                status.mpc_blocked = true;
                match bg.poll(true) {
                    Poll::Plan if bg.latest.t <= t => {}
                    Poll::Plan | Poll::Nothing => return,
                    Poll::Gone => {
                        self.solver_gone(status);
                        return;
                    }
                }
            }
        }
        self.adopt_plan(status);
    }

    /// The MPC's worker thread has ended: a failed solve, every time one is due.
    fn solver_gone(&mut self, status: &mut ControllerStatus) {
        status.mpc_status = QpStatus::SolverGone;
        status.mpc_failures += 1;
        self.consecutive_failures += 1;
    }

    /// Takes the plan last solved (in this thread or on the worker) into use.
    fn adopt_plan(&mut self, status: &mut ControllerStatus) {
        let plan = match &self.mpc {
            MpcRunner::Inline { plan, .. } => plan,
            MpcRunner::Background(bg) => &bg.latest,
        };
        status.mpc_solve_us = plan.solve_us;
        status.mpc_status = plan.status;
        status.mpc_iterations = plan.iterations;
        status.mpc_ran = true;
        if plan.status.is_ok() {
            self.plan_forces.copy_from_slice(&plan.forces);
            status.planned_com.copy_from_slice(&plan.com);
            self.plan_valid = true;
            self.plan_t = plan.t;
            self.consecutive_failures = 0;
        } else {
            status.mpc_failures += 1;
            self.consecutive_failures += 1;
        }
    }

    /// Forces for this tick from the plan (or the fallback).
    fn current_forces(
        &mut self,
        cx: &TickContext<'_>,
        out: &mut LocomotionTargets,
        status: &mut ControllerStatus,
    ) {
        let (cfg, robot, t) = (cx.cfg, cx.robot, cx.t);
        let nc = robot.n_contacts();
        let h = cfg.mpc.horizon;
        let n_stance = out.stance.iter().filter(|c| **c).count();
        let weight = robot.mass * robot.model.gravity.z.abs();
        let k = (((t - self.plan_t) / cfg.mpc.dt).floor().max(0.0) as usize).min(h - 1);
        let use_plan = self.plan_valid && t - self.plan_t < h as f64 * cfg.mpc.dt;
        let scale = if self.consecutive_failures > 0 {
            status.fallback = Fallback::MpcForces;
            cfg.fallback_decay.powi(self.consecutive_failures as i32)
        } else {
            1.0
        };
        for c in 0..nc {
            let stance = out.stance[c];
            let mut f = Vector3::zeros();
            if stance {
                let planned = if use_plan { self.plan_forces[k * nc + c] } else { Vector3::zeros() };
                f = if planned.z > 1e-6 {
                    planned * scale
                } else {
                    // No plan, or the plan thought this foot was in the air: share the weight.
                    if !use_plan {
                        status.fallback = Fallback::MpcForces;
                    }
                    Vector3::new(0.0, 0.0, weight / n_stance.max(1) as f64)
                };
            }
            out.force[c] = f;
            status.mpc_forces[c] = [f.x, f.y, f.z];
        }
    }
}
