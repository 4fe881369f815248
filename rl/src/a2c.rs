//! Advantage Actor-Critic, the synchronous variant of A3C (Mnih et al. 2016,
//! "Asynchronous Methods for Deep Reinforcement Learning", ICML; Algorithm S3), as
//! Stable-Baselines3's `A2C`: `n_envs` environments stepped in lockstep for `n_steps`
//! steps, n-step returns, one gradient step per rollout on the whole batch.
//!
//! ```text
//! R_t = r_t + γ r_{t+1} + … + γ^{k−1} r_{t+k−1} + γ^k V(s_{t+k})   (cut at episode ends)
//! Â_t = R_t − V(s_t)      (gae_lambda = 1; below 1, GAE(γ, λ) over the rollout, as SB3)
//! L   = −mean[Â_t log π(a_t|s_t)] + c_v mean[(V(s_t) − R_t)²] − c_e H[π]
//! ```
//!
//! minimised with RMSprop (α = 0.99, ε = 10⁻⁵, SB3's default; Adam is available) after
//! clipping the global gradient norm at 0.5. Truncated episodes bootstrap with the final
//! observation's value. Optional observation normalisation and reward scaling as in
//! [`crate::ppo`] (off by default, as SB3).

use std::ops::ControlFlow;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::algorithm::{Algorithm, ExplorationFloor};
use crate::buffer::{RolloutBuffer, gae, n_step_returns};
use crate::checkpoint::Checkpoint;
use crate::distributions::{gaussian_entropy, gaussian_log_prob, gaussian_log_prob_grad};
use crate::error::{RlError, check, check_critic_lr, check_loss_terms, check_norm_clips};
use crate::metrics::{EpisodeWindow, UpdateMetrics};
use crate::nn::{Activation, Init, Mlp, MlpBuffers};
use crate::normalizer::{RewardScaler, RunningMeanStd};
use crate::on_policy::{Collector, LearnerState, PolicyValue, RolloutSettings};
use crate::optim::{Adam, OptimizerKind, RmsProp, clip_grad_norm, linear_decay};
use crate::policy::{ObsNorm, Policy, PolicyHead};
use centaur_gym::Rng;
use centaur_gym::{BoxSpace, VecEnv};

/// A2C hyperparameters (defaults: Stable-Baselines3 2.x `A2C`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct A2cConfig {
    /// Seed of initialisation, action sampling and env resets (default: 0).
    pub seed: u64,
    /// Steps per environment per update (default: 5).
    pub n_steps: usize,
    /// Learning rate (default: 7e-4).
    pub learning_rate: f64,
    /// The critic's learning rate, annealed alike; unset: the same as `learning_rate`
    /// (default: unset).
    pub critic_learning_rate: Option<f64>,
    /// Anneal the learning rate linearly to 0 (default: false).
    pub anneal_lr: bool,
    /// Environment steps over which the learning rate anneals; unset means the
    /// `total_steps` of the first `learn` call (default: unset).
    pub lr_decay_steps: Option<u64>,
    /// Optimiser (default: "rmsprop").
    pub optimizer: OptimizerKind,
    /// RMSprop smoothing α (default: 0.99).
    pub rmsprop_alpha: f64,
    /// Optimiser ε (RMSprop or Adam) (default: 1e-5).
    pub optimizer_eps: f64,
    /// Discount γ (default: 0.99).
    pub gamma: f64,
    /// GAE's λ (Schulman et al. 2016) over each rollout; 1 gives the n-step returns above,
    /// SB3's default (default: 1.0).
    pub gae_lambda: f64,
    /// Normalise advantages over the batch (default: false).
    pub norm_adv: bool,
    /// Entropy coefficient `c_e` (default: 0.0).
    pub ent_coef: f64,
    /// Value-loss coefficient `c_v` (default: 0.5).
    pub vf_coef: f64,
    /// Maximum global gradient norm (default: 0.5).
    pub max_grad_norm: f64,
    /// Normalise observations with running statistics (default: false).
    pub norm_obs: bool,
    /// Clip of normalised observations (default: 10.0).
    pub clip_obs: f64,
    /// Scale rewards by the running std of the discounted return (default: false).
    pub norm_reward: bool,
    /// Clip of scaled rewards (default: 10.0).
    pub clip_reward: f64,
    /// Bootstrap truncated episodes with `V(final observation)` (default: true).
    pub bootstrap_truncation: bool,
    /// Step the environments with the sampled actions clipped to the action bounds (the
    /// unclipped actions are what the loss sees) (default: true).
    pub clip_actions: bool,
    /// Actor hidden layer sizes (default: [64, 64]).
    pub actor_hidden: Vec<usize>,
    /// Critic hidden layer sizes (default: [64, 64]).
    pub critic_hidden: Vec<usize>,
    /// Hidden activation (default: "tanh").
    pub activation: Activation,
    /// Orthogonal initialisation (gains √2 / 0.01 / 1); off: PyTorch's default (default: true).
    pub ortho_init: bool,
    /// Initial log standard deviation (default: 0.0).
    pub log_std_init: f64,
    /// Updates between metrics records (default: 100).
    pub log_interval: u64,
}

