//! Quick diagnostics: random actions on the Gymnasium locomotion envs.
use centaur_envs::{LocomotionConfig, LocomotionEnv, LocomotionRobot};
use centaur_gym::{Env, Rng};
fn main() {
    for robot in [
        LocomotionRobot::Ant,
        LocomotionRobot::Walker2d,
        LocomotionRobot::Hopper,
        LocomotionRobot::HalfCheetah,
        LocomotionRobot::Humanoid,
    ] {
        let mut env = LocomotionEnv::new(LocomotionConfig::preset(robot)).unwrap();
        let mut obs = vec![0.0f32; env.observation_space().dim()];
        let mut act = vec![0.0f32; env.action_space().dim()];
        let mut rng = Rng::seed_from_u64(3);
        let (mut rets, mut lens) = (vec![], vec![]);
        let t0 = std::time::Instant::now();
        let mut steps = 0;
        for ep in 0..10 {
            env.reset(Some(ep), &mut obs).unwrap();
            let (mut r, mut n) = (0.0, 0);
            loop {
                env.action_space().sample(&mut rng, &mut act);
                let s = env.step(&act, &mut obs).unwrap();
                r += s.reward;
                n += 1;
                steps += 1;
                if s.info.unstable {
                    println!("  unstable!");
                }
                if s.done() {
                    break;
                }
            }
            rets.push(r);
            lens.push(n);
        }
        let m = rets.iter().sum::<f64>() / 10.0;
        let sd = (rets.iter().map(|r| (r - m) * (r - m)).sum::<f64>() / 10.0).sqrt();
        println!(
            "{:12} obs {:3} act {:2}: return {:8.2} ± {:6.2}, length {:6.1}, {:7.0} steps/s",
            robot.name(),
            obs.len(),
            act.len(),
            m,
            sd,
            lens.iter().sum::<usize>() as f64 / 10.0,
            steps as f64 / t0.elapsed().as_secs_f64()
        );
    }
}
