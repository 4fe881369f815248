//! The values the Python bindings must return, from the Rust calls they wrap.
//!
//! `python/tests/data/rust_reference.json` holds inputs and the Rust outputs for them
//! (dynamics on three models, controller ticks, a policy's actions, an environment's
//! trajectory); `python/tests/test_reference.py` checks that `centaur.Model`,
//! `centaur.Controller`, `centaur.Policy` and `gymnasium.make` return exactly these
//! numbers. This test checks that the file is what the Rust code computes today, so the
//! two together compare the bindings with Rust. After a deliberate numerical change,
//! `CENTAUR_BLESS=1 cargo test --profile ci --test python_reference` rewrites the file.

use std::path::{Path, PathBuf};

use centaur::registry::{controller_config, make_env, make_robot_env};
use centaur_dynamics::nalgebra::Matrix6xX;
use centaur_dynamics::{
    BaseKind, Data, Model, ReferenceFrame, aba, center_of_mass, compute_joint_jacobians, crba, difference,
    forward_kinematics, frame_jacobian, frame_placement, gravity_torques, integrate, kinetic_energy,
    nonlinear_effects, normalize, potential_energy, rnea, update_frame_placements,
};
use centaur_gym::Rng;
use centaur_mpc::{Command, Gait, LocomotionController};
use centaur_rl::{Algorithm, Policy, Ppo, PpoConfig};
use serde_json::{Value, json};

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("python/tests/data")
}

/// A valid configuration near the neutral one, and a velocity and acceleration, from `rng`.
fn state(model: &Model, rng: &mut Rng) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut q: Vec<f64> = model.neutral_configuration().iter().map(|x| x + rng.range(-0.4, 0.4)).collect();
    normalize(model, &mut q);
    let v = (0..model.nv).map(|_| rng.range(-1.0, 1.0)).collect();
    let a = (0..model.nv).map(|_| rng.range(-1.0, 1.0)).collect();
    (q, v, a)
}

fn rows(m: impl Fn(usize, usize) -> f64, r: usize, c: usize) -> Value {
    json!((0..r).map(|i| (0..c).map(|j| m(i, j)).collect::<Vec<_>>()).collect::<Vec<_>>())
}

fn dynamics(label: &str, model: &Model, source: Value, seed: u64) -> Value {
    let mut rng = Rng::seed_from_u64(seed);
    let (q, v, a) = state(model, &mut rng);
    let mut d = Data::new(model);
    let tau = rnea(model, &mut d, &q, &v, &a).as_slice().to_vec();
    let ddq = aba(model, &mut d, &q, &v, &tau).as_slice().to_vec();
    let m = crba(model, &mut d, &q).clone();
    let h = nonlinear_effects(model, &mut d, &q, &v).as_slice().to_vec();
    let g = gravity_torques(model, &mut d, &q).as_slice().to_vec();
    let com = center_of_mass(model, &mut d, &q);
    let energy = [kinetic_energy(model, &mut d, &q, &v), potential_energy(model, &mut d, &q)];
    let frame = model.frames.len() - 1;
    forward_kinematics(model, &mut d, &q);
    update_frame_placements(model, &mut d);
    let p = frame_placement(model, &d, frame);
    let h4 = rows(
        |i, j| match (i, j) {
            (3, 3) => 1.0,
            (3, _) => 0.0,
            (_, 3) => p.translation[i],
            _ => p.rotation[(i, j)],
        },
        4,
        4,
    );
    compute_joint_jacobians(model, &mut d, &q);
    let mut jacobians = serde_json::Map::new();
    for (name, rf) in [
        ("world", ReferenceFrame::World),
        ("local_world_aligned", ReferenceFrame::LocalWorldAligned),
        ("local", ReferenceFrame::Local),
    ] {
        let mut j = Matrix6xX::zeros(model.nv);
        frame_jacobian(model, &d, frame, rf, &mut j);
        jacobians.insert(name.into(), rows(|r, c| j[(r, c)], 6, model.nv));
    }
    let mut q_next = vec![0.0; model.nq];
    integrate(model, &q, &v, &mut q_next);
    let mut dq = vec![0.0; model.nv];
    difference(model, &q, &q_next, &mut dq);
    json!({
        "label": label, "source": source, "nq": model.nq, "nv": model.nv,
        "q": q, "v": v, "a": a, "rnea": tau, "aba": ddq, "crba": rows(|i, j| m[(i, j)], model.nv, model.nv),
        "nonlinear_effects": h, "gravity_torques": g, "center_of_mass": [com.x, com.y, com.z], "energy": energy,
        "frame": model.frames[frame].name, "frame_placement": h4, "frame_jacobian": Value::Object(jacobians),
        "integrate": q_next, "difference": dq,
    })
}

