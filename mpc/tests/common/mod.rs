//! Shared helpers: loading the robots of `assets/`.
#![allow(dead_code)]

use centaur_dynamics::{BaseKind, Model};
use centaur_mpc::{ControllerConfig, HardConstraints};

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
