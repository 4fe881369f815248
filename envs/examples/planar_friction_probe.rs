//! Measures whether ground friction holds a body on a planar (fixed-base, x–z–pitch) chain
//! of Rapier multibody joints, the way Walker2d, Hopper and HalfCheetah are built.
//!
//! A 10 kg box rests on the ground (μ = 1) at the end of `rootx` (prismatic x) → `rootz`
//! (prismatic z) → `rooty`; after 1 s a 30 N horizontal force pushes it for 2 s. Friction can
//! give up to 98 N, so the box should not move, with `rooty` fixed or a revolute joint.
//! Before `Sim` built the frames of coordinate-axis joints exactly (see `joint_axis_frame` in
//! `sim.rs`), the revolute case slid 4.4 m, as if friction were 8 N: the hinge's rounded
//! frames left the blocked y tangent an effective mass of ~3e-15, which Rapier inverted.
//! Run: `cargo run --release -p centaur-envs --example planar_friction_probe`.

use centaur_dynamics::nalgebra::Vector3;
use centaur_dynamics::{BaseKind, Model, RobotState};
use centaur_envs::{ColliderSpec, Sim, SimConfig};

fn urdf(pitch_joint: &str) -> String {
    let limit = if pitch_joint == "revolute" {
        r#"<limit lower="-3" upper="3" effort="0" velocity="1000"/>"#
    } else {
        ""
    };
    format!(
        r#"<?xml version="1.0"?>
<robot name="planar_box">
  <link name="world"/>
  <link name="x"/>
  <joint name="rootx" type="prismatic"><parent link="world"/><child link="x"/><axis xyz="1 0 0"/><limit effort="0" velocity="1000"/></joint>
  <link name="z"/>
  <joint name="rootz" type="prismatic"><parent link="x"/><child link="z"/><axis xyz="0 0 1"/><limit effort="0" velocity="1000"/></joint>
  <link name="box">
    <inertial><mass value="10"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.4 0.4 0.2"/></geometry></collision>
  </link>
  <joint name="rooty" type="{pitch_joint}"><parent link="z"/><child link="box"/><axis xyz="0 1 0"/>{limit}</joint>
</robot>"#
    )
}

fn main() {
    println!("rooty     | x after the push (m) | speed (m/s) | friction it implies (N, up to 98 expected)");
    for pitch_joint in ["fixed", "revolute"] {
        let path = std::env::temp_dir().join(format!("planar_box_{pitch_joint}.urdf"));
        std::fs::write(&path, urdf(pitch_joint)).expect("write the URDF");
        let model = Model::from_urdf_file(&path, BaseKind::Fixed).expect("URDF loads");
        let config = SimConfig::default();
        let mut sim = Sim::new(&model, &config, &ColliderSpec::default(), &[]).expect("sim");
        let mut s = RobotState::new(&model);
        s.q[1] = 0.1;
        sim.set_state(&s);
        let steps = |secs: f64| (secs / config.dt).round() as usize;
        for _ in 0..steps(1.0) {
            sim.step();
        }
        sim.set_external_force(model.njoints() - 1, Vector3::new(30.0, 0.0, 0.0));
        for _ in 0..steps(2.0) {
            sim.step();
        }
        sim.read_state(&mut s);
        // x = a t²/2 under a constant net force: friction = 30 N − m a.
        let a = 2.0 * s.q[0] / 4.0;
        println!("{pitch_joint:9} | {:20.3} | {:11.3} | {:.1}", s.q[0], s.v[0], 30.0 - 10.0 * a);
    }
}
