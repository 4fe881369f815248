//! Soft Actor-Critic, version 1 (Haarnoja, Zhou, Abbeel & Levine 2018, "Soft Actor-Critic:
//! Off-Policy Maximum Entropy Deep Reinforcement Learning with a Stochastic Actor", ICML;
//! Algorithm 1): a state-value network `V_ψ` with a Polyak-averaged target `V_ψ̄`, two Q
//! networks (the minimum is used, section 4.2), a tanh-squashed Gaussian policy and a
//! **fixed** temperature α (the paper's reward scale is `1/α`; its default scale 5 gives
//! α = 0.2). Hyperparameters: the paper's Table 1 (Adam 3·10⁻⁴, batch 256, [256, 256] ReLU,
//! τ = 0.005, one gradient step per env step); the paper's small mean/log-std regulariser
//! on the policy outputs is not used.
//!
//! Per gradient step on a batch `(s, a, r, s', d)`, all losses from the same parameters:
//!
//! ```text
//! ã ~ π(·|s), log π(ã|s)                                           (reparameterised)
//! J(V)  = ½ mean[(V(s) − (min_i Q_i(s, ã) − α log π(ã|s)))²]      (eq. 5)
//! y     = r + γ (1 − d) V̄(s')                                      (eq. 8)
//! J(Q)  = ½ Σ_i mean[(Q_i(s, a) − y)²]                              (eq. 7)
//! J(π)  = mean[α log π(ã|s) − min_i Q_i(s, ã)]                      (eq. 12)
//! ψ̄    ← τ ψ + (1 − τ) ψ̄
//! ```
//!
//! Compare [`crate::sac`] (v2), which drops `V`, keeps target Q networks and learns α.
//!
//! The collection loop around the gradient step (warm-up, replay buffer, logging) is the one
//! all replay-buffer learners share, in `off_policy.rs`.

use std::ops::ControlFlow;

use serde::{Deserialize, Serialize};

use crate::algorithm::Algorithm;
use crate::buffer::{ReplayBatch, concat_obs_act};
use crate::checkpoint::Checkpoint;
use crate::distributions::squashed_gaussian_backward;
use crate::error::{RlError, check, check_critic_lr};
use crate::metrics::UpdateMetrics;
use crate::nn::{Activation, Init, Mlp, MlpBuffers, polyak};
use crate::off_policy::{self, Collector, LoopSettings, OffPolicyLearner};
use crate::optim::Adam;
use crate::policy::{Policy, PolicyHead};
use crate::sac::Sac;
pub use crate::sac::{LOG_STD_MAX, LOG_STD_MIN};
use centaur_gym::Rng;
use centaur_gym::{BoxSpace, VecEnv};

/// SAC v1 hyperparameters (defaults: Haarnoja et al. 2018a, Table 1; learning starts as
/// Stable-Baselines3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SacV1Config {
    /// Seed of initialisation, exploration, sampling and env resets (default: 0).
    pub seed: u64,
    /// Replay buffer capacity (transitions) (default: 1000000).
    pub buffer_size: usize,
    /// Environment steps of uniformly random actions before learning starts (default: 100).
    pub learning_starts: u64,
    /// During the first `learning_starts` steps, act with the policy's own exploration
    /// instead of uniformly random actions (default: false). A residual policy whose output
    /// starts at zero then fills the replay buffer with its controller's behaviour plus the
    /// exploration noise, as residual RL does (Johannink et al. 2019); uniform actions are
    /// Stable-Baselines3's warm-up.
    pub warmup_with_policy: bool,
    /// Minibatch size (default: 256).
    pub batch_size: usize,
    /// Learning rate of the actor (default: 3e-4).
    pub learning_rate: f64,
    /// The critics' (V and twin Q) learning rate; unset: `learning_rate` (default: unset).
    pub critic_learning_rate: Option<f64>,
    /// Adam ε (default: 1e-8).
    pub adam_eps: f64,
    /// Polyak coefficient τ (default: 0.005).
    pub tau: f64,
    /// Discount γ (default: 0.99).
    pub gamma: f64,
    /// Gradient steps after each vectorised environment step (default: 1).
    pub gradient_steps: usize,
    /// Update the target V network every this many gradient steps (default: 1).
    pub target_update_interval: u64,
    /// Temperature α, the inverse reward scale (default: 0.2).
    pub alpha: f64,
    /// Actor hidden layer sizes (default: [256, 256]).
    pub actor_hidden: Vec<usize>,
    /// Q and V hidden layer sizes (default: [256, 256]).
    pub critic_hidden: Vec<usize>,
    /// Hidden activation (default: "relu").
    pub activation: Activation,
    /// Environment steps between metrics records (default: 1000).
    pub log_interval: u64,
}