impl Default for A2cConfig {
    fn default() -> Self {
        A2cConfig {
            seed: 0,
            n_steps: 5,
            learning_rate: 7e-4,
            critic_learning_rate: None,
            anneal_lr: false,
            lr_decay_steps: None,
            optimizer: OptimizerKind::Rmsprop,
            rmsprop_alpha: 0.99,
            optimizer_eps: 1e-5,
            gamma: 0.99,
            gae_lambda: 1.0,
            norm_adv: false,
            ent_coef: 0.0,
            vf_coef: 0.5,
            max_grad_norm: 0.5,
            norm_obs: false,
            clip_obs: 10.0,
            norm_reward: false,
            clip_reward: 10.0,
            bootstrap_truncation: true,
            clip_actions: true,
            actor_hidden: vec![64, 64],
            critic_hidden: vec![64, 64],
            activation: Activation::Tanh,
            ortho_init: true,
            log_std_init: 0.0,
            log_interval: 100,
        }
    }
}

impl A2cConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), RlError> {
        const A: &str = "a2c";
        check(self.n_steps > 0, A, "n_steps", self.n_steps, "must be positive")?;
        check(
            self.learning_rate.is_finite() && self.learning_rate > 0.0,
            A,
            "learning_rate",
            self.learning_rate,
            "must be positive",
        )?;
        check_critic_lr(A, self.critic_learning_rate)?;
        check(self.lr_decay_steps != Some(0), A, "lr_decay_steps", self.lr_decay_steps, "must be positive")?;
        check(
            (0.0..1.0).contains(&self.rmsprop_alpha),
            A,
            "rmsprop_alpha",
            self.rmsprop_alpha,
            "must be in [0, 1)",
        )?;
        check(
            self.optimizer_eps.is_finite() && self.optimizer_eps > 0.0,
            A,
            "optimizer_eps",
            self.optimizer_eps,
            "must be positive",
        )?;
        check((0.0..=1.0).contains(&self.gamma), A, "gamma", self.gamma, "must be in [0, 1]")?;
        check((0.0..=1.0).contains(&self.gae_lambda), A, "gae_lambda", self.gae_lambda, "must be in [0, 1]")?;
        check_loss_terms(A, self.ent_coef, self.vf_coef, self.max_grad_norm)?;
        check_norm_clips(A, self.clip_obs, self.clip_reward)?;
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
        check(self.log_std_init.is_finite(), A, "log_std_init", self.log_std_init, "must be finite")?;
        check(self.log_interval > 0, A, "log_interval", self.log_interval, "must be positive")?;
        Ok(())
    }
}

/// The optimiser state of the three parameter groups.
enum Optim {
    Adam([Adam; 3]),
    Rms([RmsProp; 3]),
}

