//! The residual (hybrid) environment and the MCAP recordings.

use centaur_gym::{Env, EnvError, Rng};
use centaur_lab::hybrid::{ActionMapping, Authority, Fade, HybridError, Residual, ResidualConfig};
use centaur_lab::recording::{CommandFrame, Frame, Recorder, TOPICS};
use centaur_lab::registry::{
    RegistryError, controller_config, make_residual_env, make_robot_env, residual_config,
};
use centaur_lab::residual::RESIDUAL_TERM;
use centaur_mpc::{Command, ConfigError, Gait, LocomotionController};

/// Observations and rewards (as bits) of the controller alone for `steps` steps.
fn controller_alone(env_name: &str, command: Command, steps: usize) -> Vec<u64> {
    let mut env = make_robot_env(env_name, None).unwrap();
    let mut ctrl = LocomotionController::new(env.model(), controller_config(env_name).unwrap()).unwrap();
    let mut mapping = ActionMapping::new(env.as_ref(), &ctrl).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let mut action = vec![0.0f32; env.action_space().dim()];
    env.reset(Some(3), &mut obs).unwrap();
    let mut trace: Vec<u64> = obs.iter().map(|x| x.to_bits() as u64).collect();
    for _ in 0..steps {
        let t = env.episode_time();
        let cmd = mapping.tick(&mut ctrl, env.as_ref(), &command, t);
        mapping.action(env.as_mut(), cmd, &mut action);
        let s = env.step(&action, &mut obs).unwrap();
        trace.extend(obs.iter().map(|x| x.to_bits() as u64));
        trace.push(s.reward.to_bits());
        if s.done() {
            break;
        }
    }
    trace
}

/// Robot observations and rewards (as bits) of `env` under a zero policy output for
/// `steps` steps from reset seed 3 (the same trace as [`controller_alone`]).
fn zero_output_trace(env: &mut centaur_lab::residual::ResidualEnv, steps: usize) -> Vec<u64> {
    let zero = vec![0.0f32; env.action_space().dim()];
    let n_env = env.inner().observation_space().dim();
    trace(env, &zero, n_env, steps, |s| assert_eq!(s.info.reward_terms[RESIDUAL_TERM], 0.0))
}

/// The bits of the first `n_obs` observation entries after reset seed 3 and of every
/// step's observation and reward while `action` is held for `steps` steps (or to the end of
/// the episode); `check` sees every step.
fn trace(
    env: &mut centaur_lab::residual::ResidualEnv,
    action: &[f32],
    n_obs: usize,
    steps: usize,
    check: impl Fn(&centaur_gym::Step),
) -> Vec<u64> {
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(3), &mut obs).unwrap();
    let mut trace: Vec<u64> = obs[..n_obs].iter().map(|x| x.to_bits() as u64).collect();
    for _ in 0..steps {
        let s = env.step(action, &mut obs).unwrap();
        check(&s);
        trace.extend(obs[..n_obs].iter().map(|x| x.to_bits() as u64));
        trace.push(s.reward.to_bits());
        if s.done() {
            break;
        }
    }
    trace
}

#[test]
fn a_zero_residual_acts_exactly_like_the_controller() {
    for env_name in ["minitaur", "walker2d"] {
        let command = Command::forward(0.3, if env_name == "walker2d" { Gait::Walk } else { Gait::Trot });
        let reference = controller_alone(env_name, command, 80);
        let mut env =
            make_residual_env(env_name, ResidualConfig { command, ..ResidualConfig::default() }).unwrap();
        let trace = zero_output_trace(&mut env, 80);
        assert_eq!(trace, reference, "{env_name}: a zero residual changed the trajectory");
    }
}

/// The default residual setup, commanding the walk Walker2d offers (the default trot it does
/// not offer is refused, below).
fn walker_walk() -> ResidualConfig {
    ResidualConfig { command: Command::forward(0.3, Gait::Walk), ..ResidualConfig::default() }
}

/// A rising bound scales the residual by the ramp's factor at the samples the learner told
/// the environment, and by nothing (the full scale) in an environment never told (an
/// evaluation); the applied action is the reference plus that residual.
#[test]
fn a_rising_bound_follows_the_training_samples_the_env_is_told() {
    use centaur_lab::hybrid::BoundRamp;
    let (scale, ramp) = (0.2, BoundRamp { from: 0.04, samples: 1000 });
    let config = ResidualConfig { scale: vec![scale], bound_ramp: Some(ramp), ..walker_walk() };
    let action = vec![0.5f32; make_residual_env("walker2d", config.clone()).unwrap().action_space().dim()];
    for told in [None, Some(0), Some(500), Some(1000), Some(5000)] {
        let mut env = make_residual_env("walker2d", config.clone()).unwrap();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        env.reset(Some(0), &mut obs).unwrap();
        if let Some(samples) = told {
            env.set_training_samples(samples);
        }
        let factor = told.map_or(1.0, |t| ramp.factor(t));
        let reference = env.reference().to_vec();
        let s = env.step(&action, &mut obs).unwrap();
        let bound = scale as f32 * factor;
        let rms = s.info.reward_terms[RESIDUAL_TERM];
        assert!((rms - f64::from(bound * 0.5)).abs() < 1e-6, "{told:?}: rms {rms}, bound {bound}");
        let (low, high) = (&env.inner().action_space().low, &env.inner().action_space().high);
        for k in 0..reference.len() {
            assert_eq!(env.applied()[k], (reference[k] + bound * 0.5).clamp(low[k], high[k]), "{told:?}");
        }
    }
    assert_eq!((ramp.factor(0), ramp.factor(500)), (0.04, 0.2));
}

