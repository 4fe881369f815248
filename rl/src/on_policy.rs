//! The rollout collection the on-policy learners ([`crate::Ppo`], [`crate::A2c`]) share:
//! `n_steps × n_envs` transitions with Gaussian exploration `a = μ(s) + σ ε`,
//! `ε ~ N(0, 𝟙)`, stored unclipped with their log-probabilities and values, stepped
//! clipped to the action bounds (a setting of both learners, on by default), with
//! running observation normalisation and reward scaling when enabled, and `V(s_final)` of
//! truncated episodes for bootstrapping (Gymnasium's truncation, or, with
//! `bootstrap_truncation` off, a truncation counted as a termination as in older codes).
//!
//! What differs between the learners — the networks (PPO may share a trunk) — comes in
//! through [`PolicyValue`]; everything else is here, once.

use centaur_gym::{BoxSpace, Rng, VecEnv, VecStep};

use crate::buffer::{RolloutBuffer, StepEnd};
use crate::distributions::gaussian_log_prob;
use crate::error::RlError;
use crate::metrics::EpisodeWindow;
use crate::normalizer::{RewardScaler, RunningMeanStd, normalize_obs};

/// The networks a rollout evaluates, for a batch of `n` (policy-input) observations.
pub(crate) trait PolicyValue {
    /// The Gaussian policy's mean `μ(s)` (`n × act_dim`).
    fn mean(&mut self, obs: &[f32], n: usize) -> &[f32];
    /// The value `V(s)` (`n`).
    fn value(&mut self, obs: &[f32], n: usize) -> &[f32];
}

/// The learner settings a rollout follows (fields of its config).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RolloutSettings {
    /// Steps per environment per rollout.
    pub n_steps: usize,
    /// Step the environments with actions clipped to the bounds.
    pub clip_actions: bool,
    /// Normalise observations with running statistics.
    pub norm_obs: bool,
    /// Clip of normalised observations.
    pub clip_obs: f64,
    /// Scale rewards by the running std of the discounted return.
    pub norm_reward: bool,
    /// Bootstrap truncated episodes from their final observation.
    pub bootstrap_truncation: bool,
}

/// The learner's state a rollout reads and updates.
pub(crate) struct LearnerState<'a> {
    /// `log σ` of the Gaussian policy.
    pub log_std: &'a [f32],
    /// The exploration generator.
    pub rng: &'a mut Rng,
    /// Observation statistics.
    pub obs_rms: &'a mut RunningMeanStd,
    /// Reward scaling.
    pub reward_scaler: &'a mut RewardScaler,
    /// Where the transitions go.
    pub rollout: &'a mut RolloutBuffer,
    /// Environment steps taken so far.
    pub steps_done: &'a mut u64,
}

/// The collector's per-step buffers, allocated once.
pub(crate) struct Collector {
    /// Policy input for the current step (`n × obs_dim`, normalised if enabled).
    obs: Vec<f32>,
    /// Sampled actions (`n × act_dim`) and their clipped version for the env.
    actions: Vec<f32>,
    env_actions: Vec<f32>,
    step: VecStep,
    rewards: Vec<f64>,
    /// Final observations of truncated environments, compacted, and their indices.
    final_obs: Vec<f32>,
    final_idx: Vec<usize>,
    /// `V(s)` of the observations after the last step (to bootstrap the rollout's end).
    pub last_values: Vec<f32>,
    /// Raw environment rewards summed since [`Collector::take_reward_mean`], and their count.
    reward_sum: f64,
    reward_steps: u64,
}

/// The policy input of raw observations: normalised with the running statistics if enabled.
fn policy_input(s: &RolloutSettings, obs_rms: &RunningMeanStd, raw: &[f32], out: &mut [f32]) {
    if s.norm_obs {
        normalize_obs(&obs_rms.mean, &obs_rms.var, s.clip_obs, raw, out);
    } else {
        out.copy_from_slice(raw);
    }
}

impl Collector {
    pub(crate) fn new(n_envs: usize, obs_dim: usize, act_dim: usize) -> Collector {
        Collector {
            obs: vec![0.0; n_envs * obs_dim],
            actions: vec![0.0; n_envs * act_dim],
            env_actions: vec![0.0; n_envs * act_dim],
            step: VecStep::new(n_envs, obs_dim),
            rewards: vec![0.0; n_envs],
            final_obs: vec![0.0; n_envs * obs_dim],
            final_idx: Vec::with_capacity(n_envs),
            last_values: vec![0.0; n_envs],
            reward_sum: 0.0,
            reward_steps: 0,
        }
    }