/// Preallocated buffers of the rollout and update loops.
struct Work {
    /// Rollout collection (shared with PPO).
    collector: Collector,
    mb_adv: Vec<f32>,
    d_mean: Vec<f32>,
    d_value: Vec<f32>,
    d_mu: Vec<f32>,
    d_ls: Vec<f32>,
    actor_buf: MlpBuffers,
    critic_buf: MlpBuffers,
}
/// An A2C learner; see the module documentation.
pub struct A2c {
    config: A2cConfig,
    obs_space: BoxSpace,
    act_space: BoxSpace,
    n_envs: usize,
    actor: Mlp,
    log_std: Vec<f32>,
    log_std_grad: Vec<f32>,
    /// A rising floor under the exploration σ, if set ([`ExplorationFloor`]).
    exploration_floor: Option<ExplorationFloor>,
    critic: Mlp,
    optim: Optim,
    obs_rms: RunningMeanStd,
    reward_scaler: RewardScaler,
    rng: Rng,
    steps_done: u64,
    updates: u64,
    lr_horizon: Option<u64>,
    wall_time: f64,
    rollout: RolloutBuffer,
    work: Work,
}

impl A2c {
    /// A new learner for `n_envs` environments with the given spaces.
    pub fn new(
        config: A2cConfig,
        obs_space: &BoxSpace,
        act_space: &BoxSpace,
        n_envs: usize,
    ) -> Result<A2c, RlError> {
        config.validate()?;
        crate::error::check_sizes(
            "a2c",
            ("n_steps", config.n_steps, n_envs),
            obs_space.dim() + act_space.dim() + 8,
            &[("actor_hidden", &config.actor_hidden), ("critic_hidden", &config.critic_hidden)],
            obs_space.dim(),
            act_space.dim(),
            config.n_steps.saturating_mul(n_envs),
        )?;
        if n_envs == 0 {
            return Err(RlError::Incompatible {
                algo: "a2c",
                reason: "needs at least one environment".into(),
            });
        }
        let (od, ad) = (obs_space.dim(), act_space.dim());
        let mut rng = Rng::derive(config.seed, 1);
        let (actor_init, critic_init) = if config.ortho_init {
            (
                Init::Orthogonal { hidden_gain: 2f32.sqrt(), output_gain: 0.01 },
                Init::Orthogonal { hidden_gain: 2f32.sqrt(), output_gain: 1.0 },
            )
        } else {
            (Init::TorchDefault, Init::TorchDefault)
        };
        let sizes = |hidden: &[usize], out: usize| [&[od][..], hidden, &[out]].concat();
        let actor = Mlp::new(&sizes(&config.actor_hidden, ad), config.activation, actor_init, &mut rng);
        let critic = Mlp::new(&sizes(&config.critic_hidden, 1), config.activation, critic_init, &mut rng);
        let eps = config.optimizer_eps as f32;
        let sizes_p = [actor.n_params(), act_space.dim(), critic.n_params()];
        let optim = match config.optimizer {
            OptimizerKind::Adam => Optim::Adam(sizes_p.map(|n| Adam::new(n, eps))),
            OptimizerKind::Rmsprop => {
                Optim::Rms(sizes_p.map(|n| RmsProp::new(n, config.rmsprop_alpha as f32, eps)))
            }
        };
        let len = config.n_steps * n_envs;
        let cap = len;
        let b = len;
        let work = Work {
            collector: Collector::new(n_envs, od, ad),
            mb_adv: vec![0.0; b],
            d_mean: vec![0.0; b * ad],
            d_value: vec![0.0; b],
            d_mu: vec![0.0; ad],
            d_ls: vec![0.0; ad],
            actor_buf: actor.buffers(cap),
            critic_buf: critic.buffers(cap),
        };
        Ok(A2c {
            optim,
            log_std: vec![config.log_std_init as f32; ad],
            log_std_grad: vec![0.0; ad],
            exploration_floor: None,
            actor,
            critic,
            obs_rms: RunningMeanStd::new(od),
            reward_scaler: RewardScaler::new(n_envs, config.gamma, config.clip_reward),
            rng,
            steps_done: 0,
            updates: 0,
            lr_horizon: config.lr_decay_steps,
            wall_time: 0.0,
            rollout: RolloutBuffer::new(config.n_steps, n_envs, od, ad),
            work,
            obs_space: obs_space.clone(),
            act_space: act_space.clone(),
            n_envs,
            config,
        })
    }

    /// A learner for `env`'s spaces and number of environments.
    pub fn for_env(config: A2cConfig, env: &VecEnv) -> Result<A2c, RlError> {
        A2c::new(config, env.observation_space(), env.action_space(), env.len())
    }

    /// The configuration.
    pub fn config(&self) -> &A2cConfig {
        &self.config
    }