/// Cadence steering runs the controller's gait clock at `1 + cadence · c`: held at c = 1
/// the clock reaches 1 + cadence at its slew and its phase runs ahead of the plain walk's,
/// held at −1 behind; at c = 0 the hybrid is the plain one to the bit. The policy's last
/// action entry is the cadence.
#[test]
fn cadence_steering_runs_the_gait_clock_faster_or_slower() {
    use centaur_lab::hybrid::Steering;
    use centaur_lab::mpc::GAIT_RATE_SLEW;
    let cadence = 0.5;
    let config = ResidualConfig { steering: Steering { cadence, ..Steering::OFF }, ..walker_walk() };
    let run = |config: &ResidualConfig, c: Option<f32>, steps: usize| {
        let mut env = make_residual_env("walker2d", config.clone()).unwrap();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        env.reset(Some(0), &mut obs).unwrap();
        let mut action = vec![0.0f32; env.action_space().dim()];
        if let Some(c) = c {
            *action.last_mut().unwrap() = c;
        }
        let mut phases = Vec::new();
        for _ in 0..steps {
            env.step(&action, &mut obs).unwrap();
            phases.push(env.controller().status().phase);
        }
        (phases, env.controller().gait_rate(), obs)
    };
    let plain = run(&walker_walk(), None, 60);
    let zero = run(&config, Some(0.0), 60);
    assert_eq!((&zero.0, zero.1), (&plain.0, 1.0), "c = 0 is the plain walk");
    assert_eq!(zero.2[..plain.2.len()], plain.2[..], "the same observations");
    let (fast, slow) = (run(&config, Some(1.0), 60), run(&config, Some(-1.0), 60));
    // 60 steps of 8 ms: 0.48 s, more than the 0.25 s the slew takes to move the rate by 0.5.
    const { assert!(0.5 / GAIT_RATE_SLEW < 0.48) };
    assert!((fast.1 - 1.5).abs() < 1e-9 && (slow.1 - 0.5).abs() < 1e-9, "{} {}", fast.1, slow.1);
    // The walk starts after 80 ms of standing; 0.4 s later (no walk cycle has wrapped yet)
    // the phases are a tenth of a cycle and more apart.
    let (p0, p_fast, p_slow) = (plain.0[59], fast.0[59], slow.0[59]);
    assert!(p_slow + 0.1 < p0 && p0 + 0.1 < p_fast, "phases {p_slow} {p0} {p_fast}");
    for phases in [&plain.0, &fast.0, &slow.0] {
        assert!(phases[10..].windows(2).all(|w| w[1] >= w[0]), "a cycle wrapped: {phases:?}");
    }
}

/// What every gait-steering part's test shares, on the Minitaur preset with `steering`
/// (the part on, its entry the policy's last): the hybrid with a zero output is the
/// controller alone to the bit; then the last entry held at `c` for 1.5 s changes the
/// robot's path without a fall. Returns what `read` says of the controller at zero output,
/// after the 1.5 s at `c`, and after a reset.
fn steer_last_entry(
    steering: centaur_lab::hybrid::Steering,
    c: f32,
    read: fn(&LocomotionController) -> f64,
) -> (f64, f64, f64) {
    let preset = residual_config("minitaur").unwrap();
    let config = ResidualConfig { steering, ..preset };
    let mut env = make_residual_env("minitaur", config.clone()).unwrap();
    let n_env = env.inner().observation_space().dim();
    assert_eq!(env.action_space().dim(), env.inner().action_space().dim() + 2, "speed and the part");
    let reference = controller_alone("minitaur", config.command, 150);
    assert_eq!(zero_output_trace(&mut env, 150), reference, "c = 0 is the controller alone");
    let at_zero = read(env.controller());
    let mut held = vec![0.0f32; env.action_space().dim()];
    *held.last_mut().unwrap() = c;
    let t = trace(&mut env, &held, n_env, 150, |s| assert!(!s.terminated, "fell"));
    assert_eq!(t.len(), reference.len(), "ended early");
    assert!(t != reference, "steering the part changed nothing");
    let steered = read(env.controller());
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(3), &mut obs).unwrap();
    (at_zero, steered, read(env.controller()))
}

/// Duty steering moves the trot's stance fractions by `duty · c`: held at c = −1 the
/// controller's shift reaches −duty at its slew (the Minitaur trots with flight phases), and
/// a reset hands the next episode the gaits' own fractions.
#[test]
fn duty_steering_shifts_the_stance_fractions() {
    use centaur_lab::hybrid::Steering;
    use centaur_lab::mpc::DUTY_SHIFT_SLEW;
    let steering = Steering { duty: 0.2, ..residual_config("minitaur").unwrap().steering };
    // 150 steps of 10 ms: far more than the 0.2 s the slew takes.
    const { assert!(0.2 / DUTY_SHIFT_SLEW < 1.0) };
    let (zero, steered, reset) = steer_last_entry(steering, -1.0, LocomotionController::gait_duty_shift);
    assert_eq!((zero, reset), (0.0, 0.0));
    assert!((steered + 0.2).abs() < 1e-12, "{steered}");
}

