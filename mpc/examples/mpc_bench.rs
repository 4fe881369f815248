//! Times the convex MPC's two solvers side by side on the same problems, and the rest of a
//! controller tick.
//!
//! The problems are recorded from the controllers themselves: Solo12 and the Minitaur
//! trotting at 0.3 m/s, Walker2d walking (planar MPC), each ticked every 10 ms from the
//! nominal state and from eight perturbed ones (base tilt ±0.1 rad, base lowered by up to
//! 1.5 cm — raised, a frozen state would read as airborne and hold every foot in stance —
//! velocities ±0.2 m/s and ±0.3 rad/s, seeded); the problems of two gait cycles after one
//! cycle of start-up are kept (steady gait, as the earlier bench timed ticks after the first
//! 50), those of the start-up — plans from standing, every foot in stance over the whole
//! horizon — are timed apart. Each problem is then solved by the structured solver (the
//! default) and by Clarabel in turn, the sequence repeated, and the median and p99 of the
//! solve times reported per robot.
//!
//! `--json` prints exactly `{"solo12_trot": {...}, "minitaur_trot": {...},
//! "walker2d_walk": {...}}`, each with `default_median_us`, `default_p99_us`,
//! `clarabel_median_us`, `clarabel_p99_us` (and the ratio, iteration counts and number of
//! problems). Without it, a table, plus the whole-body QP, full ticks and a 1 kHz loop.

use std::time::Instant;

use centaur_dynamics::nalgebra::{UnitQuaternion, Vector3};
use centaur_dynamics::{BaseKind, Model, RobotState};
use centaur_mpc::{
    Command, ControllerConfig, ConvexMpc, FrictionModel, Gait, GaitPattern, LocomotionController,
    MpcExecution, MpcInput, MpcSolver, QpBackend,
};

fn stats(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(|a, b| a.total_cmp(b));
    let p = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (p(0.5), p(0.99))
}

fn load(name: &str) -> (Model, ControllerConfig) {
    let (path, base) = match name {
        "solo12" => ("solo12/solo12.urdf", BaseKind::Floating),
        "minitaur" => ("minitaur/minitaur.urdf", BaseKind::Floating),
        "walker2d" => ("mujoco/walker2d.urdf", BaseKind::Fixed),
        _ => unreachable!("a robot of this bench"),
    };
    let full = format!("{}/../assets/{path}", env!("CARGO_MANIFEST_DIR"));
    let model = Model::from_urdf_file(&full, base).expect("URDF loads");
    (model, ControllerConfig::preset(name).expect("preset"))
}

/// A deterministic perturbation of the nominal state.
fn perturbed(c: &LocomotionController, seed: u64) -> RobotState {
    let mut s = c.nominal_state();
    if seed == 0 {
        return s;
    }
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut u = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % 20_001) as f64 / 10_000.0 - 1.0
    };
    let r = c.robot();
    match r.planar_q {
        None => {
            let pos = s.base_position() - Vector3::new(0.0, 0.0, 0.015 * u().abs());
            s.set_base_pose(pos, UnitQuaternion::from_euler_angles(0.1 * u(), 0.1 * u(), 0.0));
            let v = Vector3::new(0.2 * u(), 0.2 * u(), 0.2 * u());
            s.set_base_twist_world(v, Vector3::new(0.3 * u(), 0.3 * u(), 0.3 * u()));
        }
        Some([_, iz, ip]) => {
            s.q[iz] -= 0.015 * u().abs();
            s.q[ip] += 0.1 * u();
            s.v[r.base_v[0]] = 0.2 * u();
            s.v[r.base_v[1]] = 0.2 * u();
            s.v[r.base_v[2]] = 0.3 * u();
        }
    }
    s
}

