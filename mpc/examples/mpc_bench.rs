//! Times the convex MPC (horizon 10, 4 feet, exact cones, 1e-8), the whole-body QP (Solo12
//! trot stance, dense and Clarabel backends) and a full controller tick; prints median and
//! p99 in microseconds as JSON, including a 1 kHz loop with the MPC inline and on the
//! controller's worker thread (`MpcExecution::Background`).

use std::time::Instant;

use centaur_dynamics::{BaseKind, Model};
use centaur_mpc::{
    Command, ControllerConfig, FrictionModel, Gait, LocomotionController, MpcExecution, QpBackend,
};

fn stats(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(|a, b| a.total_cmp(b));
    let p = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (p(0.5), p(0.99))
}

/// Ticks a trotting Solo12 and collects the per-tick MPC and WBC solve times and tick times.
/// With `paced`, ticks start 1 ms apart in wall time (a 1 kHz loop, as on a robot); else
/// back to back.
fn run(model: &Model, cfg: ControllerConfig, n: usize, paced: bool) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut c = LocomotionController::new(model, cfg).expect("config");
    let s = c.nominal_state();
    let cmd = Command::forward(0.3, Gait::Trot);
    let (mut mpc, mut wbc, mut tick) = (Vec::new(), Vec::new(), Vec::new());
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
            if st.mpc_ran {
                mpc.push(st.mpc_solve_us);
            }
            // Trot stance: two feet down.
            if st.contact.iter().filter(|c| **c).count() == 2 {
                wbc.push(st.wbc_solve_us);
            }
        }
    }
    (mpc, wbc, tick)
}

fn main() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/solo12/solo12.urdf");
    let model = Model::from_urdf_file(path, BaseKind::Floating).expect("solo12");
    let n = 3000;
    let (mpc, wbc_dense, tick) = run(&model, ControllerConfig::solo12(), n, false);
    let mut cfg = ControllerConfig::solo12();
    cfg.wbc.backend = QpBackend::Clarabel;
    let (_, wbc_clarabel_pyr, tick_clarabel) = run(&model, cfg.clone(), n, false);
    cfg.wbc.friction = FrictionModel::Cone;
    let (_, wbc_clarabel_cone, _) = run(&model, cfg, n, false);
    // MPC every tick, to time the MPC alone with more samples.
    let mut cfg = ControllerConfig::solo12();
    cfg.mpc_period = 0.0;
    let (mpc_all, _, _) = run(&model, cfg, 1500, false);
    // A 1 kHz loop, MPC inline (ticks that solve take the solve's time) and on the
    // controller's worker thread (no tick waits for a solve).
    let (_, _, tick_paced) = run(&model, ControllerConfig::solo12(), n, true);
    let cfg = ControllerConfig { mpc_execution: MpcExecution::Background, ..ControllerConfig::solo12() };
    let (mpc_background, _, tick_background) = run(&model, cfg, n, true);
    let mut out = Vec::new();
    for (name, v) in [
        ("mpc_solve_us", mpc_all),
        ("mpc_solve_us_every_20ms", mpc),
        ("wbc_dense_us", wbc_dense),
        ("wbc_clarabel_pyramid_us", wbc_clarabel_pyr),
        ("wbc_clarabel_cone_us", wbc_clarabel_cone),
        ("tick_dense_us", tick),
        ("tick_clarabel_wbc_us", tick_clarabel),
        ("tick_1khz_inline_mpc_us", tick_paced),
        ("tick_1khz_background_mpc_us", tick_background),
        ("mpc_solve_background_us", mpc_background),
    ] {
        let (m, p) = stats(v);
        out.push(format!("\"{name}\": {{\"median\": {m:.1}, \"p99\": {p:.1}}}"));
    }
    println!("{{{}}}", out.join(", "));
}
