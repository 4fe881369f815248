//! Proximal Policy Optimization (Schulman et al. 2017, "Proximal Policy Optimization
//! Algorithms", arXiv:1707.06347) for continuous actions, with the code-level details of
//! Huang et al. 2022, "The 37 Implementation Details of Proximal Policy Optimization"
//! (ICLR blog track), section "continuous action domains" — each of which can be switched
//! off in [`PpoConfig`] to rerun ablations (Engstrom et al. 2020; Andrychowicz et al. 2021):
//!
//! | detail | config switch |
//! |---|---|
//! | separate actor and critic networks (off: one trunk, two linear heads) | `separate_networks` |
//! | orthogonal init, gains √2 / 0.01 (policy) / 1 (value), zero biases | `ortho_init` |
//! | Adam with ε = 10⁻⁵ | `adam_eps` |
//! | linear learning-rate annealing to 0 | `anneal_lr` |
//! | a critic-only burn-in before the actor learns (residual RL; not in the 37 details) | `actor_burn_in_steps` |
//! | GAE(λ) (Schulman et al. 2016, eq. 16) | `gae` (off: Monte-Carlo n-step returns) |
//! | minibatch updates over `n_epochs` shuffled epochs | `n_epochs`, `batch_size` |
//! | advantage normalisation per minibatch | `norm_adv` |
//! | clipped surrogate objective (eq. 7) | `clip_policy` |
//! | clipped value loss | `clip_vloss` |
//! | entropy bonus (eq. 9) | `ent_coef` |
//! | global gradient clipping at 0.5 | `clip_grad_norm` |
//! | state-independent log-std, Gaussian actions | `log_std_init` |
//! | actions clipped to the bounds for the env, unclipped action stored | `clip_actions` |
//! | observation normalisation, clipped to ±10 | `norm_obs`, `clip_obs` |
//! | reward scaling by the discounted return's std, clipped to ±10 | `norm_reward`, `clip_reward` |
//! | approximate-KL tracking, optional early stop at a target KL | `target_kl` |
//! | adaptive KL penalty (Schulman et al. 2017, section 4), the paper's second variant | `kl_penalty`, `kl_target`, `kl_coef_init` |
//! | bootstrapping from the final observation on truncation | `bootstrap_truncation` |
//!
//! ## The loss
//!
//! With `r_t(θ) = π_θ(a_t|s_t) / π_old(a_t|s_t)` and advantages `Â_t`, per minibatch
//!
//! ```text
//! L = −mean[min(r Â, clip(r, 1−ε, 1+ε) Â)]              (policy, eq. 7)
//!     + c_v · ½ mean[max((V − R)², (V_old + clip(V − V_old, −ε, ε) − R)²)]  (value)
//!     − c_e · H[π]                                         (entropy)
//! ```
//!
//! minimised by Adam on the actor, log-std and critic parameters jointly (one global
//! gradient norm). `approx_kl = mean[(r − 1) − log r]` (Schulman's k3 estimator);
//! when it exceeds `target_kl` after an epoch, the remaining epochs are skipped (CleanRL).
//!
//! ## The adaptive KL penalty
//!
//! With `kl_penalty` the policy loss gains `β · KL[π_old ‖ π_θ]` (eq. 8 of the paper),
//! estimated per minibatch as `mean[log π_old(a|s) − log π_θ(a|s)]` over the rollout's
//! actions, which are drawn from `π_old`: its expectation is the KL and its gradient,
//! `−β · mean[∇ log π_θ(a|s)]`, is an unbiased estimate of the KL's gradient. After each
//! update `β` adapts to the measured KL `d` (the k3 estimate averaged over the last epoch's
//! minibatches): `β ← β/2` if `d < kl_target/1.5`, `β ← 2β` if `d > 1.5 · kl_target`. The
//! paper's variant has no clipping: `kl_penalty = true, clip_policy = false`; with both on,
//! the penalty is added to the clipped surrogate. `β` is logged as `kl_coef` and kept in
//! checkpoints.

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
use crate::optim::{Adam, clip_grad_norm, linear_decay};
use crate::policy::{ObsNorm, Policy, PolicyHead};
use centaur_gym::Rng;
use centaur_gym::{BoxSpace, VecEnv};