    /// The settings of a rollout.
    fn rollout_settings(&self) -> RolloutSettings {
        let c = &self.config;
        RolloutSettings {
            n_steps: c.n_steps,
            clip_actions: c.clip_actions,
            norm_obs: c.norm_obs,
            clip_obs: c.clip_obs,
            norm_reward: c.norm_reward,
            bootstrap_truncation: c.bootstrap_truncation,
        }
    }

    /// Collects one rollout of `n_steps × n_envs` transitions ([`Collector::collect`]).
    fn collect_rollout(&mut self, env: &mut VecEnv, episodes: &mut EpisodeWindow) -> Result<(), RlError> {
        let settings = self.rollout_settings();
        let mut nets = Nets {
            actor: &self.actor,
            actor_buf: &mut self.work.actor_buf,
            critic: &self.critic,
            critic_buf: &mut self.work.critic_buf,
        };
        let state = LearnerState {
            log_std: &self.log_std,
            rng: &mut self.rng,
            obs_rms: &mut self.obs_rms,
            reward_scaler: &mut self.reward_scaler,
            rollout: &mut self.rollout,
            steps_done: &mut self.steps_done,
        };
        self.work.collector.collect(
            &mut nets,
            &settings,
            state,
            &self.obs_space,
            &self.act_space,
            env,
            episodes,
        )
    }

    /// n-step returns and advantages `R − V` of the stored rollout (GAE below λ = 1).
    fn compute_advantages(&mut self) {
        let r = &mut self.rollout;
        if self.config.gae_lambda < 1.0 {
            gae(
                &r.rewards,
                &r.values,
                &r.ends,
                &r.final_values,
                &self.work.collector.last_values,
                self.config.gamma as f32,
                self.config.gae_lambda as f32,
                &mut r.advantages,
                &mut r.returns,
            );
            return;
        }
        n_step_returns(
            &r.rewards,
            &r.ends,
            &r.final_values,
            &self.work.collector.last_values,
            self.config.gamma as f32,
            &mut r.returns,
        );
        for k in 0..r.len() {
            r.advantages[k] = r.returns[k] - r.values[k];
        }
    }

    /// One gradient step on the whole rollout; fills the loss metrics.
    fn update(&mut self, lr: f32, lr_critic: f32, m: &mut UpdateMetrics) -> Result<(), RlError> {
        let ad = self.act_space.dim();
        let b = self.rollout.len();
        let (ent_coef, vf_coef) = (self.config.ent_coef as f32, self.config.vf_coef as f32);
        let w = &mut self.work;
        let r = &self.rollout;
        w.mb_adv.copy_from_slice(&r.advantages);
        if self.config.norm_adv && b > 1 {
            let mean = w.mb_adv.iter().map(|a| *a as f64).sum::<f64>() / b as f64;
            let var = w.mb_adv.iter().map(|a| (*a as f64 - mean).powi(2)).sum::<f64>() / (b - 1) as f64;
            let inv = 1.0 / (var.sqrt() + 1e-8);
            w.mb_adv.iter_mut().for_each(|a| *a = ((*a as f64 - mean) * inv) as f32);
        }

        // Policy loss −mean[Â log π(a|s)]: ∂/∂log π_j = −Â_j / B.
        let mean = self.actor.forward(&mut w.actor_buf, &r.obs, b);
        self.log_std_grad.fill(0.0);
        let mut pg = 0.0f64;
        for j in 0..b {
            let (a, mu) = (&r.actions[j * ad..(j + 1) * ad], &mean[j * ad..(j + 1) * ad]);
            let logp = gaussian_log_prob(a, mu, &self.log_std);
            pg -= (w.mb_adv[j] * logp) as f64;
            let d_logp = -w.mb_adv[j] / b as f32;
            gaussian_log_prob_grad(a, mu, &self.log_std, &mut w.d_mu, &mut w.d_ls);
            for i in 0..ad {
                w.d_mean[j * ad + i] = d_logp * w.d_mu[i];
                self.log_std_grad[i] += d_logp * w.d_ls[i];
            }
        }
        let entropy = gaussian_entropy(&self.log_std);
        self.log_std_grad.iter_mut().for_each(|g| *g -= ent_coef);
        self.actor.backward(&mut w.actor_buf, &r.obs, &w.d_mean, b, None);

        // Value loss c_v mean[(V − R)²]: ∂/∂V_j = 2 c_v (V_j − R_j) / B.
        let v = self.critic.forward(&mut w.critic_buf, &r.obs, b);
        let mut vl = 0.0f64;
        for j in 0..b {
            let d = v[j] - r.returns[j];
            vl += (d * d) as f64;
            w.d_value[j] = 2.0 * vf_coef * d / b as f32;
        }
        self.critic.backward(&mut w.critic_buf, &r.obs, &w.d_value, b, None);

        let (pg, vl) = (pg / b as f64, vl / b as f64);
        let loss = pg + vf_coef as f64 * vl - ent_coef as f64 * entropy as f64;
        if !loss.is_finite() {
            return Err(RlError::Diverged { algo: "a2c", update: self.updates + 1, what: "loss" });
        }
        clip_grad_norm(
            &mut [&mut self.actor.grads, &mut self.log_std_grad, &mut self.critic.grads],
            self.config.max_grad_norm as f32,
        );
        match &mut self.optim {
            Optim::Adam([a, l, c]) => {
                a.step(&mut self.actor.params, &self.actor.grads, lr);
                l.step(&mut self.log_std, &self.log_std_grad, lr);
                c.step(&mut self.critic.params, &self.critic.grads, lr_critic);
            }
            Optim::Rms([a, l, c]) => {
                a.step(&mut self.actor.params, &self.actor.grads, lr);
                l.step(&mut self.log_std, &self.log_std_grad, lr);
                c.step(&mut self.critic.params, &self.critic.grads, lr_critic);
            }
        }
        m.policy_loss = pg;
        m.value_loss = vl;
        m.entropy = entropy as f64;
        Ok(())
    }