/// Swing steering: the policy's last entry at −1 scales every following swing's apex to
/// 1 − span (0.5 here), and a reset goes back to the controller's own height.
#[test]
fn swing_steering_scales_the_swing_apex() {
    use centaur_lab::hybrid::Steering;
    let steering = Steering { swing: 0.5, ..residual_config("minitaur").unwrap().steering };
    let scales = steer_last_entry(steering, -1.0, LocomotionController::swing_height_scale);
    assert_eq!(scales, (1.0, 0.5, 1.0));
}

/// Foothold steering: the policy's last entry at +1 sets the offset every following swing
/// takes to the span (5 cm ahead; how a swing lands with it: `mpc/tests/foothold_offset.rs`),
/// and a reset goes back to the controller's own footholds.
#[test]
fn foothold_steering_moves_the_footholds() {
    use centaur_lab::hybrid::Steering;
    let steering = Steering { foothold: 0.05, ..residual_config("minitaur").unwrap().steering };
    let (zero, steered, reset) = steer_last_entry(steering, 1.0, LocomotionController::foothold_offset);
    assert_eq!((zero, reset), (0.0, 0.0));
    assert!((steered - 0.05).abs() < 1e-9, "{steered}");
}

#[test]
fn the_residual_is_bounded_by_its_scale_and_the_action_space() {
    let scale = 0.2;
    let mut env =
        make_residual_env("walker2d", ResidualConfig { scale: vec![scale], ..walker_walk() }).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(0), &mut obs).unwrap();
    let m = env.action_space().dim();
    let (low, high) = (env.inner().action_space().low.clone(), env.inner().action_space().high.clone());
    let mut rng = Rng::seed_from_u64(4);
    for _ in 0..30 {
        let reference = env.reference().to_vec();
        // Residuals far outside [−1, 1] are clipped to ±1 before scaling.
        let action: Vec<f32> = (0..m).map(|_| rng.range(-5.0, 5.0) as f32).collect();
        let s = env.step(&action, &mut obs).unwrap();
        for k in 0..m {
            let a = env.applied()[k];
            assert!(low[k] <= a && a <= high[k], "applied action outside the env's bounds");
            let expected = (reference[k] + scale as f32 * action[k].clamp(-1.0, 1.0)).clamp(low[k], high[k]);
            assert_eq!(a, expected);
        }
        assert!(s.info.reward_terms[RESIDUAL_TERM] <= scale + 1e-6, "the RMS residual exceeds the scale");
        if s.done() {
            break;
        }
    }
    // Regression (reliability probe): `--residual-scale 1e300` was accepted as infinity.
    for bad in [1e300, 1e3] {
        match make_residual_env("walker2d", ResidualConfig { scale: vec![bad], ..walker_walk() }) {
            Err(RegistryError::Hybrid(HybridError::BadSetting { part: "residual scale", .. })) => {}
            Err(other) => panic!("{bad}: {other}"),
            Ok(_) => panic!("residual scale {bad} accepted"),
        }
    }
}

#[test]
fn the_observation_carries_phase_command_and_reference() {
    let command = Command::forward(0.4, Gait::Trot);
    let mut env =
        make_residual_env("minitaur", ResidualConfig { command, ..ResidualConfig::default() }).unwrap();
    let n_env = env.inner().observation_space().dim();
    let m = env.action_space().dim();
    assert_eq!(env.observation_space().dim(), n_env + 5 + m);
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(1), &mut obs).unwrap();
    for _ in 0..20 {
        env.step(&vec![0.1; m], &mut obs).unwrap();
        let (s, c) = (obs[n_env], obs[n_env + 1]);
        assert!(((s * s + c * c) - 1.0).abs() < 1e-5, "phase is not on the unit circle");
        assert_eq!(&obs[n_env + 2..n_env + 5], &[0.4, 0.0, 0.0]);
        assert_eq!(&obs[n_env + 5..], env.reference());
    }
    // Without the reference in the observation.
    let env = make_residual_env(
        "minitaur",
        ResidualConfig { include_reference: false, ..ResidualConfig::default() },
    )
    .unwrap();
    assert_eq!(env.observation_space().dim(), n_env + 5);
}

#[test]
fn the_observation_can_carry_the_controllers_body_state() {
    use centaur_lab::hybrid::{OBSERVED_STATE_DIM, observed_state};
    let config = ResidualConfig { include_state: true, ..residual_config("minitaur").unwrap() };
    let mut env = make_residual_env("minitaur", config).unwrap();
    let n_env = env.inner().observation_space().dim();
    let m = env.inner().action_space().dim();
    let dim = env.observation_space().dim();
    assert_eq!(dim, n_env + 5 + m + OBSERVED_STATE_DIM);
    let mut obs = vec![0.0f32; dim];
    env.reset(Some(3), &mut obs).unwrap();
    let zero = vec![0.0f32; env.action_space().dim()];
    let mut forward = 0.0;
    for step in 0..150 {
        env.step(&zero, &mut obs).unwrap();
        // The reference action stays where it was, the state follows it.
        assert_eq!(&obs[n_env + 5..n_env + 5 + m], env.reference());
        let state = observed_state(env.controller().status());
        assert_eq!(&obs[dim - OBSERVED_STATE_DIM..], &state);
        let [vx, vy, _, h] = state;
        assert!(h > 0.1 && h < 0.3, "step {step}: a CoM height of {h} m");
        if step >= 100 {
            forward += vx / 50.0;
            assert!(vy.abs() < 1.0, "step {step}: sideways at {vy} m/s");
        }
    }
    // The preset trots forward at its command: the state the policy sees says so.
    let commanded = obs[n_env + 2];
    assert!(forward > 0.5 * commanded && forward < 1.5 * commanded, "{forward} m/s under {commanded}");
    // The law hands its observation the state only where it observes it (zeros, not
    // computed, where it does not).
    let status = env.controller().status();
    let with = Residual::new(env.config(), m).unwrap();
    assert_eq!(with.state_of(status), observed_state(status));
    let without = Residual::new(&ResidualConfig { include_state: false, ..env.config().clone() }, m).unwrap();
    assert_eq!(without.state_of(status), [0.0; OBSERVED_STATE_DIM]);
}

