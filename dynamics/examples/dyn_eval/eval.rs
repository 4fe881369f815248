//! The Pinocchio-convention evaluation behind `dyn_eval`, shared with the golden test.
//!
//! Input and output layouts are documented in `main.rs`; everything here converts between
//! the caller's joint order and the model's depth-first order.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use centaur_dynamics::{
    BaseKind, Data, Model, UrdfOptions, UrdfWarning, aba, center_of_mass, crba, forward_kinematics,
    frame_placement, nonlinear_effects, rnea,
};
use serde::{Deserialize, Serialize};

#[derive(Deserialize, Serialize, Clone, Debug)]
pub struct Input {
    pub urdf: String,
    pub floating_base: bool,
    pub joint_names: Vec<String>,
    #[serde(default)]
    pub frames: Vec<String>,
    pub cases: Vec<CaseIn>,
    /// Optional (default false): load continuous joints as (cos θ, sin θ) joints, as
    /// Pinocchio does. Inputs and outputs keep one angle per joint either way.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub continuous_as_cos_sin: bool,
    /// Optional (default false): keep bodies with non-physical inertia as given
    /// (`UrdfOptions::accept_nonphysical_inertia`), as Pinocchio does.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub accept_nonphysical_inertia: bool,
}

#[derive(Deserialize, Serialize, Clone, Debug)]
pub struct CaseIn {
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    pub a: Vec<f64>,
    pub tau: Vec<f64>,
}

#[derive(Deserialize, Serialize, Clone, Debug)]
pub struct Placement {
    pub translation: [f64; 3],
    pub rotation: [[f64; 3]; 3],
}

#[derive(Deserialize, Serialize, Clone, Debug)]
pub struct CaseOut {
    pub tau: Vec<f64>,
    pub nle: Vec<f64>,
    #[serde(rename = "M")]
    pub m: Vec<Vec<f64>>,
    /// `null` where forward dynamics is undefined (a singular mass matrix: ABA's result
    /// is not finite).
    pub ddq: Option<Vec<f64>>,
    pub com: [f64; 3],
    pub total_mass: f64,
    pub frames: BTreeMap<String, Placement>,
}

#[derive(Deserialize, Serialize, Clone, Debug)]
pub struct Output {
    pub cases: Vec<CaseOut>,
}

/// Finds the URDF: as given (relative to the working directory), else relative to `base_dir`.
pub fn resolve(urdf: &str, base_dir: &Path) -> PathBuf {
    let p = PathBuf::from(urdf);
    if p.is_absolute() || p.exists() { p } else { base_dir.join(p) }
}

/// Maps the caller's vectors to the model's layout and back.
struct Layout {
    /// For each caller joint: (model idx_q, model idx_v, whether q holds (cos θ, sin θ)).
    joints: Vec<(usize, usize, bool)>,
    base: usize,
}

impl Layout {
    fn new(model: &Model, input: &Input) -> Result<Layout, String> {
        let base = if input.floating_base { 1 } else { 0 };
        let movable: Vec<&str> = model.joints[1 + base..].iter().map(|j| j.name.as_str()).collect();
        if movable.len() != input.joint_names.len() {
            return Err(format!(
                "joint_names lists {} joints, the model has {} one-dof joints ({:?})",
                input.joint_names.len(),
                movable.len(),
                movable
            ));
        }
        let mut joints = Vec::new();
        for name in &input.joint_names {
            let idx =
                model.joint_index(name).ok_or_else(|| format!("no joint named '{name}' in the model"))?;
            let j = &model.joints[idx];
            if j.nv() != 1 {
                return Err(format!("joint '{name}' is not a one-dof joint"));
            }
            joints.push((j.idx_q, j.idx_v, j.nq() == 2));
        }
        Ok(Layout { joints, base })
    }

    fn q_in(&self, model: &Model, q: &[f64]) -> Result<Vec<f64>, String> {
        let nb = 7 * self.base;
        if q.len() != nb + self.joints.len() {
            return Err(format!("q has length {}, expected {}", q.len(), nb + self.joints.len()));
        }
        let mut out = vec![0.0; model.nq];
        out[..nb].copy_from_slice(&q[..nb]);
        for (k, &(iq, _, cos_sin)) in self.joints.iter().enumerate() {
            if cos_sin {
                let (s, c) = q[nb + k].sin_cos();
                (out[iq], out[iq + 1]) = (c, s);
            } else {
                out[iq] = q[nb + k];
            }
        }
        Ok(out)
    }

