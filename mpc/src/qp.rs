//! Solver outcomes and a small dense QP solver.
//!
//! [`DenseQp`] is the dual active-set method of Goldfarb & Idnani (1983), "A numerically
//! stable dual method for solving strictly convex quadratic programs" (as in `quadprog` and
//! `eiquadprog`, the solver of TSID), for
//!
//! ```text
//! minimise ½ xᵀ H x + gᵀ x   subject to   E x = e,   C x ≤ d,
//! ```
//!
//! with `H` symmetric positive definite. It starts at the unconstrained minimum
//! `x = −H⁻¹ g`, adds the equalities, then repeatedly adds the most violated inequality,
//! dropping active ones whose multipliers would turn negative; every step keeps the dual
//! feasible, so the method ends in a finite number of steps either optimal or with a
//! certificate that no primal-feasible point exists ([`QpStatus::PrimalInfeasible`]).
//! The factors are `J = L⁻ᵀ` (with `H = L Lᵀ`) updated by Givens rotations and an upper
//! triangular `R`, as in the paper. All buffers are allocated by [`DenseQp::new`].

/// Outcome of a QP solve (Clarabel's statuses, plus [`QpStatus::NotRun`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum QpStatus {
    /// No solve has happened (or the QP was skipped this tick).
    #[default]
    NotRun,
    /// Solved to the requested tolerance.
    Solved,
    /// Solved to the reduced tolerance.
    AlmostSolved,
    /// Certificate of primal infeasibility.
    PrimalInfeasible,
    /// Certificate of dual infeasibility (unbounded objective).
    DualInfeasible,
    /// Iteration limit reached.
    MaxIterations,
    /// Time limit reached.
    MaxTime,
    /// Numerical trouble (including non-finite problem data).
    NumericalError,
    /// The solver stopped making progress.
    InsufficientProgress,
    /// The solver is gone: the MPC's worker thread ([`crate::MpcExecution::Background`])
    /// ended after a panic inside a solve.
    SolverGone,
}

impl QpStatus {
    /// Whether the solution can be used.
    #[inline]
    pub fn is_ok(&self) -> bool {
        matches!(self, QpStatus::Solved | QpStatus::AlmostSolved)
    }

    /// From Clarabel's status.
    pub fn from_clarabel(s: clarabel::solver::SolverStatus) -> QpStatus {
        use clarabel::solver::SolverStatus as S;
        match s {
            S::Solved => QpStatus::Solved,
            S::AlmostSolved => QpStatus::AlmostSolved,
            S::PrimalInfeasible | S::AlmostPrimalInfeasible => QpStatus::PrimalInfeasible,
            S::DualInfeasible | S::AlmostDualInfeasible => QpStatus::DualInfeasible,
            S::MaxIterations => QpStatus::MaxIterations,
            S::MaxTime => QpStatus::MaxTime,
            S::NumericalError => QpStatus::NumericalError,
            S::InsufficientProgress => QpStatus::InsufficientProgress,
            S::Unsolved | S::CallbackTerminated => QpStatus::NotRun,
        }
    }
}

/// A dense QP `min ½xᵀHx + gᵀx, E x = e, C x ≤ d` in preallocated buffers (row-major
/// constraint rows; `H` column-major, both triangles).
#[derive(Clone, Debug)]
pub struct DenseQpData {
    /// Number of variables in use.
    pub n: usize,
    /// Number of equality rows in use.
    pub p: usize,
    /// Number of inequality rows in use.
    pub m: usize,
    /// `H`, `n × n` column-major with leading dimension `n` (the first `n²` entries).
    pub h: Vec<f64>,
    /// `g`.
    pub g: Vec<f64>,
    /// `E`, `p` rows of length `n`, row-major.
    pub e_mat: Vec<f64>,
    /// `e`.
    pub e: Vec<f64>,
    /// `C`, `m` rows of length `n`, row-major.
    pub c_mat: Vec<f64>,
    /// `d`.
    pub d: Vec<f64>,
}

impl DenseQpData {
    /// Buffers for up to `n_max` variables, `p_max` equalities and `m_max` inequalities.
    pub fn new(n_max: usize, p_max: usize, m_max: usize) -> Self {
        Self {
            n: 0,
            p: 0,
            m: 0,
            h: vec![0.0; n_max * n_max],
            g: vec![0.0; n_max],
            e_mat: vec![0.0; p_max * n_max],
            e: vec![0.0; p_max],
            c_mat: vec![0.0; m_max * n_max],
            d: vec![0.0; m_max],
        }
    }

