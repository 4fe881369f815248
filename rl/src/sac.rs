//! Soft Actor-Critic, version 2 (Haarnoja et al. 2018b, "Soft Actor-Critic Algorithms and
//! Applications", arXiv:1812.05905): two Q networks with Polyak-averaged targets, a
//! tanh-squashed Gaussian policy, and automatic temperature tuning. Defaults and update
//! order follow Stable-Baselines3's `SAC`.
//!
//! Actions live in `[−1, 1]^|A|` for the learner and are rescaled to the env's bounds.
//! For a batch `(s, a, r, s', d)` from the replay buffer, each gradient step does
//!
//! ```text
//! ã ~ π(·|s), log π(ã|s)                                       (reparameterised)
//! J(α)  = −mean[log α · (log π(ã|s) + H̄)],  H̄ = −|A|           (eq. 18; α from log α)
//! y     = r + γ (1 − d) [min_i Q̄_i(s', ã') − α log π(ã'|s')],  ã' ~ π(·|s')   (eq. 3, 5)
//! J(Q)  = ½ Σ_i mean[(Q_i(s, a) − y)²]                          (eq. 5)
//! J(π)  = mean[α log π(ã|s) − min_i Q_i(s, ã)]                  (eq. 7 / 17)
//! θ̄_i  ← τ θ_i + (1 − τ) θ̄_i
//! ```
//!
//! with α taken before its own update in the same step (as SB3), and the actor loss
//! evaluated with the just-updated critics. `log σ` is clamped to `[−20, 2]`.
//!
//! The collection loop around the gradient step (warm-up, replay buffer, logging) is the one
//! all replay-buffer learners share, in `off_policy.rs`.

use std::ops::ControlFlow;

use serde::{Deserialize, Serialize};

use crate::algorithm::Algorithm;
use crate::buffer::{ReplayBatch, concat_obs_act};
use crate::checkpoint::Checkpoint;
use crate::distributions::{squashed_gaussian_backward, squashed_gaussian_sample};
use crate::error::{RlError, check, check_critic_lr};
use crate::metrics::UpdateMetrics;
use crate::nn::{Activation, Init, Mlp, MlpBuffers, polyak};
use crate::off_policy::{self, Collector, LoopSettings, OffPolicyLearner};
use crate::optim::Adam;
use crate::policy::{Policy, PolicyHead};
use centaur_gym::Rng;
use centaur_gym::{BoxSpace, VecEnv};

/// Bounds of the policy's `log σ` (SB3's `LOG_STD_MIN`, `LOG_STD_MAX`).
pub const LOG_STD_MIN: f32 = -20.0;
/// Upper bound of `log σ`.
pub const LOG_STD_MAX: f32 = 2.0;

/// SAC hyperparameters (defaults: Stable-Baselines3 2.x `SAC`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SacConfig {
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
    /// Learning rate of the actor and the temperature (default: 3e-4).
    pub learning_rate: f64,
    /// The critics' (twin Q) learning rate; unset: `learning_rate` (default: unset).
    pub critic_learning_rate: Option<f64>,
    /// Adam ε (default: 1e-8).
    pub adam_eps: f64,
    /// Polyak coefficient τ (default: 0.005).
    pub tau: f64,
    /// Discount γ (default: 0.99).
    pub gamma: f64,
    /// Gradient steps after each vectorised environment step (default: 1).
    pub gradient_steps: usize,
    /// Update the targets every this many gradient steps (default: 1).
    pub target_update_interval: u64,
    /// Learn the temperature α; off: keep `alpha_init` (default: true).
    pub auto_alpha: bool,
    /// Initial (or fixed) temperature α (default: 1.0).
    pub alpha_init: f64,
    /// Target entropy H̄; unset means −|A| (default: unset).
    pub target_entropy: Option<f64>,
    /// Actor hidden layer sizes (default: [256, 256]).
    pub actor_hidden: Vec<usize>,
    /// Critic hidden layer sizes (default: [256, 256]).
    pub critic_hidden: Vec<usize>,
    /// Hidden activation (default: "relu").
    pub activation: Activation,
    /// Environment steps between metrics records (default: 1000).
    pub log_interval: u64,
}

impl Default for SacConfig {
    fn default() -> Self {
        SacConfig {
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
            auto_alpha: true,
            alpha_init: 1.0,
            target_entropy: None,
            actor_hidden: vec![256, 256],
            critic_hidden: vec![256, 256],
            activation: Activation::Relu,
            log_interval: 1000,
        }
    }
}

