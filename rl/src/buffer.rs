//! Experience storage and return estimation.
//!
//! * [`gae`]: generalised advantage estimation (Schulman et al. 2016, eq. 16),
//!   `Â_t = Σ_l (γλ)^l δ_{t+l}` with `δ_t = r_t + γ V(s_{t+1}) − V(s_t)`, computed backwards
//!   as `Â_t = δ_t + γλ Â_{t+1}`, and returns `R_t = Â_t + V(s_t)`.
//! * [`n_step_returns`]: `R_t = r_t + γ R_{t+1}`, bootstrapped with `V(s_T)` at the rollout
//!   end (A2C, Mnih et al. 2016, Algorithm S3).
//!
//! Both cut the recursion where an episode ends. A **terminated** step bootstraps with 0. A
//! **truncated** step bootstraps with the value of the *final* observation
//! `V(s_final)` — not with `V(s_{t+1})`, which belongs to the next episode after auto-reset
//! (Pardo et al. 2018, "Time limits in reinforcement learning").
//!
//! Data are laid out time-major: entry `t·n + i` is step `t` of environment `i`.
//!
//! [`RolloutBuffer`] holds an on-policy rollout; [`ReplayBuffer`] is the circular buffer
//! of the off-policy algorithms.

use centaur_gym::Rng;

/// How step `t` of an environment ended, for the return recursions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepEnd {
    /// The episode goes on: bootstrap from the next step.
    Continues,
    /// Terminal state: bootstrap with 0.
    Terminated,
    /// Time limit: bootstrap with the final observation's value.
    Truncated,
}

impl StepEnd {
    /// From Gymnasium's two flags (termination wins).
    pub fn from_flags(terminated: bool, truncated: bool) -> StepEnd {
        if terminated {
            StepEnd::Terminated
        } else if truncated {
            StepEnd::Truncated
        } else {
            StepEnd::Continues
        }
    }
}

/// GAE(λ) over a time-major rollout of `T = rewards.len() / n` steps of `n` environments.
///
/// * `values[t·n+i] = V(s_t)`, `final_values[t·n+i] = V(s_final)` (read where step `t`
///   was truncated), `last_values[i] = V(s_T)` (the observation after the rollout);
/// * writes `advantages` and `returns = advantages + values`.
#[track_caller]
pub fn gae(
    rewards: &[f32],
    values: &[f32],
    ends: &[StepEnd],
    final_values: &[f32],
    last_values: &[f32],
    gamma: f32,
    lambda: f32,
    advantages: &mut [f32],
    returns: &mut [f32],
) {
    let n = last_values.len();
    let len = rewards.len();
    assert!(n > 0 && len.is_multiple_of(n), "gae: {len} rewards for {n} environments");
    for (name, l) in [
        ("values", values.len()),
        ("ends", ends.len()),
        ("final_values", final_values.len()),
        ("advantages", advantages.len()),
        ("returns", returns.len()),
    ] {
        assert!(l == len, "gae: {name} has {l} entries, rewards {len}");
    }
    let steps = len / n;
    for i in 0..n {
        let mut next_adv = 0.0f32;
        for t in (0..steps).rev() {
            let k = t * n + i;
            let (next_value, carry) = match ends[k] {
                StepEnd::Terminated => (0.0, 0.0),
                StepEnd::Truncated => (final_values[k], 0.0),
                StepEnd::Continues => {
                    let v = if t + 1 == steps { last_values[i] } else { values[k + n] };
                    (v, if t + 1 == steps { 0.0 } else { next_adv })
                }
            };
            let delta = rewards[k] + gamma * next_value - values[k];
            let adv = delta + gamma * lambda * carry;
            advantages[k] = adv;
            returns[k] = adv + values[k];
            next_adv = adv;
        }
    }
}

