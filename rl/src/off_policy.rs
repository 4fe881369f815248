//! The collection loop of the replay-buffer learners (SAC v2, SAC v1, TD3, DDPG).
//!
//! Every one of them acts the same way around its own gradient step:
//!
//! ```text
//! until steps_done = total_steps:
//!     a = uniform(−1, 1) during the first `learning_starts` steps (unless `warmup_with_policy`),
//!         else the learner's exploration
//!     step the VecEnv with a rescaled to the action bounds
//!     store (s, a, r, s', terminated, truncated), s' = the final observation at an episode end
//!     after warm-up: `gradient_steps` gradient steps
//!     every `log_interval` steps: one UpdateMetrics record to the callback
//! ```
//!
//! [`Collector`] holds what that loop owns (step buffers, replay buffer, counters) and
//! writes it to checkpoints; a learner plugs in through [`OffPolicyLearner`] and calls
//! [`learn`] from its [`crate::Algorithm::learn`].

use std::ops::ControlFlow;
use std::time::Instant;

use crate::buffer::ReplayBuffer;
use crate::checkpoint::Checkpoint;
use crate::error::RlError;
use crate::metrics::{EpisodeWindow, UpdateMetrics};
use crate::policy::rescale_action;
use centaur_gym::Rng;
use centaur_gym::{BoxSpace, VecEnv, VecStep};

/// The loop's settings, read from a learner's config.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LoopSettings {
    /// Base seed of env resets (`seed + steps_done` for a fresh env).
    pub seed: u64,
    /// Uniformly random steps before the first gradient step.
    pub learning_starts: u64,
    /// Warm up with the learner's exploration instead of uniform actions.
    pub warmup_with_policy: bool,
    /// Gradient steps per vectorised step (one step of every environment).
    pub gradient_steps: usize,
    /// Environment steps between metric records.
    pub log_interval: u64,
    /// Reported in the metrics.
    pub learning_rate: f64,
    /// The critic's, reported in the metrics.
    pub critic_learning_rate: f64,
}

/// Step buffers, replay buffer and counters of an off-policy learner.
pub(crate) struct Collector {
    pub obs_space: BoxSpace,
    pub act_space: BoxSpace,
    /// Observations the next actions are chosen for, `n × |O|`.
    pub obs: Vec<f32>,
    /// Actions in `[−1, 1]`, `n × |A|`: what the replay buffer stores.
    pub actions: Vec<f32>,
    /// `actions` rescaled to the env's bounds.
    env_actions: Vec<f32>,
    step: VecStep,
    /// The number of environments the buffers hold.
    max_envs: usize,
    pub replay: ReplayBuffer,
    pub steps_done: u64,
    records: u64,
    wall_time: f64,
}

impl Collector {
    /// Buffers for up to `max_envs` environments and a replay buffer of `buffer_size`
    /// transitions.
    pub fn new(obs_space: &BoxSpace, act_space: &BoxSpace, max_envs: usize, buffer_size: usize) -> Collector {
        let (od, ad, n) = (obs_space.dim(), act_space.dim(), max_envs.max(1));
        Collector {
            obs_space: obs_space.clone(),
            act_space: act_space.clone(),
            obs: vec![0.0; n * od],
            actions: vec![0.0; n * ad],
            env_actions: vec![0.0; n * ad],
            step: VecStep::new(n, od),
            max_envs: n,
            replay: ReplayBuffer::new(buffer_size, od, ad),
            steps_done: 0,
            records: 0,
            wall_time: 0.0,
        }
    }

    /// The number of environments the buffers were sized for.
    pub fn max_envs(&self) -> usize {
        self.max_envs
    }

    /// `env` has this learner's spaces and no more environments than it was sized for.
    pub fn check_env(&self, algo: &'static str, env: &VecEnv) -> Result<(), RlError> {
        if env.observation_space() != &self.obs_space || env.action_space() != &self.act_space {
            return Err(RlError::Incompatible { algo, reason: "observation or action space differs".into() });
        }
        if env.len() > self.max_envs() {
            return Err(RlError::Incompatible {
                algo,
                reason: format!(
                    "learner sized for {} environments, VecEnv has {}",
                    self.max_envs(),
                    env.len()
                ),
            });
        }
        Ok(())
    }

    /// Writes the spaces, the buffer size, the counters and (if `save_replay`) the replay
    /// buffer.
    pub fn write_to(&self, c: &mut Checkpoint, save_replay: bool) {
        c.set_meta("max_envs", self.max_envs());
        c.set_meta("steps_done", self.steps_done);
        c.set_meta("records", self.records);
        c.set_meta("wall_time", self.wall_time);
        c.put_space("obs_space", &self.obs_space);
        c.put_space("act_space", &self.act_space);
        c.set_meta("replay_saved", save_replay);
        if save_replay {
            c.put_replay("replay", &self.replay);
        }
    }

    /// What a learner's constructor needs from a checkpoint written by
    /// [`Collector::write_to`]: `(obs_space, act_space, max_envs)`.
    pub fn read_shape(c: &Checkpoint) -> Result<(BoxSpace, BoxSpace, usize), RlError> {
        Ok((c.read_space("obs_space")?, c.read_space("act_space")?, c.get_meta("max_envs")?))
    }

    /// Restores the counters and the replay buffer (when saved).
    pub fn read_from(&mut self, c: &Checkpoint) -> Result<(), RlError> {
        if c.get_meta::<bool>("replay_saved")? {
            c.read_replay("replay", &mut self.replay)?;
        }
        self.steps_done = c.get_meta("steps_done")?;
        self.records = c.get_meta("records")?;
        self.wall_time = c.get_meta("wall_time")?;
        Ok(())
    }
}

