//! The model-based controller alone, in closed loop with the simulator: what `centaur control`
//! promises for the quadrupeds (trot at a commanded speed, stand still, survive a lateral push)
//! for Walker2d (stand, walk at 0.5 and 1.0 m/s) and for the Humanoid (balance on point feet by
//! stepping in place, under pushes; walk at 0.3 m/s).

use std::process::Command as Process;

use centaur_lab::control::{ControlError, ControlOptions, ControlSummary, Push, run_control};
use centaur_mpc::Gait;

fn run(env: &str, gait: Gait, speed: f64, measure_from: f64, push: Option<Push>) -> ControlSummary {
    let opts = ControlOptions {
        env: env.into(),
        gait,
        speed,
        seconds: 10.0 + measure_from,
        seed: 0,
        push,
        measure_from,
        ..ControlOptions::default()
    };
    run_control(&opts).unwrap()
}

fn lateral(force: f64, duration: f64) -> Option<Push> {
    Some(Push { at: 3.0, force: [0.0, force, 0.0], duration })
}

/// Trots 10 s at 0.3 m/s: no fall, mean speed within 25 %, yaw drift below 0.3 rad.
fn assert_trots(s: &ControlSummary) {
    assert!(!s.fell, "{} fell after {:.2} s", s.env, s.seconds);
    assert!((s.mean_speed - 0.3).abs() < 0.075, "{}: mean speed {:.3} m/s for 0.3", s.env, s.mean_speed);
    assert!(s.yaw_drift < 0.3, "{}: yaw drift {:.3} rad", s.env, s.yaw_drift);
}

/// The controller issue's target for a commanded `speed`: no fall, mean speed within 15 %,
/// yaw drift below 0.2 rad.
fn assert_meets_target(s: &ControlSummary, speed: f64) {
    assert!(!s.fell, "{} fell after {:.2} s", s.env, s.seconds);
    assert!(
        (s.mean_speed - speed).abs() <= 0.15 * speed,
        "{}: mean speed {:.3} m/s for {speed}",
        s.env,
        s.mean_speed
    );
    assert!(s.yaw_drift < 0.2, "{}: yaw drift {:.3} rad", s.env, s.yaw_drift);
}

/// Stands 10 s: no fall, the body drifts less than `tol` metres in the plane and turns less
/// than `max_yaw` radians.
fn assert_stands(s: &ControlSummary, tol: f64, max_yaw: f64) {
    assert!(!s.fell, "{} fell after {:.2} s", s.env, s.seconds);
    assert!(
        s.distance.abs() < tol && s.lateral_drift.abs() < tol,
        "{}: drifted {:.3} m forward, {:.3} m sideways",
        s.env,
        s.distance,
        s.lateral_drift
    );
    assert!(s.yaw_drift < max_yaw, "{}: yaw drift {:.3} rad", s.env, s.yaw_drift);
}

#[test]
fn the_minitaur_trots_at_the_commanded_speed() {
    let s = run("minitaur", Gait::Trot, 0.3, 0.0, None);
    assert_trots(&s);
    // Inline, every tick that solves the MPC blocks on it.
    assert_eq!(s.mpc_execution, "inline");
    assert!(s.mpc_blocking_ticks > 100, "{} blocking ticks", s.mpc_blocking_ticks);
}

#[test]
fn the_minitaur_trot_holds_over_the_envs_randomisation() {
    // Reset seeds draw masses (±20 %), battery voltage, motor damping and foot friction.
    let survived = (1..=6).filter(|&seed| {
        let opts =
            ControlOptions { env: "minitaur".into(), seconds: 10.0, seed, ..ControlOptions::default() };
        !run_control(&opts).unwrap().fell
    });
    assert_eq!(survived.count(), 6);
}

/// The deployment arrangement: the MPC on the controller's worker thread and the simulation
/// in real time, so each plan arrives one solve late, as on a robot.
#[test]
fn the_minitaur_trots_with_the_mpc_on_a_worker_thread() {
    let opts = ControlOptions { env: "minitaur".into(), background_mpc: true, ..ControlOptions::default() };
    let s = run_control(&opts).unwrap();
    assert_trots(&s);
    assert_eq!(s.qp_failures, 0);
    // Only the first tick waited for a solve (inline, every tick that solves does).
    assert_eq!(s.mpc_execution, "background");
    assert_eq!(s.mpc_blocking_ticks, 1);
}

