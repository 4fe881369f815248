//! Modular robots (Revolve2-style bodies): the builder's checks, the generated model against
//! Revolve2's V1 module numbers, and the environment's behaviour.

use centaur_dynamics::nalgebra::Vector3;
use centaur_dynamics::{Data, JointKind, Model, forward_kinematics};
use centaur_envs::modular::{
    Body, Face, ModularConfig, ModularEnv, ModularError, ModularObservation, ModularReward, ModuleKind,
    ModuleSpecs,
};
use centaur_envs::{ObsOptions, RobotEnv};
use centaur_gym::{Env, EnvError, Rng};

fn joint_of(model: &Model, body: &Body, path: &[Face]) -> usize {
    let mut id = body.core();
    for f in path {
        id = body.child(id, *f).expect("module on the path");
    }
    assert_eq!(body.kind(id), Some(ModuleKind::ActiveHinge));
    model.joint_index(&format!("hinge{}", id.0)).expect("hinge joint")
}

#[test]
fn builder_rejects_what_cannot_be_built_and_keeps_the_body_unchanged() {
    let mut b = Body::new();
    let c = b.core();
    let brick = b.brick(c, Face::Front, 0.0).unwrap();
    let hinge = b.hinge(c, Face::Left, 0.0).unwrap();
    assert!(matches!(b.brick(brick, Face::Back, 0.0), Err(ModularError::NoSuchFace { kind: "brick", .. })));
    assert!(matches!(b.brick(hinge, Face::Front, 0.0), Err(ModularError::NoSuchFace { kind: "hinge", .. })));
    assert!(matches!(b.hinge(c, Face::Attachment, 0.0), Err(ModularError::NoSuchFace { kind: "core", .. })));
    let taken = b.hinge(c, Face::Front, 0.0).unwrap_err();
    assert_eq!(taken, ModularError::FaceTaken { path: "core".into(), face: "front" });
    assert_eq!(b.attach(c, Face::Back, ModuleKind::Core, 0.0), Err(ModularError::SecondCore));
    assert!(matches!(b.hinge(c, Face::Back, f64::NAN), Err(ModularError::BadRotation(_))));
    assert_eq!(b.brick(centaur_envs::ModuleId(99), Face::Front, 0.0), Err(ModularError::NoSuchModule(99)));
    // A body is bounded (reliability probe: a 1,833-module body ran at 10 steps/s): a chain
    // of bricks grows to MAX_MODULES modules and no further.
    let mut chain = Body::new();
    let mut last = chain.core();
    for _ in 1..centaur_envs::modular::MAX_MODULES {
        last = chain.brick(last, Face::Front, 0.0).unwrap();
    }
    assert_eq!(chain.brick(last, Face::Front, 0.0), Err(ModularError::TooManyModules));
    // A brick left of the front brick would sit where the left arm's side brick is.
    let mut b = Body::new();
    let c = b.core();
    let left = b.brick(c, Face::Left, 0.0).unwrap();
    b.brick(left, Face::Right, 0.0).unwrap();
    let front = b.brick(c, Face::Front, 0.0).unwrap();
    let before = b.clone();
    let err = b.brick(front, Face::Left, 0.0).unwrap_err();
    assert_eq!(
        err,
        ModularError::Overlap { new: "core.front.left".into(), existing: "core.left.right".into() }
    );
    assert_eq!(b, before, "a rejected module leaves no trace");
    assert!(b.child(front, Face::Left).is_none());
    let msg = err.to_string();
    assert!(msg.contains("core.front.left") && msg.contains("overlap"), "{msg}");
}

