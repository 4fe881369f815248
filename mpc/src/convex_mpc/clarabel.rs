//! The reference solver ([`super::MpcSolver::Clarabel`]): the sparse formulation handed to
//! Clarabel's generic interior point.
//!
//! Both states and forces are decision variables, `z = [x₁ … x_N, u₀ … u_{N−1}]` with the
//! full 13-entry state (gravity included), and every foot has variables and a cone at
//! every step: a foot predicted in swing has zero columns in `B_k`, so it cannot act on the
//! body and the `R` term drives its force to zero (reported forces of swing feet are
//! exactly zero). Constraint rows: the dynamics (`ZeroConeT`), `f_z ≤ f_max` and the hard
//! bounds (`NonnegativeConeT`), friction (`SecondOrderConeT(3)` with `s = (μ f_z, f_x, f_y)`,
//! or four pyramid rows).
//!
//! The problem is built once with every entry that may ever be non-zero stored explicitly
//! (Clarabel keeps explicit zeros from triplets), and each solve rewrites the values of `A`,
//! `q` and `b` in place (`update_A/q/b`, presolve off).

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SupportedConeT};
use nalgebra::{Matrix3, Vector3};

use super::problem::{MpcInput, NX, SrbModel, state_index};
use crate::error::ConfigError;
use crate::qp::QpStatus;

/// Clarabel and the problem's fixed sparsity.
pub(crate) struct ClarabelMpc {
    solver: DefaultSolver<f64>,
    // A in CSC with a fixed pattern: values in triplet order and their nzval positions.
    a_pos: Vec<usize>,
    a_nz: Vec<f64>,
    q: Vec<f64>,
    b: Vec<f64>,
    /// The diagonal of `P` (its values in CSC order) and the state weights it holds.
    pd: Vec<f64>,
    weights: [f64; 12],
}

