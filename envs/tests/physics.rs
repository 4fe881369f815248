//! Physics checks of the simulator: mass, free fall, momentum, standing still, friction,
//! joint limits, and the Minitaur's loop closures.

use centaur_dynamics::nalgebra::{DVector, Vector3};
use centaur_dynamics::{BaseKind, Data, Model, RobotState, centroidal_momentum};
use centaur_envs::minitaur::minitaur_model;
use centaur_envs::{
    ColliderSpec, LocomotionConfig, LocomotionEnv, LocomotionRobot, MinitaurConfig, MinitaurEnv, RobotEnv,
    Sim, SimConfig, SimError,
};
use centaur_gym::{Env, Rng};

fn asset(rel: &str) -> String {
    format!("{}/../assets/{rel}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn total_mass_equals_the_urdf() {
    let minitaur = MinitaurEnv::new(MinitaurConfig::deterministic()).unwrap();
    assert!((minitaur.model().total_mass() - 6.0).abs() < 1e-12, "Minitaur: 6 kg in the URDF");
    assert!((minitaur.sim().total_mass() - 6.0).abs() < 1e-5, "simulated {}", minitaur.sim().total_mass());
    for robot in [
        LocomotionRobot::Ant,
        LocomotionRobot::Walker2d,
        LocomotionRobot::Hopper,
        LocomotionRobot::HalfCheetah,
        LocomotionRobot::Humanoid,
    ] {
        let env = LocomotionEnv::new(LocomotionConfig::preset(robot)).unwrap();
        let expected = env.sidecar().total_mass;
        let sim_mass = env.sim().total_mass();
        assert!((env.model().total_mass() - expected).abs() < 1e-9 * expected, "{robot:?} model mass");
        assert!(
            (sim_mass - expected).abs() < 1e-5 * expected,
            "{robot:?}: simulated {sim_mass} vs MuJoCo {expected}"
        );
    }
}

#[test]
fn free_fall_matches_g() {
    // A floating robot high above the ground falls as z(t) = z₀ − ½ g t².
    let model = minitaur_model().unwrap();
    let config = SimConfig { gravity: [0.0, 0.0, -9.81], ..SimConfig::default() };
    let mut sim = Sim::new(&model, &config, &ColliderSpec::default(), &[]).unwrap();
    let mut s = RobotState::new(&model);
    s.q[2] = 10.0;
    sim.set_state(&s);
    let steps = 250; // 0.5 s
    for _ in 0..steps {
        sim.step();
    }
    sim.read_state(&mut s);
    let t = steps as f64 * config.dt;
    // Semi-implicit Euler: z_n = z₀ − g dt² n(n+1)/2, which tends to ½ g t².
    let expected = 10.0 - 9.81 * config.dt * config.dt * (steps * (steps + 1)) as f64 / 2.0;
    assert!((s.q[2] - expected).abs() < 1e-3, "z = {}, expected {expected}", s.q[2]);
    assert!((s.q[2] - (10.0 - 0.5 * 9.81 * t * t)).abs() < 0.01);
    let vz = s.base_linear_velocity_world().z;
    assert!((vz + 9.81 * t).abs() < 1e-3, "v_z = {vz}");
}

#[test]
fn torque_free_body_conserves_momentum() {
    // In the air, without gravity or torques, a robot set spinning and flailing keeps its
    // linear and angular momentum (the Minitaur's joints have no limits or damping).
    let model = minitaur_model().unwrap();
    let mut data = Data::new(&model);
    let config = SimConfig { gravity: [0.0; 3], ..SimConfig::default() };
    let mut sim = Sim::new(&model, &config, &ColliderSpec::default(), &[]).unwrap();
    let mut s = RobotState::new(&model);
    s.q[2] = 10.0;
    let mut rng = Rng::seed_from_u64(2);
    for k in 0..model.nv {
        s.v[k] = rng.normal();
    }
    sim.set_state(&s);
    sim.read_state(&mut s);
    let h0 = centroidal_momentum(&model, &mut data, s.q.as_slice(), s.v.as_slice());
    for _ in 0..1000 {
        sim.step();
    }
    sim.read_state(&mut s);
    let h1 = centroidal_momentum(&model, &mut data, s.q.as_slice(), s.v.as_slice());
    let dp = (h1.linear - h0.linear).norm();
    let dl = (h1.angular - h0.angular).norm();
    assert!(
        dp < 1e-3 * (1.0 + h0.linear.norm()),
        "linear momentum changed by {dp} (from {})",
        h0.linear.norm()
    );
    assert!(
        dl < 2e-2 * (1.0 + h0.angular.norm()),
        "angular momentum changed by {dl} (from {})",
        h0.angular.norm()
    );
}

#[test]
fn minitaur_under_pd_stands_30_s_without_creeping_jitter_or_sleeping() {
    let mut env =
        MinitaurEnv::new(MinitaurConfig { max_episode_steps: 4000, ..MinitaurConfig::deterministic() })
            .unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(0), &mut obs).unwrap();
    let zero = [0.0f32; 8];
    for _ in 0..100 {
        env.step(&zero, &mut obs).unwrap();
    }
    let start = env.robot_state().clone();
    let mut max_joint_speed: f64 = 0.0;
    for _ in 0..3000 {
        let s = env.step(&zero, &mut obs).unwrap();
        assert!(!s.done(), "the Minitaur fell while standing");
        max_joint_speed = max_joint_speed.max(obs[8..16].iter().map(|v| v.abs() as f64).fold(0.0, f64::max));
    }
    let end = env.robot_state().clone();
    let creep = (end.base_position() - start.base_position()).norm();
    assert!(creep < 1e-3, "base moved {creep} m in 30 s");
    assert!(max_joint_speed < 0.05, "joints jitter at up to {max_joint_speed} rad/s");
    // Not asleep: a push still moves it.
    env.push(Vector3::new(0.0, 20.0, 0.0), 0.1);
    for _ in 0..20 {
        env.step(&zero, &mut obs).unwrap();
    }
    let moved = (env.robot_state().base_position() - end.base_position()).norm();
    assert!(moved > 5e-3, "a 20 N push moved the base by only {moved} m: asleep?");
}

