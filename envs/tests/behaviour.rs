//! Environment behaviour: random-action statistics in the references' range, determinism,
//! bad actions, blow-ups, vectorised stepping and the observation options.

use centaur_envs::{
    LocomotionConfig, LocomotionEnv, LocomotionRobot, MinitaurConfig, MinitaurEnv, ObsOptions, RobotEnv,
    Servo,
};
use centaur_gym::{Env, EnvError, Rng, VecEnv};

fn all_envs() -> Vec<Box<dyn Env>> {
    let mut v: Vec<Box<dyn Env>> = vec![Box::new(MinitaurEnv::new(MinitaurConfig::default()).unwrap())];
    for r in [
        LocomotionRobot::Ant,
        LocomotionRobot::Walker2d,
        LocomotionRobot::Hopper,
        LocomotionRobot::HalfCheetah,
        LocomotionRobot::Humanoid,
    ] {
        v.push(Box::new(LocomotionEnv::new(LocomotionConfig::preset(r)).unwrap()));
    }
    v
}

/// Mean return and length over `episodes` episodes of uniform random actions.
fn random_stats(env: &mut dyn Env, episodes: u64) -> (f64, f64) {
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let mut act = vec![0.0f32; env.action_space().dim()];
    let mut rng = Rng::seed_from_u64(3);
    let (mut returns, mut len) = (Vec::new(), 0.0);
    for ep in 0..episodes {
        env.reset(Some(ep), &mut obs).unwrap();
        let mut ret = 0.0;
        loop {
            env.action_space().sample(&mut rng, &mut act);
            let s = env.step(&act, &mut obs).unwrap();
            ret += s.reward;
            len += 1.0;
            assert!(obs.iter().all(|x| x.is_finite()), "{}: non-finite observation", env.name());
            if s.done() {
                break;
            }
        }
        returns.push(ret);
    }
    let n = episodes as f64;
    let mean = returns.iter().sum::<f64>() / n;
    let std = (returns.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
    // The README's table (`cargo test --release -p centaur-envs --test behaviour -- --nocapture`).
    println!("{}: return {mean:.2} ± {std:.2}, length {:.0}", env.name(), len / n);
    (mean, len / n)
}

#[test]
fn random_actions_give_returns_and_lengths_in_the_references_range() {
    // References (10 episodes each, measured on this kind of machine): PyBullet Minitaur
    // −1.33 / 829 steps (−0.99 / 633 in a second run); MuJoCo v5 Ant −17 / 108 (−96 / 264),
    // Walker2d 5.7 / 28 (4.3 / 23), Hopper 31 / 32 (17 / 21), HalfCheetah −234 / 1000
    // (−278 / 1000), Humanoid 90 / 19 (118 / 25). Random-action statistics over 10
    // episodes vary that much between seeds in the references themselves; the bounds below
    // hold both reference runs with that margin.
    // (env, mean return range, mean length range)
    type Range = (f64, f64);
    let bounds: [(&str, Range, Range); 6] = [
        ("minitaur", (-3.0, 0.0), (450.0, 1000.0)),
        ("ant", (-250.0, 0.0), (60.0, 600.0)),
        ("walker2d", (-5.0, 25.0), (10.0, 60.0)),
        ("hopper", (5.0, 60.0), (10.0, 60.0)),
        ("half_cheetah", (-450.0, -100.0), (1000.0, 1000.0)),
        ("humanoid", (60.0, 160.0), (12.0, 40.0)),
    ];
    for (mut env, (name, r, l)) in all_envs().into_iter().zip(bounds) {
        assert_eq!(env.name(), name);
        let (ret, len) = random_stats(env.as_mut(), 10);
        assert!(r.0 <= ret && ret <= r.1, "{name}: mean return {ret:.2} outside {r:?}");
        assert!(l.0 <= len && len <= l.1, "{name}: mean length {len:.1} outside {l:?}");
    }
}

/// Observations and rewards of 60 random steps after `reset(seed)`, as bits.
fn trajectory(env: &mut dyn Env, seed: u64) -> Vec<u64> {
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let mut act = vec![0.0f32; env.action_space().dim()];
    let mut rng = Rng::seed_from_u64(seed ^ 0xABCD);
    let mut out = Vec::new();
    env.reset(Some(seed), &mut obs).unwrap();
    out.extend(obs.iter().map(|x| x.to_bits() as u64));
    for _ in 0..60 {
        env.action_space().sample(&mut rng, &mut act);
        let s = env.step(&act, &mut obs).unwrap();
        out.extend(obs.iter().map(|x| x.to_bits() as u64));
        out.push(s.reward.to_bits());
        if s.done() {
            break;
        }
    }
    out
}

#[test]
fn same_seed_gives_bit_identical_trajectories() {
    for (mut used, mut fresh) in all_envs().into_iter().zip(all_envs()) {
        // `used` runs another episode first: a reset with a seed must not remember it.
        let _ = trajectory(used.as_mut(), 99);
        let a = trajectory(used.as_mut(), 5);
        let b = trajectory(fresh.as_mut(), 5);
        assert_eq!(a, b, "{}: same seed, different trajectory", used.name());
        let c = trajectory(fresh.as_mut(), 6);
        assert_ne!(a, c, "{}: different seeds gave the same trajectory", used.name());
    }
}

#[test]
fn bad_actions_are_refused_or_clipped() {
    for mut env in all_envs() {
        let name = env.name().to_string();
        let n = env.action_space().dim();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        assert!(matches!(env.step(&vec![0.0; n], &mut obs), Err(EnvError::NeedsReset)), "{name}");
        env.reset(Some(1), &mut obs).unwrap();
        let mut nan = vec![0.0f32; n];
        nan[0] = f32::NAN;
        assert!(
            matches!(env.step(&nan, &mut obs), Err(EnvError::NonFiniteAction { index: 0, .. })),
            "{name}"
        );
        assert!(
            matches!(env.step(&vec![0.0; n + 1], &mut obs), Err(EnvError::ActionLength { .. })),
            "{name}"
        );
        let mut short_obs = vec![0.0f32; 3];
        assert!(
            matches!(env.step(&vec![0.0; n], &mut short_obs), Err(EnvError::ObservationLength { .. })),
            "{name}"
        );
        // Out of bounds: clipped to the bound, so it acts exactly like the bound itself.
        let high = env.action_space().high.clone();
        let too_big: Vec<f32> = high.iter().map(|h| h * 10.0).collect();
        let mut other = all_envs().into_iter().find(|e| e.name() == name).unwrap();
        let mut obs2 = obs.clone();
        env.reset(Some(1), &mut obs).unwrap();
        other.reset(Some(1), &mut obs2).unwrap();
        env.step(&too_big, &mut obs).unwrap();
        other.step(&high, &mut obs2).unwrap();
        assert_eq!(obs, obs2, "{name}: an out-of-bounds action did not act like the clipped one");
    }
}

#[test]
fn a_blown_up_simulation_ends_the_episode_with_a_flag() {
    let mut env = LocomotionEnv::new(LocomotionConfig::walker2d()).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(0), &mut obs).unwrap();
    let qpos = env.qpos().to_vec();
    let mut qvel = env.qvel().to_vec();
    qvel[3] = 1e9; // a joint spinning at an absurd rate
    env.set_mujoco_state(&qpos, &qvel);
    let before = obs.clone();
    let s = env.step(&[0.0; 6], &mut obs).unwrap();
    assert!(s.info.unstable && s.terminated, "the blow-up was not flagged");
    assert!(obs.iter().all(|x| x.is_finite()));
    assert_eq!(obs, before, "the observation must stay the last finite one");
    assert!(matches!(env.step(&[0.0; 6], &mut obs), Err(EnvError::NeedsReset)));
}

