//! Deployment: a trained policy that maps observations to actions, deterministically.
//!
//! [`Policy`] holds only what acting needs — the actor network, the observation
//! normaliser's frozen statistics and the action bounds — and no training code. It is
//! written into every checkpoint (`policy` metadata and `policy/…` blobs) and read back
//! with [`Policy::load`]; [`Policy::act`] allocates nothing.
//!
//! The deterministic action is
//! * [`PolicyHead::GaussianMean`] (PPO, A2C): the Gaussian mean `μ(s)`, clipped to the bounds;
//! * [`PolicyHead::TanhRescaled`] (SAC, TD3, DDPG): `tanh y(s)` mapped from `[−1, 1]` to
//!   `[low, high]` by `low + (t + 1)(high − low)/2` (for SAC `y` is the mean of `u`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::checkpoint::{Checkpoint, CheckpointError};
use centaur_gym::{BoxSpace, Env};

use crate::error::RlError;
use crate::nn::{Activation, Mlp, MlpBuffers, tanh_fast};
use crate::normalizer::normalize_obs;

/// How the actor's output becomes an action.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PolicyHead {
    /// The first `act_dim` outputs are the Gaussian mean, clipped to the bounds.
    GaussianMean,
    /// `tanh` of the first `act_dim` outputs, rescaled to the bounds.
    TanhRescaled,
}

/// Maps `t ∈ [−1, 1]` to `[low, high]` (Stable-Baselines3's `unscale_action`).
#[inline]
pub fn rescale_action(t: f32, low: f32, high: f32) -> f32 {
    low + 0.5 * (t + 1.0) * (high - low)
}

/// Frozen observation-normalisation statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct ObsNorm {
    /// Means.
    pub mean: Vec<f64>,
    /// Variances.
    pub var: Vec<f64>,
    /// Clip of the normalised values.
    pub clip: f64,
}

#[derive(Serialize, Deserialize)]
struct PolicySpec {
    head: PolicyHead,
    actor_sizes: Vec<usize>,
    activation: Activation,
    obs_dim: usize,
    act_dim: usize,
    obs_norm_clip: Option<f64>,
}

/// A deterministic policy for deployment.
#[derive(Clone, Debug)]
pub struct Policy {
    head: PolicyHead,
    actor: Mlp,
    buf: MlpBuffers,
    obs_norm: Option<ObsNorm>,
    obs_dim: usize,
    act_dim: usize,
    low: Vec<f32>,
    high: Vec<f32>,
    scratch: Vec<f32>,
}

impl Policy {
    /// A policy from its parts. The actor has `obs_dim` inputs and at least `act_dim`
    /// outputs.
    #[track_caller]
    pub fn new(head: PolicyHead, actor: Mlp, obs_norm: Option<ObsNorm>, action_space: &BoxSpace) -> Policy {
        let act_dim = action_space.dim();
        assert!(
            actor.n_out() >= act_dim,
            "Policy: actor has {} outputs for {act_dim} actions",
            actor.n_out()
        );
        if let Some(n) = &obs_norm {
            assert!(
                n.mean.len() == actor.n_in(),
                "Policy: normaliser for {} inputs, actor has {}",
                n.mean.len(),
                actor.n_in()
            );
        }
        let obs_dim = actor.n_in();
        Policy {
            head,
            buf: actor.buffers(1),
            actor,
            obs_norm,
            obs_dim,
            act_dim,
            low: action_space.low.clone(),
            high: action_space.high.clone(),
            scratch: vec![0.0; obs_dim],
        }
    }

    /// Reads the policy part of a checkpoint file.
    pub fn load(path: &Path) -> Result<Policy, CheckpointError> {
        Policy::from_checkpoint(&Checkpoint::read(path)?)
    }

    /// The policy part of a checkpoint.
    pub fn from_checkpoint(c: &Checkpoint) -> Result<Policy, CheckpointError> {
        let spec: PolicySpec = c.get_meta("policy")?;
        let bad = |reason: String| CheckpointError::Metadata { path: c.path().to_path_buf(), reason };
        if spec.actor_sizes.len() < 2
            || spec.actor_sizes.iter().any(|&s| s == 0 || s > 1 << 20)
            || spec.actor_sizes[0] != spec.obs_dim
            || *spec.actor_sizes.last().expect("≥ 2") < spec.act_dim
            || spec.act_dim == 0
        {
            return Err(bad(format!(
                "policy actor sizes {:?} do not fit obs_dim {} / act_dim {}",
                spec.actor_sizes, spec.obs_dim, spec.act_dim
            )));
        }
        // The parameter count the sizes imply must match the stored weights before anything
        // is allocated from the (possibly corrupt) sizes.
        let n_params = spec.actor_sizes.windows(2).map(|w| w[0] * w[1] + w[1]).sum::<usize>();
        let stored = c.f32("policy/actor", None)?.len();
        if stored != n_params {
            return Err(bad(format!(
                "policy actor sizes {:?} need {n_params} weights, {stored} stored",
                spec.actor_sizes
            )));
        }
        let mut actor = Mlp::zeros(&spec.actor_sizes, spec.activation);
        c.read_f32_into("policy/actor", &mut actor.params)?;
        let obs_norm = match spec.obs_norm_clip {
            Some(clip) => Some(ObsNorm {
                mean: c.f64("policy/obs_mean", Some(spec.obs_dim))?.to_vec(),
                var: c.f64("policy/obs_var", Some(spec.obs_dim))?.to_vec(),
                clip,
            }),
            None => None,
        };
        let low = c.f32("policy/action_low", Some(spec.act_dim))?.to_vec();
        let high = c.f32("policy/action_high", Some(spec.act_dim))?.to_vec();
        if spec.head == PolicyHead::TanhRescaled && low.iter().chain(&high).any(|b| !b.is_finite()) {
            return Err(bad("tanh policy with unbounded action space".into()));
        }
        Ok(Policy::new(spec.head, actor, obs_norm, &BoxSpace::new(low, high)))
    }