    /// `1 − Var(R − V) / Var(R)` over the rollout.
    fn explained_variance(&self) -> f64 {
        let r = &self.rollout;
        let n = r.len() as f64;
        let mean = |f: &dyn Fn(usize) -> f64| (0..r.len()).map(f).sum::<f64>() / n;
        let mr = mean(&|k| r.returns[k] as f64);
        let var_r = mean(&|k| (r.returns[k] as f64 - mr).powi(2));
        let md = mean(&|k| (r.returns[k] - r.values[k]) as f64);
        let var_d = mean(&|k| ((r.returns[k] - r.values[k]) as f64 - md).powi(2));
        if var_r == 0.0 { f64::NAN } else { 1.0 - var_d / var_r }
    }

    fn check_env(&self, env: &VecEnv) -> Result<(), RlError> {
        if env.observation_space() != &self.obs_space || env.action_space() != &self.act_space {
            return Err(RlError::Incompatible {
                algo: "a2c",
                reason: "observation or action space differs".into(),
            });
        }
        if env.len() != self.n_envs {
            return Err(RlError::Incompatible {
                algo: "a2c",
                reason: format!("learner built for {} environments, VecEnv has {}", self.n_envs, env.len()),
            });
        }
        Ok(())
    }

    /// Reads a learner saved by [`Algorithm::save`].
    pub fn load(path: &std::path::Path) -> Result<A2c, RlError> {
        A2c::from_checkpoint(&Checkpoint::read(path)?)
    }