impl SacConfig {
    /// For the locomotion robots: learning starts after 5,000 steps of uniformly random
    /// actions instead of 100 (the other settings are the defaults).
    pub fn locomotion() -> Self {
        SacConfig { learning_starts: 5000, ..SacConfig::default() }
    }
}

impl SacConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), RlError> {
        const A: &str = "sac";
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
        check(
            self.alpha_init.is_finite() && self.alpha_init > 0.0,
            A,
            "alpha_init",
            self.alpha_init,
            "must be positive",
        )?;
        check(
            self.target_entropy.is_none_or(f64::is_finite),
            A,
            "target_entropy",
            self.target_entropy,
            "must be finite",
        )?;
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
    next_eps: Vec<f32>,
    log_std: Vec<f32>,
    d_a: Vec<f32>,
    d_q2: Vec<f32>,
    pi_actions: Vec<f32>,
    pi_log_probs: Vec<f32>,
    next_actions: Vec<f32>,
    next_log_probs: Vec<f32>,
    q_in: Vec<f32>,
    q_next_in: Vec<f32>,
    target: Vec<f32>,
    d_q: Vec<f32>,
    d_q_in: Vec<f32>,
    d_q_in2: Vec<f32>,
    d_actor_out: Vec<f32>,
    actor_buf: MlpBuffers,
    actor_next_buf: MlpBuffers,
    q_buf: [MlpBuffers; 2],
    q_target_buf: [MlpBuffers; 2],
}

/// Running sums of the losses between metrics records.
#[derive(Clone, Copy, Default)]
pub(crate) struct LossSums {
    n: u64,
    q_loss: f64,
    policy_loss: f64,
    entropy: f64,
    mean_q: f64,
}

/// A SAC (v2) learner; see the module documentation.
pub struct Sac {
    config: SacConfig,
    collector: Collector,
    actor: Mlp,
    q: [Mlp; 2],
    q_target: [Mlp; 2],
    opt_actor: Adam,
    opt_q: [Adam; 2],
    log_alpha: Vec<f32>,
    opt_alpha: Adam,
    target_entropy: f32,
    rng: Rng,
    gradient_steps_done: u64,
    work: Work,
}

