//! `tick` allocates nothing after construction (counting global allocator). With the
//! default solvers — the structured MPC and the dense whole-body QP — no tick allocates at
//! all. Clarabel, where chosen (`MpcSolver::Clarabel`, `QpBackend::Clarabel`), makes one
//! small allocation inside every solve: Clarabel 0.11 resets its internal timer tree at the
//! start of `solve()`, dropping the nested `HashMap` of sub-timers and re-creating it
//! (`timers.rs`, `reset_timer("solve")`), which no setting turns off; for it the test proves
//! zero allocations on ticks without a Clarabel solve and at most one per Clarabel solve.
//! With the MPC on its worker thread (`MpcExecution::Background`) that solve allocates
//! there: the ticking thread allocates nothing at all. (Allocations are counted per
//! thread.)

mod common;

use std::time::{Duration, Instant};

use centaur_mpc::{Command, Gait, LocomotionController, MpcExecution, MpcSolver, QpBackend};
use centaur_test_support::{CountingAllocator, allocations};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Allocations this thread makes inside `f`.
fn counted(f: impl FnOnce()) -> usize {
    allocations(f)
}

/// Counts of one run of ticks.
struct Counts {
    /// Allocations on ticks without a Clarabel solve, and on ticks with one.
    quiet: usize,
    loud: usize,
    /// Clarabel solves, and MPC plans run or adopted.
    clarabel_solves: usize,
    plans: usize,
}

fn count_ticks(name: &str, solver: MpcSolver, backend: QpBackend, exec: MpcExecution) -> Counts {
    let (model, mut cfg) = common::load(name);
    cfg.mpc.solver = solver;
    cfg.wbc.backend = backend;
    cfg.mpc_execution = exec;
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    // Warm up once (first MPC solve), then count over gait changes and a NaN state.
    c.tick(&s, &Command::stand(), 0.0);
    let mut bad = s.clone();
    bad.q[0] = f64::NAN;
    let (mut quiet, mut loud, mut solves, mut plans) = (0, 0, 0, 0);
    let mut t = 0.0;
    // Ticks, counting allocations; returns whether the tick ran (or adopted) an MPC plan.
    let mut run = |c: &mut LocomotionController, state, cmd: &Command, t: f64| {
        let n = counted(|| {
            c.tick(state, cmd, t);
        });
        let st = c.status();
        let clarabel = usize::from(st.mpc_ran && solver == MpcSolver::Clarabel)
            + usize::from(backend == QpBackend::Clarabel && st.wbc_status != centaur_mpc::QpStatus::NotRun);
        if clarabel == 0 {
            quiet += n;
        } else {
            loud += n;
            solves += clarabel;
        }
        plans += usize::from(st.mpc_ran);
        st.mpc_ran
    };
    // On the worker thread a plan arrives after a solve's wall time, not after a number of
    // ticks: pace the ticks a little, and keep ticking (bounded) until one has been adopted,
    // so that the count does not depend on the machine's load.
    let background = exec == MpcExecution::Background;
    let pace = || {
        if background {
            std::thread::sleep(Duration::from_micros(100));
        }
    };
    let mut adopted = false;
    for (k, gait) in [Gait::Stand, Gait::Trot, Gait::Walk, Gait::Trot].iter().enumerate() {
        for _ in 0..150 {
            t += 0.002;
            adopted |= run(&mut c, &s, &Command::forward(0.3 * k as f64, *gait), t);
            pace();
        }
    }
    let start = Instant::now();
    while background && !adopted && start.elapsed() < Duration::from_secs(30) {
        t += 0.002;
        adopted |= run(&mut c, &s, &Command::stand(), t);
        std::thread::sleep(Duration::from_millis(1));
    }
    run(&mut c, &bad, &Command::stand(), t + 0.001);
    Counts { quiet, loud, clarabel_solves: solves, plans }
}

#[test]
fn tick_does_not_allocate() {
    // The default solvers: nothing at all, MPC solves included.
    for name in ["solo12", "ant", "minitaur", "walker2d", "humanoid"] {
        let n = count_ticks(name, MpcSolver::Structured, QpBackend::Dense, MpcExecution::Inline);
        assert!(n.plans > 0 && n.clarabel_solves == 0);
        assert_eq!((n.quiet, n.loud), (0, 0), "{name}: allocations with the default solvers");
    }
    // Clarabel for the MPC: at most one allocation per solve, none outside.
    for name in ["solo12", "walker2d"] {
        let n = count_ticks(name, MpcSolver::Clarabel, QpBackend::Dense, MpcExecution::Inline);
        assert_eq!(n.quiet, 0, "{name} (Clarabel MPC): allocations outside Clarabel");
        let (loud, solves) = (n.loud, n.clarabel_solves);
        assert!(solves > 0 && loud <= solves, "{name}: {loud} allocations in {solves} Clarabel solves");
    }
    // With the Clarabel WBC each of the 16 per-stance-pattern solvers also fills its timer
    // map on its first solve.
    let n = count_ticks("solo12", MpcSolver::Structured, QpBackend::Clarabel, MpcExecution::Inline);
    let (loud, solves) = (n.loud, n.clarabel_solves);
    assert_eq!(n.quiet, 0);
    assert!(loud <= solves + 16, "solo12 (Clarabel WBC): {loud} allocations in {solves} Clarabel solves");
}

#[test]
fn with_the_mpc_on_its_worker_thread_tick_never_allocates() {
    // The first tick, which waits for the worker's first plan, included.
    let (model, mut cfg) = common::load("solo12");
    cfg.mpc_execution = MpcExecution::Background;
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    let n = counted(|| {
        c.tick(&s, &Command::stand(), 0.0);
    });
    assert!(c.status().mpc_blocked && c.status().mpc_status.is_ok());
    assert_eq!(n, 0, "the first (waiting) tick allocated");
    for name in ["solo12", "minitaur", "walker2d"] {
        let n = count_ticks(name, MpcSolver::Structured, QpBackend::Dense, MpcExecution::Background);
        assert_eq!((n.quiet, n.loud), (0, 0), "{name}: allocations on the ticking thread");
        assert!(n.plans > 0, "{name}: no plan adopted");
    }
}
