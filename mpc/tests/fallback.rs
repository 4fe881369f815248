//! Contrived failures: infeasible MPC problems are reported with the right status in
//! bounded time, the fallback is used, and non-finite states never panic.

mod common;

use std::time::Instant;

use centaur_mpc::{Command, ControlMode, Fallback, Gait, HardConstraints, LocomotionController, QpStatus};

#[test]
fn weak_robot_mpc_infeasible_uses_fallback_forces() {
    // f_max = 0.1 m g per foot cannot hold the weight; the body may sink at most 1 cm.
    let (model, mut cfg) = common::load("solo12");
    cfg.mpc.max_normal_force_ratio = 0.1;
    cfg.mpc.hard = HardConstraints { max_height_drop: Some(0.01), terminal_velocity_band: None };
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    let t0 = Instant::now();
    c.tick(&s, &Command::stand(), 0.0);
    let elapsed = t0.elapsed().as_secs_f64();
    let st = c.status();
    assert_eq!(st.mpc_status, QpStatus::PrimalInfeasible);
    assert_eq!(st.fallback, Fallback::MpcForces);
    assert_eq!(st.mpc_failures, 1);
    assert!(elapsed < 0.05, "a tick with an infeasible MPC took {elapsed} s");
    // No plan yet: the weight is split over the four stance feet (2.5 kg · 9.81 / 4).
    let fz: f64 = st.forces.iter().map(|f| f[2]).sum();
    assert!(fz > 0.0);
    assert!(c.command().tau.iter().all(|x| x.is_finite()));
}

#[test]
fn low_friction_mpc_infeasible_decays_last_forces() {
    // A feasible solve first, then μ too low to reach the commanded speed within the horizon.
    let (model, cfg) = common::low_friction_solo12();
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    c.tick(&s, &Command::stand(), 0.0);
    assert!(c.status().mpc_status.is_ok(), "{:?}", c.status().mpc_status);
    let before: f64 = c.status().forces.iter().map(|f| f[2]).sum();
    assert!(before > 20.0);
    // 1 m/s: out of friction's reach.
    let t0 = Instant::now();
    c.tick(&s, &Command::forward(1.0, Gait::Stand), 0.05);
    assert!(t0.elapsed().as_secs_f64() < 0.05);
    let st = c.status();
    assert_eq!(st.mpc_status, QpStatus::PrimalInfeasible);
    assert_eq!(st.fallback, Fallback::MpcForces);
}

#[test]
fn a_body_height_beyond_the_legs_gives_posture_pd() {
    let (model, cfg) = common::load("solo12");
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    let standing = c.robot().nominal_com_height;
    let at = |h: f64| Command { body_height: Some(h), ..Command::stand() };
    // Within 0.5–2 × the standing height: accepted and run.
    assert!(c.check_command(&at(1.1 * standing)).is_ok());
    c.tick(&s, &at(1.1 * standing), 0.0);
    assert_eq!(c.status().fallback, Fallback::None);
    // In centimetres, or a tenth of the standing height: refused, and a tick holds the posture.
    for (k, h) in [100.0 * standing, 0.1 * standing].into_iter().enumerate() {
        let err = c.check_command(&at(h)).unwrap_err().to_string();
        assert!(err.contains("command.body_height") && err.contains("standing CoM height"), "{err}");
        // The text names the range the check uses.
        let (low, high) = centaur_mpc::BODY_HEIGHT_RANGE;
        assert!(err.contains(&format!("{low}–{high} ×")), "{err}");
        c.tick(&s, &at(h), 0.001 * (k + 1) as f64);
        assert_eq!(c.status().fallback, Fallback::PosturePd, "{h}");
    }
    c.tick(&s, &Command::stand(), 0.003);
    assert_eq!(c.status().fallback, Fallback::None);
}