/// n-step discounted returns `R_t = r_t + γ R_{t+1}` over a time-major rollout, with
/// `R_T = V(s_T)` (`last_values`), 0 after a terminated step and `V(s_final)` after a
/// truncated one. Equal to [`gae`] with λ = 1 plus the values.
#[track_caller]
pub fn n_step_returns(
    rewards: &[f32],
    ends: &[StepEnd],
    final_values: &[f32],
    last_values: &[f32],
    gamma: f32,
    returns: &mut [f32],
) {
    let n = last_values.len();
    let len = rewards.len();
    assert!(n > 0 && len.is_multiple_of(n), "n_step_returns: {len} rewards for {n} environments");
    assert!(
        ends.len() == len && final_values.len() == len && returns.len() == len,
        "n_step_returns: ends {}, final_values {}, returns {} entries for {len} rewards",
        ends.len(),
        final_values.len(),
        returns.len()
    );
    let steps = len / n;
    for i in 0..n {
        let mut next = last_values[i];
        for t in (0..steps).rev() {
            let k = t * n + i;
            let boot = match ends[k] {
                StepEnd::Terminated => 0.0,
                StepEnd::Truncated => final_values[k],
                StepEnd::Continues => next,
            };
            returns[k] = rewards[k] + gamma * boot;
            next = returns[k];
        }
    }
}

/// An on-policy rollout of `steps × n_envs` transitions, time-major.
#[derive(Clone, Debug)]
pub struct RolloutBuffer {
    /// Steps per environment `T`.
    pub steps: usize,
    /// Number of environments `n`.
    pub n_envs: usize,
    /// Observation dimension.
    pub obs_dim: usize,
    /// Action dimension.
    pub act_dim: usize,
    /// Observations as the policy saw them (normalised if enabled), `T n × obs_dim`.
    pub obs: Vec<f32>,
    /// Sampled (unclipped) actions, `T n × act_dim`.
    pub actions: Vec<f32>,
    /// `log π(a_t | s_t)` at collection.
    pub log_probs: Vec<f32>,
    /// Rewards (scaled if enabled).
    pub rewards: Vec<f32>,
    /// `V(s_t)` at collection.
    pub values: Vec<f32>,
    /// How each step ended.
    pub ends: Vec<StepEnd>,
    /// `V(s_final)` for truncated steps (0 elsewhere).
    pub final_values: Vec<f32>,
    /// Advantages (filled by [`gae`]).
    pub advantages: Vec<f32>,
    /// Value targets (filled by [`gae`] or [`n_step_returns`]).
    pub returns: Vec<f32>,
}

impl RolloutBuffer {
    /// The mean of the critic's values `V(s_t)` over the rollout (the logged `value_mean`,
    /// in the learner's reward units: scaled when rewards are normalised).
    pub fn mean_value(&self) -> f64 {
        self.values.iter().map(|&v| f64::from(v)).sum::<f64>() / self.values.len().max(1) as f64
    }

    /// A buffer for `steps` steps of `n_envs` environments.
    pub fn new(steps: usize, n_envs: usize, obs_dim: usize, act_dim: usize) -> RolloutBuffer {
        let len = steps * n_envs;
        RolloutBuffer {
            steps,
            n_envs,
            obs_dim,
            act_dim,
            obs: vec![0.0; len * obs_dim],
            actions: vec![0.0; len * act_dim],
            log_probs: vec![0.0; len],
            rewards: vec![0.0; len],
            values: vec![0.0; len],
            ends: vec![StepEnd::Continues; len],
            final_values: vec![0.0; len],
            advantages: vec![0.0; len],
            returns: vec![0.0; len],
        }
    }

    /// Number of transitions `T n`.
    pub fn len(&self) -> usize {
        self.steps * self.n_envs
    }

    /// Whether the buffer holds no transitions.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A sampled minibatch of transitions, in buffers reused across samples.
#[derive(Clone, Debug)]
pub struct ReplayBatch {
    /// `B × obs_dim`.
    pub obs: Vec<f32>,
    /// `B × act_dim`.
    pub actions: Vec<f32>,
    /// `B`.
    pub rewards: Vec<f32>,
    /// `B × obs_dim`: the observation after the action (the final one at an episode end).
    pub next_obs: Vec<f32>,
    /// `B`: 1 where the transition terminated (no bootstrap), else 0.
    pub terminated: Vec<f32>,
}

impl ReplayBatch {
    /// Buffers for `batch` transitions.
    pub fn new(batch: usize, obs_dim: usize, act_dim: usize) -> ReplayBatch {
        ReplayBatch {
            obs: vec![0.0; batch * obs_dim],
            actions: vec![0.0; batch * act_dim],
            rewards: vec![0.0; batch],
            next_obs: vec![0.0; batch * obs_dim],
            terminated: vec![0.0; batch],
        }
    }

    /// Batch size.
    pub fn len(&self) -> usize {
        self.rewards.len()
    }