/// PPO hyperparameters. Defaults: CleanRL's `ppo_continuous_action.py` (= the 37 details),
/// which match Stable-Baselines3's PPO except for learning-rate annealing, value clipping
/// and the normalisation wrappers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PpoConfig {
    /// Seed of the network initialisation, action sampling, minibatch shuffling and
    /// environment resets (default: 0).
    pub seed: u64,
    /// Steps per environment per rollout; a rollout holds `n_steps × n_envs` transitions
    /// (default: 2048).
    pub n_steps: usize,
    /// Minibatch size (default: 64).
    pub batch_size: usize,
    /// Passes over each rollout (default: 10).
    pub n_epochs: usize,
    /// Adam learning rate, the initial one if annealed (default: 3e-4).
    pub learning_rate: f64,
    /// The critic's learning rate (the value network, or the value head on a shared
    /// trunk, which itself learns at `learning_rate`), annealed alike; unset: the same as
    /// `learning_rate` (default: unset).
    pub critic_learning_rate: Option<f64>,
    /// Critic burn-in: for the first this many environment steps only the critic learns;
    /// the actor, its log-std (and a shared trunk) keep their parameters and their
    /// optimisers do not step (logged learning rate 0; an exploration floor still raises
    /// the log-std; the actor's gradients are still computed, then dropped, and count in
    /// the global gradient-norm clip, as after the burn-in). For a policy that starts at a good
    /// controller's gait (residual RL), whose first updates would otherwise follow the
    /// advantages of a critic that has not yet learnt that gait's value (Silver et al.
    /// 2018, "Residual Policy Learning", arXiv:1812.06298, section 4). Must be below the
    /// learning-rate horizon (default: 0, no burn-in).
    pub actor_burn_in_steps: u64,
    /// Anneal the learning rate linearly to 0 (default: true).
    pub anneal_lr: bool,
    /// Environment steps over which the learning rate anneals; unset means the
    /// `total_steps` of the first `learn` call (default: unset).
    pub lr_decay_steps: Option<u64>,
    /// Adam ε (default: 1e-5).
    pub adam_eps: f64,
    /// Discount γ (default: 0.99).
    pub gamma: f64,
    /// Use GAE(λ); off: advantages from n-step returns, `R − V` (default: true).
    pub gae: bool,
    /// GAE λ (default: 0.95).
    pub gae_lambda: f64,
    /// Normalise advantages per minibatch (default: true).
    pub norm_adv: bool,
    /// Surrogate clipping ε, also the value-clipping range (default: 0.2).
    pub clip_coef: f64,
    /// Use the clipped surrogate; off: the plain ratio objective `−r Â` (default: true).
    pub clip_policy: bool,
    /// Clip the value loss around the rollout's values (default: true).
    pub clip_vloss: bool,
    /// Entropy coefficient `c_e` (default: 0.0).
    pub ent_coef: f64,
    /// Value-loss coefficient `c_v` (default: 0.5).
    pub vf_coef: f64,
    /// Clip the global gradient norm (default: true).
    pub clip_grad_norm: bool,
    /// Maximum global gradient norm (default: 0.5).
    pub max_grad_norm: f64,
    /// Stop an update's epochs once the approximate KL exceeds this; unset: never
    /// (default: unset).
    pub target_kl: Option<f64>,
    /// Add the adaptive KL penalty `β · KL[π_old ‖ π_θ]` to the policy loss (see the module
    /// docs) (default: false).
    pub kl_penalty: bool,
    /// The penalty's target KL `d_targ` (default: 0.01).
    pub kl_target: f64,
    /// The penalty's initial coefficient `β` (default: 1.0).
    pub kl_coef_init: f64,
    /// Normalise observations with running statistics (default: true).
    pub norm_obs: bool,
    /// Clip of normalised observations (default: 10.0).
    pub clip_obs: f64,
    /// Scale rewards by the running std of the discounted return (default: true).
    pub norm_reward: bool,
    /// Clip of scaled rewards (default: 10.0).
    pub clip_reward: f64,
    /// Clip sampled actions to the action bounds before stepping the env (the unclipped
    /// action is stored for the update) (default: true).
    pub clip_actions: bool,
    /// Bootstrap truncated episodes with `V(final observation)`; off: treat them as
    /// terminal (default: true).
    pub bootstrap_truncation: bool,
    /// Separate actor and critic networks; off: one trunk of `actor_hidden` layers
    /// feeding a linear mean head and a linear value head (`critic_hidden` unused), trained
    /// on the joint loss (default: true).
    pub separate_networks: bool,
    /// Actor hidden layer sizes (default: [64, 64]).
    pub actor_hidden: Vec<usize>,
    /// Critic hidden layer sizes (default: [64, 64]).
    pub critic_hidden: Vec<usize>,
    /// Hidden activation (default: "tanh").
    pub activation: Activation,
    /// Orthogonal initialisation; off: PyTorch's default init (default: true).
    pub ortho_init: bool,
    /// Initial log standard deviation of the Gaussian policy (default: 0.0).
    pub log_std_init: f64,
}

impl Default for PpoConfig {
    fn default() -> Self {
        PpoConfig {
            seed: 0,
            n_steps: 2048,
            batch_size: 64,
            n_epochs: 10,
            learning_rate: 3e-4,
            critic_learning_rate: None,
            actor_burn_in_steps: 0,
            anneal_lr: true,
            lr_decay_steps: None,
            adam_eps: 1e-5,
            gamma: 0.99,
            gae: true,
            gae_lambda: 0.95,
            norm_adv: true,
            clip_coef: 0.2,
            clip_policy: true,
            clip_vloss: true,
            ent_coef: 0.0,
            vf_coef: 0.5,
            clip_grad_norm: true,
            max_grad_norm: 0.5,
            target_kl: None,
            kl_penalty: false,
            kl_target: 0.01,
            kl_coef_init: 1.0,
            norm_obs: true,
            clip_obs: 10.0,
            norm_reward: true,
            clip_reward: 10.0,
            clip_actions: true,
            bootstrap_truncation: true,
            separate_networks: true,
            actor_hidden: vec![64, 64],
            critic_hidden: vec![64, 64],
            activation: Activation::Tanh,
            ortho_init: true,
            log_std_init: 0.0,
        }
    }
}

impl PpoConfig {
    /// PPO for the Minitaur: RL Zoo's `MinitaurBulletEnv-v0` settings (normalised
    /// observations and rewards, `n_steps` 2048 per env, 10 epochs, learning rate 2.5e-4,
    /// clip 0.2, λ 0.95, no entropy bonus), with minibatches of 512 and γ 0.995 instead of
    /// 0.99. The Minitaur's reward has no survival bonus, so at γ 0.99 (a horizon of about
    /// 1 s) a fall costs little: residual PPO learned a 1.24 m/s gait that fell in 9 of 10
    /// evaluation episodes (return 6.6); at γ 0.995 it keeps the speed and falls once
    /// (return 11.6, seed 0, 300k steps).
    pub fn minitaur() -> Self {
        PpoConfig {
            n_steps: 2048,
            batch_size: 512,
            n_epochs: 10,
            learning_rate: 2.5e-4,
            clip_coef: 0.2,
            gae_lambda: 0.95,
            gamma: 0.995,
            ent_coef: 0.0,
            ..PpoConfig::default()
        }
    }
}

impl PpoConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), RlError> {
        const A: &str = "ppo";
        check(self.n_steps > 0, A, "n_steps", self.n_steps, "must be positive")?;
        check(self.batch_size > 0, A, "batch_size", self.batch_size, "must be positive")?;
        check(self.n_epochs > 0, A, "n_epochs", self.n_epochs, "must be positive")?;
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
            self.lr_decay_steps.is_none_or(|h| self.actor_burn_in_steps < h),
            A,
            "actor_burn_in_steps",
            self.actor_burn_in_steps,
            "must be below `lr_decay_steps`",
        )?;
        check(
            self.adam_eps.is_finite() && self.adam_eps > 0.0,
            A,
            "adam_eps",
            self.adam_eps,
            "must be positive",
        )?;
        check((0.0..=1.0).contains(&self.gamma), A, "gamma", self.gamma, "must be in [0, 1]")?;
        check((0.0..=1.0).contains(&self.gae_lambda), A, "gae_lambda", self.gae_lambda, "must be in [0, 1]")?;
        check(
            self.clip_coef.is_finite() && self.clip_coef > 0.0,
            A,
            "clip_coef",
            self.clip_coef,
            "must be positive",
        )?;
        check_loss_terms(A, self.ent_coef, self.vf_coef, self.max_grad_norm)?;
        check(
            self.target_kl.is_none_or(|k| k.is_finite() && k > 0.0),
            A,
            "target_kl",
            format_args!("{}", self.target_kl.unwrap_or_default()),
            "must be positive",
        )?;
        check(
            self.kl_target.is_finite() && self.kl_target > 0.0,
            A,
            "kl_target",
            self.kl_target,
            "must be positive",
        )?;
        check(
            self.kl_coef_init.is_finite() && self.kl_coef_init >= 0.0,
            A,
            "kl_coef_init",
            self.kl_coef_init,
            "must be ≥ 0",
        )?;
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
        Ok(())
    }
}