impl Sac {
    /// A new learner for the given spaces; `max_envs` sizes the per-step buffers (the
    /// number of environments of the VecEnvs it will train on).
    pub fn new(
        config: SacConfig,
        obs_space: &BoxSpace,
        act_space: &BoxSpace,
        max_envs: usize,
    ) -> Result<Sac, RlError> {
        config.validate()?;
        crate::error::check_sizes(
            "sac",
            ("buffer_size", config.buffer_size, 1),
            2 * obs_space.dim() + act_space.dim() + 2,
            &[("actor_hidden", &config.actor_hidden), ("critic_hidden", &config.critic_hidden)],
            obs_space.dim(),
            act_space.dim(),
            config.batch_size.max(max_envs),
        )?;
        if !act_space.is_bounded() {
            return Err(RlError::Incompatible { algo: "sac", reason: "needs a bounded action space".into() });
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
        let q_target = q.clone();
        let eps = config.adam_eps as f32;
        let cap = b.max(n);
        let work = Work {
            batch: ReplayBatch::new(b, od, ad),
            eps: vec![0.0; cap * ad],
            next_eps: vec![0.0; b * ad],
            log_std: vec![0.0; ad],
            d_a: vec![0.0; ad],
            d_q2: vec![0.0; b],
            pi_actions: vec![0.0; cap * ad],
            pi_log_probs: vec![0.0; cap],
            next_actions: vec![0.0; b * ad],
            next_log_probs: vec![0.0; b],
            q_in: vec![0.0; b * (od + ad)],
            q_next_in: vec![0.0; b * (od + ad)],
            target: vec![0.0; b],
            d_q: vec![0.0; b],
            d_q_in: vec![0.0; b * (od + ad)],
            d_q_in2: vec![0.0; b * (od + ad)],
            d_actor_out: vec![0.0; b * 2 * ad],
            actor_buf: actor.buffers(cap),
            actor_next_buf: actor.buffers(b),
            q_buf: [q[0].buffers(b), q[1].buffers(b)],
            q_target_buf: [q[0].buffers(b), q[1].buffers(b)],
        };
        Ok(Sac {
            opt_actor: Adam::new(actor.n_params(), eps),
            opt_q: [Adam::new(q[0].n_params(), eps), Adam::new(q[1].n_params(), eps)],
            log_alpha: vec![config.alpha_init.ln() as f32],
            opt_alpha: Adam::new(1, eps),
            target_entropy: config.target_entropy.unwrap_or(-(ad as f64)) as f32,
            collector: Collector::new(obs_space, act_space, n, config.buffer_size),
            actor,
            q,
            q_target,
            rng,
            gradient_steps_done: 0,
            work,
            config,
        })
    }

    /// A learner for `env`'s spaces.
    pub fn for_env(config: SacConfig, env: &VecEnv) -> Result<Sac, RlError> {
        Sac::new(config, env.observation_space(), env.action_space(), env.len())
    }

    /// The configuration.
    pub fn config(&self) -> &SacConfig {
        &self.config
    }

    /// Current temperature α.
    pub fn alpha(&self) -> f64 {
        (self.log_alpha[0] as f64).exp()
    }

    /// Samples `ã ~ π(·|s)` for a batch: writes actions and log-probabilities; the actor's
    /// activations stay in `buf` and the noise in `eps` for the backward pass.
    /// `log_std` is scratch of length |A|.
    pub(crate) fn sample_actions(
        actor: &Mlp,
        buf: &mut MlpBuffers,
        obs: &[f32],
        batch: usize,
        rng: &mut Rng,
        eps: &mut [f32],
        log_std: &mut [f32],
        actions: &mut [f32],
        log_probs: &mut [f32],
    ) {
        let ad = log_std.len();
        let out = actor.forward(buf, obs, batch);
        for j in 0..batch {
            let (mean, ls) = out[j * 2 * ad..(j + 1) * 2 * ad].split_at(ad);
            let e = &mut eps[j * ad..(j + 1) * ad];
            for k in 0..ad {
                e[k] = rng.normal() as f32;
                log_std[k] = ls[k].clamp(LOG_STD_MIN, LOG_STD_MAX);
            }
            log_probs[j] = squashed_gaussian_sample(mean, log_std, e, &mut actions[j * ad..(j + 1) * ad]);
        }
    }

    /// Reads a learner saved by [`Algorithm::save`].
    pub fn load(path: &std::path::Path) -> Result<Sac, RlError> {
        Sac::from_checkpoint(&Checkpoint::read(path)?)
    }

    /// A learner from an in-memory checkpoint.
    pub fn from_checkpoint(c: &Checkpoint) -> Result<Sac, RlError> {
        c.expect_algo("sac")?;
        let config: SacConfig = c.get_meta("config")?;
        let (obs_space, act_space, max_envs) = Collector::read_shape(c)?;
        let mut s = Sac::new(config, &obs_space, &act_space, max_envs)?;
        c.read_mlp("actor", &mut s.actor)?;
        for i in 0..2 {
            c.read_mlp(&format!("q{i}"), &mut s.q[i])?;
            c.read_mlp(&format!("q{i}_target"), &mut s.q_target[i])?;
            c.read_adam(&format!("adam/q{i}"), &mut s.opt_q[i])?;
        }
        c.read_adam("adam/actor", &mut s.opt_actor)?;
        c.read_f32_into("log_alpha", &mut s.log_alpha)?;
        c.read_adam("adam/alpha", &mut s.opt_alpha)?;
        s.collector.read_from(c)?;
        s.rng = c.read_rng("rng")?;
        s.gradient_steps_done = c.get_meta("gradient_steps_done")?;
        Ok(s)
    }

    /// Like [`Algorithm::to_checkpoint`], optionally without the replay buffer (smaller
    /// files; resuming then refills it from scratch).
    pub fn to_checkpoint_with(&self, save_replay: bool) -> Checkpoint {
        let mut c = Checkpoint::new("sac");
        c.set_meta("config", &self.config);
        self.collector.write_to(&mut c, save_replay);
        c.set_meta("gradient_steps_done", self.gradient_steps_done);
        c.put_f32("actor", &self.actor.params);
        for i in 0..2 {
            c.put_f32(&format!("q{i}"), &self.q[i].params);
            c.put_f32(&format!("q{i}_target"), &self.q_target[i].params);
            c.put_adam(&format!("adam/q{i}"), &self.opt_q[i]);
        }
        c.put_adam("adam/actor", &self.opt_actor);
        c.put_f32("log_alpha", &self.log_alpha);
        c.put_adam("adam/alpha", &self.opt_alpha);
        c.put_rng("rng", &self.rng);
        self.policy().write_to(&mut c);
        c
    }
}

impl Algorithm for Sac {
    fn name(&self) -> &'static str {
        "sac"
    }

