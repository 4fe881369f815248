//! Shared helpers: loading the robots of `assets/`.
#![allow(dead_code)]

use centaur_dynamics::nalgebra::{UnitQuaternion, Vector3};
use centaur_dynamics::{BaseKind, Model, RobotState};
use centaur_mpc::{ControllerConfig, HardConstraints, LocomotionController};

/// The five robots: name, URDF path relative to the workspace, base kind.
pub const ROBOTS: [(&str, &str, BaseKind); 5] = [
    ("solo12", "assets/solo12/solo12.urdf", BaseKind::Floating),
    ("ant", "assets/mujoco/ant.urdf", BaseKind::Floating),
    ("walker2d", "assets/mujoco/walker2d.urdf", BaseKind::Fixed),
    ("humanoid", "assets/mujoco/humanoid.urdf", BaseKind::Floating),
    ("minitaur", "assets/minitaur/minitaur.urdf", BaseKind::Floating),
];

/// Loads a robot's model and preset configuration.
pub fn load(name: &str) -> (Model, ControllerConfig) {
    let (_, path, base) = ROBOTS.iter().find(|r| r.0 == name).expect("known robot");
    let full = format!("{}/../{}", env!("CARGO_MANIFEST_DIR"), path);
    let model = Model::from_urdf_file(&full, *base).expect("URDF loads");
    (model, ControllerConfig::preset(name).expect("preset"))
}

/// Solo12 with friction too low (μ 0.05) to reach a commanded speed within the MPC's
/// horizon: standing solves, `Command::forward(1.0, _)` is primal infeasible (it needs
/// ≈ 3 m/s², friction gives at most 1.2 · 0.05 · 9.81 = 0.59 m/s²).
pub fn low_friction_solo12() -> (Model, ControllerConfig) {
    let (model, mut cfg) = load("solo12");
    cfg.mpc.mu = 0.05;
    cfg.mpc.max_normal_force_ratio = 0.3;
    cfg.mpc.hard = HardConstraints { max_height_drop: None, terminal_velocity_band: Some(0.05) };
    cfg.max_acceleration = 100.0;
    (model, cfg)
}

/// A perturbation of the nominal state.
#[derive(Clone, Debug, Default)]
pub struct Perturbation {
    pub roll: f64,
    pub pitch: f64,
    pub dz: f64,
    pub v: [f64; 3],
    pub w: [f64; 3],
    pub joint_offset: f64,
    pub joint_seed: u64,
}

pub fn perturbed(c: &LocomotionController, p: &Perturbation) -> RobotState {
    let mut s = c.nominal_state();
    let r = c.robot();
    match r.planar_q {
        None => {
            let pos = s.base_position() + Vector3::new(0.0, 0.0, p.dz);
            let rot = UnitQuaternion::from_euler_angles(p.roll, p.pitch, 0.0);
            s.set_base_pose(pos, rot);
            s.set_base_twist_world(Vector3::from(p.v), Vector3::from(p.w));
        }
        Some([ix, iz, ip]) => {
            s.q[iz] += p.dz;
            s.q[ip] += p.pitch;
            s.v[r.base_v[0]] = p.v[0];
            s.v[r.base_v[1]] = p.v[2];
            s.v[r.base_v[2]] = p.w[1];
            let _ = ix;
        }
    }
    // Deterministic pseudo-random joint offsets in ±joint_offset.
    let mut x = p.joint_seed | 1;
    for &iq in &r.joint_q {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let u = (x % 10_000) as f64 / 10_000.0 * 2.0 - 1.0;
        s.q[iq] += u * p.joint_offset;
    }
    s
}

/// Random perturbations: tilt ±0.15 rad, height −3…+2 cm, velocities ±0.3 m/s and
/// ±0.5 rad/s, joint offsets up to 0.1 rad.
pub fn perturbation() -> impl proptest::strategy::Strategy<Value = Perturbation> {
    use proptest::prelude::*;
    (
        -0.15..0.15f64,
        -0.15..0.15f64,
        -0.03..0.02f64,
        prop::array::uniform3(-0.3..0.3f64),
        prop::array::uniform3(-0.5..0.5f64),
        0.0..0.1f64,
        any::<u64>(),
    )
        .prop_map(|(roll, pitch, dz, v, w, joint_offset, joint_seed)| Perturbation {
            roll,
            pitch,
            dz,
            v,
            w,
            joint_offset,
            joint_seed,
        })
}