    /// Whether the batch is empty.
    pub fn is_empty(&self) -> bool {
        self.rewards.is_empty()
    }
}

/// A circular replay buffer of `capacity` transitions `(s, a, r, s', terminated, truncated)`.
///
/// `s'` is stored explicitly (not as the next slot's `s`) so that a truncated transition
/// keeps its final observation; only `terminated` stops bootstrapping. The storage is
/// zero-initialised at construction (the OS maps those pages lazily) and never grows.
#[derive(Clone, Debug)]
pub struct ReplayBuffer {
    capacity: usize,
    obs_dim: usize,
    act_dim: usize,
    obs: Vec<f32>,
    actions: Vec<f32>,
    rewards: Vec<f32>,
    next_obs: Vec<f32>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    /// Next slot to write.
    pos: usize,
    /// Number of stored transitions (≤ capacity).
    len: usize,
}

impl ReplayBuffer {
    /// An empty buffer.
    #[track_caller]
    pub fn new(capacity: usize, obs_dim: usize, act_dim: usize) -> ReplayBuffer {
        assert!(capacity > 0, "ReplayBuffer capacity must be positive");
        ReplayBuffer {
            capacity,
            obs_dim,
            act_dim,
            obs: vec![0.0; capacity * obs_dim],
            actions: vec![0.0; capacity * act_dim],
            rewards: vec![0.0; capacity],
            next_obs: vec![0.0; capacity * obs_dim],
            terminated: vec![false; capacity],
            truncated: vec![false; capacity],
            pos: 0,
            len: 0,
        }
    }

    /// Stored transitions.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is stored.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Capacity.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Appends a transition, overwriting the oldest once full.
    #[track_caller]
    pub fn push(
        &mut self,
        obs: &[f32],
        action: &[f32],
        reward: f32,
        next_obs: &[f32],
        terminated: bool,
        truncated: bool,
    ) {
        let (od, ad, p) = (self.obs_dim, self.act_dim, self.pos);
        assert!(
            obs.len() == od && next_obs.len() == od && action.len() == ad,
            "ReplayBuffer::push: obs {} / next_obs {} (expected {od}), action {} (expected {ad})",
            obs.len(),
            next_obs.len(),
            action.len()
        );
        self.obs[p * od..(p + 1) * od].copy_from_slice(obs);
        self.next_obs[p * od..(p + 1) * od].copy_from_slice(next_obs);
        self.actions[p * ad..(p + 1) * ad].copy_from_slice(action);
        self.rewards[p] = reward;
        self.terminated[p] = terminated;
        self.truncated[p] = truncated;
        self.pos = (p + 1) % self.capacity;
        self.len = (self.len + 1).min(self.capacity);
    }

    /// Whether transition `k` (0 = oldest) was truncated.
    pub fn truncated(&self, k: usize) -> bool {
        self.truncated[self.slot(k)]
    }

    /// Whether transition `k` (0 = oldest) terminated.
    pub fn terminated(&self, k: usize) -> bool {
        self.terminated[self.slot(k)]
    }

    fn slot(&self, k: usize) -> usize {
        (self.pos + self.capacity - self.len + k) % self.capacity
    }

    /// Fills `out` with `out.len()` transitions drawn uniformly with replacement.
    #[track_caller]
    pub fn sample(&self, rng: &mut Rng, out: &mut ReplayBatch) {
        assert!(self.len > 0, "ReplayBuffer::sample on an empty buffer");
        let (od, ad) = (self.obs_dim, self.act_dim);
        for b in 0..out.len() {
            let k = rng.below(self.len);
            out.obs[b * od..(b + 1) * od].copy_from_slice(&self.obs[k * od..(k + 1) * od]);
            out.next_obs[b * od..(b + 1) * od].copy_from_slice(&self.next_obs[k * od..(k + 1) * od]);
            out.actions[b * ad..(b + 1) * ad].copy_from_slice(&self.actions[k * ad..(k + 1) * ad]);
            out.rewards[b] = self.rewards[k];
            out.terminated[b] = if self.terminated[k] { 1.0 } else { 0.0 };
        }
    }

    /// The raw storage (for checkpoints): `(obs, actions, rewards, next_obs)` of the
    /// first `len` slots, flags, write position.
    pub fn raw(&self) -> ReplayRaw<'_> {
        let n = self.len;
        ReplayRaw {
            obs: &self.obs[..n * self.obs_dim],
            actions: &self.actions[..n * self.act_dim],
            rewards: &self.rewards[..n],
            next_obs: &self.next_obs[..n * self.obs_dim],
            terminated: &self.terminated[..n],
            truncated: &self.truncated[..n],
            pos: self.pos,
        }
    }