#[test]
fn non_finite_state_gives_posture_pd() {
    for (name, _, _) in common::ROBOTS {
        let (model, cfg) = common::load(name);
        let mut c = LocomotionController::new(&model, cfg).unwrap();
        let mut s = c.nominal_state();
        c.tick(&s, &Command::stand(), 0.0);
        s.q[0] = f64::NAN;
        let cmd = c.tick(&s, &Command::forward(0.3, Gait::Trot), 0.001).clone();
        assert_eq!(c.status().fallback, Fallback::PosturePd, "{name}");
        assert_eq!(c.status().invalid_states, 1);
        assert!(cmd.tau.iter().all(|x| *x == 0.0));
        assert!(cmd.q_des.iter().chain(&cmd.kp).chain(&cmd.kd).all(|x| x.is_finite()));
        // Infinite velocity, NaN command and NaN time too.
        s.q[0] = 0.0;
        s.v[0] = f64::INFINITY;
        c.tick(&s, &Command::stand(), 0.002);
        assert_eq!(c.status().fallback, Fallback::PosturePd);
        s.v[0] = 0.0;
        c.tick(&s, &Command { forward_velocity: f64::NAN, ..Command::stand() }, 0.003);
        assert_eq!(c.status().fallback, Fallback::PosturePd);
        c.tick(&s, &Command::stand(), f64::NAN);
        assert_eq!(c.status().fallback, Fallback::PosturePd);
        // And it recovers.
        c.tick(&s, &Command::stand(), 0.004);
        assert_eq!(c.status().fallback, Fallback::None, "{name}");
    }
}

#[test]
fn cheap_path_holds_the_weight() {
    // Stance legs τ = −Jᵀf: for Solo12 standing the MPC forces sum to m g and the torques
    // are finite and within limits.
    let (model, mut cfg) = common::load("solo12");
    cfg.mode = ControlMode::Cheap;
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    c.tick(&s, &Command::stand(), 0.0);
    let st = c.status();
    assert_eq!(st.wbc_status, QpStatus::NotRun);
    let fz: f64 = st.forces.iter().map(|f| f[2]).sum();
    assert!((fz - 2.5 * 9.81).abs() < 0.3, "{fz}");
    let tau = &c.command().tau;
    assert!(tau.iter().all(|x| x.abs() <= 2.7 + 1e-9));
    // Knees carry load: |τ_KFE| > 0.1 N·m.
    assert!(tau[2].abs() > 0.1, "{tau:?}");
}

#[test]
fn cheap_path_on_closed_loops_keeps_passive_knees_free() {
    let (model, mut cfg) = common::load("minitaur");
    cfg.mode = ControlMode::Cheap;
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    for k in 0..10 {
        c.tick(&s, &Command::forward(0.3, Gait::Trot), k as f64 * 0.01);
        assert!(c.command().tau.iter().all(|x| x.is_finite()));
    }
    assert_eq!(c.joint_names().len(), 8);
    assert!(c.joint_names().iter().all(|n| n.starts_with("motor_")));
}

#[test]
fn a_model_with_cos_sin_joints_is_refused_with_a_typed_error() {
    // The controller reads joint angles from q; a (cos θ, sin θ) joint would be misread.
    let (_, cfg) = common::load("minitaur");
    let path = format!("{}/../assets/minitaur/minitaur.urdf", env!("CARGO_MANIFEST_DIR"));
    let options = centaur_dynamics::UrdfOptions {
        continuous_as_cos_sin: true,
        ..centaur_dynamics::UrdfOptions::default()
    };
    let model =
        centaur_dynamics::Model::from_urdf_file_with(&path, centaur_dynamics::BaseKind::Floating, options)
            .expect("URDF loads");
    let Err(err) = LocomotionController::new(&model, cfg) else { panic!("a (cos, sin) model was accepted") };
    assert!(
        matches!(&err, centaur_mpc::ConfigError::Inconsistent(m) if m.contains("motor_") && m.contains("cos θ")),
        "{err}"
    );
}