/// The MPC problems the controller poses from nine states: those of two gait cycles after
/// one cycle of start-up, those of the start-up, and a solver for them (the controller's
/// own MPC, the inputs replaced per solve).
fn record(name: &str, gait: Gait) -> (Vec<MpcInput>, Vec<MpcInput>, ConvexMpc) {
    let (model, cfg) = load(name);
    let period = GaitPattern::new(cfg.gait_for(gait), cfg.robot.n_legs).map_or(0.5, |g| g.period)
        * cfg.gait_period_scale;
    let (mut steady, mut start) = (Vec::new(), Vec::new());
    let mut solver = None;
    for seed in 0..9 {
        let mut c = LocomotionController::new(&model, cfg.clone()).expect("config");
        let state = perturbed(&c, seed);
        let cmd = Command::forward(0.3, gait);
        let mut k = 0;
        while (k as f64) * 0.01 < 3.0 * period {
            let t = k as f64 * 0.01;
            c.tick(&state, &cmd, t);
            if c.status().mpc_ran {
                let mpc = c.mpc().expect("inline MPC");
                let into = if t < period { &mut start } else { &mut steady };
                into.push(mpc.input.clone());
                solver.get_or_insert_with(|| mpc.twin(|_| {}).expect("twin"));
            }
            k += 1;
        }
    }
    (steady, start, solver.expect("at least one MPC solve"))
}

/// Per-solve times (µs) and iterations of both solvers over `reps` passes of `problems`,
/// the solvers alternating problem by problem.
struct Timed {
    default_us: Vec<f64>,
    clarabel_us: Vec<f64>,
    default_iter: Vec<f64>,
    clarabel_iter: Vec<f64>,
}

fn time_solvers(problems: &[MpcInput], template: &ConvexMpc, reps: usize) -> Timed {
    let mut structured = template.twin(|c| c.solver = MpcSolver::Structured).expect("structured");
    let mut clarabel = template.twin(|c| c.solver = MpcSolver::Clarabel).expect("Clarabel");
    let mut out =
        Timed { default_us: vec![], clarabel_us: vec![], default_iter: vec![], clarabel_iter: vec![] };
    for _ in 0..reps {
        for p in problems {
            for (mpc, us, it) in [
                (&mut structured, &mut out.default_us, &mut out.default_iter),
                (&mut clarabel, &mut out.clarabel_us, &mut out.clarabel_iter),
            ] {
                mpc.input.clone_from(p);
                let t0 = Instant::now();
                let status = mpc.solve();
                us.push(t0.elapsed().as_secs_f64() * 1e6);
                it.push(mpc.iterations() as f64);
                assert!(status.is_ok(), "{:?}: {status:?}", mpc.config().solver);
            }
        }
    }
    out
}

/// Ticks a trotting Solo12 and collects the per-tick WBC solve times and tick times. With
/// `paced`, ticks start 1 ms apart in wall time (a 1 kHz loop); else back to back.
fn run_ticks(model: &Model, cfg: ControllerConfig, n: usize, paced: bool) -> (Vec<f64>, Vec<f64>) {
    let mut c = LocomotionController::new(model, cfg).expect("config");
    let s = c.nominal_state();
    let cmd = Command::forward(0.3, Gait::Trot);
    let (mut wbc, mut tick) = (Vec::new(), Vec::new());
    let start = Instant::now();
    for k in 0..n {
        let t = k as f64 * 0.001;
        if paced {
            while start.elapsed().as_secs_f64() < t {
                std::hint::spin_loop();
            }
        }
        let t0 = Instant::now();
        c.tick(&s, &cmd, t);
        let dt = t0.elapsed().as_secs_f64() * 1e6;
        let st = c.status();
        if k > 50 {
            tick.push(dt);
            if st.contact.iter().filter(|c| **c).count() == 2 {
                wbc.push(st.wbc_solve_us);
            }
        }
    }
    (wbc, tick)
}