/// The Minitaur's rated trot (to 2.5 m/s) over the whole randomisation: seed 0 at 2.0 m/s
/// in CI (`tools/closed_loop_table.py` runs 0.3–2.5 m/s over seeds 0–4): 10 s after the
/// ramp, speed within 15 %, yaw drift below 0.2 rad.
#[test]
fn the_minitaur_trots_at_two_metres_per_second() {
    assert_meets_target(&run("minitaur", Gait::Trot, 2.0, 2.0, None), 2.0);
}

/// The Minitaur's bound, at its own 0.19 m CoM height and half the table's cycle, at
/// 1.5 m/s (seed 0 in CI; the table tool runs 0.3–2.0 m/s over seeds 0–4): the target's
/// speed and yaw drift, and a 4 N·s side push at 3 s.
#[test]
fn the_minitaur_bounds_at_one_and_a_half_metres_per_second() {
    assert_meets_target(&run("minitaur", Gait::Bound, 1.5, 1.0, None), 1.5);
    let s = run("minitaur", Gait::Bound, 1.5, 1.0, lateral(-40.0, 0.1));
    assert!(!s.fell, "bounding, pushed with -40 N for 0.1 s: fell at {:.2} s", s.seconds);
}

/// A learner's exploration perturbs the controller's actions: Gaussian noise of 10 % of the
/// action range every step (seed 0 here; the table tool runs seeds 0–4 at 0.3 and 1.0 m/s).
#[test]
fn the_minitaur_trots_under_action_noise() {
    let opts = ControlOptions {
        env: "minitaur".into(),
        speed: 0.3,
        seconds: 11.0,
        measure_from: 1.0,
        action_noise: 0.1,
        ..ControlOptions::default()
    };
    let s = run_control(&opts).unwrap();
    assert!(!s.fell, "fell after {:.2} s", s.seconds);
    assert!((s.mean_speed - 0.3).abs() < 0.045, "mean speed {:.3} m/s for 0.3", s.mean_speed);
}

/// The Minitaur for 4 s (measured from 1 s) on `gait`, at 1 m/s (0 on the stand), with the
/// rest of `opts` as given.
fn minitaur_for_4_s(gait: Gait, opts: ControlOptions) -> Result<ControlSummary, ControlError> {
    let speed = if gait == Gait::Stand { 0.0 } else { 1.0 };
    run_control(&ControlOptions {
        env: "minitaur".into(),
        gait,
        speed,
        seconds: 4.0,
        measure_from: 1.0,
        ..opts
    })
}

/// `period_scale` runs the gait's clock faster or slower (as the hybrid's does): the trot on
/// 0.7 of its period holds 1 m/s and is a different run from the trot on its own; a scale
/// outside [0.25, 4], not finite, or on the stand (no period) is refused.
#[test]
fn the_minitaur_trots_on_a_scaled_period_and_bad_scales_are_refused() {
    let trot = |period_scale: f64, gait: Gait| {
        minitaur_for_4_s(gait, ControlOptions { period_scale, ..ControlOptions::default() })
    };
    let own = trot(1.0, Gait::Trot).unwrap();
    let faster = trot(0.7, Gait::Trot).unwrap();
    assert_eq!((own.period_scale, faster.period_scale), (1.0, 0.7));
    assert!(!faster.fell, "fell after {:.2} s", faster.seconds);
    assert!((faster.mean_speed - 1.0).abs() < 0.15, "mean speed {:.3} m/s for 1.0", faster.mean_speed);
    assert_ne!(own.distance.to_bits(), faster.distance.to_bits(), "the period scale changed nothing");
    // Out of range: the hybrid's own refusal; on the stand: the controller's.
    for bad in [0.1, 4.5, f64::NAN] {
        match trot(bad, Gait::Trot) {
            Err(e @ ControlError::Hybrid(_)) => assert!(e.to_string().contains("period_scale"), "{bad}: {e}"),
            other => panic!("period scale {bad}: {other:?}"),
        }
    }
    match trot(0.7, Gait::Stand) {
        Err(e @ ControlError::Invalid(_)) => assert!(e.to_string().contains("no gait period"), "{e}"),
        other => panic!("period scale 0.7 on the stand: {other:?}"),
    }
}