    fn learn(
        &mut self,
        env: &mut VecEnv,
        total_steps: u64,
        callback: &mut dyn FnMut(&UpdateMetrics) -> ControlFlow<()>,
    ) -> Result<(), RlError> {
        off_policy::learn(self, "sac", env, total_steps, callback)
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

impl OffPolicyLearner for Sac {
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
        let gamma = self.config.gamma as f32;
        let w = &mut self.work;
        self.collector.replay.sample(&mut self.rng, &mut w.batch);

        // ã ~ π(·|s) (kept for the actor loss).
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

        // Temperature: α used in this step is the one before its update.
        let alpha = self.log_alpha[0].exp();
        if self.config.auto_alpha {
            let mean_term =
                w.pi_log_probs[..b].iter().map(|lp| (lp + self.target_entropy) as f64).sum::<f64>()
                    / b as f64;
            let grad = [-(mean_term as f32)];
            self.opt_alpha.step(&mut self.log_alpha, &grad, self.config.learning_rate as f32);
        }

        // Soft Bellman target y = r + γ(1 − d)(min Q̄(s', ã') − α log π(ã'|s')).
        Sac::sample_actions(
            &self.actor,
            &mut w.actor_next_buf,
            &w.batch.next_obs,
            b,
            &mut self.rng,
            &mut w.next_eps,
            &mut w.log_std,
            &mut w.next_actions,
            &mut w.next_log_probs,
        );
        concat_obs_act(&w.batch.next_obs, &w.next_actions, b, &mut w.q_next_in);
        let [tb0, tb1] = &mut w.q_target_buf;
        let q1n = self.q_target[0].forward(tb0, &w.q_next_in, b);
        let q2n = self.q_target[1].forward(tb1, &w.q_next_in, b);
        for j in 0..b {
            let soft = q1n[j].min(q2n[j]) - alpha * w.next_log_probs[j];
            w.target[j] = w.batch.rewards[j] + gamma * (1.0 - w.batch.terminated[j]) * soft;
        }

        // Critics: J(Q) = ½ Σ_i mean (Q_i(s, a) − y)².
        concat_obs_act(&w.batch.obs, &w.batch.actions, b, &mut w.q_in);
        let lr = self.config.learning_rate as f32;
        let lr_q = self.config.critic_learning_rate.unwrap_or(self.config.learning_rate) as f32;
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

        // Actor: J(π) = mean(α log π(ã|s) − min_i Q_i(s, ã)), with the updated critics.
        concat_obs_act(&w.batch.obs, &w.pi_actions[..b * ad], b, &mut w.q_in);
        let [qb0, qb1] = &mut w.q_buf;
        let q1 = self.q[0].forward(qb0, &w.q_in, b);
        let q2 = self.q[1].forward(qb1, &w.q_in, b);
        let mut actor_loss = 0.0f64;
        // ∂J/∂Q_min = −1/B flows into the critic that attains the minimum.
        for j in 0..b {
            let (m, first) = if q1[j] <= q2[j] { (q1[j], true) } else { (q2[j], false) };
            actor_loss += (alpha * w.pi_log_probs[j] - m) as f64 / b as f64;
            w.d_q[j] = if first { -1.0 / b as f32 } else { 0.0 };
            w.d_q2[j] = if first { 0.0 } else { -1.0 / b as f32 };
        }
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
            // The clamp passes no gradient outside [LOG_STD_MIN, LOG_STD_MAX].
            for k in 0..ad {
                if !(LOG_STD_MIN..=LOG_STD_MAX).contains(&ls_raw[k]) {
                    d_ls[k] = 0.0;
                }
            }
        }
        self.actor.backward(&mut w.actor_buf, &w.batch.obs, &w.d_actor_out, b, None);
        self.opt_actor.step(&mut self.actor.params, &self.actor.grads, lr);
        if !actor_loss.is_finite() || !sums.q_loss.is_finite() {
            return Err(RlError::Diverged {
                algo: "sac",
                update: self.gradient_steps_done + 1,
                what: "loss",
            });
        }
        sums.policy_loss += actor_loss;
        sums.entropy -= w.pi_log_probs[..b].iter().map(|x| *x as f64).sum::<f64>() / b as f64;
        sums.n += 1;

        self.gradient_steps_done += 1;
        if self.gradient_steps_done.is_multiple_of(self.config.target_update_interval) {
            let tau = self.config.tau as f32;
            for i in 0..2 {
                polyak(&mut self.q_target[i].params, &self.q[i].params, tau);
            }
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
        }
    }
}