#[test]
fn presets_have_revolve2s_modules_masses_and_joints() {
    // (body, modules, hinges, mass): V1 core 250 g, brick 30 g, hinge 11 + 58 + 20 g.
    for (name, body, modules, hinges, mass) in [
        ("gecko", Body::gecko(), 13, 6, 0.964),
        ("modular-ant", Body::ant(), 17, 8, 1.202),
        ("spider", Body::spider(), 17, 8, 1.202),
    ] {
        assert_eq!(body.num_modules(), modules, "{name}");
        assert_eq!(body.hinges().len(), hinges, "{name}");
        assert!((body.mass() - mass).abs() < 1e-12, "{name}: {}", body.mass());
        let model = body.to_model(name).unwrap();
        assert!((model.total_mass() - mass).abs() < 1e-12, "{name}: model mass {}", model.total_mass());
        assert_eq!(model.nv, 6 + hinges, "{name}: a free-flyer and one dof per hinge");
        for j in 2..model.njoints() {
            assert!(model.joints[j].name.starts_with("hinge"), "{name}: {}", model.joints[j].name);
            let v = model.joints[j].idx_v;
            // 60°: Revolve2 writes 1.047197551.
            assert!(
                (model.upper_position_limit[model.joints[j].idx_q] - std::f64::consts::FRAC_PI_3).abs()
                    < 1e-12
            );
            assert!((model.effort_limit[v] - 0.948013269).abs() < 1e-12);
        }
    }
}

/// World axis of a revolute joint at the current kinematics.
fn joint_axis(model: &Model, data: &Data, j: usize) -> Vector3<f64> {
    match model.joints[j].kind {
        JointKind::Revolute { axis } => data.o_m_i[j].rotation * axis,
        _ => panic!("joint {j} is not revolute"),
    }
}

#[test]
fn geometry_and_axes_follow_revolve2s_construction() {
    let body = Body::gecko();
    let model = body.to_model("gecko").unwrap();
    let mut data = Data::new(&model);
    let q = model.neutral_configuration();
    forward_kinematics(&model, &mut data, q.as_slice());
    // Distances along the chain, from Revolve2's V1 numbers: half the core 0.0445; a hinge's
    // slot to its joint 0.034525 (frame offset / 2 + joint offset) and to its child's slot
    // 0.083675 (frame offset / 2 + servo offset + servo half length + 2 mm); a brick's
    // length 0.06288625.
    let (core, joint, hinge, brick) = (0.0445, 0.034525, 0.083675, 0.06288625);
    let hip = -(core + hinge + brick + hinge + brick / 2.0);
    // Every hinge: (path, joint position, joint axis), all at z = 0. A leg on a face at
    // yaw ψ (rotation 0) turns about R_z(ψ) y; the spine (rotation π/2 on the back face,
    // whose yaw is π) about R_z(π) R_x(π/2) y = +z; the hip brick faces backwards (yaw π),
    // so its left leg is on the −y side.
    let expected: [(&[Face], [f64; 3], [f64; 3]); 6] = [
        (&[Face::Left], [0.0, core + joint, 0.0], [-1.0, 0.0, 0.0]),
        (&[Face::Right], [0.0, -(core + joint), 0.0], [1.0, 0.0, 0.0]),
        (&[Face::Back], [-(core + joint), 0.0, 0.0], [0.0, 0.0, 1.0]),
        (
            &[Face::Back, Face::Attachment, Face::Front],
            [-(core + hinge + brick + joint), 0.0, 0.0],
            [0.0, 0.0, 1.0],
        ),
        (
            &[Face::Back, Face::Attachment, Face::Front, Face::Attachment, Face::Left],
            [hip, -(brick / 2.0 + joint), 0.0],
            [1.0, 0.0, 0.0],
        ),
        (
            &[Face::Back, Face::Attachment, Face::Front, Face::Attachment, Face::Right],
            [hip, brick / 2.0 + joint, 0.0],
            [-1.0, 0.0, 0.0],
        ),
    ];
    for (path, position, axis) in expected {
        let j = joint_of(&model, &body, path);
        let p = data.o_m_i[j].translation;
        assert!(
            (p - Vector3::from(position)).norm() < 1e-12,
            "{path:?}: joint at {p:?}, expected {position:?}"
        );
        let a = joint_axis(&model, &data, j);
        assert!((a - Vector3::from(axis)).norm() < 1e-12, "{path:?}: axis {a:?}, expected {axis:?}");
    }
    // The left foot brick's centre: hinge slot 0.0445, slot to child slot 0.083675, half a
    // brick.
    let foot = body.child(body.child(body.core(), Face::Left).unwrap(), Face::Attachment).unwrap();
    let f = model.frame_index(&format!("brick{}", foot.0)).unwrap();
    let placement = centaur_dynamics::frame_placement(&model, &data, f);
    let expected = core + hinge + brick / 2.0;
    assert!((placement.translation - Vector3::new(0.0, expected, 0.0)).norm() < 1e-15, "{placement:?}");
}