/// `swing_height` replaces the controller's swing apex (as the hybrid's does): the trot with
/// 4.5 cm swings holds 1 m/s on a different trajectory, and the summary names the height;
/// a height in centimetres, none or a non-finite one is refused.
#[test]
fn the_minitaur_trots_on_a_lower_swing_and_bad_heights_are_refused() {
    let trot = |swing_height: Option<f64>| {
        minitaur_for_4_s(Gait::Trot, ControlOptions { swing_height, ..ControlOptions::default() })
    };
    let own = trot(None).unwrap();
    let low = trot(Some(0.045)).unwrap();
    assert_eq!((own.swing_height, low.swing_height), (0.07, 0.045));
    assert!(!low.fell, "fell after {:.2} s", low.seconds);
    assert!((low.mean_speed - 1.0).abs() < 0.15, "mean speed {:.3} m/s for 1.0", low.mean_speed);
    assert_ne!(own.distance.to_bits(), low.distance.to_bits(), "the swing height changed nothing");
    for bad in [7.0, 0.0, f64::NAN] {
        match trot(Some(bad)) {
            Err(e @ ControlError::Hybrid(_)) => assert!(e.to_string().contains("swing_height"), "{bad}: {e}"),
            other => panic!("swing height {bad}: {other:?}"),
        }
    }
}

/// `centaur control --duty-shift`: the Minitaur's trot with its stance fractions moved
/// (0.4 of the cycle, flight phases between the pairs' stances) still holds 1 m/s, on a
/// different trajectory from its own fractions; a shift out of range, or on the stand, is
/// refused.
#[test]
fn the_minitaur_trots_with_shifted_stance_fractions_and_bad_shifts_are_refused() {
    let trot = |duty_shift: f64, gait: Gait| {
        minitaur_for_4_s(gait, ControlOptions { duty_shift, ..ControlOptions::default() })
    };
    let own = trot(0.0, Gait::Trot).unwrap();
    let flying = trot(-0.1, Gait::Trot).unwrap();
    assert_eq!((own.duty_shift, flying.duty_shift), (0.0, -0.1));
    assert!(!flying.fell, "fell after {:.2} s", flying.seconds);
    assert!((flying.mean_speed - 1.0).abs() < 0.15, "mean speed {:.3} m/s for 1.0", flying.mean_speed);
    assert_ne!(own.distance.to_bits(), flying.distance.to_bits(), "the shift changed nothing");
    for bad in [0.31, -0.5, f64::NAN] {
        match trot(bad, Gait::Trot) {
            Err(e @ ControlError::Invalid(_)) => assert!(e.to_string().contains("duty shift"), "{bad}: {e}"),
            other => panic!("duty shift {bad}: {other:?}"),
        }
    }
    match trot(-0.1, Gait::Stand) {
        Err(e @ ControlError::Invalid(_)) => assert!(e.to_string().contains("--duty-shift"), "{e}"),
        other => panic!("duty shift on the stand: {other:?}"),
    }
}

/// `centaur control --max-acceleration`: the Minitaur's command ramp at 6 m/s² instead of
/// its own 3 reaches 2 m/s sooner, so it covers more ground in 1 s, and still trots; a ramp
/// out of (0, 20] m/s² is refused.
#[test]
fn a_faster_command_ramp_gets_the_minitaur_up_to_speed_sooner_and_bad_ramps_are_refused() {
    let run = |max_acceleration: Option<f64>, seconds: f64| {
        run_control(&ControlOptions {
            env: "minitaur".into(),
            speed: 2.0,
            seconds,
            max_acceleration,
            ..ControlOptions::default()
        })
    };
    let (own, fast) = (run(None, 1.0).unwrap(), run(Some(6.0), 1.0).unwrap());
    assert_eq!((own.max_acceleration, fast.max_acceleration), (3.0, 6.0));
    assert!(
        fast.distance > own.distance + 0.2,
        "{:.3} m against {:.3} m in 1 s",
        fast.distance,
        own.distance
    );
    let on = run(Some(6.0), 4.0).unwrap();
    assert!(!on.fell, "fell after {:.2} s", on.seconds);
    for bad in [0.0, -3.0, 25.0, f64::NAN] {
        match run(Some(bad), 1.0) {
            Err(e) => assert!(e.to_string().contains("max_acceleration"), "{bad}: {e}"),
            other => panic!("ramp {bad}: {other:?}"),
        }
    }
}

/// Speed steps within one run: 0 → 1.5 → 0 m/s; the robot reaches its speed and stops.
#[test]
fn the_minitaur_speeds_up_to_its_rating_and_stops() {
    let opts = ControlOptions {
        env: "minitaur".into(),
        speed: 0.0,
        speed_schedule: vec![(1.0, 1.5), (6.0, 0.0)],
        seconds: 10.0,
        ..ControlOptions::default()
    };
    let s = run_control(&opts).unwrap();
    assert!(!s.fell, "fell after {:.2} s", s.seconds);
    assert_eq!(s.segments.len(), 3);
    // The 5 s at 1.5 m/s include the 1.5 s ramp at 1 m/s²: at least 1.5 − 0.75·1.5/5.
    assert!(s.segments[1].mean_speed > 1.2, "{:?}", s.segments[1]);
    // The last 4 s include the ramp down: less than 0.75·1.5/4 on average, and stopped at the end.
    assert!(s.segments[2].mean_speed < 0.3, "{:?}", s.segments[2]);
}