    fn v_in(&self, model: &Model, name: &str, v: &[f64]) -> Result<Vec<f64>, String> {
        let nb = 6 * self.base;
        if v.len() != nb + self.joints.len() {
            return Err(format!("{name} has length {}, expected {}", v.len(), nb + self.joints.len()));
        }
        let mut out = vec![0.0; model.nv];
        out[..nb].copy_from_slice(&v[..nb]);
        for (k, &(_, iv, _)) in self.joints.iter().enumerate() {
            out[iv] = v[nb + k];
        }
        Ok(out)
    }

    /// Caller order → model v index, for every entry of a v-sized vector.
    fn v_order(&self) -> Vec<usize> {
        let nb = 6 * self.base;
        (0..nb).chain(self.joints.iter().map(|&(_, iv, _)| iv)).collect()
    }
}

/// Evaluates every case; also returns what the loader reported about the URDF.
pub fn run(input: &Input, base_dir: &Path) -> Result<(Output, Vec<UrdfWarning>), String> {
    let path = resolve(&input.urdf, base_dir);
    let base = if input.floating_base { BaseKind::Floating } else { BaseKind::Fixed };
    let options = UrdfOptions {
        continuous_as_cos_sin: input.continuous_as_cos_sin,
        accept_nonphysical_inertia: input.accept_nonphysical_inertia,
        ..UrdfOptions::default()
    };
    let model = Model::from_urdf_file_with(&path, base, options).map_err(|e| e.to_string())?;
    let mut data = Data::new(&model);
    let layout = Layout::new(&model, input)?;
    let order = layout.v_order();
    let pick = |x: &[f64]| order.iter().map(|&i| x[i]).collect::<Vec<f64>>();
    let mut frame_ids = Vec::new();
    for name in &input.frames {
        let f = model.frame_index(name).ok_or_else(|| format!("no frame (link) named '{name}'"))?;
        frame_ids.push((name.clone(), f));
    }
    let mut cases = Vec::new();
    for (n, c) in input.cases.iter().enumerate() {
        let ctx = |e: String| format!("case {n}: {e}");
        let q = layout.q_in(&model, &c.q).map_err(ctx)?;
        let v = layout.v_in(&model, "v", &c.v).map_err(ctx)?;
        let a = layout.v_in(&model, "a", &c.a).map_err(ctx)?;
        let tau_in = layout.v_in(&model, "tau", &c.tau).map_err(ctx)?;
        let tau = pick(rnea(&model, &mut data, &q, &v, &a).as_slice());
        let nle = pick(nonlinear_effects(&model, &mut data, &q, &v).as_slice());
        let mm = crba(&model, &mut data, &q).clone();
        let m = order.iter().map(|&r| order.iter().map(|&c| mm[(r, c)]).collect()).collect();
        let ddq = pick(aba(&model, &mut data, &q, &v, &tau_in).as_slice());
        let ddq = ddq.iter().all(|x| x.is_finite()).then_some(ddq);
        let com = center_of_mass(&model, &mut data, &q);
        forward_kinematics(&model, &mut data, &q);
        let mut frames = BTreeMap::new();
        for (name, f) in &frame_ids {
            let p = frame_placement(&model, &data, *f);
            let r = p.rotation;
            frames.insert(
                name.clone(),
                Placement {
                    translation: [p.translation.x, p.translation.y, p.translation.z],
                    rotation: [
                        [r[(0, 0)], r[(0, 1)], r[(0, 2)]],
                        [r[(1, 0)], r[(1, 1)], r[(1, 2)]],
                        [r[(2, 0)], r[(2, 1)], r[(2, 2)]],
                    ],
                },
            );
        }
        cases.push(CaseOut {
            tau,
            nle,
            m,
            ddq,
            com: [com.x, com.y, com.z],
            total_mass: model.total_mass(),
            frames,
        });
    }
    Ok((Output { cases }, model.load_warnings))
}
