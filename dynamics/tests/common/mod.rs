//! Shared helpers for the dynamics tests: a seeded RNG, random states, the test models.
#![allow(dead_code)]

use centaur_dynamics::{BaseKind, JointKind, Model, UrdfOptions};
use nalgebra::DVector;

/// SplitMix64: small, seeded, good enough for test inputs.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A random configuration: joints uniform within finite limits (else [−π, π]), base at a
/// random position with a random unit quaternion.
pub fn random_q(model: &Model, rng: &mut Rng) -> DVector<f64> {
    let mut q = DVector::zeros(model.nq);
    for j in &model.joints[1..] {
        match j.kind {
            JointKind::FreeFlyer => {
                for k in 0..3 {
                    q[j.idx_q + k] = rng.range(-1.0, 1.0);
                }
                let mut quat = [rng.normal(), rng.normal(), rng.normal(), rng.normal()];
                let n = quat.iter().map(|x| x * x).sum::<f64>().sqrt();
                quat.iter_mut().for_each(|x| *x /= n);
                q.as_mut_slice()[j.idx_q + 3..j.idx_q + 7].copy_from_slice(&quat);
            }
            JointKind::Revolute { .. } | JointKind::Prismatic { .. } => {
                let (lo, hi) = (model.lower_position_limit[j.idx_q], model.upper_position_limit[j.idx_q]);
                q[j.idx_q] = if lo.is_finite() && hi.is_finite() {
                    rng.range(lo, hi)
                } else {
                    rng.range(-std::f64::consts::PI, std::f64::consts::PI)
                };
            }
            JointKind::RevoluteUnbounded { .. } => {
                let (s, c) = rng.range(-std::f64::consts::PI, std::f64::consts::PI).sin_cos();
                (q[j.idx_q], q[j.idx_q + 1]) = (c, s);
            }
            JointKind::Universe => {}
        }
    }
    q
}

pub fn random_v(model: &Model, rng: &mut Rng) -> DVector<f64> {
    DVector::from_fn(model.nv, |_, _| rng.normal())
}

pub fn asset(rel: &str) -> String {
    format!("{}/../assets/{rel}", env!("CARGO_MANIFEST_DIR"))
}

/// The models every identity is checked on: real published URDFs plus the MuJoCo
/// conversions (which add prismatic joints, planar roots and massless intermediate links).
pub fn test_models() -> Vec<Model> {
    let spec = [
        ("solo12/solo12.urdf", BaseKind::Floating),
        ("minitaur/minitaur.urdf", BaseKind::Floating),
        ("talos/talos_reduced.urdf", BaseKind::Floating),
        ("ur5/ur5_robot.urdf", BaseKind::Fixed),
        ("mujoco/humanoid.urdf", BaseKind::Floating),
        ("mujoco/walker2d.urdf", BaseKind::Fixed),
        ("mujoco/ant.urdf", BaseKind::Floating),
    ];
    let mut models: Vec<Model> = spec
        .iter()
        .map(|(p, b)| Model::from_urdf_file(asset(p), *b).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    models.push(minitaur_cos_sin());
    models
}

/// The Minitaur with its continuous joints parametrised by `(cos θ, sin θ)`, as Pinocchio
/// loads it (nq 31, nv 22).
pub fn minitaur_cos_sin() -> Model {
    let options = UrdfOptions { continuous_as_cos_sin: true, ..UrdfOptions::default() };
    Model::from_urdf_file_with(asset("minitaur/minitaur.urdf"), BaseKind::Floating, options)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// ‖a − b‖∞ / max(‖b‖∞, 1).
pub fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let num = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    let den = b.iter().map(|y| y.abs()).fold(1.0, f64::max);
    num / den
}
