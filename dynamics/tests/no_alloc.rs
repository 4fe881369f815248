//! Every algorithm runs without allocating once `Data::new` has run: a counting global
//! allocator (counting only this thread's allocations) proves it.

mod common;

use centaur_dynamics::*;
use centaur_test_support::{CountingAllocator, allocations};
use common::{Rng, random_q, random_v, test_models};
use nalgebra::{DMatrix, Matrix6xX};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn algorithms_allocate_nothing_after_data_new() {
    let mut rng = Rng(3);
    for model in test_models() {
        let mut data = Data::new(&model);
        let q = random_q(&model, &mut rng);
        let v = random_v(&model, &mut rng);
        let a = random_v(&model, &mut rng);
        let mut jac = Matrix6xX::zeros(model.nv);
        let mut minv = DMatrix::zeros(model.nv, model.nv);
        let mut b = v.clone();
        let mut q_out = q.clone();
        let (q, v, a) = (q.as_slice(), v.as_slice(), a.as_slice());
        let foot = model.frames.len() - 1;
        let n = allocations(|| {
            forward_kinematics(&model, &mut data, q);
            forward_kinematics_velocity(&model, &mut data, q, v);
            forward_kinematics_acceleration(&model, &mut data, q, v, a);
            update_frame_placements(&model, &mut data);
            let _ = frame_velocity(&model, &data, foot, ReferenceFrame::LocalWorldAligned);
            let _ = frame_classical_acceleration(&model, &data, foot);
            compute_joint_jacobians(&model, &mut data, q);
            frame_jacobian(&model, &data, foot, ReferenceFrame::LocalWorldAligned, &mut jac);
            joint_jacobian(&model, &data, model.njoints() - 1, ReferenceFrame::Local, &mut jac);
            rnea(&model, &mut data, q, v, a);
            nonlinear_effects(&model, &mut data, q, v);
            gravity_torques(&model, &mut data, q);
            crba(&model, &mut data, q);
            cholesky_decompose(&model, &mut data);
            mass_matrix_solve(&model, &data, b.as_mut_slice());
            mass_matrix_inverse(&model, &data, &mut minv);
            aba(&model, &mut data, q, v, a);
            center_of_mass(&model, &mut data, q);
            jacobian_center_of_mass(&model, &mut data, q);
            center_of_mass_velocity(&model, &mut data, q, v);
            centroidal_map(&model, &mut data, q);
            centroidal_momentum(&model, &mut data, q, v);
            kinetic_energy(&model, &mut data, q, v);
            potential_energy(&model, &mut data, q);
            integrate(&model, q, v, q_out.as_mut_slice());
        });
        assert_eq!(n, 0, "{}: {n} allocations in the algorithms", model.name);
    }
}

#[test]
fn the_counter_sees_allocations() {
    // Guards the test above against a counter that counts nothing.
    assert!(allocations(|| vec![1u8; 16]) >= 1);
}