    /// Writes the policy part into a checkpoint.
    pub fn write_to(&self, c: &mut Checkpoint) {
        c.set_meta(
            "policy",
            PolicySpec {
                head: self.head,
                actor_sizes: self.actor.sizes().to_vec(),
                activation: self.actor.activation(),
                obs_dim: self.obs_dim,
                act_dim: self.act_dim,
                obs_norm_clip: self.obs_norm.as_ref().map(|n| n.clip),
            },
        );
        c.put_f32("policy/actor", &self.actor.params);
        if let Some(n) = &self.obs_norm {
            c.put_f64("policy/obs_mean", &n.mean);
            c.put_f64("policy/obs_var", &n.var);
        }
        c.put_f32("policy/action_low", &self.low);
        c.put_f32("policy/action_high", &self.high);
    }

    /// Observation dimension.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Action dimension.
    pub fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// The action head.
    pub fn head(&self) -> PolicyHead {
        self.head
    }

    /// The deterministic action for `obs`, written to `out`.
    #[track_caller]
    pub fn act(&mut self, obs: &[f32], out: &mut [f32]) {
        assert!(
            obs.len() == self.obs_dim,
            "Policy::act: obs has {} entries, expected {}",
            obs.len(),
            self.obs_dim
        );
        assert!(
            out.len() == self.act_dim,
            "Policy::act: out has {} entries, expected {}",
            out.len(),
            self.act_dim
        );
        let input: &[f32] = match &self.obs_norm {
            Some(n) => {
                normalize_obs(&n.mean, &n.var, n.clip, obs, &mut self.scratch);
                &self.scratch
            }
            None => obs,
        };
        let y = self.actor.forward(&mut self.buf, input, 1);
        for i in 0..self.act_dim {
            out[i] = match self.head {
                PolicyHead::GaussianMean => y[i].clamp(self.low[i], self.high[i]),
                PolicyHead::TanhRescaled => rescale_action(tanh_fast(y[i]), self.low[i], self.high[i]),
            };
        }
    }
}

/// Returns of deterministic evaluation episodes.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalStats {
    /// Undiscounted return of each episode.
    pub returns: Vec<f64>,
    /// Length of each episode.
    pub lengths: Vec<usize>,
    /// Mean return.
    pub mean: f64,
    /// Standard deviation of the returns.
    pub std: f64,
}

impl EvalStats {
    /// Mean episode length (0 without an episode).
    pub fn length_mean(&self) -> f64 {
        self.lengths.iter().sum::<usize>() as f64 / self.lengths.len().max(1) as f64
    }
}

/// Runs `episodes` episodes with the deterministic policy; episode `k` starts with
/// `reset(seed + k)`.
pub fn evaluate(
    policy: &mut Policy,
    env: &mut dyn Env,
    episodes: usize,
    seed: u64,
) -> Result<EvalStats, RlError> {
    let mut obs = vec![0.0; env.observation_space().dim()];
    let mut act = vec![0.0; env.action_space().dim()];
    if obs.len() != policy.obs_dim() || act.len() != policy.act_dim() {
        return Err(RlError::PolicyMismatch {
            policy: (policy.obs_dim(), policy.act_dim()),
            env: (obs.len(), act.len()),
        });
    }
    let (mut returns, mut lengths) = (Vec::with_capacity(episodes), Vec::with_capacity(episodes));
    for k in 0..episodes {
        env.reset(Some(seed.wrapping_add(k as u64)), &mut obs)?;
        let (mut ret, mut len) = (0.0, 0);
        loop {
            policy.act(&obs, &mut act);
            let s = env.step(&act, &mut obs)?;
            ret += s.reward;
            len += 1;
            if s.done() {
                break;
            }
        }
        returns.push(ret);
        lengths.push(len);
    }
    let n = episodes.max(1) as f64;
    let mean = returns.iter().sum::<f64>() / n;
    let std = (returns.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
    Ok(EvalStats { returns, lengths, mean, std })
}