#[test]
fn the_minitaur_stands_still() {
    assert_stands(&run("minitaur", Gait::Stand, 0.0, 0.0, None), 0.02, 0.05);
}

#[test]
fn the_minitaur_survives_lateral_pushes() {
    // 2 N·s either way while trotting and while standing.
    for f in [20.0, -20.0] {
        let s = run("minitaur", Gait::Trot, 0.3, 0.0, lateral(f, 0.1));
        assert!(!s.fell, "trotting, pushed with {f} N for 0.1 s: fell at {:.2} s", s.seconds);
    }
    for f in [20.0, -20.0] {
        let s = run("minitaur", Gait::Stand, 0.0, 0.0, lateral(f, 0.1));
        assert!(!s.fell, "standing, pushed with {f} N for 0.1 s: fell at {:.2} s", s.seconds);
    }
}

// Gymnasium drops the Ant from 0.75 m: the runs measure from t = 1 s, after it has landed.

#[test]
fn the_ant_trots_at_the_commanded_speed() {
    assert_trots(&run("ant", Gait::Trot, 0.3, 1.0, None));
}

/// The controller issue's CI row: the Ant trots 10 s at 1.0 m/s within 15 %, yaw drift
/// below 0.2 rad (seed 0; seeds 0–4 made 0.95–0.98 m/s).
#[test]
fn the_ant_trots_at_one_metre_per_second() {
    assert_meets_target(&run("ant", Gait::Trot, 1.0, 1.0, None), 1.0);
}

/// The Ant's static walk, offered to 0.3 m/s since its joint PD runs on the env's servo.
#[test]
fn the_ant_walks_at_the_commanded_speed() {
    assert_trots(&run("ant", Gait::Walk, 0.3, 1.0, None));
}

/// Trots `env` at `speed` for 11 s with a yaw-rate command, checks it does not fall and
/// keeps its speed along the heading within 15 % after the first second, and returns the
/// mean yaw rate from then on.
fn trot_turning(env: &str, speed: f64, yaw_rate: f64) -> f64 {
    turning(env, Gait::Trot, speed, yaw_rate)
}

/// [`trot_turning`] with `gait`.
fn turning(env: &str, gait: Gait, speed: f64, yaw_rate: f64) -> f64 {
    let opts = ControlOptions {
        env: env.into(),
        gait,
        speed,
        yaw_rate,
        seconds: 11.0,
        measure_from: 1.0,
        ..ControlOptions::default()
    };
    let s = run_control(&opts).unwrap();
    assert!(!s.fell, "{env} fell after {:.2} s", s.seconds);
    assert!(
        (s.mean_forward_speed - speed).abs() <= 0.15 * speed,
        "{env}: speed {:.3} m/s",
        s.mean_forward_speed
    );
    s.mean_yaw_rate
}

/// The Minitaur, without abduction, turns both ways on its staggered trot: commanded
/// ±0.5 rad/s at 0.5 m/s it turns within 15 % of the command (the bar; seeds 0–9
/// of `control_probe`: 0.453–0.496 and −0.426 to −0.461) and keeps its speed along the
/// heading.
#[test]
fn the_minitaur_turns_both_ways_while_trotting() {
    for yaw_rate in [0.5, -0.5] {
        let rate = trot_turning("minitaur", 0.5, yaw_rate);
        assert!((rate - yaw_rate).abs() < 0.075, "yaw rate {rate:.3} for {yaw_rate}");
    }
}

/// Above 0.6 m/s the Minitaur turns on its bound: with its two front or two hind feet
/// planted the body yaws about their midpoint, each foot moving fore and aft in its leg's
/// plane.
/// Commanded ±0.5 rad/s at 1.0 m/s it turns within 15 % and keeps its speed along the
/// heading (seed 0; seeds 0–9 of `control_probe`: 0.472–0.513 rad/s either way).
#[test]
fn the_minitaur_turns_both_ways_while_bounding_at_one_metre_per_second() {
    for yaw_rate in [0.5, -0.5] {
        let rate = turning("minitaur", Gait::Bound, 1.0, yaw_rate);
        assert!((rate - yaw_rate).abs() < 0.075, "yaw rate {rate:.3} for {yaw_rate}");
    }
}

