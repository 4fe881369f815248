//! The hybrid pipeline in one straight `main`, CleanRL-style: a simulated Minitaur and a
//! controller built from its model, a residual environment putting a policy's bounded
//! corrections on the controller's actions, PPO training it, and the trained policy run
//! with the controller the way robot software runs it.
//!
//! ```text
//! cargo run --release --example hybrid_pipeline -- [STEPS]   (default 20000)
//! ```

use std::ops::ControlFlow;

use centaur::deploy::{HybridStack, Simulated};
use centaur::envs::{MinitaurConfig, MinitaurEnv, RobotEnv};
use centaur::gym::{Env, VecEnv};
use centaur::hybrid::ResidualConfig;
use centaur::mpc::{Command, ControllerConfig, Gait, LocomotionController};
use centaur::residual::ResidualEnv;
use centaur::rl::{Algorithm, Policy, Ppo, PpoConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let steps: u64 = std::env::args().nth(1).map_or(Ok(20_000), |s| s.parse())?;

    // 1. The hybrid: the Minitaur (Rapier, from its URDF), the controller built from the same
    //    model, and the law applied = clip(controller's action + 0.25 ⊙ policy output).
    let residual = ResidualConfig::new(0.25, Command::forward(0.3, Gait::Trot));
    let hybrid = || -> Result<Box<dyn Env>, Box<dyn std::error::Error>> {
        let robot = Box::new(MinitaurEnv::new(MinitaurConfig::default())?);
        let controller = LocomotionController::new(robot.model(), ControllerConfig::minitaur())?;
        Ok(Box::new(ResidualEnv::new(robot, controller, residual.clone())?))
    };
    let mut envs = VecEnv::new(vec![hybrid()?, hybrid()?], 2)?;

    // 2. PPO with the policy's mean output zeroed: the untrained hybrid is the controller.
    let config = PpoConfig { n_steps: 1024, seed: 0, ..PpoConfig::minitaur() };
    let mut ppo = Ppo::for_env(config, &envs)?;
    ppo.zero_policy_output();
    ppo.learn(&mut envs, steps, &mut |m| {
        println!("{:>7} steps: training return {:.2}", m.env_steps, m.episode_return_mean);
        ControlFlow::Continue(())
    })?;

    // 3. Deploy: the policy loaded back from its checkpoint, with the controller, behind
    //    the robot interface a real robot would implement; one 10 s episode.
    let path = std::env::temp_dir().join("centaur-hybrid-pipeline.ckpt");
    ppo.save(&path)?;
    let policy = Policy::load(&path)?;
    let mut robot = MinitaurEnv::new(MinitaurConfig::default())?;
    let mut obs = vec![0.0f32; robot.observation_space().dim()];
    robot.reset(Some(1), &mut obs)?;
    let mut stack = HybridStack::new(
        &Simulated { env: &robot, obs: &obs },
        ControllerConfig::minitaur(),
        Some(policy),
        residual,
    )?;
    let (x0, mut ret) = (robot.robot_state().q[0], 0.0);
    loop {
        let action = stack.tick(&Simulated { env: &robot, obs: &obs });
        let step = robot.step(action, &mut obs)?;
        ret += step.reward;
        if step.done() {
            break;
        }
    }
    let walked = robot.robot_state().q[0] - x0;
    println!("deployed: return {ret:.2}, {walked:.2} m forward in {:.1} s", robot.episode_time());
    Ok(())
}
