//! The model-based controller driving a simulated robot: closed-loop runs and the summary
//! `centaur control` writes. The robot environments and controller presets come from the
//! registry ([`crate::registry`]); the controller drives the robot through
//! [`ActionMapping`], as the hybrid and the deployed stack do.

use std::time::Instant;

use centaur_dynamics::nalgebra::Vector3;
use centaur_envs::RobotEnv;
use centaur_gym::{BoxSpace, EnvError, Rng};
use centaur_mpc::{Command, ConfigError, Gait, LocomotionController, MpcExecution, MpcSolver};

use crate::hybrid::{ActionMapping, ControllerOverrides, HybridError, MAX_YAW_RATE};
use crate::registry::{
    RegistryError, controller_config, controller_motor, make_robot_env, make_robot_env_with,
};
use crate::settings::EnvSettings;
use centaur_envs::minitaur::MotorInverse;

/// Why a control run could not happen.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    /// The environment or its controller preset.
    #[error(transparent)]
    Registry(#[from] RegistryError),
    /// Unknown gait name.
    #[error("unknown gait `{0}` (stand, walk, trot, pace, bound, pronk, gallop)")]
    UnknownGait(String),
    /// The environment failed.
    #[error("environment: {0}")]
    Env(#[from] EnvError),
    /// The controller configuration is invalid.
    #[error("controller: {0}")]
    Config(#[from] ConfigError),
    /// The controller does not fit the robot.
    #[error(transparent)]
    Hybrid(#[from] HybridError),
    /// A bad option.
    #[error("{0}")]
    Invalid(String),
    /// The simulation blew up (non-finite state or an absurd base speed), e.g. under a push
    /// far beyond what the robot and the integrator can take; no summary is written.
    #[error(
        "the simulation diverged at t = {t:.3} s (base speed {base_speed:.3e} m/s): its results would be meaningless"
    )]
    Diverged {
        /// Simulated time (s).
        t: f64,
        /// Norm of the base's linear velocity (m/s), NaN when the state is not finite.
        base_speed: f64,
    },
    /// Writing the summary failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: std::path::PathBuf,
        /// The error.
        source: std::io::Error,
    },
}

/// The longest control run (simulated seconds): one hour; longer runs are refused before
/// anything is allocated for them.
pub const MAX_SECONDS: f64 = 3600.0;

/// The largest push force (N) a control run takes: far beyond any robot here (the Humanoid
/// weighs ≈ 400 N), below what breaks the simulator's integration.
pub const MAX_PUSH_FORCE: f64 = 10_000.0;

/// A base speed (m/s) no legged robot here reaches: above it the run is reported as diverged.
const MAX_BASE_SPEED: f64 = 100.0;

/// A push during a control run: force (N, world frame) on the base from `at` for `duration` s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Push {
    /// Start time (s).
    pub at: f64,
    /// Force (N).
    pub force: [f64; 3],
    /// Duration (s).
    pub duration: f64,
}

