//! Quick diagnostics of the Minitaur env against PyBullet's measured numbers.
use centaur_envs::{MinitaurConfig, MinitaurEnv, RobotEnv};
use centaur_gym::{Env, Rng};
use std::time::Instant;

fn main() {
    let mut env = MinitaurEnv::new(MinitaurConfig::deterministic()).unwrap();
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(0), &mut obs).unwrap();
    println!("after reset: base z {:.4}, motor angles {:?}", env.robot_state().q[2], &obs[..8]);
    let zero = [0.0f32; 8];
    let mut gaps = vec![0.0; 4];
    let t = Instant::now();
    for k in 0..500 {
        let s = env.step(&zero, &mut obs).unwrap();
        if k % 100 == 99 {
            env.sim().loop_closure_gaps(&mut gaps);
            println!(
                "t={:.2}s z={:.4} x={:.4} done={} gaps(mm)={:.3?}",
                (k + 1) as f64 * 0.01,
                env.robot_state().q[2],
                env.robot_state().q[0],
                s.done(),
                gaps.iter().map(|g| g * 1e3).collect::<Vec<_>>()
            );
        }
    }
    println!("stand 500 steps: {:.1} µs/step", t.elapsed().as_secs_f64() * 1e6 / 500.0);
    // Open-loop trot: a[0:4] = 0.35 cos(4πt + φ), diagonal pairs in phase.
    env.reset(Some(0), &mut obs).unwrap();
    let mut energy = 0.0;
    let mut maxgap: f64 = 0.0;
    for k in 0..1000 {
        let t = k as f64 * 0.01;
        let mut a = [0.0f32; 8];
        for leg in 0..4 {
            let phase = if leg == 0 || leg == 3 { 0.0 } else { std::f64::consts::PI };
            a[leg] = (0.35 * (4.0 * std::f64::consts::PI * t + phase).cos()) as f32;
        }
        let s = env.step(&a, &mut obs).unwrap();
        energy += s.info.energy;
        env.sim().loop_closure_gaps(&mut gaps);
        maxgap = maxgap.max(gaps.iter().cloned().fold(0.0, f64::max));
        if s.done() {
            println!("trot ended at step {k}");
            break;
        }
    }
    println!(
        "open-loop trot 10 s: x = {:.3} m, energy {:.1} J, max gap {:.2} mm",
        env.robot_state().q[0],
        energy,
        maxgap * 1e3
    );
    env.reset(Some(0), &mut obs).unwrap();
    let mut energy = 0.0;
    let mut n = 0;
    for k in 0..1000 {
        let t = k as f64 * 0.01;
        let mut a = [0.0f32; 8];
        for leg in 0..4 {
            let phase = if leg == 0 || leg == 3 { 0.0 } else { std::f64::consts::PI };
            a[leg] = (0.3 * (4.0 * std::f64::consts::PI * t + phase).cos()) as f32;
            a[4 + leg] = (0.3 * (4.0 * std::f64::consts::PI * t + phase).sin()) as f32;
        }
        let s = env.step(&a, &mut obs).unwrap();
        energy += s.info.energy;
        n += 1;
        if s.done() {
            break;
        }
    }
    println!(
        "lift trot: x = {:.3} y = {:.3} steps {n} energy {:.1} J",
        env.robot_state().q[0],
        env.robot_state().q[1],
        energy
    );
    // Random actions.
    let mut env = MinitaurEnv::new(MinitaurConfig::default()).unwrap();
    let mut rng = Rng::seed_from_u64(1);
    let (mut rets, mut lens, mut falls) = (vec![], vec![], 0);
    let t = Instant::now();
    let mut steps = 0;
    for ep in 0..10 {
        env.reset(Some(ep), &mut obs).unwrap();
        let (mut r, mut n) = (0.0, 0);
        loop {
            let mut a = [0.0f32; 8];
            env.action_space().sample(&mut rng, &mut a);
            let s = env.step(&a, &mut obs).unwrap();
            r += s.reward;
            n += 1;
            steps += 1;
            if s.done() {
                if s.terminated {
                    falls += 1;
                }
                break;
            }
        }
        rets.push(r);
        lens.push(n);
    }
    let mean = rets.iter().sum::<f64>() / 10.0;
    let std = (rets.iter().map(|r| (r - mean) * (r - mean)).sum::<f64>() / 10.0).sqrt();
    println!(
        "random: return {:.2} ± {:.2}, length {:.0}, falls {}, {:.0} steps/s",
        mean,
        std,
        lens.iter().sum::<usize>() as f64 / 10.0,
        falls,
        steps as f64 / t.elapsed().as_secs_f64()
    );
}