#[test]
fn vec_env_results_do_not_depend_on_the_thread_count() {
    let make = |threads: usize| {
        let envs: Vec<Box<dyn Env>> = (0..4)
            .map(|_| {
                // Short episodes so that auto-resets happen inside the window.
                Box::new(
                    MinitaurEnv::new(MinitaurConfig { max_episode_steps: 15, ..MinitaurConfig::default() })
                        .unwrap(),
                ) as Box<dyn Env>
            })
            .collect();
        VecEnv::new(envs, threads).unwrap()
    };
    let run = |mut v: VecEnv| {
        let mut obs = vec![0.0f32; 4 * 28];
        v.reset(42, &mut obs).unwrap();
        let mut out = v.make_step_buffers();
        let mut rng = Rng::seed_from_u64(1);
        let mut acts = vec![0.0f32; 4 * 8];
        let mut trace = Vec::new();
        let mut finished = 0;
        for _ in 0..40 {
            for a in acts.iter_mut() {
                *a = rng.range(-1.0, 1.0) as f32;
            }
            v.step(&acts, &mut out).unwrap();
            trace.extend(out.obs.iter().map(|x| x.to_bits()));
            trace.extend(out.rewards.iter().map(|x| x.to_bits() as u32));
            finished += out.episodes.len();
        }
        (trace, finished)
    };
    let (a, fa) = run(make(1));
    let (b, fb) = run(make(2));
    assert!(fa >= 8, "auto-resets should have happened ({fa} episodes)");
    assert_eq!(fa, fb);
    assert!(a == b, "1 and 2 threads gave different results");
}

