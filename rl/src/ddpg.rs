//! Deep Deterministic Policy Gradient (Lillicrap et al. 2016, "Continuous control with
//! deep reinforcement learning", ICLR; Algorithm 1). Defaults: Stable-Baselines3's `DDPG`
//! (which follows the "OurDDPG" variant of Fujimoto et al. 2018: batch 256, learning rate
//! 10⁻³ for both networks, no weight decay, τ = 0.005) with Gaussian exploration noise
//! σ = 0.1; the paper's Ornstein–Uhlenbeck noise (θ = 0.15, σ = 0.2) is available.
//!
//! A deterministic actor `μ(s) = tanh(y(s)) ∈ [−1, 1]^|A|` (rescaled to the env's bounds),
//! one critic, and target copies of both. Per gradient step on a batch `(s, a, r, s', d)`:
//!
//! ```text
//! y    = r + γ (1 − d) Q̄(s', μ̄(s'))                       (Algorithm 1, line 12)
//! J(Q) = mean[(Q(s, a) − y)²]                              (line 13)
//! J(μ) = −mean[Q(s, μ(s))]                                 (line 14, deterministic policy gradient)
//! θ̄   ← τ θ + (1 − τ) θ̄  for actor and critic             (line 15)
//! ```
//!
//! Exploration: `a = clip(μ(s) + n, −1, 1)` after `learning_starts` uniformly random steps,
//! with `n ~ N(0, σ²)` or the Ornstein–Uhlenbeck process
//! `n ← n + θ (0 − n) dt + σ √dt ξ`, `ξ ~ N(0, 1)`, reset at each episode start.
//!
//! The collection loop around the gradient step (warm-up, replay buffer, logging) is the one
//! all replay-buffer learners share, in `off_policy.rs`.

use std::ops::ControlFlow;

use serde::{Deserialize, Serialize};

use crate::algorithm::Algorithm;
use crate::buffer::{ReplayBatch, concat_obs_act};
use crate::checkpoint::Checkpoint;
use crate::error::{MAX_NOISE, RlError, check, check_critic_lr};
use crate::metrics::UpdateMetrics;
use crate::nn::{Activation, Init, Mlp, MlpBuffers, polyak, tanh_fast};
use crate::off_policy::{self, Collector, LoopSettings, OffPolicyLearner};
use crate::optim::Adam;
use crate::policy::{Policy, PolicyHead};
use centaur_gym::Rng;
use centaur_gym::{BoxSpace, VecEnv};

/// DDPG hyperparameters (defaults: Stable-Baselines3 2.x `DDPG` with Gaussian exploration
/// noise σ = 0.1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DdpgConfig {
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
    /// Learning rate of the actor (default: 1e-3).
    pub learning_rate: f64,
    /// The critic's (Q) learning rate; unset: `learning_rate` (default: unset).
    pub critic_learning_rate: Option<f64>,
    /// Adam ε (default: 1e-8).
    pub adam_eps: f64,
    /// Polyak coefficient τ (default: 0.005).
    pub tau: f64,
    /// Discount γ (default: 0.99).
    pub gamma: f64,
    /// Gradient steps after each vectorised environment step (default: 1).
    pub gradient_steps: usize,
    /// Exploration noise process (default: "gaussian").
    pub noise: NoiseKind,
    /// Std σ of the exploration noise, in the [−1, 1] action scale (default: 0.1).
    pub exploration_noise: f64,
    /// Mean-reversion rate θ of the Ornstein–Uhlenbeck noise (default: 0.15).
    pub ou_theta: f64,
    /// Time step dt of the Ornstein–Uhlenbeck noise (default: 0.01).
    pub ou_dt: f64,
    /// Actor hidden layer sizes (default: [400, 300]).
    pub actor_hidden: Vec<usize>,
    /// Critic hidden layer sizes (default: [400, 300]).
    pub critic_hidden: Vec<usize>,
    /// Hidden activation (default: "relu").
    pub activation: Activation,
    /// Environment steps between metrics records (default: 1000).
    pub log_interval: u64,
}

impl Default for DdpgConfig {
    fn default() -> Self {
        DdpgConfig {
            seed: 0,
            buffer_size: 1_000_000,
            learning_starts: 100,
            warmup_with_policy: false,
            batch_size: 256,
            learning_rate: 1e-3,
            critic_learning_rate: None,
            adam_eps: 1e-8,
            tau: 0.005,
            gamma: 0.99,
            gradient_steps: 1,
            noise: NoiseKind::Gaussian,
            exploration_noise: 0.1,
            ou_theta: 0.15,
            ou_dt: 0.01,
            actor_hidden: vec![400, 300],
            critic_hidden: vec![400, 300],
            activation: Activation::Relu,
            log_interval: 1000,
        }
    }
}

