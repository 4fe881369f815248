//! `tick` allocates nothing after construction (counting global allocator) — except one
//! small allocation inside every Clarabel solve: Clarabel 0.11 resets its internal timer
//! tree at the start of `solve()`, dropping the nested `HashMap` of sub-timers and
//! re-creating it (`timers.rs`, `reset_timer("solve")`), which no setting turns off. The
//! test therefore proves: zero allocations on ticks without a Clarabel solve, and at most
//! one per Clarabel solve. With the MPC on its worker thread (`MpcExecution::Background`)
//! that solve allocates there: the ticking thread allocates nothing at all. (Allocations are
//! counted per thread.)

mod common;

use std::time::{Duration, Instant};

use centaur_mpc::{Command, Gait, LocomotionController, MpcExecution, QpBackend};
use centaur_test_support::{CountingAllocator, allocations};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Allocations this thread makes inside `f`.
fn counted(f: impl FnOnce()) -> usize {
    allocations(f)
}

/// Returns (allocations on ticks without a Clarabel solve, allocations on ticks with one,
/// number of Clarabel solves).
fn count_ticks(name: &str, backend: QpBackend, exec: MpcExecution) -> (usize, usize, usize) {
    let (model, mut cfg) = common::load(name);
    cfg.wbc.backend = backend;
    cfg.mpc_execution = exec;
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    // Warm up once (first MPC solve), then count over gait changes and a NaN state.
    c.tick(&s, &Command::stand(), 0.0);
    let mut bad = s.clone();
    bad.q[0] = f64::NAN;
    let (mut quiet, mut loud, mut solves) = (0, 0, 0);
    let mut t = 0.0;
    // Ticks, counting allocations; returns whether the tick ran (or adopted) an MPC plan.
    let mut run = |c: &mut LocomotionController, state, cmd: &Command, t: f64| {
        let n = counted(|| {
            c.tick(state, cmd, t);
        });
        let st = c.status();
        let clarabel = usize::from(st.mpc_ran)
            + usize::from(backend == QpBackend::Clarabel && st.wbc_status != centaur_mpc::QpStatus::NotRun);
        if clarabel == 0 {
            quiet += n;
        } else {
            loud += n;
            solves += clarabel;
        }
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
    (quiet, loud, solves)
}

#[test]
fn tick_does_not_allocate() {
    for name in ["solo12", "ant", "minitaur", "walker2d", "humanoid"] {
        let (quiet, loud, solves) = count_ticks(name, QpBackend::Dense, MpcExecution::Inline);
        assert_eq!(quiet, 0, "{name} (dense WBC): allocations outside Clarabel");
        assert!(solves > 0 && loud <= solves, "{name}: {loud} allocations in {solves} Clarabel solves");
    }
    // With the Clarabel WBC each of the 16 per-stance-pattern solvers also fills its timer
    // map on its first solve.
    let (_, loud, solves) = count_ticks("solo12", QpBackend::Clarabel, MpcExecution::Inline);
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
        let (quiet, loud, solves) = count_ticks(name, QpBackend::Dense, MpcExecution::Background);
        assert_eq!((quiet, loud), (0, 0), "{name}: allocations on the ticking thread");
        assert!(solves > 0, "{name}: no plan adopted");
    }
}