#[test]
fn observation_options_add_joint_history_and_drop_orientation() {
    let obs_opts = ObsOptions { joint_history: 3, drop_base_orientation: true };
    let mut env =
        MinitaurEnv::new(MinitaurConfig { obs: obs_opts.clone(), ..MinitaurConfig::deterministic() })
            .unwrap();
    assert_eq!(env.observation_space().dim(), 24 + 3 * 8);
    let mut obs = vec![0.0f32; 48];
    env.reset(Some(0), &mut obs).unwrap();
    let mut previous = Vec::new();
    for k in 0..4 {
        previous.push(obs[..8].to_vec());
        env.step(&[0.3; 8], &mut obs).unwrap();
        if k >= 2 {
            // History = the motor angles of the last 3 steps (oldest first), current included.
            assert_eq!(&obs[24 + 16..24 + 24], &obs[..8]);
            assert_eq!(&obs[24 + 8..24 + 16], previous[k].as_slice());
            assert_eq!(&obs[24..24 + 8], previous[k - 1].as_slice());
        }
    }
    let mut walker =
        LocomotionEnv::new(LocomotionConfig { obs: obs_opts, ..LocomotionConfig::walker2d() }).unwrap();
    // Walker2d: 17 − 1 (torso angle) + 3 × 6 joint positions.
    assert_eq!(walker.observation_space().dim(), 16 + 18);
    let mut wobs = vec![0.0f32; 34];
    walker.reset(Some(0), &mut wobs).unwrap();
    assert_eq!(walker.qpos()[1] as f32, wobs[0], "the height stays");
    assert_eq!(walker.qpos()[3] as f32, wobs[1], "the torso angle (qpos[2]) is gone");
}