impl DdpgConfig {
    /// For the locomotion robots: learning starts after 5,000 steps of uniformly random
    /// actions instead of 100 (the other settings are the defaults).
    pub fn locomotion() -> Self {
        DdpgConfig { learning_starts: 5000, ..DdpgConfig::default() }
    }
}

impl DdpgConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), RlError> {
        const A: &str = "ddpg";
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
            self.ou_theta.is_finite() && self.ou_theta >= 0.0,
            A,
            "ou_theta",
            self.ou_theta,
            "must be ≥ 0",
        )?;
        check(self.ou_dt > 0.0 && self.ou_dt <= 1.0, A, "ou_dt", self.ou_dt, "must be in (0, 1]")?;
        check(
            self.ou_theta * self.ou_dt <= 1.0,
            A,
            "ou_theta",
            self.ou_theta,
            "times ou_dt must be at most 1 (the Euler step of the OU process overshoots its mean beyond)",
        )?;
        check(
            (0.0..=MAX_NOISE).contains(&self.exploration_noise),
            A,
            "exploration_noise",
            self.exploration_noise,
            "must be in [0, 10]",
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

/// The exploration noise process.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseKind {
    /// Independent `N(0, σ²)` each step.
    Gaussian,
    /// Ornstein–Uhlenbeck process (Uhlenbeck & Ornstein 1930), as in the DDPG paper.
    OrnsteinUhlenbeck,
}

/// Preallocated buffers.
struct Work {
    /// Ornstein–Uhlenbeck state per environment and action dimension.
    ou: Vec<f32>,
    batch: ReplayBatch,
    next_actions: Vec<f32>,
    pi_actions: Vec<f32>,
    q_in: Vec<f32>,
    target: Vec<f32>,
    d_q: Vec<f32>,
    d_q_in: Vec<f32>,
    d_actor: Vec<f32>,
    actor_buf: MlpBuffers,
    actor_target_buf: MlpBuffers,
    q_buf: MlpBuffers,
    q_target_buf: MlpBuffers,
}

#[derive(Clone, Copy, Default)]
pub(crate) struct LossSums {
    n_q: u64,
    n_pi: u64,
    q_loss: f64,
    policy_loss: f64,
    mean_q: f64,
}

/// A DDPG learner; see the module documentation.
pub struct Ddpg {
    config: DdpgConfig,
    collector: Collector,
    actor: Mlp,
    actor_target: Mlp,
    q: Mlp,
    q_target: Mlp,
    opt_actor: Adam,
    opt_q: Adam,
    rng: Rng,
    gradient_steps_done: u64,
    work: Work,
}

impl Ddpg {
    /// A new learner; `max_envs` sizes the per-step buffers.
    pub fn new(
        config: DdpgConfig,
        obs_space: &BoxSpace,
        act_space: &BoxSpace,
        max_envs: usize,
    ) -> Result<Ddpg, RlError> {
        config.validate()?;
        crate::error::check_sizes(
            "ddpg",
            ("buffer_size", config.buffer_size, 1),
            2 * obs_space.dim() + act_space.dim() + 2,
            &[("actor_hidden", &config.actor_hidden), ("critic_hidden", &config.critic_hidden)],
            obs_space.dim(),
            act_space.dim(),
            config.batch_size.max(max_envs),
        )?;
        if !act_space.is_bounded() {
            return Err(RlError::Incompatible {
                algo: "ddpg",
                reason: "needs a bounded action space".into(),
            });
        }
        let (od, ad, n, b) = (obs_space.dim(), act_space.dim(), max_envs.max(1), config.batch_size);
        let mut rng = Rng::derive(config.seed, 1);
        let actor_sizes = [&[od][..], &config.actor_hidden, &[ad]].concat();
        let q_sizes = [&[od + ad][..], &config.critic_hidden, &[1]].concat();
        let actor = Mlp::new(&actor_sizes, config.activation, Init::TorchDefault, &mut rng);
        let q = Mlp::new(&q_sizes, config.activation, Init::TorchDefault, &mut rng);
        let eps = config.adam_eps as f32;
        let work = Work {
            ou: vec![0.0; n * ad],
            batch: ReplayBatch::new(b, od, ad),
            next_actions: vec![0.0; b * ad],
            pi_actions: vec![0.0; b * ad],
            q_in: vec![0.0; b * (od + ad)],
            target: vec![0.0; b],
            d_q: vec![0.0; b],
            d_q_in: vec![0.0; b * (od + ad)],
            d_actor: vec![0.0; b * ad],
            actor_buf: actor.buffers(b.max(n)),
            actor_target_buf: actor.buffers(b),
            q_buf: q.buffers(b),
            q_target_buf: q.buffers(b),
        };
        Ok(Ddpg {
            opt_actor: Adam::new(actor.n_params(), eps),
            opt_q: Adam::new(q.n_params(), eps),
            collector: Collector::new(obs_space, act_space, n, config.buffer_size),
            actor_target: actor.clone(),
            actor,
            q_target: q.clone(),
            q,
            rng,
            gradient_steps_done: 0,
            work,
            config,
        })
    }