impl Default for SacV1Config {
    fn default() -> Self {
        SacV1Config {
            seed: 0,
            buffer_size: 1_000_000,
            learning_starts: 100,
            warmup_with_policy: false,
            batch_size: 256,
            learning_rate: 3e-4,
            critic_learning_rate: None,
            adam_eps: 1e-8,
            tau: 0.005,
            gamma: 0.99,
            gradient_steps: 1,
            target_update_interval: 1,
            alpha: 0.2,
            actor_hidden: vec![256, 256],
            critic_hidden: vec![256, 256],
            activation: Activation::Relu,
            log_interval: 1000,
        }
    }
}

impl SacV1Config {
    /// For the locomotion robots: learning starts after 5,000 steps of uniformly random
    /// actions instead of 100 (the other settings are the defaults).
    pub fn locomotion() -> Self {
        SacV1Config { learning_starts: 5000, ..SacV1Config::default() }
    }
}

impl SacV1Config {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), RlError> {
        const A: &str = "sac1";
        check(self.buffer_size > 0, A, "buffer_size", self.buffer_size, "must be positive")?;
        check(self.batch_size > 0, A, "batch_size", self.batch_size, "must be positive")?;
        check(
            self.learning_rate.is_finite() && self.learning_rate > 0.0,
            A,
            "learning_rate",
            self.learning_rate,
            "must be positive",
        )?;
        check_critic_lr(A, self.critic_learning_rate)?;
        check(
            self.adam_eps.is_finite() && self.adam_eps > 0.0,
            A,
            "adam_eps",
            self.adam_eps,
            "must be positive",
        )?;
        check(self.tau > 0.0 && self.tau <= 1.0, A, "tau", self.tau, "must be in (0, 1]")?;
        check((0.0..=1.0).contains(&self.gamma), A, "gamma", self.gamma, "must be in [0, 1]")?;
        check(self.gradient_steps > 0, A, "gradient_steps", self.gradient_steps, "must be positive")?;
        check(
            self.target_update_interval > 0,
            A,
            "target_update_interval",
            self.target_update_interval,
            "must be positive",
        )?;
        check(self.alpha.is_finite() && self.alpha >= 0.0, A, "alpha", self.alpha, "must be ≥ 0")?;
        check(
            !self.actor_hidden.is_empty() && self.actor_hidden.iter().all(|&h| h > 0),
            A,
            "actor_hidden",
            &self.actor_hidden,
            "needs at least one positive layer size",
        )?;
        check(
            !self.critic_hidden.is_empty() && self.critic_hidden.iter().all(|&h| h > 0),
            A,
            "critic_hidden",
            &self.critic_hidden,
            "needs at least one positive layer size",
        )?;
        check(self.log_interval > 0, A, "log_interval", self.log_interval, "must be positive")?;
        Ok(())
    }
}