#[test]
fn bad_residuals_and_configs_are_refused() {
    let mut env = make_residual_env("walker2d", walker_walk()).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(0), &mut obs).unwrap();
    let m = env.action_space().dim();
    let mut bad = vec![0.0f32; m];
    bad[2] = f32::NAN;
    assert!(matches!(env.step(&bad, &mut obs), Err(EnvError::NonFiniteAction { index: 2, .. })));
    assert!(matches!(env.step(&vec![0.0; m + 1], &mut obs), Err(EnvError::ActionLength { .. })));
    assert!(
        make_residual_env("walker2d", ResidualConfig { scale: vec![0.1, 0.2], ..walker_walk() }).is_err()
    );
    assert!(make_residual_env("walker2d", ResidualConfig { scale: vec![-1.0], ..walker_walk() }).is_err());
    assert!(make_residual_env("hopper", ResidualConfig::default()).is_err(), "no controller for the Hopper");
    // A gait the robot does not offer: refused, naming those it does (the
    // controller used to stand instead, without a word).
    match make_residual_env("walker2d", ResidualConfig::default()) {
        Err(e @ RegistryError::Hybrid(HybridError::Controller(ConfigError::GaitNotOffered { .. }))) => {
            assert!(e.to_string().contains("walk (0–1 m/s; straight only)"), "{e}")
        }
        Err(other) => panic!("{other}"),
        Ok(_) => panic!("a trot accepted on Walker2d"),
    }
    // Regression (reliability probe): a comparison with a learner setting out of range is
    // refused by the field's name before it writes anything (it left empty seed folders).
    let out = std::env::temp_dir().join(format!("centaur-bad-compare-{}", std::process::id()));
    let algo = centaur_rl::AlgoConfig::Ppo(centaur_rl::PpoConfig { gamma: 2.0, ..Default::default() });
    let opts = centaur_lab::compare::CompareOptions {
        env: "minitaur".into(),
        algo,
        seeds: 1,
        steps: 10,
        out: out.clone(),
        n_envs: 1,
        threads: 1,
        jobs: 1,
        eval_episodes: 10,
        residual: residual_config("minitaur").unwrap(),
        eval_every: None,
        resume: false,
        overwrite: false,
        env_settings: Default::default(),
        pure_from: None,
        hybrid_algo: None,
        spec: None,
        command: None,
    };
    let err = centaur_lab::compare::run_compare(&opts, &mut |_, _, _| {}).unwrap_err();
    assert!(err.to_string().contains("gamma"), "{err}");
    assert!(!out.exists(), "a refused comparison left {}", out.display());
    // So are the hybrid's own hyperparameters, when bad or another algorithm's.
    let ppo = centaur_rl::PpoConfig::default();
    let bad_hybrid = centaur_rl::AlgoConfig::Ppo(centaur_rl::PpoConfig { gamma: 2.0, ..ppo.clone() });
    let sac = centaur_rl::AlgoConfig::Sac(Default::default());
    for (hybrid, says) in [(bad_hybrid, "gamma"), (sac, "the hybrid's hyperparameters are sac's")] {
        let opts = centaur_lab::compare::CompareOptions {
            algo: centaur_rl::AlgoConfig::Ppo(ppo.clone()),
            hybrid_algo: Some(hybrid),
            ..opts.clone()
        };
        let err = centaur_lab::compare::run_compare(&opts, &mut |_, _, _| {}).unwrap_err();
        assert!(err.to_string().contains(says), "{err}");
        assert!(!out.exists(), "a refused comparison left {}", out.display());
    }
}