#[test]
fn the_minitaur_can_observe_its_body_state() {
    use centaur_dynamics::{Data, center_of_mass};
    let config = MinitaurConfig {
        observe_body_state: true,
        obs: ObsOptions { joint_history: 1, drop_base_orientation: false },
        ..MinitaurConfig::deterministic()
    };
    let mut env = MinitaurEnv::new(config).unwrap();
    assert_eq!(env.observation_space().dim(), 28 + 8 + 4);
    let mut obs = vec![0.0f32; 40];
    env.reset(Some(2), &mut obs).unwrap();
    // The CoM of the nominal model (the deterministic robot's own) at the env's state.
    let model = env.model().clone();
    let mut data = Data::new(&model);
    let mut com = |env: &MinitaurEnv| center_of_mass(&model, &mut data, env.robot_state().q.as_slice());
    let dt = env.dt();
    let mut start = com(&env);
    assert!((obs[39] as f64 - start.z).abs() < 1e-6, "height {} against {}", obs[39], start.z);
    // A walking pattern of actions: the body moves and rocks.
    let mut velocity = obs[36..39].to_vec();
    let mut travelled = [0.0f64; 3];
    let mut rng = Rng::seed_from_u64(5);
    for step in 0..60 {
        let action: Vec<f32> = (0..8)
            .map(|k| 0.6 * ((step as f32 * 0.4 + k as f32).sin()) + 0.05 * rng.normal() as f32)
            .collect();
        env.step(&action, &mut obs).unwrap();
        let now = com(&env);
        assert!((obs[39] as f64 - now.z).abs() < 1e-6, "step {step}: height");
        // The heading stays near the start's (yaw ≈ 0 on this short run), so the heading
        // frame is close to the world's: trapezoid-integrate the observed velocity.
        for i in 0..3 {
            travelled[i] += 0.5 * (velocity[i] + obs[36 + i]) as f64 * dt;
        }
        velocity.copy_from_slice(&obs[36..39]);
        if step == 19 {
            // Compare the integral with the CoM's displacement from here on (the first
            // steps settle from the reset pose).
            start = now;
            travelled = [0.0; 3];
        }
    }
    let moved = com(&env) - start;
    for i in 0..3 {
        assert!(
            (travelled[i] - moved[i]).abs() < 0.01 + 0.1 * moved[i].abs(),
            "axis {i}: the observed velocity integrates to {} m, the CoM moved {} m",
            travelled[i],
            moved[i]
        );
    }
    assert!(moved.norm() > 0.01, "the body did not move ({} m)", moved.norm());
}

/// Every numeric setting out of range is refused before anything is built, with an error
/// that names the field and its value (reliability probe: a NaN healthy reward, an inverted
/// z range were accepted; a huge history or latency aborted on allocation; a huge frame
/// skip hung).
#[test]
fn settings_out_of_range_are_refused_naming_the_field() {
    use centaur_envs::{MAX_FRAME_SKIP, MAX_JOINT_HISTORY, ModularConfig};
    let history = |k| ObsOptions { joint_history: k, ..ObsOptions::default() };
    let walker = LocomotionConfig::walker2d;
    let locomotion = [
        ("healthy_reward = NaN", LocomotionConfig { healthy_reward: f64::NAN, ..walker() }),
        ("contact_cost_weight = inf", LocomotionConfig { contact_cost_weight: f64::INFINITY, ..walker() }),
        ("healthy_z_range = [1.0, 0.5]", LocomotionConfig { healthy_z_range: (1.0, 0.5), ..walker() }),
        (
            "healthy_angle_range = [NaN, 1.0]",
            LocomotionConfig { healthy_angle_range: (f64::NAN, 1.0), ..walker() },
        ),
        ("frame_skip = 1001", LocomotionConfig { frame_skip: MAX_FRAME_SKIP + 1, ..walker() }),
        ("frame_skip = 0", LocomotionConfig { frame_skip: 0, ..walker() }),
        ("joint_history = 101", LocomotionConfig { obs: history(MAX_JOINT_HISTORY + 1), ..walker() }),
        ("joint_history = 18446744073709551615", LocomotionConfig { obs: history(usize::MAX), ..walker() }),
        ("reset_noise_scale = -1.0", LocomotionConfig { reset_noise_scale: -1.0, ..walker() }),
    ];
    for (says, config) in locomotion {
        let err = LocomotionEnv::new(config).err().unwrap_or_else(|| panic!("{says}: accepted"));
        assert!(err.to_string().contains(says), "{says}: {err}");
    }
    let minitaur = MinitaurConfig::default;
    let strength = |low, high| {
        Some(centaur_envs::minitaur::MinitaurRandomization {
            motor_strength: (low, high),
            ..Default::default()
        })
    };
    let minitaur_cases = [
        ("latency = 1000000000.0", MinitaurConfig { latency: 1e9, ..minitaur() }),
        ("latency = -0.01", MinitaurConfig { latency: -0.01, ..minitaur() }),
        (
            "observation_noise_std = inf",
            MinitaurConfig { observation_noise_std: f64::INFINITY, ..minitaur() },
        ),
        ("action_repeat (frame_skip in [env]) = 0", MinitaurConfig { action_repeat: 0, ..minitaur() }),
        ("shake_weight = NaN", MinitaurConfig { shake_weight: f64::NAN, ..minitaur() }),
        ("joint_history = 1000", MinitaurConfig { obs: history(1000), ..minitaur() }),
        ("motor_strength = (-0.2, 1.0)", MinitaurConfig { randomization: strength(-0.2, 1.0), ..minitaur() }),
        ("motor_strength = (1.2, 0.8)", MinitaurConfig { randomization: strength(1.2, 0.8), ..minitaur() }),
        (
            "motor_strength = (0.8, NaN)",
            MinitaurConfig { randomization: strength(0.8, f64::NAN), ..minitaur() },
        ),
    ];
    for (says, config) in minitaur_cases {
        let err = MinitaurEnv::new(config).err().unwrap_or_else(|| panic!("{says}: accepted"));
        assert!(err.to_string().contains(says), "{says}: {err}");
    }
    for (says, config) in [
        ("frame_skip = 5000", ModularConfig { frame_skip: 5000, ..ModularConfig::gecko() }),
        ("ctrl_cost_weight = NaN", ModularConfig { ctrl_cost_weight: f64::NAN, ..ModularConfig::gecko() }),
        ("joint_history = 101", ModularConfig { obs: history(101), ..ModularConfig::gecko() }),
    ] {
        let err = centaur_envs::ModularEnv::new(config).err().unwrap_or_else(|| panic!("{says}: accepted"));
        assert!(err.to_string().contains(says), "{says}: {err}");
    }
    // The bounds themselves are accepted.
    LocomotionEnv::new(LocomotionConfig {
        frame_skip: MAX_FRAME_SKIP,
        obs: history(MAX_JOINT_HISTORY),
        ..walker()
    })
    .unwrap();
    MinitaurEnv::new(MinitaurConfig { latency: centaur_envs::minitaur::MAX_LATENCY, ..minitaur() }).unwrap();
}