/// What to run.
#[derive(Clone, Debug)]
pub struct ControlOptions {
    /// Environment name (see [`crate::registry::ROBOTS`]) (default: "minitaur").
    pub env: String,
    /// Gait (default: trot).
    pub gait: Gait,
    /// Commanded forward speed (m/s) (default: 0.3).
    pub speed: f64,
    /// Duration (s) (default: 10).
    pub seconds: f64,
    /// Reset seed (default: 0).
    pub seed: u64,
    /// Optional push (default: none).
    pub push: Option<Push>,
    /// Time (s) from which distance, mean speed, lateral and yaw drift are measured, e.g.
    /// after the Ant, which Gymnasium drops from 0.75 m, has landed (default: 0).
    pub measure_from: f64,
    /// Solve the MPC on the controller's worker thread ([`MpcExecution::Background`]) and
    /// run the simulation in real time, so that plans arrive as late as on a robot; the run
    /// then takes `seconds` of wall time and is not reproducible bit for bit (default:
    /// false).
    pub background_mpc: bool,
    /// The MPC's solver (default: [`MpcSolver::Structured`], the controller's default;
    /// [`MpcSolver::Clarabel`] to compare).
    pub mpc_solver: MpcSolver,
    /// Commanded yaw rate (rad/s, positive to the left) (default: 0).
    pub yaw_rate: f64,
    /// Commanded forward speed over time: `(from, speed)` pairs in increasing time; the
    /// speed of the last pair whose time has come is commanded, `speed` before the first
    /// (default: empty, `speed` throughout). The summary reports each segment's mean speed.
    pub speed_schedule: Vec<(f64, f64)>,
    /// Independent Gaussian noise added to every action entry every control step, as a
    /// fraction of that entry's half-range `(high − low)/2` (the perturbation a learner's
    /// exploration adds: a hybrid policy with log-std −1.2 and residual scale 0.25 adds
    /// 0.075); the noisy action is clipped to the bounds (default: 0).
    pub action_noise: f64,
    /// Lift the preset's gait offers for this run: every gait defined for the robot's legs
    /// runs (offered ones at their own periods) at any speed, to measure what is not rated
    /// (default: false, a gait or speed outside the offers is refused).
    pub unrated: bool,
    /// Minitaur: turn the controller's torques into actions with the motor model drawn at
    /// reset (`MotorInverse::Drawn`, the earlier default, to reproduce figures
    /// measured with it) instead of the nominal one (default: false: the nominal motor, since a
    /// controller on the robot does not know its motors' drawn strength, damping and battery
    /// voltage).
    pub drawn_motor: bool,
    /// Multiplies the commanded gait's period, a factor in
    /// [`crate::hybrid::PERIOD_SCALE_RANGE`]: below 1 the gait clock steps faster, as the
    /// hybrid's `period_scale` makes it (default: 1, the gait's own period).
    pub period_scale: f64,
    /// Moves every leg's stance fraction by this much from its gait's own, in
    /// ±[`centaur_mpc::MAX_DUTY_SHIFT`]: below 0 the feet lift off sooner (a trot with
    /// flight phases), as a hybrid's duty steering (`Steering::duty`) makes it; the shift
    /// reaches its value at the controller's slew in the first 0.3 s at most (default: 0,
    /// the gait's own fractions).
    pub duty_shift: f64,
    /// The command ramp (m/s², in (0, 20]) replacing the controller's own `max_acceleration`,
    /// as the hybrid's `max_acceleration` does (default: `None`, the controller's own).
    pub max_acceleration: Option<f64>,
    /// The swing feet's apex height (m, in [`crate::hybrid::SWING_HEIGHT_RANGE`]) replacing
    /// the controller's own `swing_height`, as the hybrid's `swing_height` does (default:
    /// `None`, the controller's own).
    pub swing_height: Option<f64>,
}

impl Default for ControlOptions {
    fn default() -> Self {
        ControlOptions {
            env: "minitaur".into(),
            gait: Gait::Trot,
            speed: 0.3,
            seconds: 10.0,
            seed: 0,
            push: None,
            measure_from: 0.0,
            background_mpc: false,
            mpc_solver: MpcSolver::Structured,
            yaw_rate: 0.0,
            speed_schedule: Vec::new(),
            action_noise: 0.0,
            unrated: false,
            drawn_motor: false,
            period_scale: 1.0,
            duty_shift: 0.0,
            max_acceleration: None,
            swing_height: None,
        }
    }
}