const BLOCK_LINK: &str = r#"<link name="box">
        <inertial><mass value="1"/><inertia ixx="0.00167" iyy="0.00167" izz="0.00167" ixy="0" ixz="0" iyz="0"/></inertial>
        <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>"#;

/// The free 10 cm cube.
fn free_block() -> Model {
    let urdf = format!(r#"<robot name="block">{BLOCK_LINK}</robot>"#);
    Model::from_urdf_str(&urdf, "block.urdf", BaseKind::Floating).unwrap()
}

/// The cube on a fixed-base planar chain, the way Walker2d, Hopper and HalfCheetah are built:
/// `rootx` (slide x) → `rootz` (slide z) → `rooty` (hinge about `pitch_axis`, y or −y).
fn planar_block(pitch_axis: &str) -> Model {
    let urdf = format!(
        r#"<robot name="planar_block"><link name="world"/><link name="x"/><link name="z"/>{BLOCK_LINK}
        <joint name="rootx" type="prismatic"><parent link="world"/><child link="x"/><axis xyz="1 0 0"/><limit effort="0" velocity="100"/></joint>
        <joint name="rootz" type="prismatic"><parent link="x"/><child link="z"/><axis xyz="0 0 1"/><limit effort="0" velocity="100"/></joint>
        <joint name="rooty" type="revolute"><parent link="z"/><child link="box"/><axis xyz="{pitch_axis}"/><limit lower="-3" upper="3" effort="0" velocity="100"/></joint>
        </robot>"#
    );
    Model::from_urdf_str(&urdf, "planar_block.urdf", BaseKind::Fixed).unwrap()
}

/// A simulation of `model` resting on the ground plane with gravity tilted by θ (an inclined
/// plane) and friction μ, started 5 cm up (`q[z]`) and stepped `settle` times.
fn on_slope(model: &Model, z: usize, theta: f64, mu: f64, settle: usize) -> Sim {
    let g = 9.81;
    let config = SimConfig {
        gravity: [g * theta.sin(), 0.0, -g * theta.cos()],
        ground_friction: mu,
        ..SimConfig::default()
    };
    let colliders = ColliderSpec { default_friction: mu, ..ColliderSpec::default() };
    let mut sim = Sim::new(model, &config, &colliders, &[]).unwrap();
    let mut s = RobotState::new(model);
    s.q[z] = 0.05;
    sim.set_state(&s);
    for _ in 0..settle {
        sim.step();
    }
    sim
}

/// How far (m) a block slides in 1 s down the slope; `q[x]` and `q[z]` are its x and height
/// coordinates.
fn block_slides(model: &Model, x: usize, z: usize, theta: f64, mu: f64) -> f64 {
    let mut sim = on_slope(model, z, theta, mu, 50);
    let mut s = RobotState::new(model);
    sim.read_state(&mut s);
    let x0 = s.q[x];
    for _ in 0..500 {
        sim.step();
    }
    sim.read_state(&mut s);
    s.q[x] - x0
}

/// The ground force `Sim::contact_force` reports on a block resting on a 20° slope (μ = 0.5)
/// balances its weight: (−m g sin θ, 0, m g cos θ) in the world frame.
fn check_reported_contact_force(model: &Model, z: usize, what: &str) {
    let (g, theta) = (9.81, 20f64.to_radians());
    let sim = on_slope(model, z, theta, 0.5, 300);
    let collider = sim.geometry_collider(0).expect("the block's box is a collider");
    let (f, _) = sim.contact_force(collider).expect("the block touches the ground");
    let weight = model.total_mass() * g;
    let expected = Vector3::new(-weight * theta.sin(), 0.0, weight * theta.cos());
    assert!(
        (f - expected).norm() < 0.03 * weight,
        "{what}: reported ground force {f:?}, expected {expected:?}"
    );
}

#[test]
fn reported_contact_force_balances_the_weight_on_a_slope() {
    // A multibody link (a single free body reports the normal part only, see
    // `Sim::contact_force`). With x and y of the friction basis swapped, as before, the
    // reported friction pointed along y.
    check_reported_contact_force(&planar_block("0 1 0"), 1, "planar block");
}

#[test]
fn block_on_a_slope_slides_iff_tan_theta_exceeds_mu() {
    check_slope(&free_block(), 0, 2, "free block");
}

/// Regression: Rapier gave a block on a planar chain a few percent of its friction (it slid
/// down a 20° slope at μ = 0.5 like on ice), because the joint frames of the pitch hinge left
/// the blocked y tangent a ~3e-15 effective mass instead of zero (see `Sim`'s docs).
#[test]
fn block_on_a_planar_chain_slides_iff_tan_theta_exceeds_mu() {
    check_slope(&planar_block("0 1 0"), 0, 1, "planar block, hinge about +y");
    check_slope(&planar_block("0 -1 0"), 0, 1, "planar block, hinge about −y");
}

fn check_slope(model: &Model, x: usize, z: usize, what: &str) {
    let mu = 0.5;
    for (theta_deg, slides) in [(20.0f64, false), (25.0, false), (29.0, true), (35.0, true)] {
        let theta = theta_deg.to_radians();
        let d = block_slides(model, x, z, theta, mu);
        // Sliding: ½ g (sinθ − μ cosθ) t² over 1 s (≥ 4 cm at 29°).
        let expected = 0.5 * 9.81 * (theta.sin() - mu * theta.cos()).max(0.0);
        if slides {
            assert!(
                d > 0.5 * expected && d < 1.5 * expected,
                "{what}, θ = {theta_deg}°: slid {d} m, expected ≈ {expected}"
            );
        } else {
            assert!(d.abs() < 2e-3, "{what}, θ = {theta_deg}° (tan θ = {:.3} < μ): slid {d} m", theta.tan());
        }
    }
}

#[test]
fn joint_limits_hold() {
    // Walker2d's knee range is [−150°, 0]: full torque past the upper limit stops there.
    let model = Model::from_urdf_file(asset("mujoco/walker2d.urdf"), BaseKind::Fixed).unwrap();
    let mut sim = Sim::new(
        &model,
        &SimConfig { gravity: [0.0; 3], ..SimConfig::default() },
        &ColliderSpec::default(),
        &[],
    )
    .unwrap();
    let mut s = RobotState::new(&model);
    s.q[model.joints[model.joint_index("rootz").unwrap()].idx_q] = 5.0;
    sim.set_state(&s);
    let knee = model.joint_index("leg_joint").unwrap();
    let (iq, iv) = (model.joints[knee].idx_q, model.joints[knee].idx_v);
    let upper = model.upper_position_limit[iq];
    let lower = model.lower_position_limit[iq];
    let mut tau = DVector::zeros(model.nv);
    for (sign, limit) in [(1.0, upper), (-1.0, lower)] {
        tau[iv] = sign * 100.0;
        sim.set_joint_torques(tau.as_slice());
        let mut worst: f64 = 0.0;
        for _ in 0..500 {
            sim.step();
            sim.read_state(&mut s);
            worst = worst.max(sign * (s.q[iq] - limit));
        }
        assert!(worst < 0.02, "the knee passed its limit {limit} by {worst} rad");
        assert!((s.q[iq] - limit).abs() < 0.02, "the knee rests at {} instead of its limit {limit}", s.q[iq]);
    }
}

#[test]
fn minitaur_loop_closure_gap_stays_below_1_mm_while_trotting() {
    let mut env = MinitaurEnv::new(MinitaurConfig::deterministic()).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(0), &mut obs).unwrap();
    let mut gaps = vec![0.0; 4];
    let mut worst: f64 = 0.0;
    for k in 0..1000 {
        let t = k as f64 * 0.01;
        let mut a = [0.0f32; 8];
        for leg in 0..4 {
            let phase = if leg == 0 || leg == 3 { 0.0 } else { std::f64::consts::PI };
            a[leg] = (0.3 * (4.0 * std::f64::consts::PI * t + phase).cos()) as f32;
            a[4 + leg] = (0.3 * (4.0 * std::f64::consts::PI * t + phase).sin()) as f32;
        }
        let s = env.step(&a, &mut obs).unwrap();
        env.sim().loop_closure_gaps(&mut gaps);
        worst = worst.max(gaps.iter().cloned().fold(0.0, f64::max));
        if s.done() {
            break;
        }
    }
    assert!(worst < 1e-3, "loop gap reached {} mm", worst * 1e3);
    assert!(
        env.robot_state().q[0] < -1.0,
        "the open-loop trot should walk (it walks backwards, as in PyBullet)"
    );
}