/// Periodic pushes as a setting of the env (`PushSchedule`): the same seed gives the same
/// pushed episode, the pushes move the robot (sideways on the Ant, along x on the planar
/// Walker2d) and a zero force does not, and out-of-range schedules are refused by field.
#[test]
fn scheduled_pushes_move_the_robot_reproducibly() {
    use centaur_envs::PushSchedule;
    let pushes = PushSchedule { force: 100.0, every: 0.05, duration: 0.025 };
    let run = |config: LocomotionConfig, seed: u64| -> Vec<f64> {
        let mut env = LocomotionEnv::new(config).unwrap();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        env.reset(Some(seed), &mut obs).unwrap();
        let zero = vec![0.0f32; env.action_space().dim()];
        for _ in 0..20 {
            if env.step(&zero, &mut obs).unwrap().done() {
                break;
            }
        }
        env.qpos()[..3].to_vec()
    };
    for (robot, axis) in [(LocomotionConfig::ant(), 1), (LocomotionConfig::walker2d(), 0)] {
        let pushed = LocomotionConfig { pushes: Some(pushes), ..robot.clone() };
        let (a, b, still) = (run(pushed.clone(), 3), run(pushed.clone(), 3), run(robot.clone(), 3));
        assert_eq!(a, b, "{:?}: the same seed, the same pushes", robot.robot);
        // A schedule of zero force pushes nothing: the trajectory is the unpushed one, bit
        // for bit (the schedule itself perturbs nothing else).
        let zero = LocomotionConfig { pushes: Some(PushSchedule { force: 0.0, ..pushes }), ..robot.clone() };
        assert_eq!(run(zero, 3), still, "{:?}: zero-force pushes moved it", robot.robot);
        assert!(
            (a[axis] - still[axis]).abs() > 0.02,
            "{:?}: pushed {a:?}, not pushed {still:?}",
            robot.robot
        );
    }
    for (says, bad) in [
        ("pushes.duration = 0.5", PushSchedule { duration: 0.5, ..pushes }),
        ("pushes.force = NaN", PushSchedule { force: f64::NAN, ..pushes }),
        ("pushes.every = -1.0", PushSchedule { every: -1.0, ..pushes }),
        ("pushes.duration = 0.0", PushSchedule { duration: 0.0, ..pushes }),
    ] {
        let config = MinitaurConfig { pushes: Some(bad), ..MinitaurConfig::default() };
        let err = MinitaurEnv::new(config).err().unwrap_or_else(|| panic!("{says}: accepted"));
        assert!(err.to_string().contains(says), "{says}: {err}");
    }
}