/// Preallocated buffers.
struct Work {
    batch: ReplayBatch,
    eps: Vec<f32>,
    log_std: Vec<f32>,
    d_a: Vec<f32>,
    d_q2: Vec<f32>,
    pi_actions: Vec<f32>,
    pi_log_probs: Vec<f32>,
    q_in: Vec<f32>,
    q_next_in: Vec<f32>,
    target: Vec<f32>,
    d_q: Vec<f32>,
    d_q_in: Vec<f32>,
    d_q_in2: Vec<f32>,
    d_actor_out: Vec<f32>,
    actor_buf: MlpBuffers,
    q_buf: [MlpBuffers; 2],
    v_buf: MlpBuffers,
    v_target_buf: MlpBuffers,
}

/// Running sums of the losses between metrics records.
#[derive(Clone, Copy, Default)]
pub(crate) struct LossSums {
    n: u64,
    q_loss: f64,
    value_loss: f64,
    policy_loss: f64,
    entropy: f64,
    mean_q: f64,
    /// Mean V(s) over the batches (the logged `value_mean`).
    mean_v: f64,
}

/// A SAC (v1) learner; see the module documentation.
pub struct SacV1 {
    config: SacV1Config,
    collector: Collector,
    actor: Mlp,
    q: [Mlp; 2],
    v: Mlp,
    v_target: Mlp,
    opt_actor: Adam,
    opt_q: [Adam; 2],
    opt_v: Adam,
    rng: Rng,
    gradient_steps_done: u64,
    work: Work,
}

impl SacV1 {
    /// A new learner for the given spaces; `max_envs` sizes the per-step buffers (the
    /// number of environments of the VecEnvs it will train on).
    pub fn new(
        config: SacV1Config,
        obs_space: &BoxSpace,
        act_space: &BoxSpace,
        max_envs: usize,
    ) -> Result<SacV1, RlError> {
        config.validate()?;
        crate::error::check_sizes(
            "sac1",
            ("buffer_size", config.buffer_size, 1),
            2 * obs_space.dim() + act_space.dim() + 2,
            &[("actor_hidden", &config.actor_hidden), ("critic_hidden", &config.critic_hidden)],
            obs_space.dim(),
            act_space.dim(),
            config.batch_size.max(max_envs),
        )?;
        if !act_space.is_bounded() {
            return Err(RlError::Incompatible {
                algo: "sac1",
                reason: "needs a bounded action space".into(),
            });
        }
        let (od, ad, n, b) = (obs_space.dim(), act_space.dim(), max_envs.max(1), config.batch_size);
        let mut rng = Rng::derive(config.seed, 1);
        let actor_sizes = [&[od][..], &config.actor_hidden, &[2 * ad]].concat();
        let q_sizes = [&[od + ad][..], &config.critic_hidden, &[1]].concat();
        let actor = Mlp::new(&actor_sizes, config.activation, Init::TorchDefault, &mut rng);
        let q = [
            Mlp::new(&q_sizes, config.activation, Init::TorchDefault, &mut rng),
            Mlp::new(&q_sizes, config.activation, Init::TorchDefault, &mut rng),
        ];
        let v_sizes = [&[od][..], &config.critic_hidden, &[1]].concat();
        let v = Mlp::new(&v_sizes, config.activation, Init::TorchDefault, &mut rng);
        let eps = config.adam_eps as f32;
        let cap = b.max(n);
        let work = Work {
            batch: ReplayBatch::new(b, od, ad),
            eps: vec![0.0; cap * ad],
            log_std: vec![0.0; ad],
            d_a: vec![0.0; ad],
            d_q2: vec![0.0; b],
            pi_actions: vec![0.0; cap * ad],
            pi_log_probs: vec![0.0; cap],
            q_in: vec![0.0; b * (od + ad)],
            q_next_in: vec![0.0; b * (od + ad)],
            target: vec![0.0; b],
            d_q: vec![0.0; b],
            d_q_in: vec![0.0; b * (od + ad)],
            d_q_in2: vec![0.0; b * (od + ad)],
            d_actor_out: vec![0.0; b * 2 * ad],
            actor_buf: actor.buffers(cap),
            q_buf: [q[0].buffers(b), q[1].buffers(b)],
            v_buf: v.buffers(b),
            v_target_buf: v.buffers(b),
        };
        Ok(SacV1 {
            opt_actor: Adam::new(actor.n_params(), eps),
            opt_q: [Adam::new(q[0].n_params(), eps), Adam::new(q[1].n_params(), eps)],
            opt_v: Adam::new(v.n_params(), eps),
            v_target: v.clone(),
            v,
            collector: Collector::new(obs_space, act_space, n, config.buffer_size),
            actor,
            q,
            rng,
            gradient_steps_done: 0,
            work,
            config,
        })
    }