    /// Before a `learn`: continues a live `VecEnv` from its observations, or resets a fresh
    /// one with `seed` (its first observations update the statistics).
    pub(crate) fn start(
        &mut self,
        env: &mut VecEnv,
        s: &RolloutSettings,
        obs_rms: &mut RunningMeanStd,
        seed: u64,
    ) -> Result<(), RlError> {
        match env.observations() {
            Some(obs) => {
                let raw = obs.to_vec();
                policy_input(s, obs_rms, &raw, &mut self.obs);
            }
            None => {
                let mut raw = vec![0.0; self.obs.len()];
                env.reset(seed, &mut raw)?;
                if s.norm_obs {
                    obs_rms.update(&raw);
                }
                policy_input(s, obs_rms, &raw, &mut self.obs);
            }
        }
        Ok(())
    }

    /// The mean raw environment reward per step since the last call (NaN without a step).
    pub(crate) fn take_reward_mean(&mut self) -> f64 {
        let mean = if self.reward_steps == 0 { f64::NAN } else { self.reward_sum / self.reward_steps as f64 };
        (self.reward_sum, self.reward_steps) = (0.0, 0);
        mean
    }

    /// Collects one rollout of `n_steps × n_envs` transitions into `state.rollout`, and the
    /// values to bootstrap its end into [`Collector::last_values`].
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn collect(
        &mut self,
        nets: &mut impl PolicyValue,
        s: &RolloutSettings,
        state: LearnerState<'_>,
        obs_space: &BoxSpace,
        act_space: &BoxSpace,
        env: &mut VecEnv,
        episodes: &mut EpisodeWindow,
    ) -> Result<(), RlError> {
        let LearnerState { log_std, rng, obs_rms, reward_scaler, rollout, steps_done } = state;
        let (od, ad) = (obs_space.dim(), act_space.dim());
        let n = self.rewards.len();
        let w = &mut self.obs;
        for t in 0..s.n_steps {
            // π(·|s_t) and V(s_t) for all environments at once.
            let mean = nets.mean(w, n);
            for i in 0..n {
                let (a, m) = (&mut self.actions[i * ad..(i + 1) * ad], &mean[i * ad..(i + 1) * ad]);
                for j in 0..ad {
                    a[j] = m[j] + log_std[j].exp() * rng.normal() as f32;
                }
                rollout.log_probs[t * n + i] = gaussian_log_prob(a, m, log_std);
            }
            let values = nets.value(w, n);
            rollout.values[t * n..(t + 1) * n].copy_from_slice(values);
            rollout.obs[t * n * od..(t + 1) * n * od].copy_from_slice(w);
            rollout.actions[t * n * ad..(t + 1) * n * ad].copy_from_slice(&self.actions);

            // Step with the clipped action; the unclipped one stays in the buffer.
            self.env_actions.copy_from_slice(&self.actions);
            if s.clip_actions {
                for a in self.env_actions.chunks_exact_mut(ad) {
                    act_space.clip(a);
                }
            }
            env.step(&self.env_actions, &mut self.step)?;
            *steps_done += n as u64;
            for e in &self.step.episodes {
                episodes.push(e.ret, e.length);
            }

            // Observation statistics see every returned observation (auto-reset ones too).
            if s.norm_obs {
                obs_rms.update(&self.step.obs);
            }
            policy_input(s, obs_rms, &self.step.obs, w);

            let st = &self.step;
            if s.norm_reward {
                reward_scaler.scale(&st.rewards, |i| st.terminated[i] || st.truncated[i], &mut self.rewards);
            } else {
                self.rewards.copy_from_slice(&st.rewards);
            }
            self.final_idx.clear();
            self.reward_sum += st.rewards.iter().sum::<f64>();
            self.reward_steps += n as u64;
            for i in 0..n {
                let k = t * n + i;
                rollout.rewards[k] = self.rewards[i] as f32;
                let truncated = st.truncated[i] && !st.terminated[i];
                rollout.ends[k] = if truncated && !s.bootstrap_truncation {
                    StepEnd::Terminated
                } else {
                    StepEnd::from_flags(st.terminated[i], st.truncated[i])
                };
                rollout.final_values[k] = 0.0;
                if rollout.ends[k] == StepEnd::Truncated {
                    self.final_idx.push(i);
                }
            }
            // V(s_final) of truncated episodes, normalised with the current statistics.
            let m = self.final_idx.len();
            if m > 0 {
                for (slot, &i) in self.final_idx.iter().enumerate() {
                    let raw = &self.step.final_obs[i * od..(i + 1) * od];
                    let dst = &mut self.final_obs[slot * od..(slot + 1) * od];
                    policy_input(s, obs_rms, raw, dst);
                }
                let v = nets.value(&self.final_obs[..m * od], m);
                for (slot, &i) in self.final_idx.iter().enumerate() {
                    rollout.final_values[t * n + i] = v[slot];
                }
            }
        }
        let last = nets.value(w, n);
        self.last_values.copy_from_slice(last);
        Ok(())
    }
}
