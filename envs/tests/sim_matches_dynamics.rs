//! The simulator and the dynamics model agree: with no contact, Rapier's joint
//! accelerations equal centaur-dynamics' ABA for the same state and torques, and states
//! written into the simulator read back unchanged.

use centaur_dynamics::nalgebra::DVector;
use centaur_dynamics::{BaseKind, Data, JointKind, Model, RobotState, aba};
use centaur_envs::{ColliderSpec, Sim, SimConfig};
use centaur_gym::Rng;

fn asset(rel: &str) -> String {
    format!("{}/../assets/{rel}", env!("CARGO_MANIFEST_DIR"))
}

/// Random joint angles within limits (±1 rad where unlimited), base 5 m up with a random
/// orientation, so that nothing touches the ground.
fn random_state(model: &Model, rng: &mut Rng, velocity_scale: f64) -> RobotState {
    let mut s = RobotState::new(model);
    for j in &model.joints[1..] {
        match j.kind {
            JointKind::FreeFlyer => {
                let mut quat = [rng.normal(), rng.normal(), rng.normal(), rng.normal()];
                let n = quat.iter().map(|x| x * x).sum::<f64>().sqrt();
                quat.iter_mut().for_each(|x| *x /= n);
                s.q.as_mut_slice()[j.idx_q..j.idx_q + 7]
                    .copy_from_slice(&[0.1, -0.2, 5.0, quat[0], quat[1], quat[2], quat[3]]);
            }
            JointKind::Revolute { .. } | JointKind::Prismatic { .. } => {
                let (lo, hi) = (model.lower_position_limit[j.idx_q], model.upper_position_limit[j.idx_q]);
                let (lo, hi) = if lo.is_finite() && hi.is_finite() { (lo, hi) } else { (-1.0, 1.0) };
                s.q[j.idx_q] = rng.range(lo, hi);
            }
            JointKind::RevoluteUnbounded { .. } => unreachable!("the simulator rejects (cos, sin) joints"),
            JointKind::Universe => {}
        }
    }
    for k in 0..model.nv {
        s.v[k] = velocity_scale * rng.normal();
    }
    s
}

fn models() -> Vec<(&'static str, Model)> {
    let mut out = Vec::new();
    for (name, path, base) in [
        ("solo12", "solo12/solo12.urdf", BaseKind::Floating),
        ("minitaur", "minitaur/minitaur.urdf", BaseKind::Floating),
        ("ant", "mujoco/ant.urdf", BaseKind::Floating),
        ("humanoid", "mujoco/humanoid.urdf", BaseKind::Floating),
        ("walker2d", "mujoco/walker2d.urdf", BaseKind::Fixed),
        ("half_cheetah", "mujoco/half_cheetah.urdf", BaseKind::Fixed),
        ("ur5", "ur5/ur5_robot.urdf", BaseKind::Fixed),
    ] {
        let mut m = Model::from_urdf_file(asset(path), base).unwrap();
        // Rapier integrates damping implicitly, which changes the acceleration it reports.
        m.damping.fill(0.0);
        if name == "walker2d" || name == "half_cheetah" {
            // Lift the planar robots' root: rootz is the second joint.
            out.push((name, m));
        } else {
            out.push((name, m));
        }
    }
    out
}

#[test]
fn state_round_trips_through_the_simulator() {
    let mut rng = Rng::seed_from_u64(5);
    for (name, model) in models() {
        let mut sim = Sim::new(&model, &SimConfig::default(), &ColliderSpec::default(), &[]).unwrap();
        for _ in 0..5 {
            let s = random_state(&model, &mut rng, 0.5);
            sim.set_state(&s);
            let mut back = RobotState::new(&model);
            sim.read_state(&mut back);
            let dq = (&back.q - &s.q).amax();
            // Quaternions may come back negated.
            let dq_neg = {
                let mut b = back.q.clone();
                if model.has_floating_base() {
                    for k in 3..7 {
                        b[k] = -b[k];
                    }
                }
                (&b - &s.q).amax()
            };
            assert!(dq.min(dq_neg) < 1e-5, "{name}: q round trip error {dq}");
            let dv = (&back.v - &s.v).amax();
            assert!(dv < 1e-5, "{name}: v round trip error {dv}");
        }
    }
}

#[test]
fn rapier_accelerations_equal_aba_without_contact() {
    let mut rng = Rng::seed_from_u64(9);
    for (name, model) in models() {
        let mut data = Data::new(&model);
        let mut sim = Sim::new(&model, &SimConfig::default(), &ColliderSpec::default(), &[]).unwrap();
        let mut worst = 0.0f64;
        for _ in 0..5 {
            let mut s = random_state(&model, &mut rng, 0.0);
            if !model.has_floating_base() && model.joints[1].kind != JointKind::Universe {
                // Planar robots: put the body high above the ground through rootz.
                if let Some(z) = model.joint_index("rootz") {
                    s.q[model.joints[z].idx_q] = 5.0;
                }
            }
            let mut tau = DVector::zeros(model.nv);
            let first = if model.has_floating_base() { 6 } else { 0 };
            for k in first..model.nv {
                tau[k] = rng.normal() * model.inertias.iter().map(|y| y.mass).sum::<f64>().min(10.0) * 0.1;
            }
            sim.set_state(&s);
            sim.set_joint_torques(tau.as_slice());
            sim.step();
            let mut ours = vec![0.0; model.nv];
            sim.unconstrained_joint_accelerations(&mut ours);
            let reference = aba(&model, &mut data, s.q.as_slice(), s.v.as_slice(), tau.as_slice()).clone();
            let scale = reference.rows(first, model.nv - first).amax().max(1.0);
            for k in first..model.nv {
                let e = (ours[k] - reference[k]).abs() / scale;
                worst = worst.max(e);
                assert!(
                    e < 2e-3,
                    "{name}: dof {k} Rapier {} vs ABA {} (relative {e:e})",
                    ours[k],
                    reference[k]
                );
            }
        }
        eprintln!("{name}: worst relative difference Rapier vs ABA {worst:e}");
    }
}