    /// A learner for `env`'s spaces.
    pub fn for_env(config: SacV1Config, env: &VecEnv) -> Result<SacV1, RlError> {
        SacV1::new(config, env.observation_space(), env.action_space(), env.len())
    }

    /// The configuration.
    pub fn config(&self) -> &SacV1Config {
        &self.config
    }

    /// The (fixed) temperature α.
    pub fn alpha(&self) -> f64 {
        self.config.alpha
    }

    /// Reads a learner saved by [`Algorithm::save`].
    pub fn load(path: &std::path::Path) -> Result<SacV1, RlError> {
        SacV1::from_checkpoint(&Checkpoint::read(path)?)
    }

    /// A learner from an in-memory checkpoint.
    pub fn from_checkpoint(c: &Checkpoint) -> Result<SacV1, RlError> {
        c.expect_algo("sac1")?;
        let config: SacV1Config = c.get_meta("config")?;
        let (obs_space, act_space, max_envs) = Collector::read_shape(c)?;
        let mut s = SacV1::new(config, &obs_space, &act_space, max_envs)?;
        c.read_mlp("actor", &mut s.actor)?;
        for i in 0..2 {
            c.read_mlp(&format!("q{i}"), &mut s.q[i])?;
            c.read_adam(&format!("adam/q{i}"), &mut s.opt_q[i])?;
        }
        c.read_mlp("v", &mut s.v)?;
        c.read_mlp("v_target", &mut s.v_target)?;
        c.read_adam("adam/v", &mut s.opt_v)?;
        c.read_adam("adam/actor", &mut s.opt_actor)?;
        s.collector.read_from(c)?;
        s.rng = c.read_rng("rng")?;
        s.gradient_steps_done = c.get_meta("gradient_steps_done")?;
        Ok(s)
    }

    /// Like [`Algorithm::to_checkpoint`], optionally without the replay buffer (smaller
    /// files; resuming then refills it from scratch).
    pub fn to_checkpoint_with(&self, save_replay: bool) -> Checkpoint {
        let mut c = Checkpoint::new("sac1");
        c.set_meta("config", &self.config);
        self.collector.write_to(&mut c, save_replay);
        c.set_meta("gradient_steps_done", self.gradient_steps_done);
        c.put_f32("actor", &self.actor.params);
        for i in 0..2 {
            c.put_f32(&format!("q{i}"), &self.q[i].params);
            c.put_adam(&format!("adam/q{i}"), &self.opt_q[i]);
        }
        c.put_f32("v", &self.v.params);
        c.put_f32("v_target", &self.v_target.params);
        c.put_adam("adam/v", &self.opt_v);
        c.put_adam("adam/actor", &self.opt_actor);
        c.put_rng("rng", &self.rng);
        self.policy().write_to(&mut c);
        c
    }
}