    /// A learner for `env`'s spaces.
    pub fn for_env(config: DdpgConfig, env: &VecEnv) -> Result<Ddpg, RlError> {
        Ddpg::new(config, env.observation_space(), env.action_space(), env.len())
    }

    /// The configuration.
    pub fn config(&self) -> &DdpgConfig {
        &self.config
    }

    /// Reads a learner saved by [`Algorithm::save`].
    pub fn load(path: &std::path::Path) -> Result<Ddpg, RlError> {
        Ddpg::from_checkpoint(&Checkpoint::read(path)?)
    }

    /// A learner from an in-memory checkpoint.
    pub fn from_checkpoint(c: &Checkpoint) -> Result<Ddpg, RlError> {
        c.expect_algo("ddpg")?;
        let config: DdpgConfig = c.get_meta("config")?;
        let (obs_space, act_space, max_envs) = Collector::read_shape(c)?;
        let mut s = Ddpg::new(config, &obs_space, &act_space, max_envs)?;
        c.read_mlp("actor", &mut s.actor)?;
        c.read_mlp("actor_target", &mut s.actor_target)?;
        c.read_adam("adam/actor", &mut s.opt_actor)?;
        c.read_mlp("q", &mut s.q)?;
        c.read_mlp("q_target", &mut s.q_target)?;
        c.read_adam("adam/q", &mut s.opt_q)?;
        c.read_f32_into("ou", &mut s.work.ou)?;
        s.collector.read_from(c)?;
        s.rng = c.read_rng("rng")?;
        s.gradient_steps_done = c.get_meta("gradient_steps_done")?;
        Ok(s)
    }

    /// Like [`Algorithm::to_checkpoint`], optionally without the replay buffer.
    pub fn to_checkpoint_with(&self, save_replay: bool) -> Checkpoint {
        let mut c = Checkpoint::new("ddpg");
        c.set_meta("config", &self.config);
        self.collector.write_to(&mut c, save_replay);
        c.set_meta("gradient_steps_done", self.gradient_steps_done);
        c.put_f32("actor", &self.actor.params);
        c.put_f32("actor_target", &self.actor_target.params);
        c.put_adam("adam/actor", &self.opt_actor);
        c.put_f32("q", &self.q.params);
        c.put_f32("q_target", &self.q_target.params);
        c.put_adam("adam/q", &self.opt_q);
        c.put_f32("ou", &self.work.ou);
        c.put_rng("rng", &self.rng);
        self.policy().write_to(&mut c);
        c
    }
}

impl Algorithm for Ddpg {
    fn name(&self) -> &'static str {
        "ddpg"
    }

    fn learn(
        &mut self,
        env: &mut VecEnv,
        total_steps: u64,
        callback: &mut dyn FnMut(&UpdateMetrics) -> ControlFlow<()>,
    ) -> Result<(), RlError> {
        off_policy::learn(self, "ddpg", env, total_steps, callback)
    }

    fn to_checkpoint(&self) -> Checkpoint {
        self.to_checkpoint_with(true)
    }

    fn policy(&self) -> Policy {
        Policy::new(PolicyHead::TanhRescaled, self.actor.clone(), None, &self.collector.act_space)
    }

    fn zero_policy_output(&mut self) {
        self.actor.zero_output_rows(0..self.collector.act_space.dim());
        self.actor_target = self.actor.clone();
    }

    fn set_warmup_with_policy(&mut self) -> Result<(), RlError> {
        self.config.warmup_with_policy = true;
        Ok(())
    }

    fn steps_done(&self) -> u64 {
        self.collector.steps_done
    }
}

impl OffPolicyLearner for Ddpg {
    type Sums = LossSums;

    fn settings(&self) -> LoopSettings {
        off_policy::loop_settings!(self.config)
    }

    fn parts(&mut self) -> (&mut Collector, &mut Rng) {
        (&mut self.collector, &mut self.rng)
    }

    /// `a = clip(μ(s) + noise, −1, 1)`, Gaussian or Ornstein–Uhlenbeck noise.
    fn explore(&mut self, n: usize) {
        let (c, w) = (&mut self.collector, &mut self.work);
        let (od, ad) = (c.obs_space.dim(), c.act_space.dim());
        let y = self.actor.forward(&mut w.actor_buf, &c.obs[..n * od], n);
        let sigma = self.config.exploration_noise;
        for k in 0..n * ad {
            let noise = match self.config.noise {
                NoiseKind::Gaussian => (self.rng.normal() * sigma) as f32,
                NoiseKind::OrnsteinUhlenbeck => {
                    let (theta, dt) = (self.config.ou_theta, self.config.ou_dt);
                    let x = w.ou[k] as f64;
                    w.ou[k] = (x - theta * x * dt + sigma * dt.sqrt() * self.rng.normal()) as f32;
                    w.ou[k]
                }
            };
            c.actions[k] = (tanh_fast(y[k]) + noise).clamp(-1.0, 1.0);
        }
    }

