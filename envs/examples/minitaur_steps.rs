//! Profiling aid: N env steps of the deterministic Minitaur with a fixed trot.
use centaur_envs::{MinitaurConfig, MinitaurEnv};
use centaur_gym::Env;
fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(300);
    let mut env = MinitaurEnv::new(MinitaurConfig::deterministic()).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(0), &mut obs).unwrap();
    let t0 = std::time::Instant::now();
    for k in 0..n {
        let t = k as f64 * 0.01;
        let mut a = [0.0f32; 8];
        for leg in 0..4 {
            let phase = if leg == 0 || leg == 3 { 0.0 } else { std::f64::consts::PI };
            a[leg] = (0.3 * (4.0 * std::f64::consts::PI * t + phase).cos()) as f32;
            a[4 + leg] = (0.3 * (4.0 * std::f64::consts::PI * t + phase).sin()) as f32;
        }
        if env.step(&a, &mut obs).unwrap().done() {
            env.reset(None, &mut obs).unwrap();
        }
    }
    eprintln!("{:.1} µs/step", t0.elapsed().as_secs_f64() * 1e6 / n as f64);
}
