//! Criterion benches: convex MPC solve (horizon 10, 4 feet, exact cones, tolerance 1e-8),
//! whole-body QP solve (Solo12 trot stance; dense and Clarabel backends) and a full
//! controller tick. Criterion reports means and confidence intervals; the `mpc_bench`
//! example prints medians and p99.

use centaur_dynamics::{BaseKind, Model};
use centaur_mpc::{Command, ControllerConfig, Gait, LocomotionController, QpBackend};
use criterion::{Criterion, criterion_group, criterion_main};

fn solo12() -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/solo12/solo12.urdf");
    Model::from_urdf_file(path, BaseKind::Floating).expect("solo12")
}

/// A controller in the middle of a trot stance (two feet down), ticked once.
fn trotting(cfg: ControllerConfig) -> (LocomotionController, centaur_dynamics::RobotState) {
    let model = solo12();
    let mut c = LocomotionController::new(&model, cfg).expect("config");
    let s = c.nominal_state();
    for k in 0..40 {
        c.tick(&s, &Command::forward(0.3, Gait::Trot), k as f64 * 0.001);
    }
    (c, s)
}

fn benches(cr: &mut Criterion) {
    let cmd = Command::forward(0.3, Gait::Trot);
    // MPC: solve every tick (mpc_period 0), the WBC cost is ~2 % of it.
    let mut cfg = ControllerConfig::solo12();
    cfg.mpc_period = 0.0;
    let (mut c, s) = trotting(cfg);
    cr.bench_function("mpc_tick_solo12_trot_h10_cone", |b| b.iter(|| c.tick(&s, &cmd, 0.040).tau[0]));
    // Ticks without an MPC solve (the plan is followed between solves): kinematics + WBC.
    for (name, backend) in [
        ("tick_wbc_dense_solo12_trot", QpBackend::Dense),
        ("tick_wbc_clarabel_solo12_trot", QpBackend::Clarabel),
    ] {
        let mut cfg = ControllerConfig::solo12();
        cfg.wbc.backend = backend;
        cfg.mpc_period = 1e9;
        let (mut c, s) = trotting(cfg);
        // Same time every iteration: phase 0.13 of the trot, FL and HR in stance.
        cr.bench_function(name, |b| b.iter(|| c.tick(&s, &cmd, 0.040).tau[0]));
    }
}

criterion_group! {
    name = mpc;
    config = Criterion::default().sample_size(50).measurement_time(std::time::Duration::from_secs(5));
    targets = benches
}
criterion_main!(mpc);
