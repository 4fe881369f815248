//! `MpcExecution::Background`: the MPC on a worker thread. What a robot program relies on:
//! the first tick already follows a plan, and the same one the inline controller computes;
//! later ticks adopt the worker's plans as they finish; a reset never lets a plan solved for
//! the old state through; dropping the controller stops its thread.

mod common;

use std::time::{Duration, Instant};

use centaur_mpc::{Command, ControllerConfig, Fallback, Gait, LocomotionController, MpcExecution, QpStatus};

fn controllers(name: &str) -> (LocomotionController, LocomotionController) {
    let (model, cfg) = common::load(name);
    let inline = LocomotionController::new(&model, cfg.clone()).unwrap();
    let background = LocomotionController::new(
        &model,
        ControllerConfig { mpc_execution: MpcExecution::Background, ..cfg },
    )
    .unwrap();
    (inline, background)
}

#[test]
fn the_first_tick_waits_for_the_same_plan_the_inline_controller_solves() {
    for name in ["solo12", "minitaur"] {
        let (mut inline, mut background) = controllers(name);
        let s = inline.nominal_state();
        let cmd = Command::forward(0.3, Gait::Trot);
        let a = inline.tick(&s, &cmd, 0.0).clone();
        let b = background.tick(&s, &cmd, 0.0).clone();
        let st = background.status();
        assert!(st.mpc_ran && st.mpc_status == QpStatus::Solved, "{name}: {:?}", st.mpc_status);
        assert!(st.mpc_blocked, "{name}: the first tick waits for its plan");
        // Same inputs, same solver, same arithmetic: the commands agree bit for bit.
        assert_eq!(a.tau, b.tau, "{name}");
        assert_eq!(a.q_des, b.q_des, "{name}");
        assert_eq!(inline.status().mpc_forces, st.mpc_forces, "{name}");
    }
}

#[test]
fn later_plans_arrive_without_the_tick_waiting_for_them() {
    let (_, mut c) = controllers("solo12");
    let s = c.nominal_state();
    let cmd = Command::forward(0.3, Gait::Trot);
    c.tick(&s, &cmd, 0.0);
    // Ticks 1 ms apart in wall time (sleeping, so that a loaded machine still runs the
    // worker) for at least 0.3 s: the 50 Hz MPC is due 15 times; each plan comes back from
    // the worker and is adopted on a later tick.
    let (mut adopted, mut failures) = (0, 0);
    for k in 1..=300 {
        let t = k as f64 * 1e-3;
        std::thread::sleep(Duration::from_millis(1));
        c.tick(&s, &cmd, t);
        let st = c.status();
        adopted += usize::from(st.mpc_ran);
        failures = st.mpc_failures;
        // Every tick follows a plan (no fallback to the equal weight split) and none waits.
        assert_eq!(st.fallback, Fallback::None, "tick {k}");
        assert!(!st.mpc_blocked, "tick {k}");
    }
    assert_eq!(failures, 0);
    assert!(adopted >= 5, "only {adopted} plans adopted in 300 ticks");
}

#[test]
fn a_reset_discards_plans_solved_for_the_old_state() {
    // Reset right after the due tick, while the old solve (≈ 2 ms) almost surely still
    // runs: its plan is published after the reset and must be dropped by its generation.
    // And reset after it has been published but not taken: the reset clears it.
    for settle in [Duration::ZERO, Duration::from_millis(200)] {
        let (_, mut c) = controllers("solo12");
        let s = c.nominal_state();
        let cmd = Command::forward(0.3, Gait::Trot);
        c.tick(&s, &cmd, 0.0);
        c.tick(&s, &cmd, 0.02); // due: a solve for the robot at x ≈ 0
        std::thread::sleep(settle);
        // The robot reappears 1 m ahead: the first plan it follows starts there.
        c.reset();
        let mut moved = s.clone();
        moved.q[0] += 1.0;
        c.tick(&moved, &cmd, 0.0);
        let st = c.status();
        assert!(st.mpc_ran && st.mpc_blocked, "{settle:?}");
        assert!(st.com[0] > 0.9);
        assert!(
            (st.planned_com[0][0] - st.com[0]).abs() < 0.05,
            "{settle:?}: planned {:?}, com {:?}",
            st.planned_com[0],
            st.com
        );
    }
}

#[test]
fn failed_solves_are_reported_without_blocking_the_tick() {
    // A feasible stand, then a command friction cannot deliver (as in `fallback.rs`).
    let (model, mut cfg) = common::low_friction_solo12();
    cfg.mpc_execution = MpcExecution::Background;
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    c.tick(&s, &Command::stand(), 0.0);
    assert!(c.status().mpc_status.is_ok());
    for k in 1..=150 {
        std::thread::sleep(Duration::from_millis(1));
        c.tick(&s, &Command::forward(1.0, Gait::Stand), k as f64 * 1e-3);
        assert!(!c.status().mpc_blocked, "tick {k} waited for a failing solve");
    }
    let st = c.status();
    assert!(st.mpc_failures > 0);
    assert_eq!(st.mpc_status, QpStatus::PrimalInfeasible);
    assert_eq!(st.fallback, Fallback::MpcForces);
    assert!(c.command().tau.iter().all(|x| x.is_finite()));
}

#[test]
fn dropping_the_controller_stops_its_worker() {
    let (_, mut c) = controllers("solo12");
    let s = c.nominal_state();
    c.tick(&s, &Command::stand(), 0.0);
    c.tick(&s, &Command::stand(), 0.02); // leave a solve queued or running
    let t0 = Instant::now();
    drop(c);
    // Joins after at most the solve under way.
    assert!(t0.elapsed() < Duration::from_secs(5));
}