/// Yaw-rate commands of ±0.5 rad/s while trotting at 0.3 m/s: the mean yaw rate and the
/// speed along the heading within 15 % (seed 0; the table tool runs seeds 0–4).
#[test]
fn the_ant_turns_while_trotting() {
    for yaw_rate in [0.5, -0.5] {
        let rate = trot_turning("ant", 0.3, yaw_rate);
        assert!((rate - yaw_rate).abs() < 0.075, "yaw rate {rate:.3} for {yaw_rate}");
    }
}

/// The Humanoid's second turning rating: ±0.3 rad/s walking at its top speed, 0.5 m/s,
/// within 15 % and with its speed along the heading within 15 % (seed 0; seeds 0–9 in the
/// preset's docs: 0.280–0.313 rad/s).
#[test]
fn the_humanoid_turns_slower_at_its_top_walking_speed() {
    for yaw_rate in [0.3, -0.3] {
        let rate = turning("humanoid", Gait::Walk, 0.5, yaw_rate);
        assert!((rate - yaw_rate).abs() < 0.045, "yaw rate {rate:.3} for {yaw_rate}");
    }
}

/// The median of `xs`.
fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 { xs[n / 2] } else { 0.5 * (xs[n / 2 - 1] + xs[n / 2]) }
}

/// `run` on reset seeds `seeds` (the env's randomisation draws differ per seed).
fn run_seeds(
    env: &str,
    gait: Gait,
    speed: f64,
    measure_from: f64,
    seeds: std::ops::Range<u64>,
) -> Vec<ControlSummary> {
    seeds
        .map(|seed| {
            let opts = ControlOptions {
                env: env.into(),
                gait,
                speed,
                seconds: 10.0 + measure_from,
                seed,
                measure_from,
                ..ControlOptions::default()
            };
            run_control(&opts).unwrap()
        })
        .collect()
}

/// Five seeds: each stands 10 s within 0.1 m and 0.2 rad; the medians within 0.03 m and
/// 0.05 rad (measured on seeds 0–9: drift median 0.008 m, max 0.079; yaw median 0.02 rad,
/// max 0.12 — one seed in ten turns its feet while the body settles).
#[test]
fn the_ant_stands_still() {
    let runs = run_seeds("ant", Gait::Stand, 0.0, 1.0, 0..5);
    for s in &runs {
        assert_stands(s, 0.1, 0.2);
    }
    let drift = median(runs.iter().map(|s| s.distance.abs().max(s.lateral_drift.abs())).collect());
    let yaw = median(runs.iter().map(|s| s.yaw_drift).collect());
    assert!(drift < 0.03 && yaw < 0.05, "ant: median drift {drift:.3} m, median yaw drift {yaw:.3} rad");
}

#[test]
fn the_ant_survives_lateral_pushes() {
    // 4 N·s either way while trotting, 2 N·s either way while standing.
    for f in [40.0, -40.0] {
        let s = run("ant", Gait::Trot, 0.3, 1.0, lateral(f, 0.1));
        assert!(!s.fell, "trotting, pushed with {f} N for 0.1 s: fell at {:.2} s", s.seconds);
    }
    for f in [20.0, -20.0] {
        let s = run("ant", Gait::Stand, 0.0, 1.0, lateral(f, 0.1));
        assert!(!s.fell, "standing, pushed with {f} N for 0.1 s: fell at {:.2} s", s.seconds);
    }
}

#[test]
fn walker2d_stands_still() {
    // Its hips and knees rest on their joint limits; it fell within 1.5 s before the
    // whole-body QP knew the limits.
    let s = run("walker2d", Gait::Stand, 0.0, 0.0, None);
    assert_stands(&s, 0.05, 0.05);
    // Standing still it has no cost of transport.
    assert_eq!(s.cost_of_transport, None);
}

#[test]
fn walker2d_walks_at_the_commanded_speed() {
    // 0.5 m/s for 10 s from standing: no fall, mean speed within 25 %. Before the planar
    // robots' ground friction was fixed it stepped in place (0.007 m/s).
    let s = run("walker2d", Gait::Walk, 0.5, 0.0, None);
    assert!(!s.fell, "walker2d fell after {:.2} s", s.seconds);
    assert!((s.mean_speed - 0.5).abs() < 0.125, "walker2d: mean speed {:.3} m/s for 0.5", s.mean_speed);
}