    /// A learner from an in-memory checkpoint.
    pub fn from_checkpoint(c: &Checkpoint) -> Result<A2c, RlError> {
        c.expect_algo("a2c")?;
        let config: A2cConfig = c.get_meta("config")?;
        let n_envs: usize = c.get_meta("n_envs")?;
        let obs_space = c.read_space("obs_space")?;
        let act_space = c.read_space("act_space")?;
        let mut p = A2c::new(config, &obs_space, &act_space, n_envs)?;
        c.read_mlp("actor", &mut p.actor)?;
        c.read_mlp("critic", &mut p.critic)?;
        c.read_f32_into("log_std", &mut p.log_std)?;
        p.exploration_floor = ExplorationFloor::read(c, "a2c", p.act_space.dim())?;
        match &mut p.optim {
            Optim::Adam([a, l, cr]) => {
                c.read_adam("adam/actor", a)?;
                c.read_adam("adam/log_std", l)?;
                c.read_adam("adam/critic", cr)?;
            }
            Optim::Rms(opts) => {
                for (name, o) in
                    ["rmsprop/actor", "rmsprop/log_std", "rmsprop/critic"].into_iter().zip(opts.iter_mut())
                {
                    let sq = c.f32(name, Some(o.square_avg().len()))?;
                    o.restore(sq);
                }
            }
        }
        c.read_rms("obs_rms", &mut p.obs_rms)?;
        c.read_rms("return_rms", &mut p.reward_scaler.stats)?;
        p.reward_scaler.returns.copy_from_slice(c.f64("discounted_returns", Some(n_envs))?);
        p.rng = c.read_rng("rng")?;
        p.steps_done = c.get_meta("steps_done")?;
        p.updates = c.get_meta("updates")?;
        p.lr_horizon = c.get_meta("lr_horizon")?;
        p.wall_time = c.get_meta("wall_time")?;
        Ok(p)
    }
}

impl Algorithm for A2c {
    fn name(&self) -> &'static str {
        "a2c"
    }

    fn learn(
        &mut self,
        env: &mut VecEnv,
        total_steps: u64,
        callback: &mut dyn FnMut(&UpdateMetrics) -> ControlFlow<()>,
    ) -> Result<(), RlError> {
        self.check_env(env)?;
        let horizon = *self.lr_horizon.get_or_insert(total_steps.max(1));
        // Continue a live VecEnv, or reset a fresh one.
        let settings = self.rollout_settings();
        let seed = self.config.seed.wrapping_add(self.steps_done);
        self.work.collector.start(env, &settings, &mut self.obs_rms, seed)?;
        let mut episodes = EpisodeWindow::default();
        let (mut window_start, mut window_time) = (self.steps_done, 0.0);
        while self.steps_done < total_steps {
            let t0 = Instant::now();
            let (c, done) = (&self.config, self.steps_done);
            let anneal = |lr0: f64| if c.anneal_lr { linear_decay(lr0, done, horizon) } else { lr0 };
            let lr = anneal(c.learning_rate);
            let lr_critic = anneal(c.critic_learning_rate.unwrap_or(c.learning_rate));
            if let Some(floor) = &self.exploration_floor {
                floor.apply(&mut self.log_std, self.steps_done);
            }
            env.set_training_samples(self.steps_done);
            self.collect_rollout(env, &mut episodes)?;
            self.compute_advantages();
            let mut m = UpdateMetrics::empty();
            m.explained_variance = self.explained_variance();
            m.value_mean = self.rollout.mean_value();
            self.update(lr as f32, lr_critic as f32, &mut m)?;
            self.updates += 1;
            let dt = t0.elapsed().as_secs_f64();
            self.wall_time += dt;
            window_time += dt;
            if self.updates.is_multiple_of(self.config.log_interval) || self.steps_done >= total_steps {
                m.update = self.updates;
                m.env_steps = self.steps_done;
                m.wall_time = self.wall_time;
                m.steps_per_second = (self.steps_done - window_start) as f64 / window_time.max(1e-9);
                m.learning_rate = lr;
                m.critic_learning_rate = lr_critic;
                m.reward_mean = self.work.collector.take_reward_mean();
                episodes.drain_into(&mut m);
                window_start = self.steps_done;
                window_time = 0.0;
                if callback(&m).is_break() {
                    break;
                }
            }
        }
        Ok(())
    }

    fn to_checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::new("a2c");
        c.set_meta("config", &self.config);
        c.set_meta("n_envs", self.n_envs);
        c.set_meta("steps_done", self.steps_done);
        c.set_meta("updates", self.updates);
        c.set_meta("lr_horizon", self.lr_horizon);
        c.set_meta("wall_time", self.wall_time);
        c.put_space("obs_space", &self.obs_space);
        c.put_space("act_space", &self.act_space);
        c.put_f32("actor", &self.actor.params);
        c.put_f32("critic", &self.critic.params);
        c.put_f32("log_std", &self.log_std);
        ExplorationFloor::write(&self.exploration_floor, &mut c);
        match &self.optim {
            Optim::Adam([a, l, cr]) => {
                c.put_adam("adam/actor", a);
                c.put_adam("adam/log_std", l);
                c.put_adam("adam/critic", cr);
            }
            Optim::Rms([a, l, cr]) => {
                c.put_f32("rmsprop/actor", a.square_avg());
                c.put_f32("rmsprop/log_std", l.square_avg());
                c.put_f32("rmsprop/critic", cr.square_avg());
            }
        }
        c.put_rms("obs_rms", &self.obs_rms);
        c.put_rms("return_rms", &self.reward_scaler.stats);
        c.put_f64("discounted_returns", &self.reward_scaler.returns);
        c.put_rng("rng", &self.rng);
        self.policy().write_to(&mut c);
        c
    }

    fn policy(&self) -> Policy {
        let norm = self.config.norm_obs.then(|| ObsNorm {
            mean: self.obs_rms.mean.clone(),
            var: self.obs_rms.var.clone(),
            clip: self.config.clip_obs,
        });
        Policy::new(PolicyHead::GaussianMean, self.actor.clone(), norm, &self.act_space)
    }

    fn zero_policy_output(&mut self) {
        self.actor.zero_output_rows(0..self.act_space.dim());
    }

    fn set_exploration_std(&mut self, std: &[f64]) -> Result<(), RlError> {
        self.log_std = crate::algorithm::exploration_log_std("a2c", std, self.act_space.dim())?;
        Ok(())
    }

    fn set_exploration_floor(&mut self, floor: ExplorationFloor) -> Result<(), RlError> {
        floor.validate("a2c", self.act_space.dim())?;
        self.exploration_floor = Some(floor);
        Ok(())
    }

    fn steps_done(&self) -> u64 {
        self.steps_done
    }
}