/// What a replay-buffer learner supplies to [`learn`].
pub(crate) trait OffPolicyLearner {
    /// Loss sums accumulated over the gradient steps between two records.
    type Sums: Default;

    /// The loop's settings.
    fn settings(&self) -> LoopSettings;

    /// The collector and the learner's random stream (warm-up actions draw from it).
    fn parts(&mut self) -> (&mut Collector, &mut Rng);

    /// Writes exploratory actions in `[−1, 1]` for the first `n` observations of the
    /// collector into its `actions`.
    fn explore(&mut self, n: usize);

    /// Environment `env` finished an episode (DDPG restarts its noise path).
    fn episode_ended(&mut self, _env: usize) {}

    /// One gradient step on a replay batch.
    fn train_step(&mut self, sums: &mut Self::Sums) -> Result<(), RlError>;

    /// Writes the learner's own fields of a record (losses, Q, α) from `sums`.
    fn report(&self, sums: &Self::Sums, m: &mut UpdateMetrics);
}

/// Trains `learner` on `env` until it has done `total_steps` environment steps (see the
/// module docs); `algo` names it in errors.
pub(crate) fn learn<L: OffPolicyLearner>(
    learner: &mut L,
    algo: &'static str,
    env: &mut VecEnv,
    total_steps: u64,
    callback: &mut dyn FnMut(&UpdateMetrics) -> ControlFlow<()>,
) -> Result<(), RlError> {
    let s = learner.settings();
    let (c, _) = learner.parts();
    c.check_env(algo, env)?;
    let (n, od, ad) = (env.len(), c.obs_space.dim(), c.act_space.dim());
    match env.observations() {
        Some(obs) => c.obs[..n * od].copy_from_slice(obs),
        None => env.reset(s.seed.wrapping_add(c.steps_done), &mut c.obs[..n * od])?,
    }
    if c.step.rewards.len() != n {
        c.step = env.make_step_buffers();
    }
    let mut episodes = EpisodeWindow::default();
    let mut sums = L::Sums::default();
    let (mut reward_sum, mut reward_steps) = (0.0f64, 0u64);
    let (mut t0, mut steps_at_t0) = (Instant::now(), c.steps_done);
    let mut next_record = (c.steps_done / s.log_interval + 1) * s.log_interval;
    while learner.parts().0.steps_done < total_steps {
        let (c, rng) = learner.parts();
        if c.steps_done < s.learning_starts && !s.warmup_with_policy {
            c.actions[..n * ad].iter_mut().for_each(|a| *a = rng.range(-1.0, 1.0) as f32);
        } else {
            learner.explore(n);
        }

        let (c, _) = learner.parts();
        for i in 0..n * ad {
            let k = i % ad;
            c.env_actions[i] = rescale_action(c.actions[i], c.act_space.low[k], c.act_space.high[k]);
        }
        env.set_training_samples(c.steps_done);
        env.step(&c.env_actions[..n * ad], &mut c.step)?;
        reward_sum += c.step.rewards.iter().sum::<f64>();
        reward_steps += n as u64;
        for e in &c.step.episodes {
            episodes.push(e.ret, e.length);
        }
        for i in 0..n {
            let st = &c.step;
            let next = if st.terminated[i] || st.truncated[i] { &st.final_obs } else { &st.obs };
            c.replay.push(
                &c.obs[i * od..(i + 1) * od],
                &c.actions[i * ad..(i + 1) * ad],
                st.rewards[i] as f32,
                &next[i * od..(i + 1) * od],
                st.terminated[i],
                st.truncated[i],
            );
        }
        c.obs[..n * od].copy_from_slice(&c.step.obs);
        c.steps_done += n as u64;
        let steps = c.steps_done;
        for k in 0..c.step.episodes.len() {
            let e = learner.parts().0.step.episodes[k].env;
            learner.episode_ended(e);
        }

        if steps > s.learning_starts {
            for _ in 0..s.gradient_steps {
                learner.train_step(&mut sums)?;
            }
        }

        if steps >= next_record || steps >= total_steps {
            next_record = (steps / s.log_interval + 1) * s.log_interval;
            let (c, _) = learner.parts();
            c.records += 1;
            let dt = t0.elapsed().as_secs_f64();
            c.wall_time += dt;
            let mut m = UpdateMetrics::empty();
            m.update = c.records;
            m.env_steps = steps;
            m.wall_time = c.wall_time;
            m.steps_per_second = (steps - steps_at_t0) as f64 / dt.max(1e-9);
            m.learning_rate = s.learning_rate;
            m.critic_learning_rate = s.critic_learning_rate;
            learner.report(&sums, &mut m);
            m.reward_mean = reward_sum / reward_steps.max(1) as f64;
            (reward_sum, reward_steps) = (0.0, 0);
            episodes.drain_into(&mut m);
            sums = L::Sums::default();
            t0 = Instant::now();
            steps_at_t0 = steps;
            if callback(&m).is_break() {
                break;
            }
        }
    }
    Ok(())
}

/// [`LoopSettings`] from a learner config that names its fields like the others.
macro_rules! loop_settings {
    ($config:expr) => {{
        let c = &$config;
        $crate::off_policy::LoopSettings {
            seed: c.seed,
            learning_starts: c.learning_starts,
            warmup_with_policy: c.warmup_with_policy,
            gradient_steps: c.gradient_steps,
            log_interval: c.log_interval,
            learning_rate: c.learning_rate,
            critic_learning_rate: c.critic_learning_rate.unwrap_or(c.learning_rate),
        }
    }};
}
pub(crate) use loop_settings;