#[test]
fn walker2d_walks_at_one_metre_per_second() {
    // The CI row: seed 0, 10 s after a 1 s ramp, within 15 % (0.881–0.886 m/s over
    // seeds 0–4). Until the walk's own tuning (`ControllerConfig::walker2d`) it made
    // 0.67–0.73 m/s here.
    let s = run("walker2d", Gait::Walk, 1.0, 1.0, None);
    assert_meets_target(&s, 1.0);
    // Its cost of transport over the measured 10 s (0.47–0.48 over seeds 0–4): the energy
    // the actuators spent then, per weight and metre.
    let cot = s.cost_of_transport.expect("it moved");
    assert!(s.energy > 0.0 && (0.3..0.7).contains(&cot), "energy {} J, cost of transport {cot}", s.energy);
    // 4 N·s fore and aft at t = 3 s: it walks on (5 of 5 seeds each way; before the walk's
    // tuning 1 of 5 forward and 4 of 5 back).
    for f in [40.0, -40.0] {
        let push = Some(Push { at: 3.0, force: [f, 0.0, 0.0], duration: 0.1 });
        let s = run("walker2d", Gait::Walk, 1.0, 1.0, push);
        assert!(!s.fell, "pushed with {f} N along x for 0.1 s: fell at {:.2} s", s.seconds);
    }
}

#[test]
fn the_humanoid_balances_by_stepping_in_place() {
    // Point feet: a stand command steps in place. It fell within 1.5 s when it tried to
    // stand still on them.
    // Three seeds: each stays up 10 s and creeps forward less than 0.08 m/s (0.02–0.03 m/s
    // measured on seeds 0–4, 0.22–0.27 m in 10 s; 0.04–0.06 m/s on seeds
    // 0–9 with the weaker foothold position feedback before); without that feedback it
    // walked off at 0.12 m/s. Its yaw wanders less than 0.1 rad on seeds 0–4 (up to 0.67 on
    // seeds 0–9 before): the median of the three stays below 0.2 rad.
    let runs = run_seeds("humanoid", Gait::Stand, 0.0, 0.0, 0..3);
    for s in &runs {
        assert_stands(s, 0.8, f64::INFINITY);
        assert!(s.mean_speed.abs() < 0.08, "humanoid: mean speed {:.3} m/s while standing", s.mean_speed);
    }
    let yaw = median(runs.iter().map(|s| s.yaw_drift).collect());
    assert!(yaw < 0.2, "humanoid: median yaw drift {yaw:.3} rad");
}

#[test]
fn the_humanoid_walks_at_the_commanded_speed() {
    // 0.3 and 0.5 m/s (the two rows) for 10 s after a 1 s ramp, the issue's
    // tolerances: no fall, mean speed within 15 %, yaw drift below 0.2 rad. At 0.3 m/s it
    // fell on 4 of seeds 0–4 before the present preset; at 0.5 m/s it fell on 3 of seeds
    // 0–19 and drifted up to 0.59 rad on 2 more before the stronger posture task (since,
    // 40 of 40 seeds at either speed).
    for speed in [0.3, 0.5] {
        assert_meets_target(&run("humanoid", Gait::Walk, speed, 1.0, None), speed);
    }
}

#[test]
fn the_humanoid_survives_pushes_while_balancing() {
    // 4 N·s (40 N for 0.1 s) from either side, from behind and from the front.
    for force in [[0.0, 40.0, 0.0], [0.0, -40.0, 0.0], [40.0, 0.0, 0.0], [-40.0, 0.0, 0.0]] {
        let push = Some(Push { at: 3.0, force, duration: 0.1 });
        let s = run("humanoid", Gait::Stand, 0.0, 0.0, push);
        assert!(!s.fell, "pushed with {force:?} N for 0.1 s: fell at {:.2} s", s.seconds);
    }
}

