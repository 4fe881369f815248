//! The shape robot software would embed: a trained residual policy (loaded from its
//! checkpoint, no training code) on top of the controller, ticking at a fixed rate against a
//! small robot interface, with the tick time and allocations per tick reported.
//!
//! ```text
//! cargo run --release --example residual_ppo_minitaur        # produces the checkpoint
//! cargo run --release --example embed_controller -- [--checkpoint PATH] [--seconds 10] [--controller-only] [--realtime] [--background-mpc]
//! ```
//! The "robot" here is the simulated Minitaur behind [`centaur_lab::deploy::RobotInterface`];
//! on hardware the same loop would read the estimator and sensors and write the motor
//! drivers. `--realtime` sleeps to hold the 100 Hz period as a robot loop would.
//! `--background-mpc` solves the MPC on the controller's worker thread
//! (`MpcExecution::Background`), so that no tick waits for a solve; with `--realtime` its
//! plans arrive as late as they would on the robot. Allocations are counted on the loop's
//! thread only. The hybrid is rebuilt with the setup its run recorded (the checkpoint's
//! own, written by `centaur compare` and `centaur train --spec`, else its run directory's
//! `experiment.json`; the Minitaur preset's for a checkpoint with neither), so a policy
//! trained with any setup runs as trained, with no flag. A checkpoint inside a run
//! directory is also checked against that directory's record: one trained with `[env]`
//! settings that change the task is refused (those that only perturbed training, motor
//! strength drawn at reset and pushes, are taken, and the motor its controller was told,
//! `motor_inverse`, is told it here too).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use centaur_lab::deploy::{HybridStack, Simulated};
use centaur_lab::envs::minitaur::MotorInverse;
use centaur_lab::experiment::{check_trained_with, recorded_hybrid};
use centaur_lab::hybrid::ResidualConfig;
use centaur_lab::registry::{controller_config, make_robot_env_with, residual_config};
use centaur_lab::settings::EnvSettings;
use centaur_mpc::MpcExecution;
use centaur_rl::Policy;
use centaur_test_support::{CountingAllocator, thread_allocations};

