//! Runs the model-based controller alone on a robot environment and prints a trace every
//! `--every` steps (time, base position, roll/pitch/yaw, CoM velocity, planned vs measured
//! contacts, solver statuses), then the run's summary (`RESULT`) and the solvers' mean time
//! and iterations (`SOLVES`: the MPC per solve, the whole-body QP per tick):
//! `cargo run --release --example control_probe -- ant trot 0.3 10 --every 10`.

use centaur_lab::control::parse_gait;
use centaur_lab::dynamics::nalgebra::Vector3;
use centaur_lab::hybrid::ActionMapping;
use centaur_lab::mpc::{Command, LocomotionController};
use centaur_lab::registry::{controller_config, make_robot_env};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let pos: Vec<&String> = {
        let mut v = Vec::new();
        let mut skip = false;
        for a in &args {
            if skip {
                skip = false;
                continue;
            }
            if a.starts_with("--") {
                skip = true;
                continue;
            }
            v.push(a);
        }
        v
    };
    let env_name = pos.first().map_or("ant".to_string(), |s| s.to_string());
    let gait = parse_gait(pos.get(1).map_or("trot", |s| s.as_str())).expect("gait");
    let speed: f64 = pos.get(2).and_then(|s| s.parse().ok()).unwrap_or(0.3);
    let seconds: f64 = pos.get(3).and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let use_contacts = !args.iter().any(|a| a == "--no-contacts");
    let every: usize = flag("--every").and_then(|s| s.parse().ok()).unwrap_or(0);
    let seed: u64 = flag("--seed").and_then(|s| s.parse().ok()).unwrap_or(0);
    let push_y: f64 = flag("--push").and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let push_x: f64 = flag("--push-x").and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let push_at: f64 = flag("--push-at").and_then(|s| s.parse().ok()).unwrap_or(3.0);
    let push_dur: f64 = flag("--push-dur").and_then(|s| s.parse().ok()).unwrap_or(0.1);

    let probe = make_robot_env(&env_name, None).expect("env");
    let steps = (seconds / probe.dt()).round() as usize;
    drop(probe);
    let mut env = make_robot_env(&env_name, Some(steps + 1)).expect("env");
    let mut cfg = controller_config(&env_name).expect("config");
    for (i, a) in args.iter().enumerate() {
        if a == "--set" {
            let kv = &args[i + 1];
            let (k, v) = kv.split_once('=').expect("key=value");
            let x: f64 = v.parse().unwrap_or(0.0);
            match k {
                "cheap" => cfg.mode = centaur_lab::mpc::ControlMode::Cheap,
                "clarabel" => cfg.wbc.backend = centaur_lab::mpc::QpBackend::Clarabel,
                "limit_h" => cfg.wbc.joint_limit_horizon = x,
                "limit_acc" => cfg.wbc.joint_limit_max_deceleration = x,
                "cheap_kp" => cfg.cheap_swing_gains.0 = x,
                "cheap_kd" => cfg.cheap_swing_gains.1 = x,
                "td" => cfg.touchdown_detection = x != 0.0,
                "radius" => cfg.robot.contacts.iter_mut().for_each(|c| c.radius = x),
                "td_speed" => cfg.touchdown_speed = x,
                "w_force" => cfg.wbc.w_force = x,
                "w_body_linear" => cfg.wbc.w_body_linear = x,
                "w_body_angular" => cfg.wbc.w_body_angular = x,
                "w_swing" => cfg.wbc.w_swing = x,
                "w_stance" => cfg.wbc.w_stance = x,
                "swing_xy" => {
                    cfg.wbc.swing_axis_weights[0] = x;
                    cfg.wbc.swing_axis_weights[1] = x
                }
                "reg" => cfg.wbc.regularization = x,
                "wbc_fmax" => cfg.wbc.max_normal_force_ratio = x,
                "w_posture" => cfg.wbc.w_posture = x,
                "swing_height" => cfg.swing_height = x,
                "period" => cfg.gait_period_scale = x,
                "stagger" => cfg.turn_stagger = x,
                "turn_swing_height" => cfg.turn_swing_height = x,
                "turn_max_speed" => {
                    // The turning rating follows (the controller clamps yaw rates outside it).
                    cfg.turn_max_speed = x;
                    for o in cfg.gaits.iter_mut() {
                        o.max_turning_speed = o.max_turning_speed.max(x);
                        o.faster_turning = o.faster_turning.filter(|t| t.max_speed > o.max_turning_speed);
                    }
                }
                "turn_yaw_weight" => cfg.turn_yaw_weight = x,
                "turn_posture_weight" => cfg.turn_posture_weight = x,
                "turn_yaw_rate_weight" => cfg.turn_yaw_rate_weight = x,
                "turn_period" => cfg.turn_period_scale = x,
                "mpc_period" => cfg.mpc_period = x,
                "swing_kp" => cfg.swing_gains.0 = x,
                "swing_kd" => cfg.swing_gains.1 = x,
                "body_kpz" => cfg.body_kp_pos[2] = x,
                "body_kpxy" => {
                    cfg.body_kp_pos[0] = x;
                    cfg.body_kp_pos[1] = x
                }
                "body_kd" => cfg.body_kd_vel = [x; 3],
                "body_kp_ori" => cfg.body_kp_ori = [x; 3],
                "body_kd_ang" => cfg.body_kd_ang = [x; 3],
                "rp_kp" => {
                    cfg.body_kp_ori[0] = x;
                    cfg.body_kp_ori[1] = x
                }
                "rp_kd" => {
                    cfg.body_kd_ang[0] = x;
                    cfg.body_kd_ang[1] = x
                }
                "w_ang" => cfg.wbc.w_body_angular = x,
                "bw_z" => cfg.wbc.body_axis_weights[2] = x,
                "bw_rp" => {
                    cfg.wbc.body_axis_weights[3] = x;
                    cfg.wbc.body_axis_weights[4] = x
                }
                "bw_yaw" => cfg.wbc.body_axis_weights[5] = x,
                "posture_kp" => cfg.posture_gains.0 = x,
                "posture_kd" => cfg.posture_gains.1 = x,
                "fmax" => cfg.mpc.max_normal_force_ratio = x,
                "mpc_dt" => cfg.mpc.dt = x,
                "horizon" => cfg.mpc.horizon = x as usize,
                "force_weight" => cfg.mpc.force_weight = x,
                "mpc_tol" => cfg.mpc.tolerance = x,
                "mpc_clarabel" if x != 0.0 => cfg.mpc.solver = centaur_lab::mpc::MpcSolver::Clarabel,
                "raibert_kv" => cfg.raibert_kv = x,
                "fh_com" => cfg.foothold_from_com = x != 0.0,
                "fh_kp" => cfg.foothold_position_gain = x,
                "recenter" => cfg.recenter_speed = x,
                "leash" => cfg.position_leash = x,
                "max_acc" => cfg.max_acceleration = x,
                "swing_joint_kp" => cfg.swing_joint_gains.0 = x,
                "swing_joint_kd" => cfg.swing_joint_gains.1 = x,
                "stance_joint_kp" => cfg.stance_joint_gains.0 = x,
                "stance_joint_kd" => cfg.stance_joint_gains.1 = x,
                "rating" => cfg.gaits.iter_mut().for_each(|o| o.max_speed = x),
                "duty" => cfg
                    .gaits
                    .iter_mut()
                    .filter(|o| o.gait != centaur_lab::mpc::Gait::Stand)
                    .for_each(|o| o.duty_factor = Some(x)),
                "offer_w_ang" => cfg
                    .gaits
                    .iter_mut()
                    .filter(|o| o.gait != centaur_lab::mpc::Gait::Stand)
                    .for_each(|o| o.body_angular_weight = Some(x)),
                "unrated" => cfg.offer_every_gait(),
                "mu" => {
                    cfg.mpc.mu = x;
                    cfg.wbc.mu = x
                }
                "offer_default_weights" => cfg.gaits.iter_mut().for_each(|o| {
                    o.mpc_state_weights = None;
                    o.body_angular_weight = None
                }),
                _ if k.starts_with("offer_q") => {
                    let idx: usize = k["offer_q".len()..].parse().expect("offer_qN");
                    let base = cfg.mpc.state_weights;
                    for o in cfg.gaits.iter_mut().filter(|o| o.gait != centaur_lab::mpc::Gait::Stand) {
                        o.mpc_state_weights.get_or_insert(base)[idx] = x;
                    }
                }
                _ => {
                    let idx: usize = k.strip_prefix("q").and_then(|s| s.parse().ok()).expect("unknown key");
                    cfg.mpc.state_weights[idx] = x;
                }
            }
        }
    }
    let mut ctrl = LocomotionController::new(env.model(), cfg).expect("controller");
    let mut mapping = ActionMapping::new(env.as_ref(), &ctrl).expect("mapping");
    if args.iter().any(|a| a == "--info") {
        eprintln!(
            "mass {:.3} nominal com height {:.3} body height {:.3} inertia diag {:.4?}",
            ctrl.robot().mass,
            ctrl.robot().nominal_com_height,
            ctrl.robot().nominal_body_height,
            ctrl.robot().inertia_body.diagonal().as_slice()
        );
    }
    let mut obs = vec![0.0f32; env.observation_space().dim()];
    let mut action = vec![0.0f32; env.action_space().dim()];
    env.reset(Some(seed), &mut obs).expect("reset");
    let yaw_rate: f64 = flag("--yaw-rate").and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let body_height: Option<f64> = flag("--height").and_then(|s| s.parse().ok());
    let command = Command { yaw_rate, body_height, ..Command::forward(speed, gait) };
    let pd_hold: Option<(f64, f64)> = flag("--pd").map(|s| {
        let (a, b) = s.split_once(',').expect("kp,kd");
        (a.parse().expect("kp"), b.parse().expect("kd"))
    });
    let q_hold = env.robot_state().q.clone();
    let cpg: Option<(f64, f64, f64, f64)> = flag("--cpg").map(|s| {
        let v: Vec<f64> = s.split(',').map(|x| x.parse().expect("number")).collect();
        (v[0], v[1], v[2], v[3])
    });
    let noise_frac: f64 = flag("--action-noise").and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let mut noise = centaur_lab::gym::Rng::seed_from_u64(seed ^ 0x006e_6f69_7365);
    let dt = env.dt();
    let mut t = 0.0;
    let mut x0 = env.robot_state().q[0];
    let mut y0 = env.robot_state().q[1];
    let mut t_start = 0.0;
    let measure_from: Option<f64> = flag("--measure-from").and_then(|s| s.parse().ok());
    let yaw_of = |q: &[f64]| {
        if q.len() < 7 {
            return 0.0;
        }
        let (x, y, z, w) = (q[3], q[4], q[5], q[6]);
        (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
    };
    let mut yaw0 = if env.model().has_floating_base() { yaw_of(env.robot_state().q.as_slice()) } else { 0.0 };
    let (mut heading, mut yaw_prev) = (0.0f64, yaw0);
    let (mut forward_path, mut x_prev, mut y_prev) = (0.0f64, x0, y0);
    let mut fell = false;
    let mut max_tilt = 0.0f64;
    // Sums for the SOLVES line: the MPC over the ticks that solved, the WBC over every tick.
    let (mut mpc_us, mut mpc_iterations, mut mpc_solves) = (0.0f64, 0.0f64, 0usize);
    let (mut wbc_us, mut wbc_iterations, mut ticks) = (0.0f64, 0.0f64, 0usize);
    for k in 0..steps {
        if (push_y != 0.0 || push_x != 0.0) && (t - push_at).abs() < 0.5 * dt {
            env.push(Vector3::new(push_x, push_y, 0.0), push_dur);
        }
        let cmd = if use_contacts {
            mapping.tick(&mut ctrl, env.as_ref(), &command, t)
        } else {
            ctrl.tick(env.robot_state(), &command, t)
        };
        mapping.action(env.as_mut(), cmd, &mut action);
        if noise_frac > 0.0 {
            centaur_lab::control::perturb_action(&mut action, env.action_space(), noise_frac, &mut noise);
        }
        if let Some((amp, lift, period, sign)) = cpg {
            // Open-loop joint-space trot for the Ant (simulator check): diagonal pairs,
            // hips sweep front→back in stance and back→front in swing, ankles lift in swing.
            let s = env.robot_state();
            let model = env.model();
            let legs = [
                ("hip_1", "ankle_1", -1.0, 1.0, 0.0),
                ("hip_4", "ankle_4", 1.0, 1.0, 0.5),
                ("hip_2", "ankle_2", -1.0, -1.0, 0.5),
                ("hip_3", "ankle_3", 1.0, -1.0, 0.0),
            ];
            let mut tau_map = std::collections::HashMap::new();
            for (hip, ankle, fwd, side, off) in legs {
                let psi = ((t / period + off) % 1.0 + 1.0) % 1.0;
                let (h, a) = if psi < 0.5 {
                    (amp * (1.0 - 4.0 * psi), 0.0)
                } else {
                    (
                        amp * (-1.0 + 4.0 * (psi - 0.5)),
                        lift * (std::f64::consts::PI * (psi - 0.5) / 0.5).sin(),
                    )
                };
                let hq = sign * fwd * h;
                let aq = side * (1.0 - a);
                for (name, target) in [(hip, hq), (ankle, aq)] {
                    let j = model.joint_index(name).expect("joint");
                    let (iq, iv) = (model.joints[j].idx_q, model.joints[j].idx_v);
                    tau_map.insert(j, 100.0 * (target - s.q[iq]) - 10.0 * s.v[iv]);
                }
            }
            let tau: Vec<f64> = env.actuated_joints().iter().map(|j| tau_map[j]).collect();
            env.action_for_torques(&tau, &mut action);
        }
        if let Some(pd) = &pd_hold {
            // Joint PD to the reset pose instead of the controller (simulator checks).
            let s = env.robot_state();
            let model = env.model();
            let tau_pd: Vec<f64> = env
                .actuated_joints()
                .iter()
                .map(|&j| {
                    let (iq, iv) = (model.joints[j].idx_q, model.joints[j].idx_v);
                    pd.0 * (q_hold[iq] - s.q[iq]) - pd.1 * s.v[iv]
                })
                .collect();
            env.action_for_torques(&tau_pd, &mut action);
        }
        {
            let st = ctrl.status();
            if st.mpc_ran {
                mpc_us += st.mpc_solve_us;
                mpc_iterations += f64::from(st.mpc_iterations);
                mpc_solves += 1;
            }
            wbc_us += st.wbc_solve_us;
            wbc_iterations += f64::from(st.wbc_iterations);
            ticks += 1;
        }
        let tau: Vec<f64> = mapping.torques(env.as_ref(), ctrl.command()).to_vec();
        if every > 0 && k % every == 0 {
            let st = ctrl.status();
            let q = &env.robot_state().q;
            let sched: String = st.contact.iter().map(|c| if *c { '1' } else { '0' }).collect();
            let real: String =
                env.foot_contacts().iter().map(|c| if c.in_contact { '1' } else { '0' }).collect();
            let fz: Vec<String> =
                st.forces.iter().map(|f| format!("{:.1}/{:.1}/{:.1}", f[0], f[1], f[2])).collect();
            let tmax = tau.iter().fold(0.0f64, |m, t| m.max(t.abs()));
            let rfz: Vec<String> = env
                .foot_contacts()
                .iter()
                .map(|c| format!("{:.1}/{:.1}/{:.1}", c.force.x, c.force.y, c.force.z))
                .collect();
            let feet_x: Vec<String> = st
                .foot_targets
                .iter()
                .zip(&st.foot_positions)
                .map(|(p, m)| format!("{:.3}/{:.3}>{:.3}/{:.3}", p[0], p[2], m[0], m[2]))
                .collect();
            println!(
                "com {:.3} {:.3} ref {:.3} {:.3} feet [{}]",
                st.com[0],
                st.com[1],
                st.position_reference[0],
                st.position_reference[1],
                feet_x.join(" ")
            );
            println!(
                "t {:.2} x {:.3} y {:.3} z {:.3} rpy {:+.3} {:+.3} {:+.3} v {:+.2} {:+.2} {:+.2} c {} real {} fz [{}] rfz [{}] mpc {:?} wbc {:?} fb {:?} |tau| {:.2} a {:?}",
                t,
                q[0],
                q[1],
                st.com[2],
                st.rpy[0],
                st.rpy[1],
                st.rpy[2],
                st.com_velocity[0],
                st.com_velocity[1],
                st.com_velocity[2],
                sched,
                real,
                fz.join(" "),
                rfz.join(" "),
                st.mpc_status,
                st.wbc_status,
                st.fallback,
                tmax,
                action.iter().map(|a| (a * 100.0).round() / 100.0).collect::<Vec<_>>()
            );
        }
        let v_before = env.robot_state().v.clone();
        let com_before = ctrl.status().com;
        let comv_before = ctrl.status().com_velocity;
        let qdd_plan = ctrl.planned_accelerations().clone();
        let step = env.step(&action, &mut obs).expect("step");
        if env.model().has_floating_base() {
            // The displacement along the heading at the step's start, summed.
            let q = env.robot_state().q.as_slice();
            forward_path += (q[0] - x_prev) * yaw_prev.cos() + (q[1] - y_prev) * yaw_prev.sin();
            (x_prev, y_prev) = (q[0], q[1]);
            // The unwrapped heading change since the measurement started.
            let yaw = yaw_of(q);
            let d = yaw - yaw_prev;
            heading += (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
            yaw_prev = yaw;
        }
        if let Some(t0) = measure_from
            && (t - t0).abs() < 0.5 * dt
        {
            // Restart the displacement measurement (e.g. after the Ant's landing).
            x0 = env.robot_state().q[0];
            y0 = env.robot_state().q[1];
            yaw0 = if env.model().has_floating_base() { yaw_of(env.robot_state().q.as_slice()) } else { 0.0 };
            t_start = t;
            heading = 0.0;
            forward_path = 0.0;
        }
        if every > 0 && k % every == 0 && flag("--qdd").is_some() {
            let v_after = &env.robot_state().v;
            let real: Vec<String> = (0..v_after.len())
                .map(|i| format!("{:+.1}/{:+.1}", qdd_plan[i], (v_after[i] - v_before[i]) / dt))
                .collect();
            println!("qdd plan/real {}", real.join(" "));
        }
        if every > 0 && k % every == 0 && flag("--body").is_some() {
            let st = ctrl.status();
            let f = |v: &[f64; 6]| v.iter().map(|x| format!("{x:+.2}")).collect::<Vec<_>>().join(" ");
            let mf: Vec<String> =
                st.mpc_forces.iter().map(|f| format!("{:.1}/{:.1}/{:.1}", f[0], f[1], f[2])).collect();
            println!(
                "body target [{}] planned [{}] mpc f [{}] ref {:+.3} {:+.3}",
                f(&st.body_acceleration_target),
                f(&st.body_acceleration_planned),
                mf.join(" "),
                st.position_reference[0] - st.com[0],
                st.position_reference[1] - st.com[1]
            );
        }
        if every > 0 && k % every == 0 && flag("--joints").is_some() {
            let s = env.robot_state();
            let model = env.model();
            let js: Vec<String> = ctrl
                .joint_names()
                .iter()
                .enumerate()
                .map(|(i, n)| {
                    let j = model.joint_index(n).expect("joint");
                    let iq = model.joints[j].idx_q;
                    format!("{}={:+.3}(tau {:+.2})", n, s.q[iq], ctrl.command().tau[i])
                })
                .collect();
            println!("joints {}", js.join(" "));
        }
        if every > 0 && k % every == 0 && flag("--vcheck").is_some() {
            // Finite-difference CoM velocity over the step vs the controller's J_com v.
            let c = ctrl.command().clone();
            let _ = c;
            let cmd2 = ctrl.tick(env.robot_state(), &command, t + dt);
            let _ = cmd2;
            let com_after = ctrl.status().com;
            let comv_after = ctrl.status().com_velocity;
            println!(
                "vcheck fd {:+.3} {:+.3} {:+.3} mean Jv {:+.3} {:+.3} {:+.3}",
                (com_after[0] - com_before[0]) / dt,
                (com_after[1] - com_before[1]) / dt,
                (com_after[2] - com_before[2]) / dt,
                0.5 * (comv_after[0] + comv_before[0]),
                0.5 * (comv_after[1] + comv_before[1]),
                0.5 * (comv_after[2] + comv_before[2])
            );
        }
        t = (k + 1) as f64 * dt;
        max_tilt = max_tilt.max(ctrl.status().rpy[0].abs()).max(ctrl.status().rpy[1].abs());
        if step.terminated {
            fell = true;
            println!("terminated at t = {t:.2}");
            break;
        }
    }
    let x1 = env.robot_state().q[0];
    let y1 = env.robot_state().q[1];
    let yaw1 = if env.model().has_floating_base() { yaw_of(env.robot_state().q.as_slice()) } else { 0.0 };
    println!(
        "RESULT fell {fell} t {t:.2} dist {:.3} speed {:.3} lat {:.3} yaw {:.3} tilt {:.3} fails {} heading {heading:.3} yaw_rate {:.3} fwd {:.3}",
        (x1 - x0) * yaw0.cos() + (y1 - y0) * yaw0.sin(),
        ((x1 - x0) * yaw0.cos() + (y1 - y0) * yaw0.sin()) / (t - t_start).max(1e-9),
        -(x1 - x0) * yaw0.sin() + (y1 - y0) * yaw0.cos(),
        yaw1 - yaw0,
        max_tilt,
        ctrl.status().mpc_failures + ctrl.status().wbc_failures,
        heading / (t - t_start).max(1e-9),
        forward_path / (t - t_start).max(1e-9)
    );
    let per = |x: f64, n: usize| x / n.max(1) as f64;
    println!(
        "SOLVES mpc {:.1} us {:.2} iterations over {mpc_solves} solves; wbc {:.1} us {:.2} iterations over {ticks} ticks",
        per(mpc_us, mpc_solves),
        per(mpc_iterations, mpc_solves),
        per(wbc_us, ticks),
        per(wbc_iterations, ticks),
    );
    if ctrl.status().clamped_commands > 0 {
        println!(
            "NOTE {} ticks clamped to the gait's speed or turning rating (--set unrated=1 lifts it)",
            ctrl.status().clamped_commands
        );
    }
}