#[test]
fn centaur_control_writes_the_summary_and_refuses_bad_options() {
    let out = std::env::temp_dir().join(format!("centaur-control-cli-{}", std::process::id()));
    let status = Process::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["control", "--env", "minitaur", "--gait", "trot", "--speed", "0.3", "--seconds", "1"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "env",
        "gait",
        "commanded_speed",
        "mean_speed",
        "distance",
        "fell",
        "yaw_drift",
        "mean_tick_us",
        "p99_tick_us",
        "mean_mpc_solve_us",
        "mean_wbc_solve_us",
        "qp_failures",
    ] {
        assert!(json.get(key).is_some(), "summary.json lacks `{key}`: {text}");
    }
    assert_eq!(json["env"], "minitaur");
    assert_eq!(json["controller_motor"], "nominal");
    assert!((json["seconds"].as_f64().unwrap() - 1.0).abs() < 0.02);
    let stdout = String::from_utf8_lossy(&status.stdout);
    assert!(stdout.contains("minitaur trot at 0.3 m/s for 1.0 s: mean speed"), "{stdout}");
    assert_eq!((json["period_scale"].as_f64(), json["duty_shift"].as_f64()), (Some(1.0), Some(0.0)));
    assert_eq!(json["max_acceleration"].as_f64(), Some(3.0));
    let _ = std::fs::remove_dir_all(&out);
    // A scaled period is said and recorded.
    let o = Process::new(env!("CARGO_BIN_EXE_centaur"))
        .args([
            "control",
            "--env",
            "minitaur",
            "--speed",
            "0.3",
            "--period-scale",
            "0.7",
            "--duty-shift",
            "-0.1",
            "--max-acceleration",
            "5",
            "--seconds",
            "1",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("trot at 0.3 m/s (its period × 0.7) (its stance fractions -0.1) for 1.0 s"),
        "{stdout}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!((json["period_scale"].as_f64(), json["duty_shift"].as_f64()), (Some(0.7), Some(-0.1)));
    assert_eq!(json["max_acceleration"].as_f64(), Some(5.0));
    let _ = std::fs::remove_dir_all(&out);
    // A speed schedule reports each segment's command and mean speed, not the unused --speed.
    let o = Process::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["control", "--env", "minitaur", "--speed-schedule", "0:0,0.5:0.3", "--seconds", "1", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.contains("on its speed schedule for 1.0 s: mean speed ")
            && stdout.contains(" m/s from 0 s (commanded 0), ")
            && stdout.contains(" m/s from 0.5 s (commanded 0.3)"),
        "{stdout}"
    );
    let _ = std::fs::remove_dir_all(&out);
    // A fore-aft push (`--push-axis x`), the only one the planar Walker2d takes, is recorded
    // along x; a lateral one is refused for it.
    let pushed = |axis: &str| {
        let args = ["control", "--env", "walker2d", "--gait", "walk", "--speed", "0.5", "--seconds", "4"];
        Process::new(env!("CARGO_BIN_EXE_centaur"))
            .args(args)
            .args(["--push-force", "-40", "--push-at", "2", "--push-axis", axis, "--out"])
            .arg(&out)
            .output()
            .unwrap()
    };
    let o = pushed("x");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["push"]["force"], serde_json::json!([-40.0, 0.0, 0.0]));
    assert!(String::from_utf8_lossy(&o.stdout).contains("cost of transport"));
    let _ = std::fs::remove_dir_all(&out);
    let o = pushed("y");
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("lateral (y) push"));
    // The controller told the motor drawn at reset (the earlier default): recorded
    // in the summary; refused on a robot without the Minitaur's motor model.
    let drawn = |env: &str| {
        let args = ["control", "--env", env, "--drawn-motor", "--seconds", "1", "--out"];
        Process::new(env!("CARGO_BIN_EXE_centaur")).args(args).arg(&out).output().unwrap()
    };
    let o = drawn("minitaur");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["controller_motor"], "drawn");
    let _ = std::fs::remove_dir_all(&out);
    let o = drawn("ant");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("motor_inverse"), "{err}");
    let _ = std::fs::remove_dir_all(&out);
    // Regression (reliability probe): `--out` naming a file is refused before the run.
    let file = std::env::temp_dir().join(format!("centaur-control-file-{}", std::process::id()));
    std::fs::write(&file, "not a directory").unwrap();
    let o = Process::new(env!("CARGO_BIN_EXE_centaur"))
        .args(["control", "--env", "minitaur", "--seconds", "3600", "--out"])
        .arg(&file)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("not a directory"), "{err}");
    let _ = std::fs::remove_file(&file);

    for (args, needle) in [
        (vec!["--env", "pendulum", "--gait", "trot"], "pendulum"),
        (vec!["--env", "minitaur", "--gait", "moonwalk"], "moonwalk"),
        (vec!["--env", "walker2d", "--gait", "gallop"], "gallop"),
        // Not offered on the Minitaur: the error names the gaits that work.
        (vec!["--env", "minitaur", "--gait", "gallop"], "trot (0–2.5 m/s;"),
        (vec!["--env", "minitaur", "--gait", "gallop"], "bound (0–2.5 m/s;"),
        (
            vec!["--env", "minitaur", "--gait", "bound", "--speed", "1.5", "--yaw-rate", "0.5"],
            "0.3 rad/s to 1.2 m/s",
        ),
        (vec!["--env", "minitaur", "--gait", "pronk", "--speed", "1", "--yaw-rate", "0.1"], "straight only"),
        (vec!["--env", "minitaur", "--gait", "trot", "--speed", "3"], "rated 2.5 m/s"),
        // Turning outside the rating: the unstaggered trot above 0.6 m/s turned at 0.02 rad/s
        // commanded 0.5 without a word, and the walk fell turning on one seed of five.
        (
            vec!["--env", "minitaur", "--speed", "1", "--yaw-rate", "0.5"],
            "turns at up to 0.5 rad/s to 0.6 m/s",
        ),
        (
            vec!["--env", "minitaur", "--speed", "0.3", "--speed-schedule", "0.05:1", "--yaw-rate", "-0.5"],
            "at 1 m/s",
        ),
        (vec!["--env", "minitaur", "--gait", "walk", "--speed", "0.3", "--yaw-rate", "0.3"], "straight only"),
        // Two ratings: the Humanoid's walk turns ±0.5 rad/s to 0.4 m/s, ±0.3 to 0.5 m/s.
        (
            vec!["--env", "humanoid", "--gait", "walk", "--speed", "0.5", "--yaw-rate", "-0.4"],
            "turns at up to 0.5 rad/s to 0.4 m/s and 0.3 rad/s",
        ),
        (vec!["--env", "minitaur", "--speed-schedule", "0:0,1:x"], "x"),
        (vec!["--env", "minitaur", "--action-noise", "nan"], "noise"),
        (vec!["--env", "minitaur", "--push-at", "1"], "--push-force"),
    ] {
        let o = Process::new(env!("CARGO_BIN_EXE_centaur"))
            .arg("control")
            .args(&args)
            .args(["--seconds", "0.1", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(!o.status.success(), "{args:?} was accepted");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(needle), "{args:?}: the error does not name `{needle}`: {err}");
    }
}