    /// A new episode starts a new noise path.
    fn episode_ended(&mut self, env: usize) {
        let ad = self.collector.act_space.dim();
        self.work.ou[env * ad..(env + 1) * ad].fill(0.0);
    }

    /// One gradient step on a replay batch.
    fn train_step(&mut self, sums: &mut LossSums) -> Result<(), RlError> {
        let (od, ad, b) =
            (self.collector.obs_space.dim(), self.collector.act_space.dim(), self.config.batch_size);
        let (gamma, lr, lr_q) = (
            self.config.gamma as f32,
            self.config.learning_rate as f32,
            self.config.critic_learning_rate.unwrap_or(self.config.learning_rate) as f32,
        );
        let w = &mut self.work;
        self.collector.replay.sample(&mut self.rng, &mut w.batch);

        // y = r + γ(1 − d) Q̄(s', μ̄(s')).
        let y = self.actor_target.forward(&mut w.actor_target_buf, &w.batch.next_obs, b);
        for k in 0..b * ad {
            w.next_actions[k] = tanh_fast(y[k]);
        }
        concat_obs_act(&w.batch.next_obs, &w.next_actions, b, &mut w.q_in);
        let qn = self.q_target.forward(&mut w.q_target_buf, &w.q_in, b);
        for j in 0..b {
            w.target[j] = w.batch.rewards[j] + gamma * (1.0 - w.batch.terminated[j]) * qn[j];
        }

        // Critic: J(Q) = mean (Q(s, a) − y)², ∂/∂Q = 2(Q − y)/B.
        concat_obs_act(&w.batch.obs, &w.batch.actions, b, &mut w.q_in);
        let q = self.q.forward(&mut w.q_buf, &w.q_in, b);
        let mut loss = 0.0f64;
        for j in 0..b {
            let d = q[j] - w.target[j];
            loss += (d * d) as f64 / b as f64;
            w.d_q[j] = 2.0 * d / b as f32;
            sums.mean_q += q[j] as f64 / b as f64;
        }
        if !loss.is_finite() {
            return Err(RlError::Diverged {
                algo: "ddpg",
                update: self.gradient_steps_done + 1,
                what: "critic loss",
            });
        }
        sums.q_loss += loss;
        sums.n_q += 1;
        self.q.backward(&mut w.q_buf, &w.q_in, &w.d_q, b, None);
        self.opt_q.step(&mut self.q.params, &self.q.grads, lr_q);

        // Actor: J(μ) = −mean Q(s, μ(s)), through tanh (∂a/∂y = 1 − a²).
        let y = self.actor.forward(&mut w.actor_buf, &w.batch.obs, b);
        for k in 0..b * ad {
            w.pi_actions[k] = tanh_fast(y[k]);
        }
        concat_obs_act(&w.batch.obs, &w.pi_actions, b, &mut w.q_in);
        let q = self.q.forward(&mut w.q_buf, &w.q_in, b);
        sums.policy_loss -= q.iter().map(|x| *x as f64).sum::<f64>() / b as f64;
        sums.n_pi += 1;
        w.d_q.fill(-1.0 / b as f32);
        self.q.input_grad(&mut w.q_buf, &w.d_q, b, &mut w.d_q_in);
        for j in 0..b {
            for k in 0..ad {
                let a = w.pi_actions[j * ad + k];
                w.d_actor[j * ad + k] = w.d_q_in[j * (od + ad) + od + k] * (1.0 - a * a);
            }
        }
        self.actor.backward(&mut w.actor_buf, &w.batch.obs, &w.d_actor, b, None);
        self.opt_actor.step(&mut self.actor.params, &self.actor.grads, lr);

        // Soft target updates.
        let tau = self.config.tau as f32;
        polyak(&mut self.q_target.params, &self.q.params, tau);
        polyak(&mut self.actor_target.params, &self.actor.params, tau);
        self.gradient_steps_done += 1;
        Ok(())
    }

    fn report(&self, sums: &LossSums, m: &mut UpdateMetrics) {
        if sums.n_q > 0 {
            m.q_loss = sums.q_loss / sums.n_q as f64;
            m.mean_q = sums.mean_q / sums.n_q as f64;
        }
        if sums.n_pi > 0 {
            m.policy_loss = sums.policy_loss / sums.n_pi as f64;
        }
    }
}