    /// Sets the sizes and zeroes the used parts.
    #[track_caller]
    pub fn reset(&mut self, n: usize, p: usize, m: usize) {
        assert!(n * n <= self.h.len(), "QP has {n} variables, buffers hold {}", self.g.len());
        assert!(
            p * n <= self.e_mat.len() && p <= self.e.len(),
            "QP has {p} equalities, buffers hold {}",
            self.e.len()
        );
        assert!(
            m * n <= self.c_mat.len() && m <= self.d.len(),
            "QP has {m} inequalities, buffers hold {}",
            self.d.len()
        );
        self.n = n;
        self.p = p;
        self.m = m;
        self.h[..n * n].fill(0.0);
        self.g[..n].fill(0.0);
        self.e_mat[..p * n].fill(0.0);
        self.e[..p].fill(0.0);
        self.c_mat[..m * n].fill(0.0);
        self.d[..m].fill(0.0);
    }

    /// `H[(r, c)]`.
    #[inline]
    pub fn h_at(&mut self, r: usize, c: usize) -> &mut f64 {
        &mut self.h[c * self.n + r]
    }

    /// Row `i` of `E`.
    #[inline]
    pub fn e_row(&mut self, i: usize) -> &mut [f64] {
        let n = self.n;
        &mut self.e_mat[i * n..(i + 1) * n]
    }

    /// Row `i` of `C`.
    #[inline]
    pub fn c_row(&mut self, i: usize) -> &mut [f64] {
        let n = self.n;
        &mut self.c_mat[i * n..(i + 1) * n]
    }

    /// Whether every number in use is finite.
    pub fn is_finite(&self) -> bool {
        let (n, p, m) = (self.n, self.p, self.m);
        self.h[..n * n]
            .iter()
            .chain(&self.g[..n])
            .chain(&self.e_mat[..p * n])
            .chain(&self.e[..p])
            .chain(&self.c_mat[..m * n])
            .chain(&self.d[..m])
            .all(|x| x.is_finite())
    }

    /// Largest violation of the constraints at `x` (0 when feasible).
    pub fn max_violation(&self, x: &[f64]) -> f64 {
        let n = self.n;
        let mut v: f64 = 0.0;
        for i in 0..self.p {
            let r = dot(&self.e_mat[i * n..(i + 1) * n], &x[..n]) - self.e[i];
            v = v.max(r.abs());
        }
        for i in 0..self.m {
            let r = dot(&self.c_mat[i * n..(i + 1) * n], &x[..n]) - self.d[i];
            v = v.max(r);
        }
        v
    }
}

#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Goldfarb–Idnani dual active-set solver with preallocated workspace.
#[derive(Clone, Debug)]
pub struct DenseQp {
    n_max: usize,
    nc_max: usize,
    /// `J = L⁻ᵀ`, column-major `n × n`.
    j: Vec<f64>,
    /// Upper-triangular `R`, column-major `n × n`.
    r: Vec<f64>,
    x: Vec<f64>,
    x_old: Vec<f64>,
    z: Vec<f64>,
    dv: Vec<f64>,
    rv: Vec<f64>,
    np: Vec<f64>,
    u: Vec<f64>,
    u_old: Vec<f64>,
    active: Vec<isize>,
    active_old: Vec<isize>,
    s: Vec<f64>,
    iai: Vec<isize>,
    iaexcl: Vec<bool>,
    /// Maximum number of active-set changes per solve (default 1000).
    pub max_iter: usize,
    iterations: usize,
    objective: f64,
}

impl DenseQp {
    /// Workspace for up to `n_max` variables and `nc_max` constraints (equalities plus
    /// inequalities).
    pub fn new(n_max: usize, nc_max: usize) -> Self {
        Self {
            n_max,
            nc_max,
            j: vec![0.0; n_max * n_max],
            r: vec![0.0; n_max * n_max],
            x: vec![0.0; n_max],
            x_old: vec![0.0; n_max],
            z: vec![0.0; n_max],
            dv: vec![0.0; n_max],
            rv: vec![0.0; n_max + nc_max],
            np: vec![0.0; n_max],
            u: vec![0.0; n_max + nc_max + 1],
            u_old: vec![0.0; n_max + nc_max + 1],
            active: vec![0; n_max + nc_max + 1],
            active_old: vec![0; n_max + nc_max + 1],
            s: vec![0.0; nc_max],
            iai: vec![0; nc_max],
            iaexcl: vec![false; nc_max],
            max_iter: 1000,
            iterations: 0,
            objective: 0.0,
        }
    }