/// Preallocated buffers of the rollout and update loops.
struct Work {
    /// Rollout collection (shared with A2C).
    collector: Collector,
    indices: Vec<usize>,
    mb_obs: Vec<f32>,
    mb_actions: Vec<f32>,
    mb_log_probs: Vec<f32>,
    mb_adv: Vec<f32>,
    mb_returns: Vec<f32>,
    mb_values: Vec<f32>,
    d_mean: Vec<f32>,
    d_value: Vec<f32>,
    d_mu: Vec<f32>,
    d_ls: Vec<f32>,
    actor_buf: MlpBuffers,
    critic_buf: MlpBuffers,
    trunk_buf: MlpBuffers,
    /// `∂ℓ/∂features` from the two heads (shared trunk only).
    d_feat: Vec<f32>,
    d_feat_critic: Vec<f32>,
}

/// Loss terms of one minibatch.
#[derive(Clone, Copy, Debug)]
struct MinibatchLoss {
    policy_loss: f64,
    value_loss: f64,
    entropy: f64,
    approx_kl: f64,
    clip_fraction: f64,
}

/// A PPO learner; see the module documentation.
pub struct Ppo {
    config: PpoConfig,
    obs_space: BoxSpace,
    act_space: BoxSpace,
    n_envs: usize,
    /// The mean network, or the mean head on `trunk`.
    actor: Mlp,
    log_std: Vec<f32>,
    log_std_grad: Vec<f32>,
    /// A rising floor under the exploration σ, if set ([`ExplorationFloor`]).
    exploration_floor: Option<ExplorationFloor>,
    /// The KL penalty's coefficient `β` (used with `kl_penalty`).
    kl_coef: f64,
    /// The value network, or the value head on `trunk`.
    critic: Mlp,
    /// The shared feature trunk when `separate_networks` is off.
    trunk: Option<Mlp>,
    opt_trunk: Adam,
    opt_actor: Adam,
    opt_log_std: Adam,
    opt_critic: Adam,
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

impl Ppo {
    /// A new learner for `n_envs` environments with the given spaces.
    pub fn new(
        config: PpoConfig,
        obs_space: &BoxSpace,
        act_space: &BoxSpace,
        n_envs: usize,
    ) -> Result<Ppo, RlError> {
        config.validate()?;
        crate::error::check_sizes(
            "ppo",
            ("n_steps", config.n_steps, n_envs),
            obs_space.dim() + act_space.dim() + 8,
            &[("actor_hidden", &config.actor_hidden), ("critic_hidden", &config.critic_hidden)],
            obs_space.dim(),
            act_space.dim(),
            config.batch_size.max(n_envs),
        )?;
        if n_envs == 0 {
            return Err(RlError::Incompatible {
                algo: "ppo",
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
        let (trunk, actor, critic) = if config.separate_networks {
            let actor = Mlp::new(&sizes(&config.actor_hidden, ad), config.activation, actor_init, &mut rng);
            let critic = Mlp::new(&sizes(&config.critic_hidden, 1), config.activation, critic_init, &mut rng);
            (None, actor, critic)
        } else {
            // Trunk: every layer is hidden (gain √2); heads: the output gains.
            let trunk_init = match actor_init {
                Init::Orthogonal { hidden_gain, .. } => {
                    Init::Orthogonal { hidden_gain, output_gain: hidden_gain }
                }
                other => other,
            };
            let trunk_sizes = [&[od][..], &config.actor_hidden].concat();
            let trunk =
                Mlp::new(&trunk_sizes, config.activation, trunk_init, &mut rng).with_output_activation();
            let f = trunk.n_out();
            let actor = Mlp::new(&[f, ad], config.activation, actor_init, &mut rng);
            let critic = Mlp::new(&[f, 1], config.activation, critic_init, &mut rng);
            (Some(trunk), actor, critic)
        };
        let trunk_params = trunk.as_ref().map_or(0, |t| t.n_params());
        let feat = trunk.as_ref().map_or(0, |t| t.n_out());
        let eps = config.adam_eps as f32;
        let len = config.n_steps * n_envs;
        let cap = n_envs.max(config.batch_size.min(len));
        let b = config.batch_size.min(len);
        let work = Work {
            collector: Collector::new(n_envs, od, ad),
            indices: (0..len).collect(),
            mb_obs: vec![0.0; b * od],
            mb_actions: vec![0.0; b * ad],
            mb_log_probs: vec![0.0; b],
            mb_adv: vec![0.0; b],
            mb_returns: vec![0.0; b],
            mb_values: vec![0.0; b],
            d_mean: vec![0.0; b * ad],
            d_value: vec![0.0; b],
            d_mu: vec![0.0; ad],
            d_ls: vec![0.0; ad],
            actor_buf: actor.buffers(cap),
            critic_buf: critic.buffers(cap),
            trunk_buf: trunk
                .as_ref()
                .map_or_else(|| Mlp::zeros(&[1, 1], config.activation).buffers(0), |t| t.buffers(cap)),
            d_feat: vec![0.0; feat * b],
            d_feat_critic: vec![0.0; feat * b],
        };
        Ok(Ppo {
            opt_trunk: Adam::new(trunk_params, eps),
            trunk,
            opt_actor: Adam::new(actor.n_params(), eps),
            opt_log_std: Adam::new(ad, eps),
            opt_critic: Adam::new(critic.n_params(), eps),
            log_std: vec![config.log_std_init as f32; ad],
            log_std_grad: vec![0.0; ad],
            exploration_floor: None,
            kl_coef: config.kl_coef_init,
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
    pub fn for_env(config: PpoConfig, env: &VecEnv) -> Result<Ppo, RlError> {
        Ppo::new(config, env.observation_space(), env.action_space(), env.len())
    }

    /// The configuration.
    pub fn config(&self) -> &PpoConfig {
        &self.config
    }

    /// `μ(s)` for a batch, through the shared trunk if there is one.
    fn actor_forward<'b>(
        trunk: Option<&Mlp>,
        trunk_buf: &'b mut MlpBuffers,
        actor: &Mlp,
        actor_buf: &'b mut MlpBuffers,
        obs: &[f32],
        b: usize,
    ) -> &'b [f32] {
        match trunk {
            None => actor.forward(actor_buf, obs, b),
            Some(t) => actor.forward(actor_buf, t.forward(trunk_buf, obs, b), b),
        }
    }

    /// `V(s)` for a batch, through the shared trunk if there is one.
    fn critic_forward<'b>(
        trunk: Option<&Mlp>,
        trunk_buf: &'b mut MlpBuffers,
        critic: &Mlp,
        critic_buf: &'b mut MlpBuffers,
        obs: &[f32],
        b: usize,
    ) -> &'b [f32] {
        match trunk {
            None => critic.forward(critic_buf, obs, b),
            Some(t) => critic.forward(critic_buf, t.forward(trunk_buf, obs, b), b),
        }
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
        let w = &mut self.work;
        let mut nets = Nets {
            trunk: self.trunk.as_ref(),
            trunk_buf: &mut w.trunk_buf,
            actor: &self.actor,
            actor_buf: &mut w.actor_buf,
            critic: &self.critic,
            critic_buf: &mut w.critic_buf,
        };
        let state = LearnerState {
            log_std: &self.log_std,
            rng: &mut self.rng,
            obs_rms: &mut self.obs_rms,
            reward_scaler: &mut self.reward_scaler,
            rollout: &mut self.rollout,
            steps_done: &mut self.steps_done,
        };
        w.collector.collect(&mut nets, &settings, state, &self.obs_space, &self.act_space, env, episodes)
    }

    /// Advantages and value targets of the stored rollout.
    fn compute_advantages(&mut self) {
        let r = &mut self.rollout;
        let gamma = self.config.gamma as f32;
        if self.config.gae {
            let lambda = self.config.gae_lambda as f32;
            gae(
                &r.rewards,
                &r.values,
                &r.ends,
                &r.final_values,
                &self.work.collector.last_values,
                gamma,
                lambda,
                &mut r.advantages,
                &mut r.returns,
            );
        } else {
            n_step_returns(
                &r.rewards,
                &r.ends,
                &r.final_values,
                &self.work.collector.last_values,
                gamma,
                &mut r.returns,
            );
            for k in 0..r.len() {
                r.advantages[k] = r.returns[k] - r.values[k];
            }
        }
    }

    /// The loss of one minibatch (in `work.mb_*`, first `b` entries) and its gradients in
    /// `actor.grads`, `log_std_grad` and `critic.grads` (see the module doc for `L`).
    fn minibatch_gradients(&mut self, b: usize) -> MinibatchLoss {
        let (od, ad) = (self.obs_space.dim(), self.act_space.dim());
        let clip = self.config.clip_coef as f32;
        let (ent_coef, vf_coef) = (self.config.ent_coef as f32, self.config.vf_coef as f32);
        let w = &mut self.work;
        // Advantage normalisation with the unbiased std (as torch's `.std()`).
        if self.config.norm_adv && b > 1 {
            let adv = &mut w.mb_adv[..b];
            let mean = adv.iter().map(|a| *a as f64).sum::<f64>() / b as f64;
            let var = adv.iter().map(|a| (*a as f64 - mean).powi(2)).sum::<f64>() / (b - 1) as f64;
            let inv = 1.0 / (var.sqrt() + 1e-8);
            adv.iter_mut().for_each(|a| *a = ((*a as f64 - mean) * inv) as f32);
        }

        // Policy loss: clipped surrogate, gradient through log π.
        let mean = Ppo::actor_forward(
            self.trunk.as_ref(),
            &mut w.trunk_buf,
            &self.actor,
            &mut w.actor_buf,
            &w.mb_obs[..b * od],
            b,
        );
        self.log_std_grad.fill(0.0);
        let beta = if self.config.kl_penalty { self.kl_coef as f32 } else { 0.0 };
        let (mut pg, mut kl, mut cf) = (0.0f64, 0.0f64, 0.0f64);
        for j in 0..b {
            let (a, mu) = (&w.mb_actions[j * ad..(j + 1) * ad], &mean[j * ad..(j + 1) * ad]);
            let log_ratio = gaussian_log_prob(a, mu, &self.log_std) - w.mb_log_probs[j];
            let ratio = log_ratio.exp();
            let adv = w.mb_adv[j];
            let pg1 = -adv * ratio;
            let pg2 = -adv * ratio.clamp(1.0 - clip, 1.0 + clip);
            // ∂/∂ratio of max(pg1, pg2): −Â where pg1 is active, 0 where the clip is.
            let (loss, d_ratio) =
                if !self.config.clip_policy || pg1 >= pg2 { (pg1, -adv) } else { (pg2, 0.0) };
            // The penalty β (log π_old − log π_θ): ∂/∂log π_θ = −β.
            pg += (loss - beta * log_ratio) as f64;
            kl += ((ratio - 1.0) - log_ratio) as f64;
            cf += ((ratio - 1.0).abs() > clip) as u8 as f64;
            let d_logp = (d_ratio * ratio - beta) / b as f32;
            gaussian_log_prob_grad(a, mu, &self.log_std, &mut w.d_mu, &mut w.d_ls);
            for i in 0..ad {
                w.d_mean[j * ad + i] = d_logp * w.d_mu[i];
                self.log_std_grad[i] += d_logp * w.d_ls[i];
            }
        }
        // Entropy bonus: H = Σ (½ + ½ log 2π + log σ), ∂H/∂log σᵢ = 1.
        let entropy = gaussian_entropy(&self.log_std);
        self.log_std_grad.iter_mut().for_each(|g| *g -= ent_coef);
        match &self.trunk {
            None => self.actor.backward(&mut w.actor_buf, &w.mb_obs[..b * od], &w.d_mean[..b * ad], b, None),
            Some(t) => {
                let f = t.n_out();
                let feat = t.output(&w.trunk_buf, b);
                self.actor.backward(
                    &mut w.actor_buf,
                    feat,
                    &w.d_mean[..b * ad],
                    b,
                    Some(&mut w.d_feat[..f * b]),
                );
            }
        }

        // Value loss, optionally clipped around the rollout's values.
        let v = Ppo::critic_forward(
            self.trunk.as_ref(),
            &mut w.trunk_buf,
            &self.critic,
            &mut w.critic_buf,
            &w.mb_obs[..b * od],
            b,
        );
        let mut vl = 0.0f64;
        for j in 0..b {
            let (vj, ret, old) = (v[j], w.mb_returns[j], w.mb_values[j]);
            let lu = (vj - ret) * (vj - ret);
            let (loss, dv) = if self.config.clip_vloss {
                let vc = old + (vj - old).clamp(-clip, clip);
                let lc = (vc - ret) * (vc - ret);
                if lu >= lc {
                    (lu, vj - ret)
                } else {
                    (lc, if (vj - old).abs() < clip { vc - ret } else { 0.0 })
                }
            } else {
                (lu, vj - ret)
            };
            vl += 0.5 * loss as f64;
            w.d_value[j] = vf_coef * dv / b as f32;
        }
        match &mut self.trunk {
            None => self.critic.backward(&mut w.critic_buf, &w.mb_obs[..b * od], &w.d_value[..b], b, None),
            Some(t) => {
                // Both heads' gradients meet in the trunk (its activations are those of the
                // critic pass, equal to the actor pass's: same input, same parameters).
                let f = t.n_out();
                let feat = t.output(&w.trunk_buf, b);
                self.critic.backward(
                    &mut w.critic_buf,
                    feat,
                    &w.d_value[..b],
                    b,
                    Some(&mut w.d_feat_critic[..f * b]),
                );
                w.d_feat[..f * b].iter_mut().zip(&w.d_feat_critic[..f * b]).for_each(|(a, c)| *a += c);
                t.backward(&mut w.trunk_buf, &w.mb_obs[..b * od], &w.d_feat[..f * b], b, None);
            }
        }

        MinibatchLoss {
            policy_loss: pg / b as f64,
            value_loss: vl / b as f64,
            entropy: entropy as f64,
            approx_kl: kl / b as f64,
            clip_fraction: cf / b as f64,
        }
    }

    /// `n_epochs` passes of minibatch gradient steps; fills the loss metrics. Without
    /// `train_actor` (the critic's burn-in) only the critic's optimiser steps.
    fn update(
        &mut self,
        lr: f32,
        lr_critic: f32,
        train_actor: bool,
        m: &mut UpdateMetrics,
    ) -> Result<(), RlError> {
        let (od, ad) = (self.obs_space.dim(), self.act_space.dim());
        let len = self.rollout.len();
        let bs = self.config.batch_size.min(len);
        let (ent_coef, vf_coef) = (self.config.ent_coef as f32, self.config.vf_coef as f32);
        let (mut pg_sum, mut v_sum, mut kl_sum, mut cf_sum, mut n_mb) =
            (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0u64);
        let mut last_epoch_kl = 0.0f64;
        'epochs: for _epoch in 0..self.config.n_epochs {
            // A fresh permutation of 0..len each epoch (not a reshuffle of the previous
            // one, so that the order depends only on the RNG state, which checkpoints keep).
            self.work.indices.iter_mut().enumerate().for_each(|(i, k)| *k = i);
            self.rng.shuffle(&mut self.work.indices);
            let (mut epoch_kl, mut epoch_kl_sum, mut epoch_mb) = (0.0f64, 0.0f64, 0u64);
            for start in (0..len).step_by(bs) {
                let b = bs.min(len - start);
                let w = &mut self.work;
                let r = &self.rollout;
                for (j, &k) in w.indices[start..start + b].iter().enumerate() {
                    w.mb_obs[j * od..(j + 1) * od].copy_from_slice(&r.obs[k * od..(k + 1) * od]);
                    w.mb_actions[j * ad..(j + 1) * ad].copy_from_slice(&r.actions[k * ad..(k + 1) * ad]);
                    w.mb_log_probs[j] = r.log_probs[k];
                    w.mb_adv[j] = r.advantages[k];
                    w.mb_returns[j] = r.returns[k];
                    w.mb_values[j] = r.values[k];
                }
                let mb = self.minibatch_gradients(b);
                let loss = mb.policy_loss + vf_coef as f64 * mb.value_loss - ent_coef as f64 * mb.entropy;
                if !loss.is_finite() {
                    return Err(RlError::Diverged { algo: "ppo", update: self.updates + 1, what: "loss" });
                }
                if self.config.clip_grad_norm {
                    let trunk_grads: &mut [f32] = match &mut self.trunk {
                        Some(t) => &mut t.grads,
                        None => &mut [],
                    };
                    clip_grad_norm(
                        &mut [
                            &mut self.actor.grads,
                            &mut self.log_std_grad,
                            &mut self.critic.grads,
                            trunk_grads,
                        ],
                        self.config.max_grad_norm as f32,
                    );
                }
                if train_actor {
                    self.opt_actor.step(&mut self.actor.params, &self.actor.grads, lr);
                    self.opt_log_std.step(&mut self.log_std, &self.log_std_grad, lr);
                }
                self.opt_critic.step(&mut self.critic.params, &self.critic.grads, lr_critic);
                if let (Some(t), true) = (&mut self.trunk, train_actor) {
                    self.opt_trunk.step(&mut t.params, &t.grads, lr);
                }

                pg_sum += mb.policy_loss;
                v_sum += mb.value_loss;
                kl_sum += mb.approx_kl;
                cf_sum += mb.clip_fraction;
                n_mb += 1;
                m.entropy = mb.entropy;
                epoch_kl = mb.approx_kl;
                epoch_kl_sum += mb.approx_kl;
                epoch_mb += 1;
            }
            last_epoch_kl = epoch_kl_sum / epoch_mb.max(1) as f64;
            if self.config.target_kl.is_some_and(|t| epoch_kl > t) {
                break 'epochs;
            }
        }
        if self.config.kl_penalty {
            m.kl_coef = self.kl_coef;
        }
        if self.config.kl_penalty && train_actor {
            // Section 4's rule, with the KL measured over the last epoch (not while the
            // actor does not move: its KL is zero then).
            let target = self.config.kl_target;
            if last_epoch_kl < target / 1.5 {
                self.kl_coef /= 2.0;
            } else if last_epoch_kl > target * 1.5 {
                self.kl_coef *= 2.0;
            }
        }
        let n = n_mb.max(1) as f64;
        m.policy_loss = pg_sum / n;
        m.value_loss = v_sum / n;
        m.approx_kl = kl_sum / n;
        m.clip_fraction = cf_sum / n;
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
                algo: "ppo",
                reason: "observation or action space differs".into(),
            });
        }
        if env.len() != self.n_envs {
            return Err(RlError::Incompatible {
                algo: "ppo",
                reason: format!("learner built for {} environments, VecEnv has {}", self.n_envs, env.len()),
            });
        }
        Ok(())
    }

    /// Reads a learner saved by [`Algorithm::save`].
    pub fn load(path: &std::path::Path) -> Result<Ppo, RlError> {
        Ppo::from_checkpoint(&Checkpoint::read(path)?)
    }

    /// A learner from an in-memory checkpoint.
    pub fn from_checkpoint(c: &Checkpoint) -> Result<Ppo, RlError> {
        c.expect_algo("ppo")?;
        let config: PpoConfig = c.get_meta("config")?;
        let n_envs: usize = c.get_meta("n_envs")?;
        let obs_space = c.read_space("obs_space")?;
        let act_space = c.read_space("act_space")?;
        let mut p = Ppo::new(config, &obs_space, &act_space, n_envs)?;
        c.read_mlp("actor", &mut p.actor)?;
        c.read_mlp("critic", &mut p.critic)?;
        c.read_f32_into("log_std", &mut p.log_std)?;
        p.exploration_floor = ExplorationFloor::read(c, "ppo", p.act_space.dim())?;
        c.read_adam("adam/actor", &mut p.opt_actor)?;
        c.read_adam("adam/log_std", &mut p.opt_log_std)?;
        c.read_adam("adam/critic", &mut p.opt_critic)?;
        if let Some(t) = &mut p.trunk {
            c.read_mlp("trunk", t)?;
            c.read_adam("adam/trunk", &mut p.opt_trunk)?;
        }
        c.read_rms("obs_rms", &mut p.obs_rms)?;
        c.read_rms("return_rms", &mut p.reward_scaler.stats)?;
        p.reward_scaler.returns.copy_from_slice(c.f64("discounted_returns", Some(n_envs))?);
        p.rng = c.read_rng("rng")?;
        p.steps_done = c.get_meta("steps_done")?;
        p.updates = c.get_meta("updates")?;
        p.lr_horizon = c.get_meta("lr_horizon")?;
        p.wall_time = c.get_meta("wall_time")?;
        if p.config.kl_penalty {
            p.kl_coef = c.get_meta("kl_coef")?;
        }
        Ok(p)
    }
}