/// The summary of a control run (`summary.json` of `centaur control`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ControlSummary {
    /// Environment.
    pub env: String,
    /// Gait name.
    pub gait: String,
    /// Commanded forward speed (m/s).
    pub commanded_speed: f64,
    /// Mean forward speed over the run (m/s): base displacement along the initial heading / time.
    pub mean_speed: f64,
    /// Base displacement along the initial heading (m).
    pub distance: f64,
    /// Whether the episode ended by a fall (the env's termination).
    pub fell: bool,
    /// Heading error at the end (rad): |unwrapped heading change − commanded yaw rate × the
    /// measured time| (without a yaw-rate command, |final yaw − initial yaw|).
    pub yaw_drift: f64,
    /// Lateral displacement (m).
    pub lateral_drift: f64,
    /// Mean controller tick time (µs).
    pub mean_tick_us: f64,
    /// 99th-percentile controller tick time (µs).
    pub p99_tick_us: f64,
    /// Mean MPC solve time over the ticks that solved (µs).
    pub mean_mpc_solve_us: f64,
    /// Mean whole-body QP solve time (µs).
    pub mean_wbc_solve_us: f64,
    /// MPC and whole-body QP failures (fallbacks taken).
    pub qp_failures: u64,
    /// Simulated seconds actually run.
    pub seconds: f64,
    /// Time from which distance, speed and drifts are measured (s).
    pub measured_from: f64,
    /// Largest |roll| or |pitch| of the body over the run (rad).
    pub max_tilt: f64,
    /// Mechanical energy the actuators spent over the measured time, `Σ |τ·q̇| dt` (J; the
    /// env's [`centaur_gym::StepInfo::energy`]).
    pub energy: f64,
    /// Cost of transport over the measured time: `energy / (m g distance)`, `m` the robot's
    /// total mass (`None` when it moved less than 1 cm forward: standing).
    pub cost_of_transport: Option<f64>,
    /// The push, if any: force (N, world) and its start and duration (s).
    pub push: Option<PushSummary>,
    /// Environment return accumulated over the run.
    pub env_return: f64,
    /// Where the MPC ran: "inline" or "background" (its worker thread).
    pub mpc_execution: String,
    /// The MPC's solver: "structured" or "clarabel".
    pub mpc_solver: String,
    /// Ticks that solved the MPC or waited for its solve (inline: every solving tick;
    /// background: only the ticks before the first plan).
    pub mpc_blocking_ticks: u64,
    /// Commanded yaw rate (rad/s).
    pub commanded_yaw_rate: f64,
    /// Mean yaw rate over the measured time (rad/s): the unwrapped heading change / time.
    pub mean_yaw_rate: f64,
    /// Mean speed along the body's heading (m/s): each step's displacement projected on the
    /// heading at its start, summed, over the measured time (for turning runs, where
    /// `mean_speed` measures along the initial heading only).
    pub mean_forward_speed: f64,
    /// Action noise (fraction of each entry's half-range; 0: none).
    pub action_noise: f64,
    /// Whether the run lifted the gait offers (`--unrated`).
    pub unrated: bool,
    /// The factor the commanded gait's period was multiplied by (1: its own period).
    pub period_scale: f64,
    /// The shift of the stance fractions from the gait's own (0: none).
    pub duty_shift: f64,
    /// The command ramp the controller ran with (m/s²): its own, or `--max-acceleration`.
    pub max_acceleration: f64,
    /// The swing apex height the controller ran with (m): its own, or `--swing-height`.
    pub swing_height: f64,
    /// The motor model the controller's torques became actions through, on a Minitaur
    /// (`nominal`, or `drawn` with `--drawn-motor`; `null`: a robot whose actions are torques).
    pub controller_motor: Option<MotorInverse>,
    /// Per segment of the speed schedule (one segment without a schedule): its time span,
    /// commanded speed and the mean forward speed over it along the heading at its start.
    pub segments: Vec<SegmentSummary>,
}

/// One segment of a speed schedule, as recorded in the summary.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct SegmentSummary {
    /// Start (s).
    pub from: f64,
    /// End (s): the next segment's start, or the end of the run.
    pub to: f64,
    /// Commanded forward speed (m/s).
    pub commanded_speed: f64,
    /// Mean forward speed over the segment (m/s).
    pub mean_speed: f64,
}

/// The push of a run, as recorded in the summary.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct PushSummary {
    /// Force (N, world frame).
    pub force: [f64; 3],
    /// Start (s).
    pub at: f64,
    /// Duration (s).
    pub duration: f64,
    /// Impulse `|F| Δt` (N·s).
    pub impulse: f64,
}

