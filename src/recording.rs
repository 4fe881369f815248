//! MCAP recordings that open in Foxglove and show the gait.
//!
//! One message per control step on each topic, JSON-encoded with Foxglove's well-known
//! schemas (registered as JSON Schema, inlined because Foxglove does not follow `$ref`):
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/tf` | `foxglove.FrameTransforms` | world → every link frame |
//! | `/robot` | `foxglove.SceneUpdate` | every visual shape as a cube / cylinder / sphere primitive, in world coordinates |
//! | `/contacts` | `foxglove.SceneUpdate` | one arrow per foot in contact: the ground reaction force (1 cm per N / robot weight scale) |
//! | `/plan` | `foxglove.SceneUpdate` | the controller's planned centre-of-mass trajectory (line) and foot targets (spheres) |
//! | `/residual` | `centaur.Residual` | residual RMS, and the reference, residual and applied actions |
//! | `/metrics` | `centaur.Metrics` | reward, forward velocity, energy, base height; in controller and hybrid runs also the controller's command ([`CommandFrame`]: the commanded forward speed and yaw rate, the gait clock's rate and the stance fractions' shift, as a hybrid's policy steers them) |
//!
//! Link poses come from forward kinematics of the dynamics model on the recorded
//! [`RobotState`], so a robot's estimator output can be recorded the same way. Foxglove
//! places 3D objects by each message's own `timestamp`, which is the simulated time.
//! Files are written uncompressed (the pure-Rust build of `mcap` has no codecs).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use centaur_dynamics::nalgebra::{Rotation3, UnitQuaternion, Vector3};
use centaur_dynamics::{Data, GeometryRole, Model, RobotState, Se3, Shape, forward_kinematics};
use mcap::records::MessageHeader;
use serde_json::{Value, json};

/// A recording failure.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file could not be written.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("{path}: MCAP: {source}")]
    Mcap {
        /// File.
        path: PathBuf,
        /// Cause.
        source: mcap::McapError,
    },
}

/// The controller's command at a control step, as the hybrid's policy steers it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CommandFrame {
    /// Commanded forward speed (m/s): the target, before the controller's acceleration ramp.
    pub forward_speed: f64,
    /// Commanded yaw rate (rad/s).
    pub yaw_rate: f64,
    /// Rate of the gait clock (1: the gait's own period; see
    /// [`centaur_mpc::LocomotionController::gait_rate`]).
    pub gait_rate: f64,
    /// Shift of the stance fractions from the gait's own (see
    /// [`centaur_mpc::LocomotionController::gait_duty_shift`]).
    pub duty_shift: f64,
}

impl CommandFrame {
    /// The command `command` and the gait clock of `controller` now.
    pub fn of(
        command: &centaur_mpc::Command,
        controller: &centaur_mpc::LocomotionController,
    ) -> CommandFrame {
        CommandFrame {
            forward_speed: command.forward_velocity,
            yaw_rate: command.yaw_rate,
            gait_rate: controller.gait_rate(),
            duty_shift: controller.gait_duty_shift(),
        }
    }
}

/// What one control step shows.
#[derive(Clone, Copy, Debug, Default)]
pub struct Frame<'a> {
    /// Simulated time (s).
    pub time: f64,
    /// The robot's state.
    pub state: Option<&'a RobotState>,
    /// Foot contacts: (point on the ground, force in N), world frame.
    pub contacts: &'a [(Vector3<f64>, Vector3<f64>)],
    /// Planned centre-of-mass trajectory (world).
    pub planned_com: &'a [[f64; 3]],
    /// Foot targets (world).
    pub foot_targets: &'a [[f64; 3]],
    /// Reference action of the controller (hybrid and controller runs).
    pub reference: &'a [f32],
    /// Residual added by the policy, after scaling (hybrid runs).
    pub residual: &'a [f32],
    /// Action applied.
    pub applied: &'a [f32],
    /// Reward of the step.
    pub reward: f64,
    /// Forward velocity (m/s).
    pub forward_velocity: f64,
    /// Energy of the step (J).
    pub energy: f64,
    /// The controller's command (controller and hybrid runs; `None` for pure RL).
    pub command: Option<CommandFrame>,
}

/// A shape to draw, attached to a joint's body.
struct Primitive {
    joint: usize,
    placement: Se3,
    shape: Shape,
    color: [f64; 4],
}

/// Writes a Foxglove-ready MCAP file, one call to [`Recorder::record`] per control step.
///
/// The file is written under a temporary name beside `path` (`<path>.<pid>.tmp`) and renamed
/// to `path` by [`Recorder::finish`] once complete and `fsync`ed; a recorder dropped
/// unfinished (an error, a panic) removes its temporary file, so a run never leaves a
/// truncated recording behind.
pub struct Recorder {
    path: PathBuf,
    tmp: PathBuf,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    channels: [u16; 6],
    model: Model,
    data: Data,
    primitives: Vec<Primitive>,
    link_frames: Vec<usize>,
    force_scale: f64,
    seq: u32,
}

fn time_json(t: f64) -> Value {
    let t = t.max(0.0);
    let sec = t.floor();
    json!({"sec": sec as u64, "nsec": (((t - sec) * 1e9) as u64).min(999_999_999)})
}

fn vec3(v: &Vector3<f64>) -> Value {
    json!({"x": v.x, "y": v.y, "z": v.z})
}

fn quat(r: &centaur_dynamics::nalgebra::Matrix3<f64>) -> Value {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    json!({"x": q.i, "y": q.j, "z": q.k, "w": q.w})
}

fn pose(m: &Se3) -> Value {
    json!({"position": vec3(&m.translation), "orientation": quat(&m.rotation)})
}

fn color(c: [f64; 4]) -> Value {
    json!({"r": c[0], "g": c[1], "b": c[2], "a": c[3]})
}

/// JSON Schemas of Foxglove's message types (inlined: no `$ref`).
pub mod schemas {
    use serde_json::{Value, json};

    /// `time`.
    pub fn time() -> Value {
        json!({"type": "object", "properties": {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}}})
    }

    /// `duration`.
    pub fn duration() -> Value {
        json!({"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}}})
    }

    fn xyz(extra: &[&str]) -> Value {
        let mut props = serde_json::Map::new();
        for k in ["x", "y", "z"].iter().chain(extra) {
            props.insert((*k).into(), json!({"type": "number"}));
        }
        json!({"type": "object", "properties": props})
    }

    /// `foxglove.Vector3` / `Point3`.
    pub fn vector3() -> Value {
        xyz(&[])
    }

    /// `foxglove.Quaternion`.
    pub fn quaternion() -> Value {
        xyz(&["w"])
    }

    /// `foxglove.Pose`.
    pub fn pose() -> Value {
        json!({"type": "object", "properties": {"position": vector3(), "orientation": quaternion()}})
    }

    /// `foxglove.Color`.
    pub fn color() -> Value {
        json!({"type": "object", "properties": {"r": {"type": "number"}, "g": {"type": "number"}, "b": {"type": "number"}, "a": {"type": "number"}}})
    }

    /// `foxglove.FrameTransforms`.
    pub fn frame_transforms() -> Value {
        json!({
            "title": "foxglove.FrameTransforms",
            "type": "object",
            "properties": {"transforms": {"type": "array", "items": {
                "type": "object",
                "properties": {
                    "timestamp": time(),
                    "parent_frame_id": {"type": "string"},
                    "child_frame_id": {"type": "string"},
                    "translation": vector3(),
                    "rotation": quaternion()
                }
            }}}
        })
    }

    /// `foxglove.SceneUpdate` (cubes, spheres, cylinders, arrows and lines).
    pub fn scene_update() -> Value {
        let shape = |extra: Value| {
            let mut m = json!({"pose": pose(), "color": color()});
            if let (Some(m), Some(e)) = (m.as_object_mut(), extra.as_object()) {
                m.extend(e.clone());
            }
            json!({"type": "array", "items": {"type": "object", "properties": m}})
        };
        json!({
            "title": "foxglove.SceneUpdate",
            "type": "object",
            "properties": {
                "deletions": {"type": "array", "items": {"type": "object", "properties": {
                    "timestamp": time(), "type": {"type": "integer"}, "id": {"type": "string"}}}},
                "entities": {"type": "array", "items": {"type": "object", "properties": {
                    "timestamp": time(),
                    "frame_id": {"type": "string"},
                    "id": {"type": "string"},
                    "lifetime": duration(),
                    "frame_locked": {"type": "boolean"},
                    "metadata": {"type": "array", "items": {"type": "object", "properties": {"key": {"type": "string"}, "value": {"type": "string"}}}},
                    "cubes": shape(json!({"size": vector3()})),
                    "spheres": shape(json!({"size": vector3()})),
                    "cylinders": shape(json!({"size": vector3(), "bottom_scale": {"type": "number"}, "top_scale": {"type": "number"}})),
                    "arrows": shape(json!({"shaft_length": {"type": "number"}, "shaft_diameter": {"type": "number"}, "head_length": {"type": "number"}, "head_diameter": {"type": "number"}})),
                    "lines": shape(json!({"type": {"type": "integer"}, "thickness": {"type": "number"}, "scale_invariant": {"type": "boolean"}, "points": {"type": "array", "items": vector3()}, "colors": {"type": "array", "items": color()}, "indices": {"type": "array", "items": {"type": "integer"}}})),
                    "triangles": {"type": "array"},
                    "texts": {"type": "array"},
                    "models": {"type": "array"}
                }}}
            }
        })
    }

    /// `centaur.Residual`.
    pub fn residual() -> Value {
        let arr = json!({"type": "array", "items": {"type": "number"}});
        json!({"title": "centaur.Residual", "type": "object", "properties": {
            "timestamp": time(), "rms": {"type": "number"}, "reference": arr, "residual": arr, "applied": arr}})
    }

    /// `centaur.Metrics`.
    pub fn metrics() -> Value {
        json!({"title": "centaur.Metrics", "type": "object", "properties": {
            "timestamp": time(), "reward": {"type": "number"}, "forward_velocity": {"type": "number"},
            "energy": {"type": "number"}, "base_height": {"type": "number"},
            "commanded_speed": {"type": "number"}, "commanded_yaw_rate": {"type": "number"},
            "gait_rate": {"type": "number"}, "duty_shift": {"type": "number"}}})
    }
}

/// Topic names, in channel order.
pub const TOPICS: [&str; 6] = ["/tf", "/robot", "/contacts", "/plan", "/residual", "/metrics"];

impl Recorder {
    /// Creates the recording of `path` and registers the schemas and channels for `model`.
    pub fn create(path: &Path, model: &Model) -> Result<Recorder, RecordError> {
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(format!(".{}.tmp", std::process::id()));
        let tmp = PathBuf::from(tmp);
        let io = |source| RecordError::Io { path: path.to_path_buf(), source };
        let mc = |source| mcap_error(path, source);
        let file = BufWriter::new(File::create(&tmp).map_err(io)?);
        // From here on a failure drops `writer` and the file: remove it.
        let cleanup = |e: RecordError| {
            let _ = std::fs::remove_file(&tmp);
            e
        };
        let mut writer = mcap::WriteOptions::new()
            .compression(None)
            .profile("")
            .create(file)
            .map_err(mc)
            .map_err(cleanup)?;
        let schema = |w: &mut mcap::Writer<BufWriter<File>>, name: &str, s: Value| {
            w.add_schema(name, "jsonschema", s.to_string().as_bytes()).map_err(mc)
        };
        let registered = (|| {
            let tf = schema(&mut writer, "foxglove.FrameTransforms", schemas::frame_transforms())?;
            let scene = schema(&mut writer, "foxglove.SceneUpdate", schemas::scene_update())?;
            let residual = schema(&mut writer, "centaur.Residual", schemas::residual())?;
            let metrics = schema(&mut writer, "centaur.Metrics", schemas::metrics())?;
            let meta = BTreeMap::new();
            let mut channels = [0u16; 6];
            for (k, (topic, sid)) in
                TOPICS.iter().zip([tf, scene, scene, scene, residual, metrics]).enumerate()
            {
                channels[k] = writer.add_channel(sid, topic, "json", &meta).map_err(mc)?;
            }
            Ok(channels)
        })();
        let channels = match registered {
            Ok(c) => c,
            Err(e) => {
                drop(writer);
                return Err(cleanup(e));
            }
        };
        // Per link: its visual shapes, or its collision shapes when no visual is drawable
        // (meshes are not drawn).
        let drawable = |g: &&centaur_dynamics::Geometry| !matches!(g.shape, Shape::Mesh { .. });
        let mut primitives = Vec::new();
        for f in 0..model.frames.len() {
            let of = |role| model.geometries.iter().filter(move |g| g.frame == f && g.role == role);
            let visual: Vec<_> = of(GeometryRole::Visual).filter(drawable).collect();
            let shapes = if visual.is_empty() {
                of(GeometryRole::Collision).filter(drawable).collect()
            } else {
                visual
            };
            for g in shapes {
                primitives.push(Primitive {
                    joint: g.parent_joint,
                    placement: g.placement,
                    shape: g.shape.clone(),
                    color: g.rgba.unwrap_or([0.75, 0.6, 0.4, 1.0]),
                });
            }
        }
        let link_frames = (0..model.frames.len()).filter(|&f| model.frames[f].is_link).collect();
        let weight = model.total_mass() * model.gravity.norm();
        Ok(Recorder {
            path: path.to_path_buf(),
            tmp,
            writer: Some(writer),
            channels,
            data: Data::new(model),
            model: model.clone(),
            primitives,
            link_frames,
            // An arrow as long as the robot is tall (0.3 m) for its weight.
            force_scale: if weight > 0.0 { 0.3 / weight } else { 0.01 },
            seq: 0,
        })
    }

    fn write(&mut self, channel: usize, t: f64, msg: &Value) -> Result<(), RecordError> {
        let ns = (t.max(0.0) * 1e9) as u64;
        let header = MessageHeader {
            channel_id: self.channels[channel],
            sequence: self.seq,
            log_time: ns,
            publish_time: ns,
        };
        let writer = self.writer.as_mut().ok_or_else(|| finished(&self.path))?;
        writer
            .write_to_known_channel(&header, msg.to_string().as_bytes())
            .map_err(|e| mcap_error(&self.path, e))
    }

    /// Records one control step.
    pub fn record(&mut self, frame: &Frame<'_>) -> Result<(), RecordError> {
        let t = frame.time;
        let ts = time_json(t);
        if let Some(state) = frame.state {
            forward_kinematics(&self.model, &mut self.data, state.q.as_slice());
            let transforms: Vec<Value> = self
                .link_frames
                .iter()
                .map(|&f| {
                    let fr = &self.model.frames[f];
                    let m = self.data.o_m_i[fr.parent_joint].mul(&fr.placement);
                    json!({"timestamp": ts, "parent_frame_id": "world", "child_frame_id": fr.name,
                           "translation": vec3(&m.translation), "rotation": quat(&m.rotation)})
                })
                .collect();
            self.write(0, t, &json!({"transforms": transforms}))?;
            let (mut cubes, mut spheres, mut cylinders) = (Vec::new(), Vec::new(), Vec::new());
            for p in &self.primitives {
                let m = self.data.o_m_i[p.joint].mul(&p.placement);
                let c = color(p.color);
                match &p.shape {
                    Shape::Box { size } => cubes.push(json!({"pose": pose(&m), "size": vec3(size), "color": c})),
                    Shape::Sphere { radius } => {
                        let d = 2.0 * radius;
                        spheres.push(json!({"pose": pose(&m), "size": {"x": d, "y": d, "z": d}, "color": c}))
                    }
                    Shape::Cylinder { radius, length } => cylinders.push(json!({"pose": pose(&m),
                        "size": {"x": 2.0 * radius, "y": 2.0 * radius, "z": length}, "bottom_scale": 1.0, "top_scale": 1.0, "color": c})),
                    Shape::Capsule { radius, length } => {
                        let d = 2.0 * radius;
                        cylinders.push(json!({"pose": pose(&m), "size": {"x": d, "y": d, "z": length},
                            "bottom_scale": 1.0, "top_scale": 1.0, "color": c}));
                        for s in [-0.5, 0.5] {
                            let end = m.mul(&Se3::from_translation(Vector3::new(0.0, 0.0, s * length)));
                            spheres.push(json!({"pose": pose(&end), "size": {"x": d, "y": d, "z": d}, "color": c}));
                        }
                    }
                    Shape::Mesh { .. } => {}
                }
            }
            let entity = json!({"timestamp": ts, "frame_id": "world", "id": "robot", "lifetime": {"sec": 0, "nsec": 0},
                "frame_locked": false, "metadata": [], "cubes": cubes, "spheres": spheres, "cylinders": cylinders,
                "arrows": [], "lines": [], "triangles": [], "texts": [], "models": []});
            self.write(1, t, &json!({"deletions": [], "entities": [entity]}))?;
        }
        // Contact forces as arrows from the contact point along the force.
        let arrows: Vec<Value> = frame
            .contacts
            .iter()
            .filter(|(_, f)| f.norm() > 1e-6)
            .map(|(p, f)| {
                let len = f.norm() * self.force_scale;
                let dir = f.normalize();
                let rot = UnitQuaternion::rotation_between(&Vector3::x(), &dir).unwrap_or_else(UnitQuaternion::identity);
                let m = Se3::from_quaternion(&rot, *p);
                json!({"pose": pose(&m), "shaft_length": 0.8 * len, "shaft_diameter": 0.01, "head_length": 0.2 * len,
                       "head_diameter": 0.02, "color": color([0.9, 0.2, 0.2, 1.0])})
            })
            .collect();
        let entity = json!({"timestamp": ts, "frame_id": "world", "id": "contact_forces", "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": false, "metadata": [], "arrows": arrows, "cubes": [], "spheres": [], "cylinders": [], "lines": [],
            "triangles": [], "texts": [], "models": []});
        self.write(2, t, &json!({"deletions": [], "entities": [entity]}))?;
        // The controller's plan.
        let points: Vec<Value> =
            frame.planned_com.iter().map(|p| json!({"x": p[0], "y": p[1], "z": p[2]})).collect();
        let targets: Vec<Value> = frame
            .foot_targets
            .iter()
            .map(|p| json!({"pose": pose(&Se3::from_translation(Vector3::from(*p))), "size": {"x": 0.02, "y": 0.02, "z": 0.02},
                            "color": color([0.2, 0.5, 0.9, 1.0])}))
            .collect();
        let line = json!({"type": 0, "pose": pose(&Se3::identity()), "thickness": 3.0, "scale_invariant": true,
            "points": points, "color": color([0.1, 0.8, 0.3, 1.0]), "colors": [], "indices": []});
        let entity = json!({"timestamp": ts, "frame_id": "world", "id": "plan", "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": false, "metadata": [], "lines": [line], "spheres": targets, "cubes": [], "cylinders": [],
            "arrows": [], "triangles": [], "texts": [], "models": []});
        self.write(3, t, &json!({"deletions": [], "entities": [entity]}))?;
        let rms = if frame.residual.is_empty() {
            0.0
        } else {
            (frame.residual.iter().map(|r| (*r as f64).powi(2)).sum::<f64>() / frame.residual.len() as f64)
                .sqrt()
        };
        self.write(4, t, &json!({"timestamp": ts, "rms": rms, "reference": frame.reference, "residual": frame.residual, "applied": frame.applied}))?;
        let height = frame.state.map_or(0.0, |s| s.base_position().z);
        let mut metrics = json!({"timestamp": ts, "reward": frame.reward, "forward_velocity": frame.forward_velocity,
            "energy": frame.energy, "base_height": height});
        if let Some(c) = frame.command {
            metrics["commanded_speed"] = json!(c.forward_speed);
            metrics["commanded_yaw_rate"] = json!(c.yaw_rate);
            metrics["gait_rate"] = json!(c.gait_rate);
            metrics["duty_shift"] = json!(c.duty_shift);
        }
        self.write(5, t, &metrics)?;
        self.seq = self.seq.wrapping_add(1);
        Ok(())
    }

    /// Finishes the file (writes the summary section), `fsync`s it and renames it to its
    /// path: only a complete recording ever bears the name.
    pub fn finish(mut self) -> Result<mcap::Summary, RecordError> {
        let mut writer = self.writer.take().ok_or_else(|| finished(&self.path))?;
        let io = |source| RecordError::Io { path: self.path.clone(), source };
        let done = writer.finish().map_err(|e| mcap_error(&self.path, e)).and_then(|summary| {
            let file = writer.into_inner().into_inner().map_err(|e| io(e.into_error()))?;
            file.sync_all().map_err(io)?;
            std::fs::rename(&self.tmp, &self.path).map_err(io)?;
            Ok(summary)
        });
        if done.is_err() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        done
    }
}

impl Drop for Recorder {
    /// An unfinished recording (an error or a panic before [`Recorder::finish`]) is removed.
    fn drop(&mut self) {
        if let Some(writer) = self.writer.take() {
            drop(writer);
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// A writer error; an I/O failure keeps its own message ("No space left on device").
fn mcap_error(path: &Path, e: mcap::McapError) -> RecordError {
    match e {
        mcap::McapError::Io(source) => RecordError::Io { path: path.to_path_buf(), source },
        source => RecordError::Mcap { path: path.to_path_buf(), source },
    }
}

/// The error of a call after [`Recorder::finish`] (cannot happen: `finish` consumes it).
fn finished(path: &Path) -> RecordError {
    RecordError::Io { path: path.to_path_buf(), source: std::io::Error::other("recording already finished") }
}