/// A2C's networks as the collector sees them.
struct Nets<'a> {
    actor: &'a Mlp,
    actor_buf: &'a mut MlpBuffers,
    critic: &'a Mlp,
    critic_buf: &'a mut MlpBuffers,
}

impl PolicyValue for Nets<'_> {
    fn mean(&mut self, obs: &[f32], n: usize) -> &[f32] {
        self.actor.forward(self.actor_buf, obs, n)
    }
    fn value(&mut self, obs: &[f32], n: usize) -> &[f32] {
        self.critic.forward(self.critic_buf, obs, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use centaur_gym::Env;
    use centaur_gym::pendulum::Pendulum;

    /// At λ = 1 the advantages are the n-step returns less the values; below 1 they are
    /// GAE(γ, λ) of the same rollout, as [`gae`] computes it, and differ.
    #[test]
    fn a_gae_lambda_below_one_gives_gae_advantages() {
        let mut env =
            VecEnv::new((0..2).map(|_| Box::new(Pendulum::new()) as Box<dyn Env>).collect(), 1).unwrap();
        let mut a2c = A2c::for_env(A2cConfig { n_steps: 16, ..A2cConfig::default() }, &env).unwrap();
        let settings = a2c.rollout_settings();
        a2c.work.collector.start(&mut env, &settings, &mut a2c.obs_rms, 0).unwrap();
        a2c.collect_rollout(&mut env, &mut EpisodeWindow::default()).unwrap();
        a2c.compute_advantages();
        let r = &a2c.rollout;
        let n_step: Vec<f32> = (0..r.len()).map(|k| r.returns[k] - r.values[k]).collect();
        assert_eq!(r.advantages, n_step);
        a2c.config.gae_lambda = 0.9;
        a2c.compute_advantages();
        let r = &a2c.rollout;
        let (mut advantages, mut returns) = (vec![0.0; r.len()], vec![0.0; r.len()]);
        let last = &a2c.work.collector.last_values;
        gae(&r.rewards, &r.values, &r.ends, &r.final_values, last, 0.99, 0.9, &mut advantages, &mut returns);
        assert_eq!((&r.advantages, &r.returns), (&advantages, &returns));
        assert_ne!(r.advantages, n_step);
        assert_eq!(r.len(), 32);
        // Out of [0, 1]: refused, naming the key.
        let bad = A2cConfig { gae_lambda: 1.5, ..A2cConfig::default() }.validate().unwrap_err();
        assert!(bad.to_string().contains("gae_lambda"), "{bad}");
    }
}