    /// The solution of the last successful solve (length `qp.n`).
    pub fn solution(&self) -> &[f64] {
        &self.x
    }

    /// Active-set changes in the last solve.
    pub fn iterations(&self) -> usize {
        self.iterations
    }

    /// Objective value `½xᵀHx + gᵀx` at the last solution.
    pub fn objective(&self) -> f64 {
        self.objective
    }

    /// Solves `qp`. `H` is overwritten by its Cholesky factor.
    #[track_caller]
    pub fn solve(&mut self, qp: &mut DenseQpData) -> QpStatus {
        let (n, p, m) = (qp.n, qp.p, qp.m);
        assert!(n <= self.n_max, "QP has {n} variables, the solver was built for {}", self.n_max);
        assert!(
            p + m <= self.nc_max,
            "QP has {} constraints, the solver was built for {}",
            p + m,
            self.nc_max
        );
        self.iterations = 0;
        if !qp.is_finite() {
            return QpStatus::NumericalError;
        }
        let eps = f64::EPSILON;
        // c1 = trace(H), used in the termination test.
        let c1: f64 = (0..n).map(|i| qp.h[i * n + i]).sum();
        // Cholesky H = L Lᵀ in place (lower triangle, column-major).
        if !cholesky_in_place(&mut qp.h[..n * n], n) {
            return QpStatus::NumericalError;
        }
        // J = L⁻ᵀ: column k of J is row k of L⁻¹.
        let j = &mut self.j;
        j[..n * n].fill(0.0);
        for col in 0..n {
            // Solve L y = e_col; y is column `col` of L⁻¹ → row `col` of J... J[k][col] = Linv[col][k]
            // Column c of L⁻¹ has entries rows ≥ c. J[c][row] = Linv[row][c].
            let y = &mut self.z;
            y[..n].fill(0.0);
            y[col] = 1.0;
            for r in col..n {
                let mut s = y[r];
                for k in col..r {
                    s -= qp.h[k * n + r] * y[k];
                }
                y[r] = s / qp.h[r * n + r];
            }
            for r in col..n {
                // J(col, r) = L⁻¹(r, col); column-major J: index r * n + col.
                j[r * n + col] = y[r];
            }
        }
        let c2: f64 = (0..n).map(|i| j[i * n + i]).sum();
        // x = −H⁻¹ g = −J Jᵀ g.
        for c in 0..n {
            self.dv[c] = dot(&j[c * n..(c + 1) * n], &qp.g[..n]);
        }
        for r in 0..n {
            let mut s = 0.0;
            for c in 0..n {
                s += j[c * n + r] * self.dv[c];
            }
            self.x[r] = -s;
        }
        let mut f = 0.5 * dot(&qp.g[..n], &self.x[..n]);
        let mut iq = 0usize;
        let mut r_norm = 1.0f64;
        self.r[..n * n].fill(0.0);

        // Equalities E x = e, i.e. CEᵀx + ce0 = 0 with CE column = E row, ce0 = −e.
        for i in 0..p {
            self.np[..n].copy_from_slice(&qp.e_mat[i * n..(i + 1) * n]);
            self.compute_d(n);
            self.update_z(n, iq);
            self.update_r(n, iq);
            let zz = dot(&self.z[..n], &self.z[..n]);
            let znp = dot(&self.z[..n], &self.np[..n]);
            let mut t2 = 0.0;
            if zz.abs() > eps {
                t2 = (qp.e[i] - dot(&self.np[..n], &self.x[..n])) / znp;
            }
            for k in 0..n {
                self.x[k] += t2 * self.z[k];
            }
            self.u[iq] = t2;
            for k in 0..iq {
                self.u[k] -= t2 * self.rv[k];
            }
            f += 0.5 * t2 * t2 * znp;
            self.active[i] = -(i as isize) - 1;
            if !self.add_constraint(n, &mut iq, &mut r_norm) {
                // Linearly dependent equalities.
                return QpStatus::PrimalInfeasible;
            }
        }
        for i in 0..m {
            self.iai[i] = i as isize;
        }
        let mut ip = 0usize;
        'l1: loop {
            self.iterations += 1;
            if self.iterations > self.max_iter {
                return QpStatus::MaxIterations;
            }
            for i in p..iq {
                let a = self.active[i] as usize;
                self.iai[a] = -1;
            }
            // Slacks s = d − C x ≥ 0 (CIᵀx + ci0 with CI column = −C row, ci0 = d).
            let mut psi = 0.0;
            for i in 0..m {
                self.iaexcl[i] = true;
                let s = qp.d[i] - dot(&qp.c_mat[i * n..(i + 1) * n], &self.x[..n]);
                self.s[i] = s;
                psi += s.min(0.0);
            }
            if psi.abs() <= (m as f64) * eps * c1 * c2 * 100.0 {
                break 'l1;
            }
            self.u_old[..iq].copy_from_slice(&self.u[..iq]);
            self.active_old[..iq].copy_from_slice(&self.active[..iq]);
            self.x_old[..n].copy_from_slice(&self.x[..n]);
            'l2: loop {
                // Most violated inequality not yet active nor excluded.
                let mut ss = 0.0;
                for i in 0..m {
                    if self.s[i] < ss && self.iai[i] != -1 && self.iaexcl[i] {
                        ss = self.s[i];
                        ip = i;
                    }
                }
                if ss >= 0.0 {
                    break 'l1;
                }
                for k in 0..n {
                    self.np[k] = -qp.c_mat[ip * n + k];
                }
                self.u[iq] = 0.0;
                self.active[iq] = ip as isize;
                'l2a: loop {
                    self.iterations += 1;
                    if self.iterations > self.max_iter {
                        return QpStatus::MaxIterations;
                    }
                    self.compute_d(n);
                    self.update_z(n, iq);
                    self.update_r(n, iq);
                    // Dual step length t1 (blocking active inequality l), primal t2.
                    let mut l = 0usize;
                    let mut t1 = f64::INFINITY;
                    for k in p..iq {
                        if self.rv[k] > 0.0 {
                            let t = self.u[k] / self.rv[k];
                            if t < t1 {
                                t1 = t;
                                l = self.active[k] as usize;
                            }
                        }
                    }
                    let zz = dot(&self.z[..n], &self.z[..n]);
                    let znp = dot(&self.z[..n], &self.np[..n]);
                    let t2 = if zz.abs() > eps { -self.s[ip] / znp } else { f64::INFINITY };
                    let t = t1.min(t2);
                    if !t.is_finite() {
                        // No step in primal or dual space: the constraints are inconsistent.
                        return QpStatus::PrimalInfeasible;
                    }
                    if !t2.is_finite() {
                        // Step in dual space only, then drop the blocking constraint.
                        for k in 0..iq {
                            self.u[k] -= t * self.rv[k];
                        }
                        self.u[iq] += t;
                        self.iai[l] = l as isize;
                        self.delete_constraint(n, p, &mut iq, l);
                        continue 'l2a;
                    }
                    for k in 0..n {
                        self.x[k] += t * self.z[k];
                    }
                    f += t * znp * (0.5 * t + self.u[iq]);
                    for k in 0..iq {
                        self.u[k] -= t * self.rv[k];
                    }
                    self.u[iq] += t;
                    if t == t2 {
                        // Full step: add constraint ip.
                        if !self.add_constraint(n, &mut iq, &mut r_norm) {
                            self.iaexcl[ip] = false;
                            self.delete_constraint(n, p, &mut iq, ip);
                            for i in 0..m {
                                self.iai[i] = i as isize;
                            }
                            for i in 0..iq {
                                self.active[i] = self.active_old[i];
                                if self.active[i] >= 0 {
                                    let a = self.active[i] as usize;
                                    self.iai[a] = -1;
                                }
                                self.u[i] = self.u_old[i];
                            }
                            self.x[..n].copy_from_slice(&self.x_old[..n]);
                            continue 'l2;
                        }
                        self.iai[ip] = -1;
                        continue 'l1;
                    }
                    // Partial step: drop the blocking constraint and retry ip.
                    self.iai[l] = l as isize;
                    self.delete_constraint(n, p, &mut iq, l);
                    self.s[ip] = qp.d[ip] - dot(&qp.c_mat[ip * n..(ip + 1) * n], &self.x[..n]);
                }
            }
        }
        self.objective = f;
        if self.x[..n].iter().all(|v| v.is_finite()) { QpStatus::Solved } else { QpStatus::NumericalError }
    }

    /// `d = Jᵀ np`.
    fn compute_d(&mut self, n: usize) {
        for c in 0..n {
            self.dv[c] = dot(&self.j[c * n..(c + 1) * n], &self.np[..n]);
        }
    }

    /// `z = J[:, iq..] d[iq..]`.
    fn update_z(&mut self, n: usize, iq: usize) {
        self.z[..n].fill(0.0);
        for c in iq..n {
            let dc = self.dv[c];
            let col = &self.j[c * n..(c + 1) * n];
            for (zk, jk) in self.z[..n].iter_mut().zip(col) {
                *zk += jk * dc;
            }
        }
    }

    /// `r = R[..iq, ..iq]⁻¹ d[..iq]` (back substitution).
    fn update_r(&mut self, n: usize, iq: usize) {
        for i in (0..iq).rev() {
            let mut s = self.dv[i];
            for k in (i + 1)..iq {
                s -= self.r[k * n + i] * self.rv[k];
            }
            self.rv[i] = s / self.r[i * n + i];
        }
    }

    /// Appends `d` to `R` after rotating it to `(d₀…d_iq, 0…0)` with Givens rotations that
    /// are also applied to `J`. Returns `false` if the new constraint is linearly dependent.
    fn add_constraint(&mut self, n: usize, iq: &mut usize, r_norm: &mut f64) -> bool {
        let d = &mut self.dv;
        let jm = &mut self.j;
        let mut jj = n;
        while jj > *iq + 1 {
            let j = jj - 1;
            let mut cc = d[j - 1];
            let mut ss = d[j];
            let h = cc.hypot(ss);
            jj -= 1;
            if h == 0.0 {
                continue;
            }
            d[j] = 0.0;
            ss /= h;
            cc /= h;
            if cc < 0.0 {
                cc = -cc;
                ss = -ss;
                d[j - 1] = -h;
            } else {
                d[j - 1] = h;
            }
            let xny = ss / (1.0 + cc);
            for k in 0..n {
                let t1 = jm[(j - 1) * n + k];
                let t2 = jm[j * n + k];
                let a = t1 * cc + t2 * ss;
                jm[(j - 1) * n + k] = a;
                jm[j * n + k] = xny * (t1 + a) - t2;
            }
        }
        *iq += 1;
        let col = *iq - 1;
        for i in 0..*iq {
            self.r[col * n + i] = d[i];
        }
        if d[col].abs() <= f64::EPSILON * *r_norm {
            return false;
        }
        *r_norm = r_norm.max(d[col].abs());
        true
    }

    /// Removes inequality `l` from the active set and restores `R` to triangular form.
    fn delete_constraint(&mut self, n: usize, p: usize, iq: &mut usize, l: usize) {
        let mut qq = p;
        for i in p..*iq {
            if self.active[i] == l as isize {
                qq = i;
                break;
            }
        }
        for i in qq..(*iq - 1) {
            self.active[i] = self.active[i + 1];
            self.u[i] = self.u[i + 1];
            for k in 0..n {
                self.r[i * n + k] = self.r[(i + 1) * n + k];
            }
        }
        self.active[*iq - 1] = self.active[*iq];
        self.u[*iq - 1] = self.u[*iq];
        self.active[*iq] = 0;
        self.u[*iq] = 0.0;
        for k in 0..*iq {
            self.r[(*iq - 1) * n + k] = 0.0;
        }
        *iq -= 1;
        if *iq == 0 {
            return;
        }
        for j in qq..*iq {
            let mut cc = self.r[j * n + j];
            let mut ss = self.r[j * n + j + 1];
            let h = cc.hypot(ss);
            if h == 0.0 {
                continue;
            }
            cc /= h;
            ss /= h;
            self.r[j * n + j + 1] = 0.0;
            if cc < 0.0 {
                self.r[j * n + j] = -h;
                cc = -cc;
                ss = -ss;
            } else {
                self.r[j * n + j] = h;
            }
            let xny = ss / (1.0 + cc);
            for k in (j + 1)..*iq {
                let t1 = self.r[k * n + j];
                let t2 = self.r[k * n + j + 1];
                let a = t1 * cc + t2 * ss;
                self.r[k * n + j] = a;
                self.r[k * n + j + 1] = xny * (t1 + a) - t2;
            }
            for k in 0..n {
                let t1 = self.j[j * n + k];
                let t2 = self.j[(j + 1) * n + k];
                let a = t1 * cc + t2 * ss;
                self.j[j * n + k] = a;
                self.j[(j + 1) * n + k] = xny * (a + t1) - t2;
            }
        }
    }
}

