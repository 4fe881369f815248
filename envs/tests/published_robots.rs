//! Loaded means usable: published robots that the URDF loader accepts with warnings (their
//! dummy `base` links have non-physical inertias, merged into physical bodies) stand under
//! joint PD in the simulator, without drifting, like the Minitaur test in `physics.rs`.

use centaur_dynamics::nalgebra::{UnitQuaternion, Vector3};
use centaur_dynamics::{
    BaseKind, Data, Model, RobotState, UrdfWarning, forward_kinematics, update_frame_placements,
};
use centaur_envs::sim::{ColliderSpec, Sim, SimConfig};

fn corpus(rel: &str) -> String {
    format!("{}/../assets/corpus/example-robot-data/{rel}", env!("CARGO_MANIFEST_DIR"))
}

/// Puts `model` at the joint angles `pose` (by joint name suffix), lowest foot `clearance`
/// above the ground, and holds the pose with PD torques (`kp`, `kd`, clipped at the URDF's
/// effort limits) for `seconds`. Returns the base positions after 1 s and at the end, the
/// largest tilt and joint speed over the last 4 s.
fn stand(model: &Model, feet: &[&str], pose: &[(&str, f64)], kp: f64, kd: f64, seconds: f64) -> Standing {
    let mut state = RobotState::new(model);
    for j in &model.joints[2..] {
        let (_, angle) = pose
            .iter()
            .find(|(suffix, _)| j.name.ends_with(suffix))
            .unwrap_or_else(|| panic!("no pose for joint {}", j.name));
        state.q[j.idx_q] = *angle;
    }
    // Height: the lowest foot frame `clearance` above the ground (with the base at z = 0).
    let mut data = Data::new(model);
    forward_kinematics(model, &mut data, state.q.as_slice());
    update_frame_placements(model, &mut data);
    let lowest = feet
        .iter()
        .map(|f| data.o_m_f[model.frame_index(f).unwrap_or_else(|| panic!("no frame {f}"))].translation.z)
        .fold(f64::INFINITY, f64::min);
    state.set_base_pose(Vector3::new(0.0, 0.0, -lowest + 0.05), UnitQuaternion::identity());
    let target: Vec<f64> = state.joint_positions().to_vec();

    let mut sim = Sim::new(model, &SimConfig::default(), &ColliderSpec::default(), &[]).expect("sim");
    sim.set_state(&state);
    let steps = (seconds / sim.config().dt).round() as usize;
    let settle = (1.0 / sim.config().dt).round() as usize;
    let mut tau = vec![0.0; model.nv];
    let (mut after_settle, mut max_tilt, mut max_speed) = (Vector3::zeros(), 0.0f64, 0.0f64);
    for step in 0..steps {
        sim.read_state(&mut state);
        assert!(state.is_finite(), "{}: the state is not finite at step {step}", model.name);
        for (k, (q, qd)) in state.joint_positions().iter().zip(state.joint_velocities()).enumerate() {
            let v = 6 + k;
            let limit = model.effort_limit[v];
            tau[v] = (kp * (target[k] - q) - kd * qd).clamp(-limit, limit);
        }
        sim.set_joint_torques(&tau);
        sim.step();
        if step == settle {
            after_settle = state.base_position();
        }
        if step > settle {
            let up = state.base_orientation() * Vector3::z();
            max_tilt = max_tilt.max(up.z.clamp(-1.0, 1.0).acos());
            max_speed = max_speed.max(state.joint_velocities().iter().fold(0.0, |m, v| m.max(v.abs())));
        }
    }
    sim.read_state(&mut state);
    Standing { after_settle, end: state.base_position(), max_tilt, max_speed }
}

struct Standing {
    after_settle: Vector3<f64>,
    end: Vector3<f64>,
    max_tilt: f64,
    max_speed: f64,
}

fn assert_stands(name: &str, s: &Standing, height: (f64, f64)) {
    let drift = (s.end - s.after_settle).norm();
    eprintln!(
        "{name}: base height {:.3} m, drift over 4 s {:.2e} m, tilt {:.3} rad, joint speed {:.2e} rad/s",
        s.end.z, drift, s.max_tilt, s.max_speed
    );
    assert!(s.end.z > height.0 && s.end.z < height.1, "{name}: base height {} m", s.end.z);
    assert!(drift < 2e-3, "{name}: the base drifted {drift} m in 4 s of standing");
    assert!(s.max_tilt < 0.05, "{name}: tilted {} rad", s.max_tilt);
    assert!(s.max_speed < 0.05, "{name}: joints move at up to {} rad/s", s.max_speed);
}

#[test]
fn go1_stands_under_pd_for_5_s() {
    let model = Model::from_urdf_file(corpus("go1_description/urdf/go1.urdf"), BaseKind::Floating).unwrap();
    // The dummy base link ([−2.2e−22, 0, 3e−6]) is merged into the trunk and reported.
    assert!(
        model
            .load_warnings
            .iter()
            .any(|w| matches!(w, UrdfWarning::NonPhysicalLinkMerged { link, .. } if link == "base"))
    );
    let feet = ["FR_foot", "FL_foot", "RR_foot", "RL_foot"];
    let pose = [("hip_joint", 0.0), ("thigh_joint", 0.9), ("calf_joint", -1.8)];
    let s = stand(&model, &feet, &pose, 200.0, 4.0, 5.0);
    assert_stands("go1", &s, (0.2, 0.4));
}

#[test]
fn anymal_c_stands_under_pd_for_5_s() {
    let model =
        Model::from_urdf_file(corpus("anymal_c_simple_description/urdf/anymal.urdf"), BaseKind::Floating)
            .unwrap();
    let feet = ["LF_FOOT", "RF_FOOT", "LH_FOOT", "RH_FOOT"];
    let pose = [
        ("LF_HAA", 0.0),
        ("RF_HAA", 0.0),
        ("LH_HAA", 0.0),
        ("RH_HAA", 0.0),
        ("LF_HFE", 0.4),
        ("RF_HFE", 0.4),
        ("LH_HFE", -0.4),
        ("RH_HFE", -0.4),
        ("LF_KFE", -0.8),
        ("RF_KFE", -0.8),
        ("LH_KFE", 0.8),
        ("RH_KFE", 0.8),
    ];
    let s = stand(&model, &feet, &pose, 300.0, 8.0, 5.0);
    assert_stands("anymal_c", &s, (0.3, 0.7));
}
