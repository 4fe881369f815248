//! Shared helpers: loading the robots of `assets/`.
#![allow(dead_code)]

use centaur_dynamics::{BaseKind, Model};
use centaur_mpc::ControllerConfig;

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