impl Algorithm for Ppo {
    fn name(&self) -> &'static str {
        "ppo"
    }

    fn learn(
        &mut self,
        env: &mut VecEnv,
        total_steps: u64,
        callback: &mut dyn FnMut(&UpdateMetrics) -> ControlFlow<()>,
    ) -> Result<(), RlError> {
        self.check_env(env)?;
        let horizon = self.lr_horizon.unwrap_or(total_steps.max(1));
        if self.config.actor_burn_in_steps >= horizon {
            // The actor would never learn (or only at a learning rate annealed to 0).
            return Err(RlError::InvalidConfig {
                algo: "ppo",
                field: "actor_burn_in_steps",
                value: format!(
                    "{} (learning-rate horizon: {horizon} steps)",
                    self.config.actor_burn_in_steps
                ),
                reason: "must be below the learning-rate horizon (`lr_decay_steps`, or the first `learn` call's total steps)",
            });
        }
        self.lr_horizon = Some(horizon);
        // Continue a live VecEnv, or reset a fresh one.
        let settings = self.rollout_settings();
        let seed = self.config.seed.wrapping_add(self.steps_done);
        self.work.collector.start(env, &settings, &mut self.obs_rms, seed)?;
        let mut episodes = EpisodeWindow::default();
        while self.steps_done < total_steps {
            let t0 = Instant::now();
            let steps_before = self.steps_done;
            let (c, done) = (&self.config, self.steps_done);
            let anneal = |lr0: f64| if c.anneal_lr { linear_decay(lr0, done, horizon) } else { lr0 };
            let train_actor = done >= c.actor_burn_in_steps;
            let lr = if train_actor { anneal(c.learning_rate) } else { 0.0 };
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
            m.reward_mean = self.work.collector.take_reward_mean();
            self.update(lr as f32, lr_critic as f32, train_actor, &mut m)?;
            self.updates += 1;
            let dt = t0.elapsed().as_secs_f64();
            self.wall_time += dt;
            m.update = self.updates;
            m.env_steps = self.steps_done;
            m.wall_time = self.wall_time;
            m.steps_per_second = (self.steps_done - steps_before) as f64 / dt.max(1e-9);
            m.learning_rate = lr;
            m.critic_learning_rate = lr_critic;
            episodes.drain_into(&mut m);
            if callback(&m).is_break() {
                break;
            }
        }
        Ok(())
    }

    fn to_checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::new("ppo");
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
        c.put_adam("adam/actor", &self.opt_actor);
        c.put_adam("adam/log_std", &self.opt_log_std);
        c.put_adam("adam/critic", &self.opt_critic);
        if let Some(t) = &self.trunk {
            c.put_f32("trunk", &t.params);
            c.put_adam("adam/trunk", &self.opt_trunk);
        }
        c.put_rms("obs_rms", &self.obs_rms);
        c.put_rms("return_rms", &self.reward_scaler.stats);
        c.put_f64("discounted_returns", &self.reward_scaler.returns);
        c.put_rng("rng", &self.rng);
        if self.config.kl_penalty {
            c.set_meta("kl_coef", self.kl_coef);
        }
        self.policy().write_to(&mut c);
        c
    }

    fn policy(&self) -> Policy {
        let norm = self.config.norm_obs.then(|| ObsNorm {
            mean: self.obs_rms.mean.clone(),
            var: self.obs_rms.var.clone(),
            clip: self.config.clip_obs,
        });
        let actor = match &self.trunk {
            None => self.actor.clone(),
            // Trunk (activated output) + linear head = one MLP with the layers concatenated;
            // the flat parameter layouts concatenate too.
            Some(t) => {
                let sizes = [t.sizes(), &self.actor.sizes()[1..]].concat();
                let mut net = Mlp::zeros(&sizes, t.activation());
                net.params.copy_from_slice(&[&t.params[..], &self.actor.params[..]].concat());
                net
            }
        };
        Policy::new(PolicyHead::GaussianMean, actor, norm, &self.act_space)
    }

    fn zero_policy_output(&mut self) {
        self.actor.zero_output_rows(0..self.act_space.dim());
    }

    fn set_exploration_std(&mut self, std: &[f64]) -> Result<(), RlError> {
        self.log_std = crate::algorithm::exploration_log_std("ppo", std, self.act_space.dim())?;
        Ok(())
    }

    fn set_exploration_floor(&mut self, floor: ExplorationFloor) -> Result<(), RlError> {
        floor.validate("ppo", self.act_space.dim())?;
        self.exploration_floor = Some(floor);
        Ok(())
    }

    fn steps_done(&self) -> u64 {
        self.steps_done
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distributions::HALF_LOG_2PI;

    /// `y = W₂ tanh(W₁ x + b₁) + b₂` in f64 from the flat (column-major) parameters.
    fn mlp_f64(p: &[f64], sizes: [usize; 3], x: &[f64]) -> Vec<f64> {
        let [n0, n1, n2] = sizes;
        let (w1, b1) = (&p[..n1 * n0], &p[n1 * n0..n1 * n0 + n1]);
        let o = n1 * n0 + n1;
        let (w2, b2) = (&p[o..o + n2 * n1], &p[o + n2 * n1..o + n2 * n1 + n2]);
        let h: Vec<f64> =
            (0..n1).map(|i| (b1[i] + (0..n0).map(|j| w1[j * n1 + i] * x[j]).sum::<f64>()).tanh()).collect();
        (0..n2).map(|i| b2[i] + (0..n1).map(|j| w2[j * n2 + i] * h[j]).sum::<f64>()).collect()
    }

    struct Batch {
        obs: Vec<f64>,
        actions: Vec<f64>,
        old_log_probs: Vec<f64>,
        adv: Vec<f64>,
        returns: Vec<f64>,
        old_values: Vec<f64>,
    }

    /// The PPO loss written plainly from the module documentation, in f64.
    fn reference_loss(c: &PpoConfig, actor: &[f64], log_std: &[f64], critic: &[f64], d: &Batch) -> f64 {
        let b = d.adv.len();
        let mean = d.adv.iter().sum::<f64>() / b as f64;
        let std = (d.adv.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (b - 1) as f64).sqrt();
        let (eps, sigma) = (c.clip_coef, log_std[0].exp());
        let (mut pg, mut vl) = (0.0, 0.0);
        for j in 0..b {
            let s = &d.obs[3 * j..3 * j + 3];
            let mu = mlp_f64(actor, [3, 4, 1], s)[0];
            let z = (d.actions[j] - mu) / sigma;
            let logp = -0.5 * z * z - log_std[0] - 0.5 * (2.0 * std::f64::consts::PI).ln();
            let r = (logp - d.old_log_probs[j]).exp();
            let a = (d.adv[j] - mean) / (std + 1e-8);
            pg += (-a * r).max(-a * r.clamp(1.0 - eps, 1.0 + eps));
            let v = mlp_f64(critic, [3, 4, 1], s)[0];
            let old = d.old_values[j];
            let clipped = old + (v - old).clamp(-eps, eps);
            vl += 0.5 * (v - d.returns[j]).powi(2).max((clipped - d.returns[j]).powi(2));
        }
        let entropy = 0.5 + HALF_LOG_2PI as f64 + log_std[0];
        pg / b as f64 + c.vf_coef * vl / b as f64 - c.ent_coef * entropy
    }

    /// One minibatch's loss and gradients (clipped surrogate with both branches active,
    /// clipped value loss, entropy bonus, advantage normalisation) against a plain f64
    /// reference implementation and its central differences.
    #[test]
    fn minibatch_loss_and_gradients_match_reference() {
        let config = PpoConfig {
            n_steps: 8,
            batch_size: 8,
            ent_coef: 0.01,
            actor_hidden: vec![4],
            critic_hidden: vec![4],
            ..PpoConfig::default()
        };
        let obs_space = BoxSpace::unbounded(3);
        let act_space = BoxSpace::symmetric(1, 2.0);
        let mut ppo = Ppo::new(config.clone(), &obs_space, &act_space, 1).unwrap();
        let mut rng = Rng::seed_from_u64(3);
        // Larger weights than the init (policy head gain 0.01) so that every term matters.
        for p in ppo.actor.params.iter_mut().chain(ppo.critic.params.iter_mut()) {
            *p = rng.normal() as f32 * 0.7;
        }
        ppo.log_std[0] = -0.3;
        let b = 8;
        let obs: Vec<f32> = (0..3 * b).map(|_| rng.normal() as f32).collect();
        let actions: Vec<f32> = (0..b).map(|_| rng.normal() as f32).collect();
        // Current log-probs and values, then old ones offset so that ratios spread over
        // [0.55, 1.6] (several clipped) and values move up to ±0.45 (some value clipping).
        let mean = ppo.actor.forward(&mut ppo.work.actor_buf, &obs, b).to_vec();
        let values = ppo.critic.forward(&mut ppo.work.critic_buf, &obs, b).to_vec();
        let ratio_targets = [0.55f32, 0.75, 0.95, 1.05, 1.15, 1.3, 1.6, 0.85];
        let value_offsets = [0.45f32, -0.1, 0.3, -0.45, 0.05, -0.3, 0.15, 0.4];
        let d = Batch {
            obs: obs.iter().map(|x| *x as f64).collect(),
            actions: actions.iter().map(|x| *x as f64).collect(),
            old_log_probs: (0..b)
                .map(|j| {
                    (gaussian_log_prob(&actions[j..j + 1], &mean[j..j + 1], &ppo.log_std)
                        - ratio_targets[j].ln()) as f64
                })
                .collect(),
            adv: (0..b).map(|_| rng.normal()).collect(),
            returns: (0..b).map(|_| rng.normal()).collect(),
            old_values: (0..b).map(|j| (values[j] - value_offsets[j]) as f64).collect(),
        };
        let fill = |ppo: &mut Ppo| {
            let w = &mut ppo.work;
            w.mb_obs[..3 * b].copy_from_slice(&obs);
            w.mb_actions[..b].copy_from_slice(&actions);
            for j in 0..b {
                w.mb_log_probs[j] = d.old_log_probs[j] as f32;
                w.mb_adv[j] = d.adv[j] as f32;
                w.mb_returns[j] = d.returns[j] as f32;
                w.mb_values[j] = d.old_values[j] as f32;
            }
        };
        fill(&mut ppo);
        let mb = ppo.minibatch_gradients(b);
        assert!(mb.clip_fraction > 0.2 && mb.clip_fraction < 0.8, "clip fraction {}", mb.clip_fraction);

        let to64 = |v: &[f32]| v.iter().map(|x| *x as f64).collect::<Vec<f64>>();
        let (actor, log_std, critic) =
            (to64(&ppo.actor.params), to64(&ppo.log_std), to64(&ppo.critic.params));
        let want = reference_loss(&config, &actor, &log_std, &critic, &d);
        let got = mb.policy_loss + config.vf_coef * mb.value_loss - config.ent_coef * mb.entropy;
        assert!((got - want).abs() < 1e-5, "loss {got} vs reference {want}");

        let h = 1e-6;
        let fd = |f: &dyn Fn(f64) -> f64| (f(h) - f(-h)) / (2.0 * h);
        let mut worst = 0.0f64;
        for i in 0..actor.len() {
            let g = fd(&|e| {
                let mut a = actor.clone();
                a[i] += e;
                reference_loss(&config, &a, &log_std, &critic, &d)
            });
            worst = worst.max((g - ppo.actor.grads[i] as f64).abs());
        }
        for i in 0..critic.len() {
            let g = fd(&|e| {
                let mut c = critic.clone();
                c[i] += e;
                reference_loss(&config, &actor, &log_std, &c, &d)
            });
            worst = worst.max((g - ppo.critic.grads[i] as f64).abs());
        }
        let g = fd(&|e| reference_loss(&config, &actor, &[log_std[0] + e], &critic, &d));
        worst = worst.max((g - ppo.log_std_grad[0] as f64).abs());
        assert!(worst < 1e-4, "largest gradient error {worst:e}");
    }
}