#[test]
fn custom_module_specs_are_checked_and_used() {
    for (field, specs) in [
        ("velocity", ModuleSpecs { velocity: 0.0, ..ModuleSpecs::default() }),
        ("kp", ModuleSpecs { kp: f64::NAN, ..ModuleSpecs::default() }),
        ("armature", ModuleSpecs { armature: -1.0, ..ModuleSpecs::default() }),
        ("brick_size", ModuleSpecs { brick_size: [0.06, 0.0, 0.06], ..ModuleSpecs::default() }),
        ("range", ModuleSpecs { range: 4.0, ..ModuleSpecs::default() }),
    ] {
        match Body::with_specs(specs) {
            Err(ModularError::BadSpec { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: {other:?}"),
        }
    }
    // A brick twice as wide as long: children on its sides sit half its width away.
    let specs = ModuleSpecs { brick_size: [0.05, 0.1, 0.06], ..ModuleSpecs::default() };
    let mut body = Body::with_specs(specs).unwrap();
    let front = body.brick(body.core(), Face::Front, 0.0).unwrap();
    let side = body.hinge(front, Face::Left, 0.0).unwrap();
    let model = body.to_model("wide").unwrap();
    let mut data = Data::new(&model);
    forward_kinematics(&model, &mut data, model.neutral_configuration().as_slice());
    let j = model.joint_index(&format!("hinge{}", side.0)).unwrap();
    let p = data.o_m_i[j].translation;
    let expected = Vector3::new(0.0445 + 0.025, 0.05 + 0.034525, 0.0);
    assert!((p - expected).norm() < 1e-12, "{p:?}");
    assert_eq!(body.path(side).as_deref(), Some("core.front.left"));
    assert_eq!(body.path(centaur_envs::ModuleId(17)), None);
    // Odd robot names are escaped in the URDF.
    assert!(body.to_model("a<b & \"c\"").is_ok());
}

fn env(config: ModularConfig) -> (ModularEnv, Vec<f32>) {
    let env = ModularEnv::new(config).unwrap();
    let obs = vec![0.0; env.observation_space().dim()];
    (env, obs)
}

#[test]
fn rests_on_the_ground_without_creeping() {
    let (mut env, mut obs) = env(ModularConfig::gecko());
    env.reset(Some(3), &mut obs).unwrap();
    let start = env.robot_state().base_position();
    let zero = vec![0.0; env.action_space().dim()];
    for _ in 0..200 {
        let s = env.step(&zero, &mut obs).unwrap();
        assert!(!s.done());
    }
    let p = env.robot_state().base_position();
    // The core box is 0.0603 m high and lies flat on the ground.
    assert!((p.z - 0.0603 / 2.0).abs() < 1e-3, "core height {}", p.z);
    assert!((p - start).xy().norm() < 5e-3, "crept {:?}", p - start);
    assert!(env.robot_state().base_angular_velocity().norm() < 1e-2);
}

#[test]
fn servos_track_their_targets() {
    // Without gravity: on the ground, friction holds a servo as weak as kp = 5 N·m/rad
    // a few degrees off its target (measured: 3° past it, the rear half stuck).
    let body = Body::gecko();
    let mut config = ModularConfig::new("gecko", body.clone());
    config.sim.gravity = [0.0; 3];
    let (mut env, mut obs) = env(config);
    env.reset(Some(0), &mut obs).unwrap();
    let model = env.model().clone();
    let spine = joint_of(&model, &body, &[Face::Back]);
    let k = env.actuated_joints().iter().position(|&j| j == spine).unwrap();
    let mut a = vec![0.0f32; env.action_space().dim()];
    a[k] = 0.5;
    for _ in 0..20 {
        env.step(&a, &mut obs).unwrap();
    }
    let q = env.robot_state().q[model.joints[spine].idx_q];
    let target = 0.5 * std::f64::consts::FRAC_PI_3;
    assert!((q - target).abs() < 0.01, "spine at {q}, target {target}");
    // Driven back and forth at full stroke, a hinge runs at the servo's rated 6.34 rad/s
    // (measured 6.37: the torque–speed envelope acts on the previous physics step's speed,
    // so it can overshoot by up to one step's acceleration); without the envelope, at
    // 33 rad/s.
    let fastest = |velocity: f64| {
        let specs = ModuleSpecs { velocity, ..ModuleSpecs::default() };
        let mut body = Body::with_specs(specs).unwrap();
        let hinge = body.hinge(body.core(), Face::Back, std::f64::consts::FRAC_PI_2).unwrap();
        body.brick(hinge, Face::Attachment, 0.0).unwrap();
        let mut config = ModularConfig::new("arm", body);
        config.sim.gravity = [0.0; 3];
        let (mut env, mut obs) = self::env(config);
        env.reset(Some(0), &mut obs).unwrap();
        let v = env.model().joints[env.actuated_joints()[0]].idx_v;
        let mut top = 0.0f64;
        for step in 0..60 {
            let a = if (step / 5) % 2 == 0 { 1.0 } else { -1.0 };
            env.step(&[a], &mut obs).unwrap();
            top = top.max(env.robot_state().v[v].abs());
        }
        top
    };
    let (limited, unlimited) = (fastest(6.338968228), fastest(f64::INFINITY));
    assert!(limited > 5.0 && limited < 6.338968228 + 1.5, "fastest hinge speed {limited} rad/s");
    assert!(unlimited > 2.0 * limited, "without the envelope: {unlimited} rad/s");
    // Actions beyond ±1 are clipped: a = 5 behaves exactly like a = 1.
    let run = |scale: f32| {
        let (mut e, mut o) = (ModularEnv::new(ModularConfig::gecko()).unwrap(), obs.clone());
        e.reset(Some(1), &mut o).unwrap();
        let a = vec![scale; e.action_space().dim()];
        for _ in 0..10 {
            e.step(&a, &mut o).unwrap();
        }
        o
    };
    assert_eq!(run(5.0), run(1.0));
}

#[test]
fn an_episodes_return_is_the_xy_displacement_and_runs_are_reproducible() {
    let rollout = |reward: ModularReward, seed: u64| {
        let (mut env, mut obs) =
            env(ModularConfig { reward, max_episode_steps: 120, ..ModularConfig::spider() });
        env.reset(Some(seed), &mut obs).unwrap();
        let start = env.robot_state().base_position();
        let mut rng = Rng::seed_from_u64(seed);
        let (mut ret, mut trace) = (0.0, Vec::new());
        loop {
            let a: Vec<f32> = (0..env.action_space().dim()).map(|_| rng.range(-1.0, 1.0) as f32).collect();
            let s = env.step(&a, &mut obs).unwrap();
            ret += s.reward;
            trace.extend_from_slice(&obs);
            assert!(!s.terminated && !s.info.unstable);
            if s.done() {
                assert!(s.truncated);
                break;
            }
        }
        assert!(matches!(
            env.step(&vec![0.0; env.action_space().dim()], &mut obs),
            Err(EnvError::NeedsReset)
        ));
        let d = env.robot_state().base_position() - start;
        (ret, d, trace)
    };
    let (ret, d, trace) = rollout(ModularReward::XyDisplacement, 7);
    assert!((ret - d.xy().norm()).abs() < 1e-9, "return {ret} vs displacement {}", d.xy().norm());
    assert!(d.xy().norm() > 1e-3, "random flailing moves the robot a little: {d:?}");
    let (ret_x, dx, _) = rollout(ModularReward::ForwardX, 7);
    assert!((ret_x - dx.x).abs() < 1e-9);
    let (_, _, again) = rollout(ModularReward::XyDisplacement, 7);
    assert_eq!(trace, again, "same seed, same trajectory bit for bit");
    let (_, _, other) = rollout(ModularReward::XyDisplacement, 8);
    assert_ne!(trace, other);
}

#[test]
fn bad_actions_and_observation_options() {
    let (mut env, mut obs) = env(ModularConfig::ant());
    assert_eq!(env.action_space().dim(), 8);
    assert_eq!(obs.len(), 11 + 2 * 8);
    let zero = vec![0.0; 8];
    assert!(matches!(env.step(&zero, &mut obs), Err(EnvError::NeedsReset)));
    env.reset(Some(0), &mut obs).unwrap();
    let mut nan = zero.clone();
    nan[3] = f32::NAN;
    assert!(matches!(env.step(&nan, &mut obs), Err(EnvError::NonFiniteAction { index: 3, .. })));
    assert!(matches!(env.step(&zero[..5], &mut obs), Err(EnvError::ActionLength { expected: 8, got: 5 })));
    let options = ObsOptions { joint_history: 3, drop_base_orientation: true };
    let mut c = ModularConfig::ant();
    c.obs = options;
    let (mut env, mut obs) = self::env(c);
    assert_eq!(obs.len(), 11 + 2 * 8 - 4 + 3 * 8);
    env.reset(Some(0), &mut obs).unwrap();
    // The history starts filled with the reset angles (which follow the height), in all
    // three slots.
    for slot in 0..3 {
        let start = obs.len() - 24 + 8 * slot;
        assert_eq!(&obs[1..9], &obs[start..start + 8], "slot {slot}");
    }
    // After a step the newest slot holds the new angles and the oldest is dropped.
    let before = obs[1..9].to_vec();
    env.step(&[0.5; 8], &mut obs).unwrap();
    let n = obs.len();
    assert_eq!(&obs[1..9], &obs[n - 8..]);
    assert_eq!(&before[..], &obs[n - 16..n - 8]);
    assert_eq!(&before[..], &obs[n - 24..n - 16]);
    // A push no simulator survives ends the episode with the flag, without a panic.
    let (mut env, mut obs) = self::env(ModularConfig::gecko());
    env.reset(Some(0), &mut obs).unwrap();
    env.push(Vector3::new(1e30, 0.0, 0.0), 1.0);
    let mut ended = false;
    for _ in 0..5 {
        let s = env.step(&[0.0; 6], &mut obs).unwrap();
        if s.done() {
            assert!(s.terminated && s.info.unstable, "{s:?}");
            ended = true;
            break;
        }
    }
    assert!(ended, "the blown-up episode ended");
    let mut no_hinge = ModularConfig::gecko();
    no_hinge.body = Body::new();
    assert!(ModularEnv::new(no_hinge).is_err());
}

#[test]
fn the_simulator_holds_the_bodys_mass() {
    for config in [ModularConfig::gecko(), ModularConfig::ant(), ModularConfig::spider()] {
        let mass = config.body.mass();
        let env = ModularEnv::new(config).unwrap();
        assert!((env.sim().total_mass() - mass).abs() < 1e-5, "{} vs {mass}", env.sim().total_mass());
    }
}

#[test]
fn servo_torque_follows_the_pd_law_inside_the_torque_speed_envelope() {
    use centaur_envs::modular::{ModuleSpecs, servo_torque};
    let s = ModuleSpecs::default();
    // At rest: the PD law, clipped to ±effort.
    assert!((servo_torque(&s, 0.1, 0.0, 0.0) - 0.5).abs() < 1e-12);
    assert_eq!(servo_torque(&s, 1.0, 0.0, 0.0), s.effort);
    assert_eq!(servo_torque(&s, -1.0, 0.0, 0.0), -s.effort);
    // Half the rated speed leaves half the torque in the direction of motion, all of it
    // against; at the rated speed and beyond, nothing more in the direction of motion.
    let v = s.velocity;
    assert!((servo_torque(&s, 1.0, 0.0, v / 2.0) - s.effort / 2.0).abs() < 1e-12);
    assert_eq!(servo_torque(&s, -1.0, 0.0, v / 2.0), -s.effort);
    assert_eq!(servo_torque(&s, 1.0, 0.0, v), 0.0);
    assert_eq!(servo_torque(&s, 1.0, 0.0, 3.0 * v), 0.0);
    assert!((servo_torque(&s, -1.0, 0.0, -v / 2.0) + s.effort / 2.0).abs() < 1e-12);
    // Without a speed limit the envelope is the plain clip.
    let unlimited = ModuleSpecs { velocity: f64::INFINITY, ..ModuleSpecs::default() };
    assert_eq!(servo_torque(&unlimited, 1.0, 0.0, 30.0), unlimited.effort);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Random build sequences, including bad parents, faces, kinds and rotations, never
    /// panic, and every body the builder accepts loads as a model of the same mass with one
    /// degree of freedom per hinge.
    #[test]
    fn random_bodies_build_or_are_refused(
        ops in proptest::collection::vec((0usize..40, 0usize..5, 0usize..3, 0usize..6), 0..25)
    ) {
        let faces = [Face::Front, Face::Back, Face::Left, Face::Right, Face::Attachment];
        let kinds = [ModuleKind::Core, ModuleKind::Brick, ModuleKind::ActiveHinge];
        let rotations = [0.0, std::f64::consts::FRAC_PI_2, -std::f64::consts::FRAC_PI_2, 0.3, f64::NAN, f64::INFINITY];
        let mut body = Body::new();
        for (parent, face, kind, rotation) in ops {
            let before = body.clone();
            let r = body.attach(centaur_envs::ModuleId(parent), faces[face], kinds[kind], rotations[rotation]);
            if r.is_err() {
                proptest::prop_assert_eq!(&body, &before);
            }
        }
        let model = body.to_model("random").unwrap();
        proptest::prop_assert!((model.total_mass() - body.mass()).abs() < 1e-12);
        proptest::prop_assert_eq!(model.nv, 6 + body.hinges().len());
        for h in body.hinges() {
            let name = format!("hinge{}", h.0);
            proptest::prop_assert!(model.joint_index(&name).is_some(), "no joint {}", name);
        }
    }
}

#[test]
fn bodies_read_back_from_json_and_bad_documents_are_refused() {
    for body in [Body::gecko(), Body::ant(), Body::spider()] {
        let text = body.to_json();
        assert_eq!(Body::from_json(&text).unwrap(), body, "{text}");
    }
    let parse = |text: &str| Body::from_json(text).unwrap_err();
    assert!(matches!(parse("{\"kind\": \"core\""), ModularError::Parse(_)));
    assert!(matches!(parse("{\"kind\": \"core\", \"legs\": 4}"), ModularError::Parse(_)));
    assert!(matches!(parse("{\"kind\": \"brick\"}"), ModularError::Parse(_)));
    assert!(matches!(parse("{\"kind\": \"core\", \"left\": {\"kind\": \"wheel\"}}"), ModularError::Parse(_)));
    assert_eq!(parse("{\"kind\": \"core\", \"left\": {\"kind\": \"core\"}}"), ModularError::SecondCore);
    assert!(matches!(
        parse("{\"kind\": \"core\", \"left\": {\"kind\": \"hinge\", \"front\": {\"kind\": \"brick\"}}}"),
        ModularError::NoSuchFace { kind: "hinge", .. }
    ));
    let overlap = r#"{"kind": "core", "left": {"kind": "brick", "right": {"kind": "brick"}},
                      "front": {"kind": "brick", "left": {"kind": "brick"}}}"#;
    assert!(matches!(parse(overlap), ModularError::Overlap { .. }));
    // A nesting 10,000 levels deep is refused by the parser, without exhausting the stack.
    let deep = "{\"kind\": \"core\", \"front\": ".to_string()
        + &"{\"kind\": \"hinge\", \"attachment\": ".repeat(10_000)
        + "{\"kind\": \"brick\"}"
        + &"}".repeat(10_001);
    assert!(matches!(parse(&deep), ModularError::Parse(_)));
    // Regression (reliability probe): an unknown kind of 5 MB is named by its start and
    // length, not echoed whole.
    let long = format!("{{\"kind\": \"core\", \"left\": {{\"kind\": \"{}\"}}}}", "x".repeat(5_000_000));
    let msg = parse(&long).to_string();
    assert!(msg.len() < 300 && msg.contains("5000000 bytes"), "{}", &msg[..msg.len().min(300)]);
    // The example body in the assets.
    let snake = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/modular/snake.json"))
        .unwrap();
    let snake = Body::from_json(&snake).unwrap();
    assert_eq!((snake.num_modules(), snake.hinges().len()), (9, 4));
}

/// The observation sets of the modular PPO study's ablation: each holds exactly its groups,
/// in the full observation's order, and the history composes with them.
#[test]
fn observation_sets_of_the_ablation() {
    let (mut full_env, mut full) = env(ModularConfig::gecko());
    full_env.reset(Some(4), &mut full).unwrap();
    full_env.step(&[0.3; 6], &mut full).unwrap();
    // Full: height (1), quaternion (4), 6 hinge angles, 6 base velocities, 6 hinge rates.
    let (quat, hinges) = (full[1..5].to_vec(), full[5..11].to_vec());
    for (set, history, expected) in [
        (ModularObservation::HingesOrientation, 0, [&quat[..], &hinges[..]].concat()),
        (ModularObservation::Hinges, 0, hinges.clone()),
    ] {
        let mut c = ModularConfig::gecko();
        c.observation = set;
        c.obs.joint_history = history;
        let (mut e, mut obs) = env(c);
        assert_eq!(obs.len(), set.dim(6));
        e.reset(Some(4), &mut obs).unwrap();
        e.step(&[0.3; 6], &mut obs).unwrap();
        // The same seed and action: the same state, fewer entries.
        assert_eq!(obs, expected, "{set:?}");
    }
    // "The last 3 hinge positions + orientation": the set with three steps of history.
    let mut c = ModularConfig::gecko();
    c.observation = ModularObservation::HingesOrientation;
    c.obs.joint_history = 3;
    let (mut e, mut obs) = env(c.clone());
    assert_eq!(obs.len(), 4 + 6 + 3 * 6);
    e.reset(Some(4), &mut obs).unwrap();
    e.step(&[0.3; 6], &mut obs).unwrap();
    assert_eq!(&obs[4..10], &obs[obs.len() - 6..], "the newest history slot is the current angles");
    // Dropping an orientation the set does not hold is refused.
    c.observation = ModularObservation::Hinges;
    c.obs.drop_base_orientation = true;
    assert!(ModularEnv::new(c).is_err());
}

/// Study B's control rate: `frame_skip = 50` of the 5 ms physics step is 4 control steps per
/// second, recorded in the configuration a run keeps.
#[test]
fn fifty_physics_steps_per_action_is_a_4_hz_control_rate() {
    let (env, _) = env(ModularConfig { frame_skip: 50, ..ModularConfig::gecko() });
    assert!((env.dt() - 0.25).abs() < 1e-12, "{}", env.dt());
    let recorded: serde_json::Value = serde_json::from_str(&env.config_text().unwrap()).unwrap();
    assert_eq!(recorded["frame_skip"], 50);
}