fn yaw_of(q: &[f64]) -> f64 {
    let (x, y, z, w) = (q[3], q[4], q[5], q[6]);
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// Base pose (x, y, yaw) of a floating or planar robot.
fn planar_pose(env: &dyn RobotEnv) -> (f64, f64, f64) {
    let s = env.robot_state();
    if s.has_floating_base() {
        (s.q[0], s.q[1], yaw_of(s.q.as_slice()))
    } else {
        // Planar robots: rootx is the first coordinate, no lateral motion, no yaw.
        (s.q[0], 0.0, 0.0)
    }
}

/// Runs the controller alone on a robot environment and summarises the run.
pub fn run_control(opts: &ControlOptions) -> Result<ControlSummary, ControlError> {
    if !(opts.seconds > 0.0 && opts.seconds <= MAX_SECONDS && opts.speed.is_finite()) {
        return Err(ControlError::Invalid(format!(
            "seconds = {}: expected more than 0 and at most {MAX_SECONDS} s of simulated time, and a finite speed",
            opts.seconds
        )));
    }
    if !(opts.measure_from.is_finite() && opts.measure_from >= 0.0 && opts.measure_from < opts.seconds) {
        return Err(ControlError::Invalid(format!(
            "measure from {} s: expected a time from 0 to before the run's end ({} s)",
            opts.measure_from, opts.seconds
        )));
    }
    if opts.gait == Gait::Stand
        && (opts.speed != 0.0 || opts.yaw_rate != 0.0 || !opts.speed_schedule.is_empty())
    {
        return Err(ControlError::Invalid(
            "a stand keeps its feet where they are: it takes speed 0 and yaw rate 0 (no speed schedule); \
             command a walking gait to move"
                .into(),
        ));
    }
    let overrides = ControllerOverrides {
        // A factor of 1 leaves the period as it is (on the stand too, which has none).
        period_scale: (opts.period_scale != 1.0).then_some(opts.period_scale),
        max_acceleration: opts.max_acceleration,
        swing_height: opts.swing_height,
        ..ControllerOverrides::none(opts.gait)
    };
    overrides.validate()?;
    if opts.gait == Gait::Stand && opts.period_scale != 1.0 {
        return Err(ControlError::Invalid(
            "a stand has no gait period to scale: command a walking gait with --period-scale".into(),
        ));
    }
    let max_shift = centaur_mpc::MAX_DUTY_SHIFT;
    if !centaur_mpc::duty_shift_in_range(opts.duty_shift) {
        return Err(ControlError::Invalid(format!(
            "duty shift {}: expected a fraction in [-{max_shift}, {max_shift}]",
            opts.duty_shift
        )));
    }
    if opts.gait == Gait::Stand && opts.duty_shift != 0.0 {
        return Err(ControlError::Invalid(
            "a stand keeps every foot down: command a walking gait with --duty-shift".into(),
        ));
    }
    if let Some(p) = &opts.push {
        let magnitude = p.force.iter().map(|f| f * f).sum::<f64>().sqrt();
        if !(magnitude.is_finite() && magnitude <= MAX_PUSH_FORCE) {
            return Err(ControlError::Invalid(format!(
                "push force {:?} N: expected finite components and a magnitude of at most {MAX_PUSH_FORCE} N",
                p.force
            )));
        }
        if !(p.duration.is_finite() && p.duration > 0.0 && p.at.is_finite() && p.at >= 0.0) {
            return Err(ControlError::Invalid(format!(
                "push at {} s for {} s: expected a start >= 0 and a positive duration",
                p.at, p.duration
            )));
        }
        if p.at + p.duration > opts.seconds {
            return Err(ControlError::Invalid(format!(
                "push at {} s for {} s ends after the run ({} s)",
                p.at, p.duration, opts.seconds
            )));
        }
    }
    if !(opts.yaw_rate.is_finite() && opts.yaw_rate.abs() <= MAX_YAW_RATE) {
        return Err(ControlError::Invalid(format!(
            "yaw rate {} rad/s: expected a finite rate of at most 2π rad/s (one turn a second)",
            opts.yaw_rate
        )));
    }
    if !(opts.action_noise.is_finite() && opts.action_noise >= 0.0) {
        return Err(ControlError::Invalid("the action noise must be finite and >= 0".into()));
    }
    for (i, &(at, v)) in opts.speed_schedule.iter().enumerate() {
        if !(at.is_finite() && at >= 0.0 && v.is_finite()) {
            return Err(ControlError::Invalid(format!(
                "speed schedule entry {i}: time >= 0 and a finite speed"
            )));
        }
        if i > 0 && at <= opts.speed_schedule[i - 1].0 {
            return Err(ControlError::Invalid("speed schedule times must increase".into()));
        }
        if at >= opts.seconds {
            return Err(ControlError::Invalid(format!(
                "speed schedule entry {i} starts at {at} s, after the run's end ({} s)",
                opts.seconds
            )));
        }
    }
    let probe = make_robot_env(&opts.env, None)?;
    let dt = probe.dt();
    let steps = (opts.seconds / dt).round() as usize;
    let planar = !probe.robot_state().has_floating_base();
    drop(probe);
    if steps == 0 {
        return Err(ControlError::Invalid(format!(
            "seconds = {}: shorter than one control step of {} ({dt} s)",
            opts.seconds, opts.env
        )));
    }
    if planar && (opts.yaw_rate != 0.0 || opts.push.is_some_and(|p| p.force[1] != 0.0)) {
        return Err(ControlError::Invalid(format!(
            "{} moves in the x–z plane only: a yaw rate or a lateral (y) push has no effect on it",
            opts.env
        )));
    }
    let settings = EnvSettings {
        max_episode_steps: Some(steps + 1),
        motor_inverse: opts.drawn_motor.then_some(MotorInverse::Drawn),
        ..EnvSettings::default()
    };
    let mut env = make_robot_env_with(&opts.env, &settings)?;
    let mut config = controller_config(&opts.env)?;
    if opts.background_mpc {
        config.mpc_execution = MpcExecution::Background;
    }
    config.mpc.solver = opts.mpc_solver;
    if opts.unrated {
        config.offer_every_gait();
    }
    // Refuse a gait the robot does not offer, or a speed or yaw rate above its rating, naming
    // what works.
    for v in std::iter::once(opts.speed).chain(opts.speed_schedule.iter().map(|p| p.1)) {
        config.check_command(opts.gait, v, opts.yaw_rate)?;
    }
    // The same overrides as a hybrid's `[controller]` table (the gait is offered: checked above).
    overrides.apply(&mut config)?;
    let (max_acceleration, swing_height) = (config.max_acceleration, config.swing_height);
    let mut ctrl = LocomotionController::new(env.model(), config)?;
    ctrl.set_gait_duty_shift(opts.duty_shift);
    let mut mapping = ActionMapping::new(env.as_ref(), &ctrl)?;
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let mut action = vec![0.0f32; env.action_space().dim()];
    env.reset(Some(opts.seed), &mut obs)?;
    let (mut x0, mut y0, mut yaw0) = planar_pose(env.as_ref());
    let mut t0 = 0.0;
    let mut max_tilt = 0.0f64;
    let mut command = Command { yaw_rate: opts.yaw_rate, ..Command::forward(opts.speed, opts.gait) };
    let space = env.action_space().clone();
    let mut noise = Rng::seed_from_u64(opts.seed ^ 0x006e_6f69_7365);
    let (mut x_prev, mut y_prev, mut yaw_prev) = (x0, y0, yaw0);
    let mut yaw_turned = 0.0;
    let mut forward_path = 0.0;
    // Segment starts: (time, commanded speed, x, y, heading there).
    let mut seg_starts: Vec<(f64, f64, f64, f64, f64)> = Vec::new();
    let speed_at =
        |t: f64| opts.speed_schedule.iter().rev().find(|p| t >= p.0 - 1e-9).map_or(opts.speed, |p| p.1);
    let mut ticks = Vec::with_capacity(steps);
    let (mut mpc_us, mut mpc_n, mut wbc_us, mut wbc_n) = (0.0, 0usize, 0.0, 0usize);
    let mut blocking = 0u64;
    let mut fell = false;
    let mut ret = 0.0;
    let mut energy = 0.0;
    let mut t = 0.0;
    let wall = Instant::now();
    for k in 0..steps {
        if opts.background_mpc {
            // Real time: this step starts `t` seconds after the first.
            let ahead = t - wall.elapsed().as_secs_f64();
            if ahead > 0.0 {
                std::thread::sleep(std::time::Duration::from_secs_f64(ahead));
            }
        }
        if opts.measure_from > 0.0 && t0 == 0.0 && t >= opts.measure_from - 1e-9 {
            (x0, y0, yaw0) = planar_pose(env.as_ref());
            t0 = t;
            yaw_turned = 0.0;
            forward_path = 0.0;
            energy = 0.0;
        }
        command.forward_velocity = speed_at(t);
        if seg_starts.last().is_none_or(|s| s.1 != command.forward_velocity) {
            let (x, y, yaw) = planar_pose(env.as_ref());
            seg_starts.push((t, command.forward_velocity, x, y, yaw));
        }
        if let Some(p) = opts.push
            && (t - p.at).abs() < 0.5 * env.dt()
        {
            env.push(Vector3::from(p.force), p.duration);
        }
        let start = Instant::now();
        let cmd = mapping.tick(&mut ctrl, env.as_ref(), &command, t);
        ticks.push(start.elapsed().as_secs_f64() * 1e6);
        mapping.action(env.as_mut(), cmd, &mut action);
        if opts.action_noise > 0.0 {
            perturb_action(&mut action, &space, opts.action_noise, &mut noise);
        }
        let status = ctrl.status();
        max_tilt = max_tilt.max(status.rpy[0].abs()).max(status.rpy[1].abs());
        if status.mpc_ran {
            mpc_us += status.mpc_solve_us;
            mpc_n += 1;
        }
        blocking += u64::from(status.mpc_blocked);
        wbc_us += status.wbc_solve_us;
        wbc_n += 1;
        let step = env.step(&action, &mut obs)?;
        ret += step.reward;
        energy += step.info.energy;
        t = (k + 1) as f64 * env.dt();
        let state = env.robot_state();
        let base_speed = state.v.rows(0, state.v.len().min(3)).norm();
        if !(base_speed <= MAX_BASE_SPEED && state.q.iter().all(|x| x.is_finite())) {
            return Err(ControlError::Diverged { t, base_speed });
        }
        let (x_now, y_now, yaw_now) = planar_pose(env.as_ref());
        yaw_turned += centaur_mpc::wrap_pi(yaw_now - yaw_prev);
        forward_path += (x_now - x_prev) * yaw_prev.cos() + (y_now - y_prev) * yaw_prev.sin();
        (x_prev, y_prev, yaw_prev) = (x_now, y_now, yaw_now);
        if step.terminated {
            fell = true;
            break;
        }
        if step.truncated {
            break;
        }
    }
    let (x1, y1, _) = planar_pose(env.as_ref());
    let (dx, dy) = (x1 - x0, y1 - y0);
    let distance = dx * yaw0.cos() + dy * yaw0.sin();
    let lateral = -dx * yaw0.sin() + dy * yaw0.cos();
    ticks.sort_by(|a, b| a.total_cmp(b));
    let p99 = ticks.get(((ticks.len() as f64) * 0.99) as usize).or(ticks.last()).copied().unwrap_or(0.0);
    let status = ctrl.status();
    let segments = seg_starts
        .iter()
        .enumerate()
        .map(|(i, &(from, v, x, y, yaw))| {
            let (to, (xe, ye)) = match seg_starts.get(i + 1) {
                Some(next) => (next.0, (next.2, next.3)),
                None => (t, (x1, y1)),
            };
            let along = (xe - x) * yaw.cos() + (ye - y) * yaw.sin();
            SegmentSummary {
                from,
                to,
                commanded_speed: v,
                mean_speed: if to > from { along / (to - from) } else { 0.0 },
            }
        })
        .collect();
    Ok(ControlSummary {
        env: opts.env.clone(),
        gait: opts.gait.name().to_string(),
        commanded_speed: opts.speed,
        mean_speed: if t > t0 { distance / (t - t0) } else { 0.0 },
        distance,
        fell,
        yaw_drift: (yaw_turned - opts.yaw_rate * (t - t0)).abs(),
        lateral_drift: lateral,
        mean_tick_us: ticks.iter().sum::<f64>() / ticks.len().max(1) as f64,
        p99_tick_us: p99,
        mean_mpc_solve_us: mpc_us / mpc_n.max(1) as f64,
        mean_wbc_solve_us: wbc_us / wbc_n.max(1) as f64,
        qp_failures: status.mpc_failures + status.wbc_failures,
        seconds: t,
        measured_from: t0,
        max_tilt,
        energy,
        cost_of_transport: crate::experiment::cost_of_transport(energy, env.model(), distance),
        push: opts.push.map(|p| PushSummary {
            force: p.force,
            at: p.at,
            duration: p.duration,
            impulse: Vector3::from(p.force).norm() * p.duration,
        }),
        env_return: ret,
        mpc_execution: if opts.background_mpc { "background" } else { "inline" }.into(),
        mpc_solver: match opts.mpc_solver {
            MpcSolver::Structured => "structured",
            MpcSolver::Clarabel => "clarabel",
        }
        .into(),
        mpc_blocking_ticks: blocking,
        commanded_yaw_rate: opts.yaw_rate,
        mean_yaw_rate: if t > t0 { yaw_turned / (t - t0) } else { 0.0 },
        mean_forward_speed: if t > t0 { forward_path / (t - t0) } else { 0.0 },
        action_noise: opts.action_noise,
        unrated: opts.unrated,
        period_scale: opts.period_scale,
        duty_shift: opts.duty_shift,
        max_acceleration,
        swing_height,
        controller_motor: controller_motor(&opts.env, &settings),
        segments,
    })
}

/// Adds independent Gaussian noise of `fraction` × each entry's half-range `(high − low)/2`
/// to `action` and clips it to the bounds (`--action-noise`: what a learner's exploration
/// does to the controller's actions).
pub fn perturb_action(action: &mut [f32], space: &BoxSpace, fraction: f64, rng: &mut Rng) {
    for ((a, lo), hi) in action.iter_mut().zip(&space.low).zip(&space.high) {
        let half = 0.5 * (hi - lo) as f64;
        *a = (*a as f64 + fraction * half * rng.normal()).clamp(*lo as f64, *hi as f64) as f32;
    }
}

/// Writes `summary` as `dir/summary.json` (pretty-printed), creating `dir`.
pub fn write_summary(
    dir: &std::path::Path,
    summary: &ControlSummary,
) -> Result<std::path::PathBuf, ControlError> {
    let io = |path: &std::path::Path| {
        let path = path.to_path_buf();
        move |source| ControlError::Io { path, source }
    };
    check_out_dir(dir)?;
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let path = dir.join("summary.json");
    let json = serde_json::to_string_pretty(summary).expect("a summary of numbers and strings serialises");
    crate::rundir::write_atomic(&path, &(json + "\n")).map_err(io(&path))?;
    Ok(path)
}

/// Refuses an output path that exists and is not a directory; call it before a run, so
/// that a long run is not lost to a typo in `--out`.
pub fn check_out_dir(dir: &std::path::Path) -> Result<(), ControlError> {
    crate::rundir::check_not_file(dir).map_err(|source| ControlError::Io { path: dir.to_path_buf(), source })
}

/// Parses a gait name.
pub fn parse_gait(name: &str) -> Result<Gait, ControlError> {
    Gait::from_name(name).ok_or_else(|| ControlError::UnknownGait(name.to_string()))
}