/// In-place Cholesky `A = L Lᵀ` of a column-major `n × n` matrix (lower triangle written,
/// upper left as is). Returns `false` if `A` is not positive definite.
pub fn cholesky_in_place(a: &mut [f64], n: usize) -> bool {
    for c in 0..n {
        let mut d = a[c * n + c];
        for k in 0..c {
            d -= a[k * n + c] * a[k * n + c];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let d = d.sqrt();
        a[c * n + c] = d;
        for r in (c + 1)..n {
            let mut s = a[c * n + r];
            for k in 0..c {
                s -= a[k * n + r] * a[k * n + c];
            }
            a[c * n + r] = s / d;
        }
    }
    true
}

/// Solves `L Lᵀ x = b` in place with the factor of [`cholesky_in_place`].
pub fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
    for r in 0..n {
        let mut s = b[r];
        for k in 0..r {
            s -= l[k * n + r] * b[k];
        }
        b[r] = s / l[r * n + r];
    }
    for r in (0..n).rev() {
        let mut s = b[r];
        for k in (r + 1)..n {
            s -= l[r * n + k] * b[k];
        }
        b[r] = s / l[r * n + r];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn qp2(h: [[f64; 2]; 2], g: [f64; 2]) -> DenseQpData {
        let mut q = DenseQpData::new(2, 4, 4);
        q.reset(2, 0, 0);
        for r in 0..2 {
            for c in 0..2 {
                *q.h_at(r, c) = h[r][c];
            }
        }
        q.g[..2].copy_from_slice(&g);
        q
    }

    #[test]
    fn unconstrained_minimum() {
        // min ½(2x² + 2y²) − 2x − 4y → x = 1, y = 2.
        let mut q = qp2([[2.0, 0.0], [0.0, 2.0]], [-2.0, -4.0]);
        let mut s = DenseQp::new(2, 8);
        assert_eq!(s.solve(&mut q), QpStatus::Solved);
        assert!((s.solution()[0] - 1.0).abs() < 1e-12 && (s.solution()[1] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn equality_and_inequality() {
        // min x² + y² s.t. x + y = 1 → (½, ½); then add x ≤ 0.2 → (0.2, 0.8).
        let mut q = qp2([[2.0, 0.0], [0.0, 2.0]], [0.0, 0.0]);
        q.reset(2, 1, 1);
        *q.h_at(0, 0) = 2.0;
        *q.h_at(1, 1) = 2.0;
        q.e_row(0).copy_from_slice(&[1.0, 1.0]);
        q.e[0] = 1.0;
        q.c_row(0).copy_from_slice(&[1.0, 0.0]);
        q.d[0] = 0.2;
        let mut s = DenseQp::new(2, 8);
        assert_eq!(s.solve(&mut q), QpStatus::Solved);
        let x = s.solution();
        assert!((x[0] - 0.2).abs() < 1e-12 && (x[1] - 0.8).abs() < 1e-12, "{x:?}");
        // Objective 0.04 + 0.64 = 0.68.
        assert!((s.objective() - 0.68).abs() < 1e-12);
    }

    #[test]
    fn infeasible_box_is_reported() {
        // x ≤ −1 and −x ≤ −1 (x ≥ 1): no feasible point.
        let mut q = qp2([[1.0, 0.0], [0.0, 1.0]], [0.0, 0.0]);
        q.reset(2, 0, 2);
        *q.h_at(0, 0) = 1.0;
        *q.h_at(1, 1) = 1.0;
        q.c_row(0).copy_from_slice(&[1.0, 0.0]);
        q.d[0] = -1.0;
        q.c_row(1).copy_from_slice(&[-1.0, 0.0]);
        q.d[1] = -1.0;
        let mut s = DenseQp::new(2, 8);
        assert_eq!(s.solve(&mut q), QpStatus::PrimalInfeasible);
    }

    #[test]
    fn non_finite_data_is_a_numerical_error() {
        let mut q = qp2([[1.0, 0.0], [0.0, f64::NAN]], [0.0, 0.0]);
        let mut s = DenseQp::new(2, 8);
        assert_eq!(s.solve(&mut q), QpStatus::NumericalError);
    }

    #[test]
    fn cholesky_solves() {
        // A = [[4, 2], [2, 3]], b = [2, 1] → x = [0.5, 0].
        let mut a = vec![4.0, 2.0, 2.0, 3.0];
        assert!(cholesky_in_place(&mut a, 2));
        let mut b = [2.0, 1.0];
        cholesky_solve(&a, 2, &mut b);
        assert!((b[0] - 0.5).abs() < 1e-15 && b[1].abs() < 1e-15);
    }
}