/// Regression test named after the bug it guards against: a point-to-point closure that
/// also locks the out-of-plane direction over-constrains the planar 5-bar leg in Rapier
/// (motor speeds of 200–700 rad/s, the robot tips over while standing). The closure locks
/// only the two in-plane directions; random actions must never spin a motor that fast.
#[test]
fn regression_full_point_to_point_closure_made_motor_speeds_spike() {
    let mut env = MinitaurEnv::new(MinitaurConfig::deterministic()).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let mut rng = Rng::seed_from_u64(11);
    let mut a = [0.0f32; 8];
    let mut worst: f64 = 0.0;
    for ep in 0..3 {
        env.reset(Some(ep), &mut obs).unwrap();
        loop {
            env.action_space().sample(&mut rng, &mut a);
            let s = env.step(&a, &mut obs).unwrap();
            worst = worst.max(obs[8..16].iter().map(|v| v.abs() as f64).fold(0.0, f64::max));
            if s.done() {
                break;
            }
        }
    }
    assert!(worst < 60.0, "a motor reached {worst} rad/s");
}

#[test]
fn the_simulator_refuses_cos_sin_joints() {
    // Rapier's joint coordinates are angles; a (cos θ, sin θ) model gets a typed error.
    let path = format!("{}/../assets/minitaur/minitaur.urdf", env!("CARGO_MANIFEST_DIR"));
    let options = centaur_dynamics::UrdfOptions {
        continuous_as_cos_sin: true,
        ..centaur_dynamics::UrdfOptions::default()
    };
    let model = Model::from_urdf_file_with(&path, BaseKind::Floating, options).unwrap();
    let Err(err) = Sim::new(&model, &SimConfig::default(), &ColliderSpec::default(), &[]) else {
        panic!("a (cos, sin) model was accepted")
    };
    assert!(matches!(&err, SimError::CosSinJoint(name) if name.starts_with("motor_")), "{err}");
}