#[test]
fn mcap_recordings_have_foxglove_schemas_and_one_message_per_step() {
    let dir = std::env::temp_dir().join(format!("centaur-mcap-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("walk.mcap");
    let mut env = make_residual_env("minitaur", ResidualConfig::default()).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(0), &mut obs).unwrap();
    let mut rec = Recorder::create(&path, env.inner().model()).unwrap();
    let steps = 25;
    let zero = vec![0.0f32; env.action_space().dim()];
    for _ in 0..steps {
        let s = env.step(&zero, &mut obs).unwrap();
        let robot = env.inner();
        let contacts: Vec<_> =
            robot.foot_contacts().iter().filter(|c| c.in_contact).map(|c| (c.point, c.force)).collect();
        rec.record(&Frame {
            time: robot.episode_time(),
            state: Some(robot.robot_state()),
            contacts: &contacts,
            planned_com: &env.controller().status().planned_com,
            foot_targets: &env.controller().status().foot_targets,
            reference: env.reference(),
            residual: &zero,
            applied: env.applied(),
            reward: s.reward,
            forward_velocity: s.info.forward_velocity,
            energy: s.info.energy,
            command: Some(CommandFrame::of(env.command(), env.controller())),
        })
        .unwrap();
        // Regression (reliability probe, data loss 5): nothing bears the name before the
        // recording is complete.
        assert!(!path.exists(), "an unfinished recording bears its name");
    }
    rec.finish().unwrap();
    let names = |d: &std::path::Path| -> Vec<String> {
        std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect()
    };
    assert_eq!(names(&dir), ["walk.mcap"], "temporary files left beside the recording");
    // A recording abandoned by an error is removed, not left truncated.
    let abandoned = Recorder::create(&dir.join("abandoned.mcap"), env.inner().model()).unwrap();
    drop(abandoned);
    assert_eq!(names(&dir), ["walk.mcap"]);

    let bytes = std::fs::read(&path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary section");
    let mut schema_names: Vec<String> = summary.schemas.values().map(|s| s.name.clone()).collect();
    schema_names.sort();
    assert_eq!(
        schema_names,
        ["centaur.Metrics", "centaur.Residual", "foxglove.FrameTransforms", "foxglove.SceneUpdate"]
    );
    for s in summary.schemas.values() {
        assert_eq!(s.encoding, "jsonschema");
        let parsed: serde_json::Value = serde_json::from_slice(&s.data).unwrap();
        assert_eq!(parsed["title"], s.name.as_str());
    }
    let stats = summary.stats.expect("statistics");
    let mut per_topic = std::collections::BTreeMap::new();
    for (id, n) in &stats.channel_message_counts {
        let ch = &summary.channels[id];
        assert_eq!(ch.message_encoding, "json");
        per_topic.insert(ch.topic.clone(), *n);
    }
    for topic in TOPICS {
        assert_eq!(per_topic.get(topic), Some(&(steps as u64)), "{topic}");
    }
    // The robot moves: the base link's transform changes between the first and last message.
    // The metrics carry the controller's command: the preset's speed at zero output, the gait
    // clock at its own rate.
    let preset = ResidualConfig::default().command;
    let mut base = Vec::new();
    let mut commands = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic == "/tf" {
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            let t = v["transforms"].as_array().unwrap();
            assert_eq!(t.len(), env.inner().model().frames.iter().filter(|f| f.is_link).count());
            base.push(t[0]["translation"]["z"].as_f64().unwrap());
        }
        if m.channel.topic == "/robot" {
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            let e = &v["entities"][0];
            let n = e["cubes"].as_array().unwrap().len() + e["cylinders"].as_array().unwrap().len();
            assert!(n >= 17, "every link drawn ({n} primitives)");
        }
        if m.channel.topic == "/metrics" {
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            assert_eq!(v["commanded_speed"].as_f64(), Some(preset.forward_velocity), "{v}");
            assert_eq!(v["commanded_yaw_rate"].as_f64(), Some(preset.yaw_rate), "{v}");
            assert_eq!((v["gait_rate"].as_f64(), v["duty_shift"].as_f64()), (Some(1.0), Some(0.0)), "{v}");
            commands += 1;
        }
    }
    assert_eq!(commands, steps);
    assert_eq!(base.len(), steps);
    assert!(base.iter().any(|z| (z - base[0]).abs() > 1e-5), "the base never moved");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_deployed_stack_acts_exactly_like_the_residual_env_it_was_trained_in() {
    use centaur_gym::VecEnv;
    use centaur_lab::deploy::{HybridStack, Simulated};
    use centaur_rl::{Algorithm, Ppo, PpoConfig};
    let config = residual_config("minitaur").unwrap();
    // The robot observations, as bits, of 60 steps of the residual env and of the plain env
    // driven by the embedded stack, both under the same untrained PPO policy (non-zero,
    // deterministic outputs).
    let both = |config: &ResidualConfig| {
        let venv = VecEnv::new(
            vec![Box::new(make_residual_env("minitaur", config.clone()).unwrap()) as Box<dyn Env>],
            1,
        )
        .unwrap();
        let ppo = Ppo::for_env(PpoConfig { seed: 5, ..PpoConfig::default() }, &venv).unwrap();
        let mut policy = ppo.policy();

        // Training-side: the residual environment with the policy's actions.
        let mut renv = make_residual_env("minitaur", config.clone()).unwrap();
        let mut robs = vec![0.0f32; renv.observation_space().dim()];
        let mut act = vec![0.0f32; renv.action_space().dim()];
        renv.reset(Some(9), &mut robs).unwrap();
        let n_env = renv.inner().observation_space().dim();
        let mut a: Vec<u32> = robs[..n_env].iter().map(|x| x.to_bits()).collect();
        for _ in 0..60 {
            policy.act(&robs, &mut act);
            renv.step(&act, &mut robs).unwrap();
            a.extend(robs[..n_env].iter().map(|x| x.to_bits()));
        }

        // Deployment-side: the plain environment driven by the embedded stack.
        let mut env = make_robot_env("minitaur", None).unwrap();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        env.reset(Some(9), &mut obs).unwrap();
        let ctrl = controller_config("minitaur").unwrap();
        let mut stack = HybridStack::new(
            &Simulated { env: env.as_ref(), obs: &obs },
            ctrl,
            Some(ppo.policy()),
            config.clone(),
        )
        .unwrap();
        let mut b: Vec<u32> = obs.iter().map(|x| x.to_bits()).collect();
        let mut command = vec![0.0f32; env.action_space().dim()];
        for _ in 0..60 {
            command.copy_from_slice(stack.tick(&Simulated { env: env.as_ref(), obs: &obs }));
            env.step(&command, &mut obs).unwrap();
            b.extend(obs.iter().map(|x| x.to_bits()));
        }
        (a, b)
    };
    let (a, b) = both(&config);
    assert!(a == b, "the deployed stack diverged from the training environment");
    // With a safety fade that acts here (the trotting body rides 3–9 % below its height
    // reference), the stack fades the policy exactly as the env does.
    let faded = ResidualConfig { fade: Some(Fade { start: 0.03, end: 0.09 }), ..config.clone() };
    let (fa, fb) = both(&faded);
    assert!(fa == fb, "with a fade, the deployed stack diverged from the training environment");
    assert!(fa != a, "the fade changed nothing");
    // With the policy steering the cadence, the stance fractions, the swing apex and the
    // footholds on a faster clock and a lower swing, the stack runs the controller's gait as
    // the env does.
    let clocked = ResidualConfig {
        steering: centaur_lab::hybrid::Steering {
            cadence: 0.5,
            duty: 0.2,
            swing: 0.5,
            foothold: 0.05,
            ..config.steering
        },
        period_scale: Some(0.8),
        swing_height: Some(0.05),
        ..config.clone()
    };
    let (ca, cb) = both(&clocked);
    assert!(
        ca == cb,
        "with cadence, duty, swing and foothold steering, the deployed stack diverged from the training environment"
    );
    assert!(ca != a, "the cadence, the duty, the swing, the footholds and the clock changed nothing");
    // With the controller's body state in the observation, the stack observes it as the env
    // does (the policy's outputs, so the robot's path, depend on it).
    let observing = ResidualConfig { include_state: true, ..config.clone() };
    let (sa, sb) = both(&observing);
    assert!(
        sa == sb,
        "with the body state observed, the deployed stack diverged from the training environment"
    );
    assert!(sa != a, "the observed body state changed nothing");
    let mut env = make_robot_env("minitaur", None).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(9), &mut obs).unwrap();

    // The rating a hybrid was trained with reaches the embedded controller too.
    let rated = ResidualConfig { rated_speed: Some(3.0), ..config };
    let ctrl = controller_config("minitaur").unwrap();
    let stack = HybridStack::new(&Simulated { env: env.as_ref(), obs: &obs }, ctrl, None, rated).unwrap();
    assert_eq!(stack.controller().config().offer(Gait::Trot).unwrap().max_speed, 3.0);
    // ... and so does its clock.
    let trot = |c: &centaur_mpc::ControllerConfig| c.period_scales()[Gait::Trot.index()];
    let plain = trot(&controller_config("minitaur").unwrap());
    let ctrl = controller_config("minitaur").unwrap();
    let stack = HybridStack::new(&Simulated { env: env.as_ref(), obs: &obs }, ctrl, None, clocked).unwrap();
    assert_eq!(trot(stack.controller().config()), 0.8 * plain);
}

/// Undiscounted return of the controller alone (zero policy output) on `env_name`'s hybrid
/// for one episode from reset seed `seed`.
fn controller_return(config: &ResidualConfig, env_name: &str, seed: u64) -> f64 {
    let mut env = make_residual_env(env_name, config.clone()).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(seed), &mut obs).unwrap();
    let zero = vec![0.0f32; env.action_space().dim()];
    let mut ret = 0.0;
    loop {
        let s = env.step(&zero, &mut obs).unwrap();
        ret += s.reward;
        if s.done() {
            return ret;
        }
    }
}