fn main() {
    let json = std::env::args().any(|a| a == "--json");
    let reps = if json { 3 } else { 5 };
    let (mut entries, mut startup) = (Vec::new(), Vec::new());
    for (key, robot, gait) in [
        ("solo12_trot", "solo12", Gait::Trot),
        ("minitaur_trot", "minitaur", Gait::Trot),
        ("walker2d_walk", "walker2d", Gait::Walk),
    ] {
        let (problems, start, template) = record(robot, gait);
        let t = time_solvers(&problems, &template, reps);
        let (dm, dp) = stats(t.default_us);
        let (cm, cp) = stats(t.clarabel_us);
        let (di, _) = stats(t.default_iter);
        let (ci, _) = stats(t.clarabel_iter);
        entries.push((key, problems.len(), dm, dp, cm, cp, di, ci));
        let s = time_solvers(&start, &template, reps);
        let (sm, sp) = stats(s.default_us);
        let (scm, scp) = stats(s.clarabel_us);
        startup.push((key, start.len(), sm, sp, scm, scp));
    }
    if json {
        let body: Vec<String> = entries
            .iter()
            .map(|(key, n, dm, dp, cm, cp, di, ci)| {
                format!(
                    "\"{key}\": {{\"default_median_us\": {dm:.1}, \"default_p99_us\": {dp:.1}, \
                     \"clarabel_median_us\": {cm:.1}, \"clarabel_p99_us\": {cp:.1}, \
                     \"median_ratio\": {:.2}, \"default_iterations_median\": {di}, \
                     \"clarabel_iterations_median\": {ci}, \"problems\": {n}}}",
                    cm / dm
                )
            })
            .collect();
        println!("{{{}}}", body.join(", "));
        return;
    }
    println!("MPC solve (µs), the same problems, {reps} passes, solvers alternating:");
    println!(
        "| problem | problems | structured median / p99 | Clarabel median / p99 | Clarabel / structured (median) | iterations (median) |"
    );
    println!("|---|---|---|---|---|---|");
    for (key, n, dm, dp, cm, cp, di, ci) in &entries {
        println!("| {key} | {n} | {dm:.0} / {dp:.0} | {cm:.0} / {cp:.0} | {:.1}× | {di} / {ci} |", cm / dm);
    }
    println!("\nThe start-up problems (plans from standing, first gait cycle), same solvers, µs:");
    println!("| problem | problems | structured median / p99 | Clarabel median / p99 |");
    println!("|---|---|---|---|");
    for (key, n, sm, sp, cm, cp) in &startup {
        println!("| {key} start-up | {n} | {sm:.0} / {sp:.0} | {cm:.0} / {cp:.0} |");
    }
    // The rest of a tick on Solo12: the whole-body QP and full ticks, and a 1 kHz loop.
    let (model, _) = load("solo12");
    let n = 3000;
    let (wbc_dense, tick) = run_ticks(&model, ControllerConfig::solo12(), n, false);
    let mut cfg = ControllerConfig::solo12();
    cfg.wbc.backend = QpBackend::Clarabel;
    let (wbc_clarabel_pyr, tick_clarabel) = run_ticks(&model, cfg.clone(), n, false);
    cfg.wbc.friction = FrictionModel::Cone;
    let (wbc_clarabel_cone, _) = run_ticks(&model, cfg, n, false);
    let (_, tick_paced) = run_ticks(&model, ControllerConfig::solo12(), n, true);
    let mut cfg = ControllerConfig::solo12();
    cfg.mpc.solver = MpcSolver::Clarabel;
    let (_, tick_paced_clarabel) = run_ticks(&model, cfg, n, true);
    let cfg = ControllerConfig { mpc_execution: MpcExecution::Background, ..ControllerConfig::solo12() };
    let (_, tick_background) = run_ticks(&model, cfg, n, true);
    println!("\nSolo12 trotting, µs (median / p99):");
    for (name, v) in [
        ("whole-body QP, dense", wbc_dense),
        ("whole-body QP, Clarabel, pyramid", wbc_clarabel_pyr),
        ("whole-body QP, Clarabel, cone", wbc_clarabel_cone),
        ("tick, back to back (MPC every 20 ms)", tick),
        ("tick, Clarabel WBC", tick_clarabel),
        ("1 kHz loop, MPC inline (structured)", tick_paced),
        ("1 kHz loop, MPC inline (Clarabel)", tick_paced_clarabel),
        ("1 kHz loop, MPC on the worker thread", tick_background),
    ] {
        let (m, p) = stats(v);
        println!("  {name}: {m:.1} / {p:.1}");
    }
}
