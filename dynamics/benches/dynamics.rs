//! Criterion benches of every algorithm on a 12-dof quadruped (Solo12), the Minitaur (with
//! its continuous joints as angles, and as `(cos θ, sin θ)` like Pinocchio), a 38-dof
//! humanoid (Talos, reduced) and an arm (UR5). Run with
//! `cargo bench -p centaur-dynamics`; `examples/dyn_bench.rs` prints the same figures as
//! JSON for the side-by-side comparison with Pinocchio.

#[path = "../tests/common/mod.rs"]
mod common;

use centaur_dynamics::*;
use common::{Rng, asset, random_q, random_v};
use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use nalgebra::Matrix6xX;
use std::hint::black_box;

fn bench_robot(c: &mut Criterion, label: &str, path: &str, base: BaseKind) {
    bench_robot_with(c, label, path, base, UrdfOptions::default());
}

fn bench_robot_with(c: &mut Criterion, label: &str, path: &str, base: BaseKind, options: UrdfOptions) {
    let model = Model::from_urdf_file_with(asset(path), base, options).expect("bench model loads");
    let mut data = Data::new(&model);
    let mut rng = Rng(11);
    let q = random_q(&model, &mut rng);
    let v = random_v(&model, &mut rng);
    let a = random_v(&model, &mut rng);
    let (q, v, a) = (q.as_slice(), v.as_slice(), a.as_slice());
    let foot = model.frames.len() - 1;
    let mut jac = Matrix6xX::zeros(model.nv);
    let mut g = c.benchmark_group(label);
    g.bench_function("forward_kinematics", |b| {
        b.iter(|| forward_kinematics(&model, &mut data, black_box(q)))
    });
    g.bench_function("fk_velocity_acceleration", |b| {
        b.iter(|| forward_kinematics_acceleration(&model, &mut data, black_box(q), v, a))
    });
    g.bench_function("frame_placements", |b| {
        b.iter(|| {
            forward_kinematics(&model, &mut data, black_box(q));
            update_frame_placements(&model, &mut data)
        })
    });
    g.bench_function("joint_jacobians", |b| {
        b.iter(|| compute_joint_jacobians(&model, &mut data, black_box(q)))
    });
    g.bench_function("frame_jacobian", |b| {
        compute_joint_jacobians(&model, &mut data, q);
        b.iter(|| frame_jacobian(&model, &data, black_box(foot), ReferenceFrame::LocalWorldAligned, &mut jac))
    });
    g.bench_function("rnea", |b| b.iter(|| black_box(rnea(&model, &mut data, black_box(q), v, a)[0])));
    g.bench_function("nonlinear_effects", |b| {
        b.iter(|| black_box(nonlinear_effects(&model, &mut data, black_box(q), v)[0]))
    });
    g.bench_function("gravity_torques", |b| {
        b.iter(|| black_box(gravity_torques(&model, &mut data, black_box(q))[0]))
    });
    g.bench_function("crba", |b| b.iter(|| black_box(crba(&model, &mut data, black_box(q))[(0, 0)])));
    g.bench_function("aba", |b| b.iter(|| black_box(aba(&model, &mut data, black_box(q), v, a)[0])));
    g.bench_function("cholesky_decompose", |b| {
        crba(&model, &mut data, q);
        b.iter(|| cholesky_decompose(&model, &mut data))
    });
    g.bench_function("mass_matrix_solve", |b| {
        crba(&model, &mut data, q);
        cholesky_decompose(&model, &mut data);
        b.iter_batched_ref(|| v.to_vec(), |x| mass_matrix_solve(&model, &data, x), BatchSize::SmallInput)
    });
    g.bench_function("center_of_mass", |b| b.iter(|| center_of_mass(&model, &mut data, black_box(q))));
    g.bench_function("jacobian_center_of_mass", |b| {
        b.iter(|| black_box(jacobian_center_of_mass(&model, &mut data, black_box(q))[(0, 0)]))
    });
    g.bench_function("centroidal_map", |b| {
        b.iter(|| black_box(centroidal_map(&model, &mut data, black_box(q))[(0, 0)]))
    });
    g.bench_function("kinetic_energy", |b| b.iter(|| kinetic_energy(&model, &mut data, black_box(q), v)));
    g.bench_function("potential_energy", |b| b.iter(|| potential_energy(&model, &mut data, black_box(q))));
    g.finish();
}

fn benches(c: &mut Criterion) {
    bench_robot(c, "solo12", "solo12/solo12.urdf", BaseKind::Floating);
    bench_robot(c, "minitaur", "minitaur/minitaur.urdf", BaseKind::Floating);
    let cos_sin = UrdfOptions { continuous_as_cos_sin: true, ..UrdfOptions::default() };
    bench_robot_with(c, "minitaur_cos_sin", "minitaur/minitaur.urdf", BaseKind::Floating, cos_sin);
    bench_robot(c, "talos_reduced", "talos/talos_reduced.urdf", BaseKind::Floating);
    bench_robot(c, "ur5", "ur5/ur5_robot.urdf", BaseKind::Fixed);
}

criterion_group! {
    name = dynamics;
    config = Criterion::default().sample_size(30).warm_up_time(std::time::Duration::from_millis(300))
        .measurement_time(std::time::Duration::from_millis(800));
    targets = benches
}
criterion_main!(dynamics);