/// A Minitaur hybrid steered to the top of its range (+1: 3.5 m/s commanded) for `steps`
/// steps from reset seed 3: the observations' and rewards' bits.
fn full_steer_trace(config: ResidualConfig, steps: usize) -> Vec<u64> {
    let mut env = make_residual_env("minitaur", config).unwrap();
    let mut action = vec![0.0f32; env.action_space().dim()];
    *action.last_mut().unwrap() = 1.0;
    let n_obs = env.observation_space().dim();
    trace(&mut env, &action, n_obs, steps, |_| ())
}

/// `rated_speed: Some(2.5)` is the trot's own rating: the hybrid runs as with no rating of
/// its own, to the bit, even steered past it (so runs measured before the preset's first
/// rating are reproduced by `--rated-speed 2.5`); the preset's 3.5 lets the steering through.
#[test]
fn the_trots_own_rating_reproduces_the_old_preset_bit_for_bit() {
    let preset = residual_config("minitaur").unwrap();
    assert_eq!(preset.rated_speed, Some(3.5));
    let steps = 150;
    let unrated = full_steer_trace(ResidualConfig { rated_speed: None, ..preset.clone() }, steps);
    let same = full_steer_trace(ResidualConfig { rated_speed: Some(2.5), ..preset.clone() }, steps);
    let lifted = full_steer_trace(preset, steps);
    assert_eq!(unrated, same, "rated 2.5 differs from the trot's own rating");
    assert_ne!(unrated, lifted, "the preset's 3.5 rating changed nothing");
}