/// The reliability probe's silent acceptances of `centaur control`: every option that made
/// a run do nothing, something else than asked, or blow up unreported is refused by name
/// before the run, and a simulation that diverges is an error, not a summary.
#[test]
fn control_refuses_options_it_would_ignore_or_that_break_the_run() {
    let base = ControlOptions { seconds: 1.0, ..ControlOptions::default() };
    let push = |at: f64, force: f64, duration: f64| Some(Push { at, force: [0.0, force, 0.0], duration });
    let cases: Vec<(ControlOptions, &str)> = vec![
        (ControlOptions { push: push(0.5, f64::NAN, 0.1), ..base.clone() }, "push force"),
        (ControlOptions { push: push(0.5, 1e9, 0.1), ..base.clone() }, "at most 10000 N"),
        (ControlOptions { push: push(0.5, 10.0, f64::INFINITY), ..base.clone() }, "positive duration"),
        (ControlOptions { push: push(-1.0, 10.0, 0.1), ..base.clone() }, "start >= 0"),
        (ControlOptions { push: push(0.95, 10.0, 0.1), ..base.clone() }, "ends after the run"),
        (ControlOptions { measure_from: f64::NAN, ..base.clone() }, "measure from"),
        (ControlOptions { measure_from: 5.0, ..base.clone() }, "measure from"),
        (ControlOptions { seconds: 0.001, ..base.clone() }, "shorter than one control step"),
        (ControlOptions { seconds: 1e9, ..base.clone() }, "at most 3600 s"),
        // A yaw rate of 1e9 rad/s ran, reporting a yaw drift of 5e8 rad.
        (ControlOptions { yaw_rate: 1e9, ..base.clone() }, "at most 2π rad/s"),
        (ControlOptions { yaw_rate: f64::NAN, ..base.clone() }, "yaw rate NaN"),
        (
            ControlOptions { speed_schedule: vec![(0.0, 0.3), (2.0, 1.0)], ..base.clone() },
            "after the run's end",
        ),
        (ControlOptions { gait: Gait::Stand, speed: 0.3, ..base.clone() }, "speed 0"),
        (
            ControlOptions {
                env: "walker2d".into(),
                gait: Gait::Walk,
                push: push(0.5, 50.0, 0.1),
                ..base.clone()
            },
            "x–z plane",
        ),
        (
            ControlOptions { env: "walker2d".into(), gait: Gait::Walk, yaw_rate: 0.5, ..base.clone() },
            "x–z plane",
        ),
    ];
    for (opts, needle) in cases {
        let err = run_control(&opts).expect_err(needle).to_string();
        assert!(err.contains(needle), "the error does not name `{needle}`: {err}");
    }
    // 10 kN for 0.1 s throws the 4.8 kg Minitaur at ≈ 200 m/s: reported, not summarised.
    let err = run_control(&ControlOptions { push: push(0.5, 10_000.0, 0.1), ..base.clone() }).unwrap_err();
    assert!(matches!(err, centaur_lab::control::ControlError::Diverged { .. }), "{err}");
}
