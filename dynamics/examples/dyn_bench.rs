//! Times every algorithm on one URDF and prints JSON median nanoseconds per call:
//! `{"fk", "jacobians", "rnea", "crba", "aba", "centroidal"}`.
//!
//! ```text
//! cargo run --release -p centaur-dynamics --example dyn_bench -- URDF [--floating-base]
//! ```
//!
//! `--continuous-cos-sin` loads continuous joints as `(cos θ, sin θ)` joints, as Pinocchio
//! does (then both libraries take the same `q`).
//!
//! Each algorithm runs over a pool of 256 random states, in rounds of one pass over the
//! pool; the figure is the median over rounds of (round time / pool size). Compare with
//! Pinocchio side by side using `tools/pinocchio/bench_side_by_side.py`.

#[path = "../tests/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::process::ExitCode;
use std::time::Instant;

use centaur_dynamics::{
    BaseKind, Data, Model, UrdfOptions, aba, centroidal_map, compute_joint_jacobians, crba,
    forward_kinematics, rnea,
};
use common::{Rng, random_q, random_v};

const POOL: usize = 256;

fn median_ns(rounds: usize, mut pass: impl FnMut()) -> f64 {
    for _ in 0..3 {
        pass(); // warm-up
    }
    let mut t: Vec<f64> = (0..rounds)
        .map(|_| {
            let start = Instant::now();
            pass();
            start.elapsed().as_nanos() as f64 / POOL as f64
        })
        .collect();
    t.sort_by(|a, b| a.total_cmp(b));
    t[t.len() / 2]
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.iter().find(|a| !a.starts_with("--")) else {
        eprintln!(
            "usage: dyn_bench URDF [--floating-base] [--continuous-cos-sin] [--rounds N] [--only ALGO]"
        );
        return ExitCode::from(2);
    };
    let base = if args.iter().any(|a| a == "--floating-base") { BaseKind::Floating } else { BaseKind::Fixed };
    // `--only NAME` times one algorithm (the others print 0), for profiling.
    let only = args.iter().position(|a| a == "--only").and_then(|i| args.get(i + 1)).cloned();
    let wanted = |name: &str| only.as_deref().is_none_or(|o| o == name);
    let rounds = args
        .iter()
        .position(|a| a == "--rounds")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(400);
    let options = UrdfOptions {
        continuous_as_cos_sin: args.iter().any(|a| a == "--continuous-cos-sin"),
        ..UrdfOptions::default()
    };
    let model = match Model::from_urdf_file_with(path, base, options) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("dyn_bench: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut data = Data::new(&model);
    let mut rng = Rng(1);
    let qs: Vec<_> = (0..POOL).map(|_| random_q(&model, &mut rng)).collect();
    let vs: Vec<_> = (0..POOL).map(|_| random_v(&model, &mut rng)).collect();
    let as_: Vec<_> = (0..POOL).map(|_| random_v(&model, &mut rng)).collect();
    let taus: Vec<_> = (0..POOL).map(|_| random_v(&model, &mut rng)).collect();
    let fk = if !wanted("fk") {
        0.0
    } else {
        median_ns(rounds, || {
            for q in &qs {
                forward_kinematics(&model, &mut data, q.as_slice());
                black_box(&data.o_m_i);
            }
        })
    };
    let jacobians = if !wanted("jacobians") {
        0.0
    } else {
        median_ns(rounds, || {
            for q in &qs {
                compute_joint_jacobians(&model, &mut data, q.as_slice());
                black_box(&data.jacobians);
            }
        })
    };
    let rnea_ns = if !wanted("rnea") {
        0.0
    } else {
        median_ns(rounds, || {
            for k in 0..POOL {
                black_box(rnea(&model, &mut data, qs[k].as_slice(), vs[k].as_slice(), as_[k].as_slice()));
            }
        })
    };
    let crba_ns = if !wanted("crba") {
        0.0
    } else {
        median_ns(rounds, || {
            for q in &qs {
                black_box(crba(&model, &mut data, q.as_slice()));
            }
        })
    };
    let aba_ns = if !wanted("aba") {
        0.0
    } else {
        median_ns(rounds, || {
            for k in 0..POOL {
                black_box(aba(&model, &mut data, qs[k].as_slice(), vs[k].as_slice(), taus[k].as_slice()));
            }
        })
    };
    let centroidal = if !wanted("centroidal") {
        0.0
    } else {
        median_ns(rounds, || {
            for q in &qs {
                black_box(centroidal_map(&model, &mut data, q.as_slice()));
            }
        })
    };
    // Not part of the JSON contract: centre of mass alone (composite inertias), for profiling.
    if only.as_deref() == Some("com") {
        let com = median_ns(rounds, || {
            for q in &qs {
                black_box(centaur_dynamics::center_of_mass(&model, &mut data, q.as_slice()));
            }
        });
        eprintln!("center_of_mass: {com:.1} ns");
    }
    println!(
        "{{\"fk\": {fk:.1}, \"jacobians\": {jacobians:.1}, \"rnea\": {rnea_ns:.1}, \"crba\": {crba_ns:.1}, \
         \"aba\": {aba_ns:.1}, \"centroidal\": {centroidal:.1}, \"nq\": {}, \"nv\": {}}}",
        model.nq, model.nv
    );
    ExitCode::SUCCESS
}
