//! Shared machinery of the Gymnasium MuJoCo locomotion environments: the robot (URDF +
//! sidecar from `assets/mujoco/`), MuJoCo's `qpos`/`qvel` layout, actuators with gears,
//! joint springs and armature, per-body contact wrenches (`cfrc_ext`), and Gymnasium's reset
//! noise. [`crate::locomotion`] defines each robot's observations, rewards and
//! terminations on top of it ([`crate::LocomotionRobot`]).
//!
//! Conventions carried over from MuJoCo so that observations match Gymnasium's: a free
//! joint's `qpos` is `[x, y, z, qw, qx, qy, qz]` and its `qvel` is `[linear velocity in the
//! world frame, angular velocity in the body frame]`; hinge and slide joints equal the URDF
//! joint values (the conversion preserved MuJoCo's zeros and `ref`).

use centaur_dynamics::nalgebra::{Quaternion, UnitQuaternion, Vector3};
use centaur_dynamics::{BaseKind, Data, Model, RobotState, center_of_mass};
use centaur_gym::Rng;
use serde::Deserialize;

use crate::error::RobotEnvError;
use crate::sim::{ColliderSpec, Sim, SimConfig};

/// The parts of an `assets/mujoco/*.mujoco.json` sidecar the environments read.
#[derive(Debug, Clone, Deserialize)]
pub struct Sidecar {
    /// MuJoCo physics time step (s).
    pub timestep: f64,
    /// Total mass (kg).
    pub total_mass: f64,
    /// Gymnasium's initial `qpos`.
    pub init_qpos: Vec<f64>,
    /// Gymnasium's initial `qvel`.
    pub init_qvel: Vec<f64>,
    /// Joints in `qpos` order.
    pub joints: Vec<SidecarJoint>,
    /// Actuators in action order.
    pub actuators: Vec<SidecarActuator>,
    /// Robot geoms.
    pub geoms: Vec<SidecarGeom>,
    /// World geoms (the floor).
    pub world_geoms: Vec<SidecarGeom>,
    /// Bodies in MuJoCo id order (world excluded).
    pub bodies: Vec<SidecarBody>,
}

/// A MuJoCo joint.
#[derive(Debug, Clone, Deserialize)]
pub struct SidecarJoint {
    /// Name (also the URDF joint's, except the free root).
    pub name: String,
    /// `free`, `hinge` or `slide`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Reflected rotor inertia.
    pub armature: f64,
    /// Joint stiffness (spring).
    pub stiffness: f64,
    /// Spring rest position (a number; a free joint lists its whole `qpos`).
    pub springref: serde_json::Value,
}

impl SidecarJoint {
    /// The spring rest position of a hinge or slide joint.
    pub fn spring_rest(&self) -> f64 {
        self.springref.as_f64().unwrap_or(0.0)
    }
}

/// A MuJoCo motor actuator.
#[derive(Debug, Clone, Deserialize)]
pub struct SidecarActuator {
    /// Driven joint.
    pub joint: String,
    /// Gear (torque per unit control).
    pub gear: f64,
    /// Control range.
    pub ctrlrange: [f64; 2],
}

/// A MuJoCo geom.
#[derive(Debug, Clone, Deserialize)]
pub struct SidecarGeom {
    /// Link (MuJoCo body) it belongs to.
    pub link: String,
    /// Sliding, torsional, rolling friction.
    pub friction: [f64; 3],
}

/// A MuJoCo body.
#[derive(Debug, Clone, Deserialize)]
pub struct SidecarBody {
    /// Name (the URDF link's).
    pub name: String,
    /// MuJoCo body id.
    pub mujoco_id: usize,
    /// Mass (kg).
    pub mass: f64,
}

/// One Gymnasium MuJoCo robot, ready to simulate (crate-internal).
pub(crate) struct MjRobot {
    pub model: Model,
    pub sidecar: Sidecar,
    /// For each MuJoCo joint in `qpos` order: model joint index.
    joint_of: Vec<usize>,
    /// Model `v` index and gear of each actuator.
    pub actuators: Vec<(usize, f64)>,
    pub ctrl_low: Vec<f32>,
    pub ctrl_high: Vec<f32>,
    pub nq: usize,
    pub nv: usize,
    free: bool,
    /// Link frame index of each MuJoCo body (id 1..), for `cfrc_ext`.
    body_frames: Vec<usize>,
}