    /// Refills from [`ReplayBuffer::raw`] data; `false` if sizes are inconsistent.
    pub fn restore(&mut self, raw: &ReplayRaw<'_>) -> bool {
        let n = raw.rewards.len();
        if n > self.capacity
            || raw.obs.len() != n * self.obs_dim
            || raw.next_obs.len() != n * self.obs_dim
            || raw.actions.len() != n * self.act_dim
            || raw.terminated.len() != n
            || raw.truncated.len() != n
            || raw.pos >= self.capacity
            || (n < self.capacity && raw.pos != n)
        {
            return false;
        }
        self.obs[..raw.obs.len()].copy_from_slice(raw.obs);
        self.next_obs[..raw.next_obs.len()].copy_from_slice(raw.next_obs);
        self.actions[..raw.actions.len()].copy_from_slice(raw.actions);
        self.rewards[..n].copy_from_slice(raw.rewards);
        self.terminated[..n].copy_from_slice(raw.terminated);
        self.truncated[..n].copy_from_slice(raw.truncated);
        self.len = n;
        self.pos = raw.pos;
        true
    }
}

/// Borrowed contents of a [`ReplayBuffer`] (slots `0..len`, in storage order).
#[derive(Clone, Copy, Debug)]
pub struct ReplayRaw<'a> {
    /// Observations.
    pub obs: &'a [f32],
    /// Actions.
    pub actions: &'a [f32],
    /// Rewards.
    pub rewards: &'a [f32],
    /// Next observations.
    pub next_obs: &'a [f32],
    /// Terminated flags.
    pub terminated: &'a [bool],
    /// Truncated flags.
    pub truncated: &'a [bool],
    /// Next write position.
    pub pos: usize,
}