/// The hybrid setup a checkpoint's run recorded: the checkpoint's own (`residual`, written by
/// `centaur compare` and `centaur train --spec`), else its run directory's `experiment.json`.
fn recorded_setup(checkpoint: &Path, run: Option<&Path>) -> Option<ResidualConfig> {
    let from_checkpoint = centaur_rl::Checkpoint::read(checkpoint).ok().and_then(|c| {
        if !c.has_meta("residual") {
            return None;
        }
        match c.get_meta::<ResidualConfig>("residual") {
            Ok(r) => Some(r),
            Err(e) => {
                eprintln!("embed_controller: {e}");
                std::process::exit(1);
            }
        }
    });
    from_checkpoint.or_else(|| run.and_then(|r| recorded_hybrid(r).ok()).map(|(_, r)| r))
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let checkpoint = PathBuf::from(
        arg("--checkpoint").unwrap_or_else(|| "runs/residual_ppo_minitaur/hybrid/checkpoint".into()),
    );
    let seconds: f64 = match arg("--seconds").map(|s| s.parse::<f64>()) {
        None => 10.0,
        Some(Ok(s)) if s.is_finite() && s > 0.0 && s <= 3600.0 => s,
        Some(_) => {
            eprintln!("embed_controller: --seconds must be a number of seconds in (0, 3600]");
            std::process::exit(2);
        }
    };
    let realtime = args.iter().any(|a| a == "--realtime");
    let background = args.iter().any(|a| a == "--background-mpc");
    let policy = if args.iter().any(|a| a == "--controller-only") {
        None
    } else {
        match Policy::load(&checkpoint) {
            Ok(p) => Some(p),
            Err(e) => {
                eprintln!(
                    "embed_controller: cannot load {}: {e}\n(run `cargo run --release --example residual_ppo_minitaur` first, or pass --controller-only)",
                    checkpoint.display()
                );
                std::process::exit(1);
            }
        }
    };
    let has_policy = policy.is_some();
    // The hybrid's setup: the one its run recorded (in the checkpoint, else in the run
    // directory's experiment.json), else the Minitaur preset's.
    let run = checkpoint.parent().and_then(Path::parent).filter(|r| r.join("experiment.json").is_file());
    let recorded = if has_policy { recorded_setup(&checkpoint, run) } else { None };
    let residual =
        recorded.unwrap_or_else(|| residual_config("minitaur").expect("the Minitaur has a hybrid preset"));
    // A checkpoint inside a run directory: its hybrid must have been trained with this setup,
    // and its controller is told the motor it was told in training.
    let mut settings =
        EnvSettings { max_episode_steps: Some((seconds / 0.01) as usize + 1), ..EnvSettings::default() };
    if let Some(run) = run
        && has_policy
    {
        match check_trained_with(run, &residual) {
            Ok(trained) => {
                if let Some(difference) = &trained.controller_changed {
                    eprintln!(
                        "embed_controller: warning: {} was trained on another controller preset than today's ({difference}); running today's",
                        run.display()
                    );
                }
                if trained.controller_motor == Some(MotorInverse::Drawn) {
                    eprintln!(
                        "embed_controller: {} was trained with the controller told the motor drawn at reset (the earlier default); it is told so here too",
                        run.display()
                    );
                }
                settings.motor_inverse = trained.controller_motor;
                settings.observe_body_state = trained.observe_body_state.then_some(true);
            }
            Err(e) => {
                eprintln!("embed_controller: {e}");
                std::process::exit(1);
            }
        }
    }

    // The robot: a simulated Minitaur (the residual setup must be the one trained with).
    let mut env = make_robot_env_with("minitaur", &settings).expect("minitaur");
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    env.reset(Some(2024), &mut obs).expect("reset");
    let mut controller = controller_config("minitaur").expect("controller preset");
    if background {
        controller.mpc_execution = MpcExecution::Background;
    }
    let mut stack =
        match HybridStack::new(&Simulated { env: env.as_ref(), obs: &obs }, controller, policy, residual) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("embed_controller: {e}");
                std::process::exit(1);
            }
        };

    // The fixed-rate loop.
    let period = Duration::from_secs_f64(env.dt());
    let mut ticks_us = Vec::with_capacity((seconds / env.dt()) as usize + 1);
    let (mut alloc_ticks, mut allocs) = (0usize, 0usize);
    let mut command = vec![0.0f32; env.action_space().dim()];
    let x0 = env.robot_state().q[0];
    let mut next = Instant::now();
    let mut fell = false;
    while env.episode_time() < seconds {
        let before = thread_allocations();
        let start = Instant::now();
        command.copy_from_slice(stack.tick(&Simulated { env: env.as_ref(), obs: &obs }));
        let elapsed = start.elapsed();
        let n = thread_allocations() - before;
        if n > 0 {
            alloc_ticks += 1;
            allocs += n;
        }
        ticks_us.push(elapsed.as_secs_f64() * 1e6);
        // "Write the motor drivers": here, one step of the simulation.
        match env.step(&command, &mut obs) {
            Ok(s) if s.terminated => {
                fell = true;
                break;
            }
            Ok(s) if s.truncated => break,
            Ok(_) => {}
            Err(e) => {
                eprintln!("embed_controller: {e}");
                std::process::exit(1);
            }
        }
        if realtime {
            next += period;
            if let Some(wait) = next.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
        }
    }
    ticks_us.sort_by(|a, b| a.total_cmp(b));
    let pct = |p: f64| ticks_us[((ticks_us.len() - 1) as f64 * p) as usize];
    println!(
        "{} on the Minitaur for {:.1} s at {:.0} Hz: walked {:.2} m{}",
        if has_policy { "controller + residual policy" } else { "controller alone" },
        env.episode_time(),
        1.0 / env.dt(),
        env.robot_state().q[0] - x0,
        if fell { " and fell" } else { "" }
    );
    println!(
        "tick time (controller + policy): median {:.0} µs, p99 {:.0} µs, max {:.0} µs over {} ticks (budget {:.0} µs)",
        pct(0.5),
        pct(0.99),
        pct(1.0),
        ticks_us.len(),
        period.as_secs_f64() * 1e6
    );
    let mpc_solves = stack.controller().status().ticks;
    println!(
        "allocations on the loop's thread: {allocs} in {alloc_ticks} of {} ticks ({}); controller ticks: {mpc_solves}",
        ticks_us.len(),
        if background {
            "the MPC solves on its worker thread"
        } else {
            "Clarabel 0.11 rebuilds a timer map inside each MPC solve; everything else in the tick is allocation-free"
        }
    );
}
