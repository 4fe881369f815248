//! Environment steps per second: every benchmark env on one core (single env, uniform
//! random actions, resets included), then vectorised over all cores.
//!
//! ```text
//! cargo run --release --example bench_envs            # table (also the modular robots)
//! cargo run --release --example bench_envs -- --json  # {"minitaur": steps_per_s, "ant": …} (single env)
//! cargo run --release --example bench_envs -- --seconds 5 --only ant
//! ```
//! Compare with PyBullet and MuJoCo side by side with `tools/bench_envs_side_by_side.py`.

use std::time::Instant;

use centaur::envs::{
    LocomotionConfig, LocomotionEnv, LocomotionRobot, MinitaurConfig, MinitaurEnv, ModularConfig, ModularEnv,
};
use centaur::gym::{Env, Rng, VecEnv};

fn make(name: &str) -> Box<dyn Env> {
    match name {
        "minitaur" => Box::new(MinitaurEnv::new(MinitaurConfig::default()).expect("minitaur")),
        modular if let Some(c) = ModularConfig::preset(modular) => {
            Box::new(ModularEnv::new(c).expect("modular robot"))
        }
        other => {
            let robot = match other {
                "ant" => LocomotionRobot::Ant,
                "walker2d" => LocomotionRobot::Walker2d,
                "hopper" => LocomotionRobot::Hopper,
                "halfcheetah" => LocomotionRobot::HalfCheetah,
                _ => LocomotionRobot::Humanoid,
            };
            Box::new(LocomotionEnv::new(LocomotionConfig::preset(robot)).expect("locomotion env"))
        }
    }
}

/// Steps per second of one env for about `seconds`.
fn single(name: &str, seconds: f64) -> f64 {
    let mut env = make(name);
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let mut act = vec![0.0f32; env.action_space().dim()];
    let mut rng = Rng::seed_from_u64(0);
    env.reset(Some(0), &mut obs).expect("reset");
    let start = Instant::now();
    let mut steps = 0u64;
    while start.elapsed().as_secs_f64() < seconds {
        for _ in 0..50 {
            env.action_space().sample(&mut rng, &mut act);
            let s = env.step(&act, &mut obs).expect("step");
            steps += 1;
            if s.done() {
                env.reset(None, &mut obs).expect("reset");
            }
        }
    }
    steps as f64 / start.elapsed().as_secs_f64()
}

/// Total steps per second of `2 × threads` envs stepped by `threads` threads.
fn vectorised(name: &str, threads: usize, seconds: f64) -> f64 {
    let n = 2 * threads;
    let mut v = VecEnv::new((0..n).map(|_| make(name)).collect(), threads).expect("vec env");
    let (od, ad) = (v.observation_space().dim(), v.action_space().dim());
    let mut obs = vec![0.0f32; n * od];
    v.reset(0, &mut obs).expect("reset");
    let mut out = v.make_step_buffers();
    let mut acts = vec![0.0f32; n * ad];
    let mut rng = Rng::seed_from_u64(1);
    let start = Instant::now();
    let mut steps = 0u64;
    while start.elapsed().as_secs_f64() < seconds {
        for a in acts.chunks_mut(ad) {
            v.action_space().sample(&mut rng, a);
        }
        v.step(&acts, &mut out).expect("step");
        steps += n as u64;
    }
    steps as f64 / start.elapsed().as_secs_f64()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let json = args.iter().any(|a| a == "--json");
    let seconds = args
        .iter()
        .position(|a| a == "--seconds")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(2.0);
    let only = args.iter().position(|a| a == "--only").and_then(|i| args.get(i + 1)).cloned();
    // The JSON holds the issue's six benchmark envs; the table adds the modular robots.
    let mut names = vec!["minitaur", "ant", "walker2d", "hopper", "halfcheetah", "humanoid"];
    if !json {
        names.extend(["gecko", "modular-ant", "spider"]);
    }
    let names: Vec<&str> = names.into_iter().filter(|n| only.as_deref().is_none_or(|o| o == *n)).collect();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    if json {
        let fields: Vec<String> =
            names.iter().map(|n| format!("\"{n}\": {:.1}", single(n, seconds))).collect();
        println!("{{{}}}", fields.join(", "));
        return;
    }
    println!("| env | steps/s, 1 env on 1 core | steps/s, {} envs on {threads} cores |", 2 * threads);
    println!("|---|---:|---:|");
    for n in names {
        println!("| {n} | {:.0} | {:.0} |", single(n, seconds), vectorised(n, threads, seconds));
    }
}