impl Algorithm for SacV1 {
    fn name(&self) -> &'static str {
        "sac1"
    }

    fn learn(
        &mut self,
        env: &mut VecEnv,
        total_steps: u64,
        callback: &mut dyn FnMut(&UpdateMetrics) -> ControlFlow<()>,
    ) -> Result<(), RlError> {
        off_policy::learn(self, "sac1", env, total_steps, callback)
    }

    fn to_checkpoint(&self) -> Checkpoint {
        self.to_checkpoint_with(true)
    }

    fn policy(&self) -> Policy {
        Policy::new(PolicyHead::TanhRescaled, self.actor.clone(), None, &self.collector.act_space)
    }

    fn zero_policy_output(&mut self) {
        self.actor.zero_output_rows(0..self.collector.act_space.dim());
    }

    fn set_warmup_with_policy(&mut self) -> Result<(), RlError> {
        self.config.warmup_with_policy = true;
        Ok(())
    }

    fn steps_done(&self) -> u64 {
        self.collector.steps_done
    }
}

impl OffPolicyLearner for SacV1 {
    type Sums = LossSums;

    fn settings(&self) -> LoopSettings {
        off_policy::loop_settings!(self.config)
    }

    fn parts(&mut self) -> (&mut Collector, &mut Rng) {
        (&mut self.collector, &mut self.rng)
    }

    /// `ã ~ π(·|s)`.
    fn explore(&mut self, n: usize) {
        let (c, w) = (&mut self.collector, &mut self.work);
        let od = c.obs_space.dim();
        Sac::sample_actions(
            &self.actor,
            &mut w.actor_buf,
            &c.obs[..n * od],
            n,
            &mut self.rng,
            &mut w.eps,
            &mut w.log_std,
            &mut c.actions,
            &mut w.pi_log_probs,
        );
    }