/// The safety fade scales the policy's steering, then its residual, by its authority, from
/// the CoM height the controller measured before the step: none where the body has sunk
/// past the fade's end (the applied action is the controller's, the command the unsteered
/// one), all of it above its start; a fade the robot never reaches changes nothing, to the
/// bit.
#[test]
fn the_fade_hands_a_sinking_robot_back_to_the_controller() {
    let preset = residual_config("minitaur").unwrap();
    // The trotting Minitaur's CoM rides a few per cent below the height reference (0.165 m)
    // and starts above it: this fade spans both ends.
    let fade = Fade { start: 0.05, end: 0.08 };
    let mut env =
        make_residual_env("minitaur", ResidualConfig { fade: Some(fade), ..preset.clone() }).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let action = vec![0.7f32; env.action_space().dim()];
    let full_rms = 0.25f32 * 0.7;
    env.reset(Some(3), &mut obs).unwrap();
    let (mut none, mut all, mut some) = (0, 0, 0);
    for _ in 0..300 {
        let h = env.controller().height_reference(env.command());
        let sag = (h - env.controller().status().com[2]) / h;
        let a = fade.authority(sag);
        let reference = env.reference().to_vec();
        let s = env.step(&action, &mut obs).unwrap();
        let rms = s.info.reward_terms[RESIDUAL_TERM];
        assert!((rms - f64::from(a.residual * full_rms)).abs() < 1e-6, "sag {sag}, {a:?}: rms {rms}");
        let steered = preset.command.forward_velocity + preset.steering.speed * f64::from(a.steering * 0.7);
        assert_eq!(env.command().forward_velocity, steered, "sag {sag}, {a:?}");
        if a.residual == 0.0 {
            none += 1;
            assert_eq!(env.applied(), &reference[..], "sag {sag}");
        } else if a == Authority::FULL {
            all += 1;
        } else {
            some += 1;
        }
        if s.done() {
            break;
        }
    }
    assert!(
        none > 0 && all > 0 && some > 0,
        "steps without / with full / with some authority: {none} / {all} / {some}"
    );
    // Out of reach (the robot falls long before sinking half its height): bit for bit the
    // hybrid without a fade.
    let far = ResidualConfig { fade: Some(Fade { start: 0.5, end: 1.0 }), ..preset.clone() };
    assert_eq!(full_steer_trace(far, 150), full_steer_trace(preset, 150));
}

#[test]
fn a_zero_output_with_steering_on_acts_exactly_like_the_controller() {
    let config = residual_config("minitaur").unwrap();
    assert!(config.steering.speed > 0.0, "the Minitaur preset steers the speed");
    let reference = controller_alone("minitaur", config.command, 80);
    let mut env = make_residual_env("minitaur", config.clone()).unwrap();
    assert_eq!(env.action_space().dim(), env.inner().action_space().dim() + 1);
    let trace = zero_output_trace(&mut env, 80);
    assert_eq!(*env.command(), config.command);
    assert_eq!(trace, reference, "a zero output with steering on changed the trajectory");
}

#[test]
fn steering_the_speed_up_makes_the_robot_run_faster() {
    // Command only (no joint residual): the policy's one entry is the speed steering.
    let config = ResidualConfig { joint_residual: false, ..residual_config("minitaur").unwrap() };
    let run = |c: f32| {
        let mut env = make_residual_env("minitaur", config.clone()).unwrap();
        assert_eq!(env.action_space().dim(), 1);
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        env.reset(Some(1), &mut obs).unwrap();
        let mut ret = 0.0;
        for _ in 0..400 {
            let s = env.step(&[c], &mut obs).unwrap();
            assert!(!s.terminated, "fell with steering {c}");
            ret += s.reward;
        }
        // The observation carries the steered command.
        let n = env.inner().observation_space().dim();
        assert_eq!(obs[n + 2], env.command().forward_velocity as f32);
        (ret, env.command().forward_velocity)
    };
    let (slow, v_slow) = run(-1.0);
    // +0.25: 2.375 m/s, below the controller's own rating of 2.5 (the preset's 3.5, at +1,
    // is the residual's to hold: the controller alone falls at 2.75 m/s on 1 of 5 seeds and
    // at 3.0 on 4 of 5).
    let (fast, v_fast) = run(0.25);
    assert_eq!((v_slow, v_fast), (0.5, 2.375));
    // 4 s, most of it at the steered speed: ≈ 7 m apart.
    assert!(fast > slow + 3.0, "steering +0.25 scored {fast:.2}, −1 {slow:.2}");
}

/// The gentle start: an untrained hybrid's stochastic training episodes (PPO's
/// first rollout, before any update, with the preset's exploration) score at least 80 % of
/// the controller alone on the same reset seeds.
fn assert_explores_gently(robot: &str, n_steps: usize, min_controller: f64) {
    use centaur_gym::VecEnv;
    use centaur_lab::residual::start_as_controller;
    use centaur_rl::{AlgoKind, Algorithm, Ppo, PpoConfig};
    use std::ops::ControlFlow;
    let config = residual_config(robot).unwrap();
    let n_envs = 3;
    let envs = (0..n_envs)
        .map(|_| Box::new(make_residual_env(robot, config.clone()).unwrap()) as Box<dyn Env>)
        .collect();
    let mut venv = VecEnv::new(envs, 1).unwrap();
    let ppo_config = PpoConfig { n_steps, batch_size: n_steps / 2, seed: 0, ..PpoConfig::default() };
    let mut ppo = Ppo::for_env(ppo_config, &venv).unwrap();
    assert!(config.exploration.is_some(), "the {robot} preset sets a gentle start");
    start_as_controller(&mut ppo, AlgoKind::Ppo, &config, venv.action_space().dim()).unwrap();
    let mut first = None;
    ppo.learn(&mut venv, (n_steps * n_envs) as u64, &mut |m| {
        first = Some(*m);
        ControlFlow::Break(())
    })
    .unwrap();
    let m = first.expect("one rollout");
    assert!(m.episodes >= n_envs as u64, "{} episodes", m.episodes);
    // A preset's rising exploration reaches the learner (and its checkpoints); the first
    // rollout runs at its start, the gentle σ.
    if let Some(floor) = config.exploration_floor(venv.action_space().dim()) {
        let kept = ppo.to_checkpoint().get_meta::<centaur_rl::ExplorationFloor>("exploration_floor").unwrap();
        assert_eq!(kept, floor);
    }
    let controller =
        (0..n_envs as u64).map(|seed| controller_return(&config, robot, seed)).sum::<f64>() / n_envs as f64;
    eprintln!("{robot}: first rollout {:.2}, controller alone {controller:.2}", m.episode_return_mean);
    assert!(controller > min_controller, "the {robot} controller alone scored {controller:.2}");
    assert!(
        m.episode_return_mean >= 0.8 * controller,
        "{robot}: stochastic untrained hybrid {:.2} against the controller's {controller:.2}",
        m.episode_return_mean
    );
}