/// Found from Python (`gymnasium.make("centaur/Minitaur-v0", distance_limit=-1.0)` was
/// accepted and ended every episode at its first step): a distance limit must be positive.
#[test]
fn minitaur_refuses_a_distance_limit_that_is_not_positive() {
    for limit in [-1.0, 0.0, f64::NAN] {
        let err = MinitaurEnv::new(MinitaurConfig { distance_limit: limit, ..MinitaurConfig::default() })
            .err()
            .unwrap_or_else(|| panic!("distance_limit {limit} accepted"));
        assert!(err.to_string().contains("distance_limit"), "{err}");
    }
    for limit in [f64::INFINITY, 3.0] {
        MinitaurEnv::new(MinitaurConfig { distance_limit: limit, ..MinitaurConfig::default() }).unwrap();
    }
}

/// The joint servo under a controller (`RobotEnv::set_servo`): with zero gains it changes
/// nothing; stiff targets at the standing pose hold the joints where random actions move
/// them; the control cost is charged on what the actuators applied; a reset removes it;
/// the Minitaur, servoed already, has none.
#[test]
fn the_servo_adds_its_pd_torque_at_every_physics_step() {
    let run = |servo: Option<(f64, f64)>, steps: usize| {
        let mut env = LocomotionEnv::new(LocomotionConfig::ant()).unwrap();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        env.reset(Some(4), &mut obs).unwrap();
        let n = env.actuated_joints().len();
        let q0: Vec<f64> =
            env.actuated_joints().iter().map(|&j| env.robot_state().q[env.model().joints[j].idx_q]).collect();
        if let Some((kp, kd)) = servo {
            let (zeros, kps, kds) = (vec![0.0; n], vec![kp; n], vec![kd; n]);
            assert!(env.set_servo(Some(Servo { q: &q0, qd: &zeros, kp: &kps, kd: &kds })));
        }
        let mut rng = Rng::seed_from_u64(8);
        let (mut rewards, mut action) = (Vec::new(), vec![0.0f32; n]);
        for _ in 0..steps {
            env.action_space().sample(&mut rng, &mut action);
            action.iter_mut().for_each(|a| *a *= 0.3);
            rewards.push(env.step(&action, &mut obs).unwrap().reward);
        }
        let q: Vec<f64> =
            env.actuated_joints().iter().map(|&j| env.robot_state().q[env.model().joints[j].idx_q]).collect();
        let moved = q.iter().zip(&q0).map(|(a, b)| (a - b).abs()).sum::<f64>() / n as f64;
        (obs, rewards, moved, env)
    };
    let (plain_obs, plain_rewards, plain_moved, _) = run(None, 10);
    let (zero_obs, zero_rewards, _, _) = run(Some((0.0, 0.0)), 10);
    assert_eq!(plain_obs, zero_obs, "a servo with zero gains changed the motion");
    for (a, b) in plain_rewards.iter().zip(&zero_rewards) {
        assert!((a - b).abs() < 1e-12, "{a} vs {b}: the control cost of the same torques differs");
    }
    let (_, _, held, mut env) = run(Some((200.0, 10.0)), 10);
    // (The Ant lands from its 0.75 m drop meanwhile: the servo, within 150 N·m, holds the
    // joints closer to the standing pose, not exactly at it.)
    assert!(
        held < 0.6 * plain_moved,
        "held joints moved {held:.3} rad on average, free ones {plain_moved:.3}"
    );
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(4), &mut obs).unwrap();
    let (mut fresh, mut fresh_obs) = (LocomotionEnv::new(LocomotionConfig::ant()).unwrap(), obs.clone());
    fresh.reset(Some(4), &mut fresh_obs).unwrap();
    let action = vec![0.2f32; 8];
    env.step(&action, &mut obs).unwrap();
    fresh.step(&action, &mut fresh_obs).unwrap();
    assert_eq!(obs, fresh_obs, "the servo outlived the reset");
    let mut minitaur = MinitaurEnv::new(MinitaurConfig::default()).unwrap();
    assert!(!minitaur.set_servo(None));
}

