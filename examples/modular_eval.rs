//! Evaluates a trained policy on a modular robot with three physics step sizes, to check
//! that its gait is not an artefact of the simulator's 5 ms step: return (m in 30 s), motor
//! work, fastest hinge, fastest and highest core, over 3 deterministic episodes each.
//!
//! ```text
//! cargo run --release --example modular_eval -- gecko runs/gecko/checkpoint [--record gecko.mcap]
//! ```
//! (robots: gecko, modular-ant, spider or `modular:FILE.json`; the checkpoint of
//! `centaur train --env <robot>`).
//! `--record FILE` writes the first episode at the 5 ms step as an MCAP file that Foxglove
//! opens (3D panel: the modules as boxes; plots: reward, speed, actions).

use std::path::Path;

use centaur::envs::RobotEnv;
use centaur::envs::modular::ModularEnv;
use centaur::gym::Env;
use centaur::recording::{Frame, Recorder};
use centaur::rl::Policy;

fn fail(msg: String) -> ! {
    eprintln!("modular_eval: {msg}");
    std::process::exit(1);
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let record = match args.iter().position(|a| a == "--record") {
        Some(i) if i + 1 < args.len() && args[i + 1].ends_with(".mcap") => {
            Some(args.drain(i..i + 2).nth(1).unwrap_or_default())
        }
        Some(i) if i + 1 < args.len() => {
            fail(format!("--record {}: the file name must end in .mcap", args[i + 1]))
        }
        Some(_) => fail("--record needs a file name".into()),
        None => None,
    };
    let [robot, checkpoint] = args.as_slice() else {
        fail("usage: modular_eval <gecko|modular-ant|spider|modular:FILE.json> <checkpoint> [--record FILE.mcap]".into());
    };
    let base = match centaur::registry::modular_config(robot) {
        Ok(Some(c)) => c,
        Ok(None) => fail(format!("unknown robot `{robot}` (gecko, modular-ant, spider, modular:FILE.json)")),
        Err(e) => fail(e.to_string()),
    };
    let preset = |dt: f64| {
        let mut c = base.clone();
        let control_period = c.sim.dt * c.frame_skip as f64;
        c.sim.dt = dt;
        c.frame_skip = (control_period / dt).round() as usize;
        c
    };
    let mut policy =
        Policy::load(Path::new(checkpoint)).unwrap_or_else(|e| fail(format!("{checkpoint}: {e}")));
    println!(
        "| physics step | episode | return (m) | motor work (J) | max hinge speed (rad/s) | max core speed (m/s) | max core height (m) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for (k, dt) in [0.005, 0.002, 0.001].into_iter().enumerate() {
        let mut env = ModularEnv::new(preset(dt)).unwrap_or_else(|e| fail(e.to_string()));
        if policy.obs_dim() != env.observation_space().dim() || policy.act_dim() != env.action_space().dim() {
            fail(format!("{checkpoint} was not trained on {robot}"));
        }
        let mut obs = vec![0.0; env.observation_space().dim()];
        let mut action = vec![0.0; env.action_space().dim()];
        for episode in 0..3 {
            env.reset(Some(100 + episode), &mut obs).unwrap_or_else(|e| fail(e.to_string()));
            let mut recorder = match (&record, episode, k) {
                (Some(path), 0, 0) => Some(
                    Recorder::create(Path::new(path), env.model()).unwrap_or_else(|e| fail(e.to_string())),
                ),
                _ => None,
            };
            let (mut ret, mut work, mut hinge, mut speed, mut height) = (0.0, 0.0, 0.0f64, 0.0f64, 0.0f64);
            loop {
                policy.act(&obs, &mut action);
                let step = env.step(&action, &mut obs).unwrap_or_else(|e| fail(e.to_string()));
                ret += step.reward;
                work += step.info.energy;
                let state = env.robot_state();
                for &j in env.actuated_joints() {
                    hinge = hinge.max(state.v[env.model().joints[j].idx_v].abs());
                }
                speed = speed.max(state.base_linear_velocity_world().norm());
                height = height.max(state.q[2]);
                if let Some(r) = recorder.as_mut() {
                    let frame = Frame {
                        time: env.episode_time(),
                        state: Some(state),
                        applied: &action,
                        reward: step.reward,
                        forward_velocity: step.info.forward_velocity,
                        energy: step.info.energy,
                        ..Frame::default()
                    };
                    r.record(&frame).unwrap_or_else(|e| fail(e.to_string()));
                }
                if step.done() {
                    break;
                }
            }
            println!(
                "| {} ms | {episode} | {ret:.2} | {work:.1} | {hinge:.1} | {speed:.2} | {height:.3} |",
                dt * 1e3
            );
            if let (Some(r), Some(path)) = (recorder, &record) {
                r.finish().unwrap_or_else(|e| fail(e.to_string()));
                eprintln!("wrote {path}");
            }
        }
    }
}
