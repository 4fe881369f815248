//! A first program with centaur-dynamics: load two real robots from URDF and compute what a
//! controller needs — mass, centre of mass, foot positions and Jacobians, gravity torques,
//! the mass matrix and forward dynamics.

use centaur::dynamics::nalgebra::{DVector, Matrix6xX};
use centaur::dynamics::{
    BaseKind, Data, Model, ReferenceFrame, aba, center_of_mass, compute_joint_jacobians, crba,
    forward_kinematics, frame_jacobian, frame_placement, gravity_torques,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    for (path, feet) in [
        ("assets/minitaur/minitaur.urdf", ["lower_leg_front_leftL_link", "lower_leg_back_rightR_link"]),
        ("assets/solo12/solo12.urdf", ["FL_FOOT", "HR_FOOT"]),
    ] {
        let model = Model::from_urdf_file(path, BaseKind::Floating)?;
        let mut data = Data::new(&model);
        println!(
            "{path}: '{}', {} joints, nq = {}, nv = {}",
            model.name,
            model.njoints() - 1,
            model.nq,
            model.nv
        );
        println!(
            "  total mass {:.3} kg, {} frames, {} geometries",
            model.total_mass(),
            model.frames.len(),
            model.geometries.len()
        );

        let mut q = model.neutral_configuration();
        q[2] = 0.3; // base 30 cm above the ground
        let com = center_of_mass(&model, &mut data, q.as_slice());
        println!("  centre of mass at the neutral pose: [{:.4}, {:.4}, {:.4}] m", com.x, com.y, com.z);

        forward_kinematics(&model, &mut data, q.as_slice());
        compute_joint_jacobians(&model, &mut data, q.as_slice());
        let mut jac = Matrix6xX::zeros(model.nv);
        for foot in feet {
            let f = model.frame_index(foot).ok_or("foot frame missing")?;
            let p = frame_placement(&model, &data, f).translation;
            frame_jacobian(&model, &data, f, ReferenceFrame::LocalWorldAligned, &mut jac);
            let nonzero = (0..model.nv).filter(|&k| jac.column(k).norm() > 0.0).count();
            println!(
                "  {foot}: at [{:.3}, {:.3}, {:.3}] m, Jacobian touches {nonzero} of {} dofs",
                p.x, p.y, p.z, model.nv
            );
        }

        let g = gravity_torques(&model, &mut data, q.as_slice()).clone();
        println!("  gravity wrench on the base (base frame): [{:.2}, {:.2}, {:.2}] N", g[0], g[1], g[2]);
        let m = crba(&model, &mut data, q.as_slice()).clone();
        println!("  mass matrix: M[0,0] = {:.3} kg (the total mass), trace {:.3}", m[(0, 0)], m.trace());

        // Free fall: with zero torques the base accelerates at g.
        let zero = DVector::zeros(model.nv);
        let ddq = aba(&model, &mut data, q.as_slice(), zero.as_slice(), zero.as_slice());
        println!("  free fall: base acceleration [{:.3}, {:.3}, {:.3}] m/s²\n", ddq[0], ddq[1], ddq[2]);
    }
    Ok(())
}