/// Ticks of the Minitaur's controller from its nominal state, as `Controller.tick` makes them.
fn controller_ticks() -> Value {
    let env = make_robot_env("minitaur", None).unwrap();
    let model = env.model();
    let mut c = LocomotionController::new(model, controller_config("minitaur").unwrap()).unwrap();
    let joints: Vec<(usize, usize)> = c
        .joint_names()
        .iter()
        .map(|n| {
            let j = &model.joints[model.joint_index(n).unwrap()];
            (j.idx_q, j.idx_v)
        })
        .collect();
    let mut state = c.nominal_state();
    let mut rng = Rng::seed_from_u64(11);
    for x in state.v.iter_mut() {
        *x = rng.range(-0.1, 0.1);
    }
    let command = Command::forward(0.5, Gait::Trot);
    let mut ticks = Vec::new();
    for k in 0..5 {
        let t = 0.01 * k as f64;
        let cmd = c.tick(&state, &command, t).clone();
        let q: Vec<f64> = joints.iter().map(|&(iq, _)| state.q[iq]).collect();
        let qd: Vec<f64> = joints.iter().map(|&(_, iv)| state.v[iv]).collect();
        let mut torques = vec![0.0; q.len()];
        cmd.torque(&q, &qd, &mut torques);
        ticks.push(json!({"t": t, "torques": torques, "tau_ff": cmd.tau, "q_des": cmd.q_des, "kp": cmd.kp, "kd": cmd.kd}));
    }
    json!({"preset": "minitaur", "q": state.q.as_slice(), "v": state.v.as_slice(),
           "forward_velocity": 0.5, "gait": "trot", "ticks": ticks})
}

/// A fresh PPO policy for the Pendulum (written once as `policy_checkpoint`) and its actions.
fn policy_actions(bless: bool) -> Value {
    let path = data_dir().join("policy_checkpoint");
    let env = make_env("pendulum").unwrap();
    if bless {
        let ppo = Ppo::new(
            PpoConfig { seed: 5, ..PpoConfig::default() },
            env.observation_space(),
            env.action_space(),
            1,
        )
        .unwrap();
        ppo.save(&path).unwrap();
    }
    let mut policy = Policy::load(&path).expect("python/tests/data/policy_checkpoint (bless to create it)");
    let mut rng = Rng::seed_from_u64(3);
    let obs: Vec<Vec<f32>> = (0..4).map(|_| (0..3).map(|_| rng.range(-1.0, 1.0) as f32).collect()).collect();
    let actions: Vec<Vec<f32>> = obs
        .iter()
        .map(|o| {
            let mut a = vec![0.0; 1];
            policy.act(o, &mut a);
            a
        })
        .collect();
    json!({"checkpoint": "policy_checkpoint", "obs": obs, "actions": actions})
}

/// The Minitaur env from reset(seed 7) under fixed actions, as `gymnasium.make` steps it.
fn env_trajectory() -> Value {
    let mut env = make_env("minitaur").unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(7), &mut obs).unwrap();
    let reset_obs = obs.clone();
    let mut rng = Rng::seed_from_u64(9);
    let mut steps = Vec::new();
    for _ in 0..10 {
        let mut a = vec![0.0f32; env.action_space().dim()];
        env.action_space().sample(&mut rng, &mut a);
        let s = env.step(&a, &mut obs).unwrap();
        steps.push(json!({"action": a, "obs": obs, "reward": s.reward, "terminated": s.terminated}));
    }
    json!({"id": "centaur/Minitaur-v0", "seed": 7, "reset_obs": reset_obs, "steps": steps})
}

fn reference(bless: bool) -> Value {
    let minitaur = make_robot_env("minitaur", None).unwrap().model().clone();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let solo = Model::from_urdf_file(root.join("assets/solo12/solo12.urdf"), BaseKind::Floating).unwrap();
    let ur5 = Model::from_urdf_file(root.join("assets/ur5/ur5_robot.urdf"), BaseKind::Fixed).unwrap();
    json!({
        "dynamics": [
            dynamics("minitaur", &minitaur, json!({"robot": "minitaur"}), 1),
            dynamics("solo12", &solo, json!({"urdf": "assets/solo12/solo12.urdf", "floating_base": true}), 2),
            dynamics("ur5", &ur5, json!({"urdf": "assets/ur5/ur5_robot.urdf", "floating_base": false}), 3),
        ],
        "controller": controller_ticks(),
        "policy": policy_actions(bless),
        "env": env_trajectory(),
    })
}

#[test]
fn python_reference_is_what_rust_computes() {
    let bless = std::env::var_os("CENTAUR_BLESS").is_some();
    let path = data_dir().join("rust_reference.json");
    let now = reference(bless);
    if bless {
        std::fs::write(&path, serde_json::to_string(&now).unwrap() + "\n").unwrap();
        return;
    }
    let text =
        std::fs::read_to_string(&path).expect("python/tests/data/rust_reference.json (bless to create it)");
    let stored: Value = serde_json::from_str(&text).unwrap();
    assert!(
        stored == now,
        "the Rust results changed: rerun with CENTAUR_BLESS=1 if intended (python/tests/test_reference.py then checks the bindings against them)"
    );
}
