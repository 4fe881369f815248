//! Experiment: the Minitaur at other physics steps (same 10 ms control period).
use centaur_envs::{MinitaurConfig, MinitaurEnv, RobotEnv};
use centaur_rl::{Env, Rng};
fn main() {
    for (dt, repeat) in [(0.002, 5usize), (1.0 / 300.0, 3), (0.005, 2)] {
        let mut cfg = MinitaurConfig::deterministic();
        cfg.sim.dt = dt;
        cfg.action_repeat = repeat;
        let mut env = MinitaurEnv::new(cfg.clone()).unwrap();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        env.reset(Some(0), &mut obs).unwrap();
        let z0 = env.robot_state().q[2];
        for _ in 0..300 {
            env.step(&[0.0; 8], &mut obs).unwrap();
        }
        let zs = env.robot_state().q[2];
        env.reset(Some(0), &mut obs).unwrap();
        let mut energy = 0.0;
        let mut n = 0;
        let mut maxv: f64 = 0.0;
        for k in 0..1000 {
            let t = k as f64 * 0.01;
            let mut a = [0.0f32; 8];
            for leg in 0..4 {
                let phase = if leg == 0 || leg == 3 { 0.0 } else { std::f64::consts::PI };
                a[leg] = (0.3 * (4.0 * std::f64::consts::PI * t + phase).cos()) as f32;
                a[4 + leg] = (0.3 * (4.0 * std::f64::consts::PI * t + phase).sin()) as f32;
            }
            let s = env.step(&a, &mut obs).unwrap();
            maxv = maxv.max(obs[8..16].iter().map(|v| v.abs() as f64).fold(0.0, f64::max));
            energy += s.info.energy;
            n += 1;
            if s.done() {
                break;
            }
        }
        let x = env.robot_state().q[0];
        cfg.randomization = Some(Default::default());
        let mut env = MinitaurEnv::new(cfg).unwrap();
        let mut rng = Rng::seed_from_u64(1);
        let (mut rs, mut ls, mut falls) = (0.0, 0usize, 0);
        let t0 = std::time::Instant::now();
        let mut steps = 0;
        for ep in 0..10 {
            env.reset(Some(ep), &mut obs).unwrap();
            loop {
                let mut a = [0.0f32; 8];
                env.action_space().sample(&mut rng, &mut a);
                let s = env.step(&a, &mut obs).unwrap();
                rs += s.reward;
                ls += 1;
                steps += 1;
                if s.done() {
                    falls += s.terminated as usize;
                    break;
                }
            }
        }
        println!(
            "dt {:.4}: reset z {z0:.4} stand z {zs:.4} | lift trot x {x:.3} steps {n} energy {energy:.1} max|qd| {maxv:.1} | random return {:.2} len {:.0} falls {falls} | {:.0} steps/s",
            dt,
            rs / 10.0,
            ls as f64 / 10.0,
            steps as f64 / t0.elapsed().as_secs_f64()
        );
    }
}