#[test]
fn an_untrained_hybrid_explores_gently() {
    assert_explores_gently("minitaur", 1000, 10.0);
}

#[test]
fn an_untrained_ant_hybrid_explores_gently() {
    // The Ant's episodes are 1000 control steps; the 1 m/s trot scores ≈ 1250.
    assert_explores_gently("ant", 1000, 1000.0);
}

#[test]
fn an_untrained_walker2d_hybrid_explores_gently() {
    // The 1.0 m/s walk scores ≈ 1790 over its 1000 steps on its own clock, ≈ 1600 at the
    // preset's 0.6 of its period (its 0.5 m/s walk ≈ 1400 before its tuning).
    // On a residual bounded at 0.1, PPO's own σ = 1 scored 61 % of it in the first rollout
    // (falls), σ 0.1 99.8 %. Today's preset explores at σ 0.3 from the start on a residual
    // whose bound rises from 1/30 of 1.0 (the same 0.01 action units): 1,616.2 against the
    // faster walk's 1,638.9 on these reset seeds (98.6 %; on the walk's own clock 1,779.9
    // against 1,789.0). The bound is small only because PPO tells the environments its
    // samples (0 here): on the full bound this σ scores ≈ 170.
    assert_explores_gently("walker2d", 1000, 1000.0);
}

#[test]
fn an_untrained_humanoid_hybrid_explores_gently() {
    // The 0.3 m/s walk stays up for the whole 1000-step episode, ≈ 5.2 per step; the first
    // rollout at the preset's σ 0.1 scored 100.1 % of it (seed 0).
    assert_explores_gently("humanoid", 1000, 4000.0);
}

/// The return of the first training episode of a TD3 hybrid on the Ant during its warm-up
/// (1,000 steps, no gradient step), with the preset's residual setup and
/// `warmup_with_policy` as given.
fn td3_warmup_return(warmup_with_policy: bool) -> f64 {
    use centaur_gym::VecEnv;
    use centaur_lab::residual::start_as_controller;
    use centaur_rl::{AlgoKind, Algorithm, Td3, Td3Config};
    use std::ops::ControlFlow;
    let config = ResidualConfig { warmup_with_policy, ..residual_config("ant").unwrap() };
    let env = Box::new(make_residual_env("ant", config.clone()).unwrap()) as Box<dyn Env>;
    let mut venv = VecEnv::new(vec![env], 1).unwrap();
    let td3_config = Td3Config { learning_starts: 1000, log_interval: 1000, seed: 0, ..Td3Config::default() };
    let mut td3 = Td3::for_env(td3_config, &venv).unwrap();
    start_as_controller(&mut td3, AlgoKind::Td3, &config, venv.action_space().dim()).unwrap();
    let mut first = None;
    td3.learn(&mut venv, 1000, &mut |m| {
        first = Some(*m);
        ControlFlow::Break(())
    })
    .unwrap();
    let m = first.expect("one record");
    assert_eq!(m.episodes, 1, "one 1000-step episode");
    m.episode_return_mean
}

#[test]
fn an_off_policy_hybrid_can_warm_up_on_its_controller() {
    // Uniformly random warm-up actions (Stable-Baselines3's) steer and perturb the trot at
    // full scale; with `warmup_with_policy` the zero-output policy plus TD3's N(0, 0.1)
    // exploration keeps the episode close to the controller alone.
    let controller = controller_return(&residual_config("ant").unwrap(), "ant", 0);
    let with_policy = td3_warmup_return(true);
    let uniform = td3_warmup_return(false);
    assert!(
        with_policy >= 0.9 * controller,
        "policy warm-up {with_policy:.1} against the controller's {controller:.1}"
    );
    assert!(with_policy > uniform, "policy warm-up {with_policy:.1} against uniform {uniform:.1}");
    // On-policy learners have no warm-up: asking for one is refused, not ignored.
    use centaur_gym::VecEnv;
    use centaur_rl::{AlgoKind, Ppo, PpoConfig};
    let config = ResidualConfig { warmup_with_policy: true, ..residual_config("ant").unwrap() };
    let env = Box::new(make_residual_env("ant", config.clone()).unwrap()) as Box<dyn Env>;
    let venv = VecEnv::new(vec![env], 1).unwrap();
    let mut ppo = Ppo::for_env(PpoConfig::default(), &venv).unwrap();
    let err = centaur_lab::residual::start_as_controller(
        &mut ppo,
        AlgoKind::Ppo,
        &config,
        venv.action_space().dim(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("warm-up"), "{err}");
}