/// Every robot env records its whole configuration as a JSON object (what runs keep to
/// recognise a changed environment later), presets resolved: the Minitaur's randomisation
/// and its infinite distance limit (JSON null), a Gymnasium robot's name, a modular body.
#[test]
fn every_robot_env_records_its_configuration_as_json() {
    let mut envs = all_envs();
    envs.push(Box::new(centaur_envs::ModularEnv::new(centaur_envs::ModularConfig::gecko()).unwrap()));
    for env in &envs {
        let text = env.config_text().unwrap_or_else(|| panic!("{}: no configuration", env.name()));
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert!(json.is_object() && json["max_episode_steps"].is_u64(), "{}: {text}", env.name());
    }
    let minitaur: serde_json::Value = serde_json::from_str(&envs[0].config_text().unwrap()).unwrap();
    assert!(minitaur["randomization"].is_object() && minitaur["distance_limit"].is_null(), "{minitaur}");
    let ant: serde_json::Value = serde_json::from_str(&envs[1].config_text().unwrap()).unwrap();
    assert_eq!(ant["robot"], "Ant");
    let gecko: serde_json::Value =
        serde_json::from_str(&envs.last().unwrap().config_text().unwrap()).unwrap();
    assert!(gecko["body"]["nodes"].as_array().is_some_and(|n| n.len() > 1), "{gecko}");
}

/// `action_for_torques` inverts the data sheet's motor by default (`MotorInverse::Nominal`)
/// whatever was drawn and, with `MotorInverse::Drawn`, the motor drawn at reset (strength
/// included): on a robot whose drawn motor is 20 % weak the nominal inverse is the default
/// `MotorModel`'s at the robot's motor state, and the drawn inverse asks for more.
#[test]
fn the_nominal_motor_inverse_does_not_see_the_drawn_motor() {
    use centaur_envs::minitaur::{
        MOTOR_DIRECTION, MinitaurRandomization, MotorInverse, MotorModel, motor_angles_to_leg_model,
    };
    let tau = [0.4, -0.3, 0.2, -0.1, 0.3, -0.2, 0.1, -0.4];
    let weak = Some(MinitaurRandomization { motor_strength: (0.8, 0.8), ..Default::default() });
    let actions = |motor_inverse: MotorInverse| {
        let config =
            MinitaurConfig { randomization: weak.clone(), motor_inverse, ..MinitaurConfig::default() };
        let mut env = MinitaurEnv::new(config).unwrap();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        env.reset(Some(7), &mut obs).unwrap();
        let mut out = [0.0f32; 8];
        env.action_for_torques(&tau, &mut out);
        (out, env.motor_state())
    };
    let (nominal, (q, qd)) = actions(MotorInverse::Nominal);
    let (drawn, state) = actions(MotorInverse::Drawn);
    assert_eq!(state, (q, qd), "the inverse changed the reset");
    let sheet = MotorModel::default();
    let angles: [f64; 8] =
        std::array::from_fn(|i| sheet.angle_for_torque(MOTOR_DIRECTION[i] * tau[i], q[i], qd[i]));
    let expected = motor_angles_to_leg_model(&angles).map(|a| (a as f32).clamp(-1.0, 1.0));
    assert_eq!(nominal, expected);
    assert_ne!(drawn, nominal);
    assert_eq!(MinitaurConfig::default().motor_inverse, MotorInverse::Nominal);
    // The recorded configuration always names it (a record without it is from before it
    // existed: the drawn motor, `MotorInverse::legacy`).
    let text =
        |m| serde_json::to_string(&MinitaurConfig { motor_inverse: m, ..MinitaurConfig::default() }).unwrap();
    assert!(text(MotorInverse::Drawn).contains("\"motor_inverse\":\"drawn\""));
    assert!(text(MotorInverse::Nominal).contains("\"motor_inverse\":\"nominal\""));
    assert_eq!(MotorInverse::legacy(), MotorInverse::Drawn);
}