impl MjRobot {
    pub fn new(urdf: &str, sidecar: &str, name: &str, base: BaseKind) -> Result<MjRobot, RobotEnvError> {
        let missing = |what: &'static str, item: &str| RobotEnvError::Missing {
            robot: name.into(),
            what,
            name: item.into(),
        };
        let mut model = Model::from_urdf_str(urdf, &format!("assets/mujoco/{name}.urdf"), base)
            .map_err(|source| RobotEnvError::Urdf { robot: name.into(), source: Box::new(source) })?;
        let sidecar: Sidecar = serde_json::from_str(sidecar)
            .map_err(|source| RobotEnvError::Layout { robot: name.into(), source })?;
        let free = base == BaseKind::Floating;
        let mut joint_of = Vec::new();
        let (mut nq, mut nv) = (0, 0);
        for j in &sidecar.joints {
            if j.kind == "free" {
                joint_of.push(1);
                nq += 7;
                nv += 6;
            } else {
                let idx = model.joint_index(&j.name).ok_or_else(|| missing("joint", &j.name))?;
                let iv = model.joints[idx].idx_v;
                model.armature[iv] = j.armature;
                joint_of.push(idx);
                nq += 1;
                nv += 1;
            }
        }
        let mut actuators = Vec::new();
        let (mut ctrl_low, mut ctrl_high) = (Vec::new(), Vec::new());
        for a in &sidecar.actuators {
            let idx = model.joint_index(&a.joint).ok_or_else(|| missing("joint", &a.joint))?;
            actuators.push((model.joints[idx].idx_v, a.gear));
            ctrl_low.push(a.ctrlrange[0] as f32);
            ctrl_high.push(a.ctrlrange[1] as f32);
        }
        let mut body_frames = Vec::new();
        for b in &sidecar.bodies {
            body_frames.push(model.frame_index(&b.name).ok_or_else(|| missing("link", &b.name))?);
        }
        Ok(MjRobot { model, sidecar, joint_of, actuators, ctrl_low, ctrl_high, nq, nv, free, body_frames })
    }

    /// Number of MuJoCo bodies (world excluded).
    pub fn num_bodies(&self) -> usize {
        self.body_frames.len()
    }

    /// Builds the simulator: MuJoCo's time step, geoms' frictions, joint springs.
    pub fn build_sim(&self, config: &SimConfig) -> Result<Sim, RobotEnvError> {
        let floor = self.sidecar.world_geoms.first().map_or(1.0, |g| g.friction[0]);
        let mut friction: Vec<(String, f64)> = Vec::new();
        for g in &self.sidecar.geoms {
            match friction.iter_mut().find(|(l, _)| *l == g.link) {
                Some((_, f)) => *f = f.max(g.friction[0]),
                None => friction.push((g.link.clone(), g.friction[0])),
            }
        }
        let colliders =
            ColliderSpec { links: Vec::new(), friction, default_friction: floor, capsule_boxes: Vec::new() };
        let config = SimConfig { ground_friction: floor, ..config.clone() };
        let mut sim = Sim::new(&self.model, &config, &colliders, &[])
            .map_err(|source| RobotEnvError::Sim { robot: self.model.name.clone(), source })?;
        for (k, j) in self.sidecar.joints.iter().enumerate() {
            if j.kind != "free" && j.stiffness != 0.0 {
                sim.set_joint_spring(self.joint_of[k], j.stiffness, j.spring_rest());
            }
        }
        Ok(sim)
    }

    /// MuJoCo `qpos`, `qvel` of a state.
    pub fn to_mujoco(&self, s: &RobotState, qpos: &mut [f64], qvel: &mut [f64]) {
        let (mut p, mut v) = (0, 0);
        for (k, j) in self.sidecar.joints.iter().enumerate() {
            if j.kind == "free" {
                let q = &s.q;
                qpos[p..p + 7].copy_from_slice(&[q[0], q[1], q[2], q[6], q[3], q[4], q[5]]);
                let rot = UnitQuaternion::from_quaternion(Quaternion::new(q[6], q[3], q[4], q[5]));
                let lin = rot * Vector3::new(s.v[0], s.v[1], s.v[2]);
                qvel[v..v + 6].copy_from_slice(&[lin.x, lin.y, lin.z, s.v[3], s.v[4], s.v[5]]);
                p += 7;
                v += 6;
            } else {
                let mj = &self.model.joints[self.joint_of[k]];
                qpos[p] = s.q[mj.idx_q];
                qvel[v] = s.v[mj.idx_v];
                p += 1;
                v += 1;
            }
        }
    }

    /// The state of MuJoCo `qpos`, `qvel` (free-joint quaternion normalised, as MuJoCo does).
    pub fn state_from_mujoco(&self, qpos: &[f64], qvel: &[f64], s: &mut RobotState) {
        let (mut p, mut v) = (0, 0);
        for (k, j) in self.sidecar.joints.iter().enumerate() {
            if j.kind == "free" {
                let quat = UnitQuaternion::from_quaternion(Quaternion::new(
                    qpos[p + 3],
                    qpos[p + 4],
                    qpos[p + 5],
                    qpos[p + 6],
                ));
                let qq = quat.quaternion();
                s.q.as_mut_slice()[..7].copy_from_slice(&[
                    qpos[p],
                    qpos[p + 1],
                    qpos[p + 2],
                    qq.i,
                    qq.j,
                    qq.k,
                    qq.w,
                ]);
                let lin = quat.inverse_transform_vector(&Vector3::new(qvel[v], qvel[v + 1], qvel[v + 2]));
                s.v.as_mut_slice()[..6].copy_from_slice(&[
                    lin.x,
                    lin.y,
                    lin.z,
                    qvel[v + 3],
                    qvel[v + 4],
                    qvel[v + 5],
                ]);
                p += 7;
                v += 6;
            } else {
                let mj = &self.model.joints[self.joint_of[k]];
                s.q[mj.idx_q] = qpos[p];
                s.v[mj.idx_v] = qvel[v];
                p += 1;
                v += 1;
            }
        }
    }

    /// Gymnasium's reset: `qpos = init + U(−a, a)`, `qvel = init + noise` where the velocity
    /// noise is uniform `U(−b, b)` or, with `normal_velocity`, `b·N(0, 1)`.
    pub fn reset_state(
        &self,
        rng: &mut Rng,
        a: f64,
        b: f64,
        normal_velocity: bool,
        s: &mut RobotState,
        qpos: &mut [f64],
        qvel: &mut [f64],
    ) {
        for (k, x) in qpos.iter_mut().enumerate() {
            *x = self.sidecar.init_qpos[k] + rng.range(-a, a);
        }
        for (k, x) in qvel.iter_mut().enumerate() {
            let n = if normal_velocity { b * rng.normal() } else { rng.range(-b, b) };
            *x = self.sidecar.init_qvel[k] + n;
        }
        self.state_from_mujoco(qpos, qvel, s);
        if self.free {
            // Report the normalised quaternion back in qpos, as MuJoCo's state would.
            let q = &s.q;
            qpos[3..7].copy_from_slice(&[q[6], q[3], q[4], q[5]]);
        }
    }

    /// Per-body contact wrench from the ground, MuJoCo's `cfrc_ext` layout: for each body
    /// (id order), `[torque about the robot's centre of mass; force]`, world axes.
    pub fn contact_wrenches(&self, sim: &Sim, data: &mut Data, q: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|x| *x = 0.0);
        let com = center_of_mass(&self.model, data, q);
        for (k, g) in self.model.geometries.iter().enumerate() {
            let Some(c) = sim.geometry_collider(k) else { continue };
            let Some((f, p)) = sim.contact_force(c) else { continue };
            let Some(b) = self.body_frames.iter().position(|&fr| fr == g.frame) else { continue };
            let t = (p - com).cross(&f);
            let w = &mut out[6 * b..6 * b + 6];
            for i in 0..3 {
                w[i] += t[i];
                w[3 + i] += f[i];
            }
        }
    }

    /// Robot centre of mass.
    pub fn center_of_mass(&self, data: &mut Data, q: &[f64]) -> Vector3<f64> {
        center_of_mass(&self.model, data, q)
    }
}