/// Writes `[obs_j; act_j]` for each of `batch` samples into `out` (`batch × (od + ad)`), the
/// input layout of Q networks.
#[track_caller]
pub fn concat_obs_act(obs: &[f32], act: &[f32], batch: usize, out: &mut [f32]) {
    assert!(
        batch > 0 && obs.len().is_multiple_of(batch) && act.len().is_multiple_of(batch),
        "concat_obs_act: {} obs and {} action values for batch {batch}",
        obs.len(),
        act.len()
    );
    let (od, ad) = (obs.len() / batch, act.len() / batch);
    assert!(
        out.len() >= batch * (od + ad),
        "concat_obs_act: output has {} entries, need {}",
        out.len(),
        batch * (od + ad)
    );
    for j in 0..batch {
        let o = &mut out[j * (od + ad)..(j + 1) * (od + ad)];
        o[..od].copy_from_slice(&obs[j * od..(j + 1) * od]);
        o[od..].copy_from_slice(&act[j * ad..(j + 1) * ad]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use StepEnd::*;

    #[test]
    fn gae_by_hand() {
        // One env, T = 3, γ = 0.9, λ = 0.5, rewards (1, 2, 3), V = (0.5, 1, 1.5), V(s_3) = 2.
        // δ_2 = 3 + 0.9·2 − 1.5 = 3.3;  Â_2 = 3.3
        // δ_1 = 2 + 0.9·1.5 − 1 = 2.35; Â_1 = 2.35 + 0.45·3.3 = 3.835
        // δ_0 = 1 + 0.9·1 − 0.5 = 1.4;  Â_0 = 1.4 + 0.45·3.835 = 3.12575
        let (mut adv, mut ret) = ([0.0; 3], [0.0; 3]);
        gae(
            &[1.0, 2.0, 3.0],
            &[0.5, 1.0, 1.5],
            &[Continues; 3],
            &[0.0; 3],
            &[2.0],
            0.9,
            0.5,
            &mut adv,
            &mut ret,
        );
        for (a, b) in adv.iter().zip([3.12575, 3.835, 3.3]) {
            assert!((a - b).abs() < 1e-5, "{adv:?}");
        }
        for (r, b) in ret.iter().zip([3.62575, 4.835, 4.8]) {
            assert!((r - b).abs() < 1e-5, "{ret:?}");
        }
    }

    #[test]
    fn gae_cuts_at_termination_and_bootstraps_truncation() {
        // Two envs, T = 2, γ = 0.9, λ = 0.5, time-major entries (t0e0, t0e1, t1e0, t1e1).
        // Env 0: step 0 terminated (r = 1, V = 0.5): Â = 1 − 0.5 = 0.5, no carry;
        //        step 1 continues (r = 2, V = 1, V(s_2) = 4): Â = 2 + 3.6 − 1 = 4.6.
        // Env 1: step 0 truncated (r = 1, V = 0.5, V(final) = 10): Â = 1 + 9 − 0.5 = 9.5,
        //        not carrying step 1's advantage; step 1 continues (r = 0, V = 2,
        //        V(s_2) = 2): Â = 0 + 1.8 − 2 = −0.2.
        let rewards = [1.0, 1.0, 2.0, 0.0];
        let values = [0.5, 0.5, 1.0, 2.0];
        let ends = [Terminated, Truncated, Continues, Continues];
        let finals = [99.0, 10.0, 99.0, 99.0]; // only read for the truncated step
        let (mut adv, mut ret) = ([0.0; 4], [0.0; 4]);
        gae(&rewards, &values, &ends, &finals, &[4.0, 2.0], 0.9, 0.5, &mut adv, &mut ret);
        for (a, b) in adv.iter().zip([0.5, 9.5, 4.6, -0.2]) {
            assert!((a - b).abs() < 1e-5, "{adv:?}");
        }
    }

    #[test]
    fn n_step_returns_by_hand() {
        // One env, T = 4, γ = 0.5, rewards (1, 1, 1, 1), step 1 truncated with V(final) = 8,
        // V(s_4) = 4:
        // R_3 = 1 + 0.5·4 = 3; R_2 = 1 + 0.5·3 = 2.5; R_1 = 1 + 0.5·8 = 5 (truncated);
        // R_0 = 1 + 0.5·5 = 3.5.
        let mut r = [0.0; 4];
        n_step_returns(
            &[1.0; 4],
            &[Continues, Truncated, Continues, Continues],
            &[0.0, 8.0, 0.0, 0.0],
            &[4.0],
            0.5,
            &mut r,
        );
        assert_eq!(r, [3.5, 5.0, 2.5, 3.0]);
        // Terminated at step 2:
        n_step_returns(
            &[1.0; 4],
            &[Continues, Continues, Terminated, Continues],
            &[0.0; 4],
            &[4.0],
            0.5,
            &mut r,
        );
        // R_3 = 3, R_2 = 1, R_1 = 1.5, R_0 = 1.75.
        assert_eq!(r, [1.75, 1.5, 1.0, 3.0]);
        // λ = 1 GAE plus values equals n-step returns.
        let (mut adv, mut ret) = ([0.0; 4], [0.0; 4]);
        let ends = [Continues, Truncated, Continues, Continues];
        gae(
            &[1.0; 4],
            &[0.3, -0.2, 0.7, 0.1],
            &ends,
            &[0.0, 8.0, 0.0, 0.0],
            &[4.0],
            0.5,
            1.0,
            &mut adv,
            &mut ret,
        );
        n_step_returns(&[1.0; 4], &ends, &[0.0, 8.0, 0.0, 0.0], &[4.0], 0.5, &mut r);
        for (a, b) in ret.iter().zip(r) {
            assert!((a - b).abs() < 1e-6);
        }
    }

    #[test]
    fn replay_buffer_wraps_and_keeps_flags() {
        let mut rb = ReplayBuffer::new(3, 1, 1);
        for k in 0..5 {
            let x = k as f32;
            rb.push(&[x], &[x], x, &[x + 0.5], k == 3, k == 4);
        }
        // Holds transitions 2, 3, 4 (oldest first).
        assert_eq!(rb.len(), 3);
        assert!(!rb.terminated(0) && rb.terminated(1) && rb.truncated(2) && !rb.terminated(2));
        let mut batch = ReplayBatch::new(64, 1, 1);
        rb.sample(&mut Rng::seed_from_u64(0), &mut batch);
        for b in 0..64 {
            let x = batch.obs[b];
            assert!([2.0, 3.0, 4.0].contains(&x));
            assert_eq!(batch.next_obs[b], x + 0.5);
            assert_eq!(batch.rewards[b], x);
            assert_eq!(batch.terminated[b], if x == 3.0 { 1.0 } else { 0.0 });
        }
        // Round trip through raw storage.
        let mut copy = ReplayBuffer::new(3, 1, 1);
        assert!(copy.restore(&rb.raw()));
        assert!(copy.truncated(2) && copy.terminated(1));
    }
}