impl ClarabelMpc {
    /// Builds the problem for `model` (nominal data: every foot in contact, so that the
    /// pattern is complete). Fails if Clarabel rejects the setup.
    pub(crate) fn new(model: &SrbModel, nominal: &MpcInput) -> Result<Self, ConfigError> {
        let cfg = &model.cfg;
        let (n, nc) = (cfg.horizon, model.nc);
        let n_var = n * NX + n * 3 * nc;
        let rows_dyn = n * NX;
        let rows_fmax = n * nc;
        let rows_hard =
            cfg.hard.max_height_drop.map_or(0, |_| n) + cfg.hard.terminal_velocity_band.map_or(0, |_| 4);
        let rows_pyr = if cfg.friction.is_pyramid() { 4 * n * nc } else { 0 };
        let rows_soc = if cfg.friction.is_pyramid() { 0 } else { 3 * n * nc };
        let m = rows_dyn + rows_fmax + rows_hard + rows_pyr + rows_soc;
        let (mut ri, mut ci, mut vi) = (Vec::new(), Vec::new(), Vec::new());
        emit_a(model, nominal, &mut |r, c, v| {
            ri.push(r);
            ci.push(c);
            vi.push(v);
        });
        let a = CscMatrix::new_from_triplets(m, n_var, ri.clone(), ci.clone(), vi);
        let a_pos = triplet_positions(&a, &ri, &ci);
        // P: diagonal (Q for states, R for forces).
        let mut pd = vec![0.0; n_var];
        for k in 0..n {
            for s in 0..12 {
                pd[k * NX + s] = 2.0 * cfg.state_weights[s];
            }
        }
        for v in pd.iter_mut().skip(n * NX) {
            *v = 2.0 * cfg.force_weight;
        }
        let idx: Vec<usize> = (0..n_var).collect();
        let p = CscMatrix::new_from_triplets(n_var, n_var, idx.clone(), idx, pd.clone());
        let mut q = vec![0.0; n_var];
        let mut b = vec![0.0; m];
        fill_qb(model, nominal, &mut q, &mut b);
        let mut cones = vec![SupportedConeT::ZeroConeT(rows_dyn)];
        cones.push(SupportedConeT::NonnegativeConeT(rows_fmax + rows_hard + rows_pyr));
        if rows_soc > 0 {
            for _ in 0..n * nc {
                cones.push(SupportedConeT::SecondOrderConeT(3));
            }
        }
        let settings = DefaultSettings::<f64> {
            verbose: false,
            presolve_enable: false,
            max_iter: cfg.max_iter,
            tol_gap_abs: cfg.tolerance,
            tol_gap_rel: cfg.tolerance,
            tol_feas: cfg.tolerance,
            max_threads: 1,
            ..Default::default()
        };
        let a_nz = a.nzval.clone();
        let solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings)
            .map_err(|source| ConfigError::Solver { problem: "convex MPC", source })?;
        Ok(ClarabelMpc { solver, a_pos, a_nz, q, b, pd, weights: cfg.state_weights })
    }

    /// Updates Clarabel with `input` and solves; on success writes forces and states.
    /// Returns the status, iterations, Clarabel's own solve time (s) and objective.
    pub(crate) fn solve(
        &mut self,
        model: &SrbModel,
        input: &MpcInput,
        forces: &mut [Vector3<f64>],
        states: &mut [[f64; NX]],
    ) -> (QpStatus, u32, f64, f64) {
        let mut t = 0usize;
        let (vals, pos) = (&mut self.a_nz, &self.a_pos);
        emit_a(model, input, &mut |_, _, v| {
            vals[pos[t]] = v;
            t += 1;
        });
        fill_qb(model, input, &mut self.q, &mut self.b);
        // New state weights (a controller's turn): rewrite P's state diagonal.
        let mut ok = true;
        if input.state_weights != self.weights {
            for k in 0..model.cfg.horizon {
                for (s, w) in input.state_weights.iter().enumerate() {
                    self.pd[k * NX + s] = 2.0 * w;
                }
            }
            ok = self.solver.update_P(&self.pd).is_ok();
            if ok {
                self.weights = input.state_weights;
            }
        }
        let ok = ok
            && self.solver.update_A(&self.a_nz).is_ok()
            && self.solver.update_q(&self.q).is_ok()
            && self.solver.update_b(&self.b).is_ok();
        if !ok {
            return (QpStatus::NumericalError, 0, 0.0, f64::NAN);
        }
        self.solver.solve();
        let sol = &self.solver.solution;
        let status = QpStatus::from_clarabel(sol.status);
        if status.is_ok() {
            let (n, nc) = (model.cfg.horizon, model.nc);
            for k in 0..n {
                states[k].copy_from_slice(&sol.x[k * NX..(k + 1) * NX]);
                for i in 0..nc {
                    let c = n * NX + (k * nc + i) * 3;
                    let mut f = Vector3::new(sol.x[c], sol.x[c + 1], sol.x[c + 2]);
                    if !input.contact[k][i] {
                        f = Vector3::zeros();
                    }
                    if model.cfg.planar {
                        f.y = 0.0;
                    }
                    forces[k * nc + i] = f;
                }
            }
        }
        (status, sol.iterations, sol.solve_time, sol.obj_val)
    }
}