#[cfg(test)]
mod shared_trunk_tests {
    use super::*;

    /// With `separate_networks` off, the analytic gradients of the joint loss (through both
    /// heads into the trunk) match central differences of the loss itself.
    #[test]
    fn shared_trunk_gradients_match_finite_differences() {
        let config = PpoConfig {
            n_steps: 6,
            batch_size: 6,
            ent_coef: 0.01,
            separate_networks: false,
            actor_hidden: vec![5, 4],
            ..PpoConfig::default()
        };
        let mut ppo = Ppo::new(config, &BoxSpace::unbounded(3), &BoxSpace::symmetric(2, 1.0), 1).unwrap();
        let mut rng = Rng::seed_from_u64(8);
        let b = 6;
        let obs: Vec<f32> = (0..3 * b).map(|_| rng.normal() as f32).collect();
        let actions: Vec<f32> = (0..2 * b).map(|_| rng.normal() as f32 * 0.5).collect();
        let adv: Vec<f32> = (0..b).map(|_| rng.normal() as f32).collect();
        let returns: Vec<f32> = (0..b).map(|_| rng.normal() as f32).collect();
        for p in ppo.actor.params.iter_mut() {
            *p = rng.normal() as f32 * 0.5;
        }
        // Old log-probs near the current ones (ratios in [0.9, 1.1]: no clipping kinks), old
        // values far from the current ones only where clipping should be inactive.
        let mean = Ppo::actor_forward(
            ppo.trunk.as_ref(),
            &mut ppo.work.trunk_buf,
            &ppo.actor,
            &mut ppo.work.actor_buf,
            &obs,
            b,
        )
        .to_vec();
        let old_lp: Vec<f32> = (0..b)
            .map(|j| {
                gaussian_log_prob(&actions[2 * j..2 * j + 2], &mean[2 * j..2 * j + 2], &ppo.log_std)
                    + 0.03 * (j as f32 - 2.5)
            })
            .collect();
        let values = Ppo::critic_forward(
            ppo.trunk.as_ref(),
            &mut ppo.work.trunk_buf,
            &ppo.critic,
            &mut ppo.work.critic_buf,
            &obs,
            b,
        )
        .to_vec();
        let loss = |ppo: &mut Ppo| {
            let w = &mut ppo.work;
            w.mb_obs[..3 * b].copy_from_slice(&obs);
            w.mb_actions[..2 * b].copy_from_slice(&actions);
            w.mb_log_probs[..b].copy_from_slice(&old_lp);
            w.mb_adv[..b].copy_from_slice(&adv);
            w.mb_returns[..b].copy_from_slice(&returns);
            w.mb_values[..b].copy_from_slice(&values);
            let m = ppo.minibatch_gradients(b);
            m.policy_loss + 0.5 * m.value_loss - 0.01 * m.entropy
        };
        loss(&mut ppo);
        let grads: Vec<f32> = [
            &ppo.trunk.as_ref().unwrap().grads[..],
            &ppo.actor.grads[..],
            &ppo.critic.grads[..],
            &ppo.log_std_grad[..],
        ]
        .concat();
        let h = 1e-2f32;
        let mut k = 0;
        let mut worst = 0.0f64;
        for group in 0..4 {
            let n = match group {
                0 => ppo.trunk.as_ref().unwrap().n_params(),
                1 => ppo.actor.n_params(),
                2 => ppo.critic.n_params(),
                _ => ppo.log_std.len(),
            };
            for i in 0..n {
                let nudge = |ppo: &mut Ppo, delta: f32| {
                    let p = match group {
                        0 => &mut ppo.trunk.as_mut().unwrap().params[i],
                        1 => &mut ppo.actor.params[i],
                        2 => &mut ppo.critic.params[i],
                        _ => &mut ppo.log_std[i],
                    };
                    *p += delta;
                };
                nudge(&mut ppo, h);
                let lp = loss(&mut ppo);
                nudge(&mut ppo, -2.0 * h);
                let lm = loss(&mut ppo);
                nudge(&mut ppo, h);
                let fd = (lp - lm) / (2.0 * h as f64);
                worst = worst.max((fd - grads[k] as f64).abs() / (1.0 + fd.abs()));
                k += 1;
            }
        }
        assert!(worst < 5e-3, "worst relative gradient error {worst:e}");
        // The deployed policy (trunk and head fused into one MLP) gives the training mean.
        let mut policy = ppo.policy();
        let mut a = [0.0f32; 2];
        policy.act(&obs[..3], &mut a);
        // (the policy normalises observations with the initial statistics: mean 0, var 1)
        let norm: Vec<f32> = obs[..3].iter().map(|x| (*x as f64 / (1.0f64 + 1e-8).sqrt()) as f32).collect();
        let mean_n = Ppo::actor_forward(
            ppo.trunk.as_ref(),
            &mut ppo.work.trunk_buf,
            &ppo.actor,
            &mut ppo.work.actor_buf,
            &norm,
            1,
        )
        .to_vec();
        for i in 0..2 {
            assert_eq!(a[i], mean_n[i].clamp(-1.0, 1.0));
        }
    }
}

/// PPO's networks as the collector sees them (through the shared trunk if there is one).
struct Nets<'a> {
    trunk: Option<&'a Mlp>,
    trunk_buf: &'a mut MlpBuffers,
    actor: &'a Mlp,
    actor_buf: &'a mut MlpBuffers,
    critic: &'a Mlp,
    critic_buf: &'a mut MlpBuffers,
}

impl PolicyValue for Nets<'_> {
    fn mean(&mut self, obs: &[f32], n: usize) -> &[f32] {
        Ppo::actor_forward(self.trunk, self.trunk_buf, self.actor, self.actor_buf, obs, n)
    }
    fn value(&mut self, obs: &[f32], n: usize) -> &[f32] {
        Ppo::critic_forward(self.trunk, self.trunk_buf, self.critic, self.critic_buf, obs, n)
    }
}