    /// One gradient step on a replay batch.
    fn train_step(&mut self, sums: &mut LossSums) -> Result<(), RlError> {
        let (od, ad, b) =
            (self.collector.obs_space.dim(), self.collector.act_space.dim(), self.config.batch_size);
        let (gamma, lr, lr_q, alpha) = (
            self.config.gamma as f32,
            self.config.learning_rate as f32,
            self.config.critic_learning_rate.unwrap_or(self.config.learning_rate) as f32,
            self.config.alpha as f32,
        );
        let w = &mut self.work;
        self.collector.replay.sample(&mut self.rng, &mut w.batch);

        // ã ~ π(·|s), and min_i Q_i(s, ã) with the current critics.
        Sac::sample_actions(
            &self.actor,
            &mut w.actor_buf,
            &w.batch.obs,
            b,
            &mut self.rng,
            &mut w.eps,
            &mut w.log_std,
            &mut w.pi_actions,
            &mut w.pi_log_probs,
        );
        concat_obs_act(&w.batch.obs, &w.pi_actions[..b * ad], b, &mut w.q_next_in);
        let [qb0, qb1] = &mut w.q_buf;
        let q1 = self.q[0].forward(qb0, &w.q_next_in, b);
        let q2 = self.q[1].forward(qb1, &w.q_next_in, b);
        let mut actor_loss = 0.0f64;
        for j in 0..b {
            let (m, first) = if q1[j] <= q2[j] { (q1[j], true) } else { (q2[j], false) };
            // V target: min_i Q_i(s, ã) − α log π(ã|s).
            w.target[j] = m - alpha * w.pi_log_probs[j];
            actor_loss += (alpha * w.pi_log_probs[j] - m) as f64 / b as f64;
            w.d_q[j] = if first { -1.0 / b as f32 } else { 0.0 };
            w.d_q2[j] = if first { 0.0 } else { -1.0 / b as f32 };
        }

        // Policy: J(π) = mean(α log π(ã|s) − min_i Q_i(s, ã)).
        self.q[0].input_grad(&mut w.q_buf[0], &w.d_q, b, &mut w.d_q_in);
        self.q[1].input_grad(&mut w.q_buf[1], &w.d_q2, b, &mut w.d_q_in2);
        let out = self.actor.output(&w.actor_buf, b);
        for j in 0..b {
            let ls_raw = &out[j * 2 * ad + ad..(j + 1) * 2 * ad];
            for k in 0..ad {
                w.log_std[k] = ls_raw[k].clamp(LOG_STD_MIN, LOG_STD_MAX);
                w.d_a[k] = w.d_q_in[j * (od + ad) + od + k] + w.d_q_in2[j * (od + ad) + od + k];
            }
            let (d_mean, d_ls) = w.d_actor_out[j * 2 * ad..(j + 1) * 2 * ad].split_at_mut(ad);
            squashed_gaussian_backward(
                &w.log_std,
                &w.eps[j * ad..(j + 1) * ad],
                &w.pi_actions[j * ad..(j + 1) * ad],
                &w.d_a,
                alpha / b as f32,
                d_mean,
                d_ls,
            );
            for k in 0..ad {
                if !(LOG_STD_MIN..=LOG_STD_MAX).contains(&ls_raw[k]) {
                    d_ls[k] = 0.0;
                }
            }
        }
        self.actor.backward(&mut w.actor_buf, &w.batch.obs, &w.d_actor_out, b, None);
        self.opt_actor.step(&mut self.actor.params, &self.actor.grads, lr);

        // Value: J(V) = ½ mean (V(s) − target)².
        let v = self.v.forward(&mut w.v_buf, &w.batch.obs, b);
        let mut v_loss = 0.0f64;
        for j in 0..b {
            let d = v[j] - w.target[j];
            v_loss += 0.5 * (d * d) as f64 / b as f64;
            w.d_q[j] = d / b as f32;
            sums.mean_v += v[j] as f64 / b as f64;
        }
        self.v.backward(&mut w.v_buf, &w.batch.obs, &w.d_q, b, None);
        self.opt_v.step(&mut self.v.params, &self.v.grads, lr_q);

        // Critics: y = r + γ(1 − d) V̄(s'), J(Q) = ½ Σ_i mean (Q_i(s, a) − y)².
        let vn = self.v_target.forward(&mut w.v_target_buf, &w.batch.next_obs, b);
        for j in 0..b {
            w.target[j] = w.batch.rewards[j] + gamma * (1.0 - w.batch.terminated[j]) * vn[j];
        }
        concat_obs_act(&w.batch.obs, &w.batch.actions, b, &mut w.q_in);
        for i in 0..2 {
            let q = self.q[i].forward(&mut w.q_buf[i], &w.q_in, b);
            let mut loss = 0.0f64;
            for j in 0..b {
                let d = q[j] - w.target[j];
                loss += 0.5 * (d * d) as f64 / b as f64;
                w.d_q[j] = d / b as f32;
                if i == 0 {
                    sums.mean_q += q[j] as f64 / b as f64;
                }
            }
            sums.q_loss += loss;
            self.q[i].backward(&mut w.q_buf[i], &w.q_in, &w.d_q, b, None);
            self.opt_q[i].step(&mut self.q[i].params, &self.q[i].grads, lr_q);
        }
        if !actor_loss.is_finite() || !sums.q_loss.is_finite() || !v_loss.is_finite() {
            return Err(RlError::Diverged {
                algo: "sac1",
                update: self.gradient_steps_done + 1,
                what: "loss",
            });
        }
        sums.policy_loss += actor_loss;
        sums.value_loss += v_loss;
        sums.entropy -= w.pi_log_probs[..b].iter().map(|x| *x as f64).sum::<f64>() / b as f64;
        sums.n += 1;

        self.gradient_steps_done += 1;
        if self.gradient_steps_done.is_multiple_of(self.config.target_update_interval) {
            polyak(&mut self.v_target.params, &self.v.params, self.config.tau as f32);
        }
        Ok(())
    }

    fn report(&self, sums: &LossSums, m: &mut UpdateMetrics) {
        m.alpha = self.alpha();
        if sums.n > 0 {
            let k = sums.n as f64;
            m.q_loss = sums.q_loss / k;
            m.policy_loss = sums.policy_loss / k;
            m.entropy = sums.entropy / k;
            m.mean_q = sums.mean_q / k;
            m.value_loss = sums.value_loss / k;
            m.value_mean = sums.mean_v / k;
        }
    }
}