/// Emits every entry of the constraint matrix, in a fixed order, from `input`.
fn emit_a(model: &SrbModel, input: &MpcInput, emit: &mut impl FnMut(usize, usize, f64)) {
    let cfg = &model.cfg;
    let (n, nc, dt) = (cfg.horizon, model.nc, cfg.dt);
    let ucol = |k: usize, i: usize| n * NX + (k * nc + i) * 3;
    for k in 0..n {
        let row = k * NX;
        // +x_{k+1}
        for s in 0..NX {
            emit(row + s, k * NX + s, 1.0);
        }
        let frame = model.step_frame(input, k);
        let rzt = frame.rzt;
        if k > 0 {
            // −A_d at x_k: −I − A_c Δt − A_c² Δt²/2.
            let col = (k - 1) * NX;
            for s in 0..NX {
                emit(row + s, col + s, -1.0);
            }
            for r in 0..3 {
                for cc in 0..3 {
                    emit(row + r, col + 6 + cc, -rzt[(r, cc)] * dt);
                }
            }
            for r in 0..3 {
                emit(row + 3 + r, col + 9 + r, -dt);
            }
            emit(row + 5, col + 12, -0.5 * dt * dt);
            emit(row + 11, col + 12, -dt);
        }
        // −B_d at u_k (zero columns for a foot in swing).
        for i in 0..nc {
            let cols = model.force_response(input, &frame, k, i).unwrap_or([[0.0; 12]; 3]);
            let col = ucol(k, i);
            for (cc, b) in cols.iter().enumerate() {
                for r in 0..3 {
                    emit(row + r, col + cc, -b[r]);
                }
                emit(row + 3 + cc, col + cc, -b[3 + cc]);
                for r in 0..3 {
                    emit(row + 6 + r, col + cc, -b[6 + r]);
                }
                emit(row + 9 + cc, col + cc, -b[9 + cc]);
            }
        }
    }
    // f_z ≤ f_max.
    let mut row = n * NX;
    for k in 0..n {
        for i in 0..nc {
            emit(row, ucol(k, i) + 2, 1.0);
            row += 1;
        }
    }
    // Hard constraints.
    if cfg.hard.max_height_drop.is_some() {
        for k in 0..n {
            emit(row, k * NX + state_index::POS + 2, -1.0);
            row += 1;
        }
    }
    if cfg.hard.terminal_velocity_band.is_some() {
        let col = (n - 1) * NX + state_index::VEL;
        for (d, sg) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)] {
            emit(row, col + d, sg);
            row += 1;
        }
    }
    // Friction.
    let mu = cfg.mu;
    if cfg.friction.is_pyramid() {
        let rows = crate::friction::pyramid_rows(cfg.friction.pyramid_mu(mu));
        for k in 0..n {
            for i in 0..nc {
                let col = ucol(k, i);
                for a in &rows {
                    for d in 0..3 {
                        emit(row, col + d, a[d]);
                    }
                    row += 1;
                }
            }
        }
    } else {
        // s = b − A z = (μ f_z, f_x, f_y) with b = 0.
        for k in 0..n {
            for i in 0..nc {
                let col = ucol(k, i);
                emit(row, col + 2, -mu);
                emit(row + 1, col, -1.0);
                emit(row + 2, col + 1, -1.0);
                row += 3;
            }
        }
    }
}

/// `q = −2 Q x_ref` and `b` (initial-state row, force limits, hard bounds).
fn fill_qb(model: &SrbModel, input: &MpcInput, q: &mut [f64], b: &mut [f64]) {
    let cfg = &model.cfg;
    let (n, nc) = (cfg.horizon, model.nc);
    for k in 0..n {
        for s in 0..12 {
            q[k * NX + s] = -2.0 * input.state_weights[s] * input.x_ref[k][s];
        }
        q[k * NX + 12] = 0.0;
    }
    for v in q.iter_mut().skip(n * NX) {
        *v = 0.0;
    }
    // b of the first dynamics block: A₀ x₀.
    b.fill(0.0);
    let x0 = input.x0;
    let dt = cfg.dt;
    let psi = x0[2];
    let (c, s) = (psi.cos(), psi.sin());
    let rzt = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
    let w = Vector3::new(x0[6], x0[7], x0[8]);
    let th = rzt * w * dt;
    b[..NX].copy_from_slice(&x0);
    for r in 0..3 {
        b[r] += th[r];
        b[3 + r] += x0[9 + r] * dt;
    }
    b[5] += 0.5 * dt * dt * x0[12];
    b[11] += dt * x0[12];
    let weight = model.mass * x0[12].abs();
    let fmax = cfg.max_normal_force_ratio * weight;
    let mut row = n * NX;
    for _ in 0..n * nc {
        b[row] = fmax;
        row += 1;
    }
    if let Some(dz) = cfg.hard.max_height_drop {
        for _ in 0..n {
            b[row] = -(x0[5] - dz);
            row += 1;
        }
    }
    if let Some(band) = cfg.hard.terminal_velocity_band {
        let v = &input.x_ref[n - 1];
        let vals = [v[9] + band, -v[9] + band, v[10] + band, -v[10] + band];
        for val in vals {
            b[row] = val;
            row += 1;
        }
    }
}

/// For each triplet, the index of its entry in `a.nzval`.
pub(crate) fn triplet_positions(a: &CscMatrix<f64>, r: &[usize], c: &[usize]) -> Vec<usize> {
    r.iter()
        .zip(c)
        .map(|(&row, &col)| {
            let (s, e) = (a.colptr[col], a.colptr[col + 1]);
            s + a.rowval[s..e].binary_search(&row).expect("entry in pattern")
        })
        .collect()
}
