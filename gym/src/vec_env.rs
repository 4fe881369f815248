//! [`VecEnv`]: N environments stepped together, in parallel across threads, with
//! auto-reset; the results depend on the seed only, never on the number of threads.

use std::sync::{Arc, Mutex};

use crate::env::{Env, EnvError, MAX_REWARD_TERMS, StepInfo};
use crate::space::BoxSpace;

/// A finished episode, reported by [`VecEnv::step`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpisodeRecord {
    /// Index of the environment.
    pub env: usize,
    /// Undiscounted return.
    pub ret: f64,
    /// Length in steps.
    pub length: usize,
    /// Ended by termination (rather than truncation).
    pub terminated: bool,
    /// Each reward term summed over the episode ([`Env::reward_term_names`] order).
    pub terms: [f64; MAX_REWARD_TERMS],
    /// Transitions this VecEnv had stepped (all environments) when the episode ended.
    pub step: u64,
}

/// Where a [`VecEnv`] copies every finished episode when asked to
/// ([`VecEnv::log_episodes`]): a run's per-episode log, drained by its owner.
pub type EpisodeLog = Arc<Mutex<Vec<EpisodeRecord>>>;

/// The results of one [`VecEnv::step`], in buffers reused across steps.
#[derive(Clone, Debug)]
pub struct VecStep {
    /// Next observations, `n × obs_dim` (after auto-reset for finished environments).
    pub obs: Vec<f32>,
    /// Rewards, one per environment.
    pub rewards: Vec<f64>,
    /// Terminated flags.
    pub terminated: Vec<bool>,
    /// Truncated flags.
    pub truncated: Vec<bool>,
    /// For environments whose episode just ended: the final observation (valid where
    /// `terminated[i] || truncated[i]`), so that truncated episodes can bootstrap.
    pub final_obs: Vec<f32>,
    /// Per-environment step information.
    pub infos: Vec<StepInfo>,
    /// Episodes that finished during this step.
    pub episodes: Vec<EpisodeRecord>,
}

impl VecStep {
    /// Zeroed buffers for `n` environments with `obs_dim`-dimensional observations.
    pub fn new(n: usize, obs_dim: usize) -> VecStep {
        VecStep {
            obs: vec![0.0; n * obs_dim],
            rewards: vec![0.0; n],
            terminated: vec![false; n],
            truncated: vec![false; n],
            final_obs: vec![0.0; n * obs_dim],
            infos: vec![StepInfo::default(); n],
            episodes: Vec::with_capacity(n),
        }
    }
}

struct Slot {
    env: Box<dyn Env>,
    ret: f64,
    length: usize,
    terms: [f64; MAX_REWARD_TERMS],
    /// Outcome of the last step: the episode it finished, or the error it raised.
    finished: Option<EpisodeRecord>,
    error: Option<EnvError>,
}

impl Slot {
    /// One environment's share of [`VecEnv::step`].
    fn step(
        &mut self,
        a: &[f32],
        o: &mut [f32],
        fo: &mut [f32],
        out: (&mut f64, &mut bool, &mut bool, &mut StepInfo),
    ) {
        self.finished = None;
        self.error = None;
        let s = match self.env.step(a, o) {
            Ok(s) => s,
            Err(e) => {
                self.error = Some(e);
                return;
            }
        };
        self.ret += s.reward;
        self.length += 1;
        for (sum, t) in self.terms.iter_mut().zip(&s.info.reward_terms) {
            *sum += t;
        }
        *out.0 = s.reward;
        *out.1 = s.terminated;
        *out.2 = s.truncated;
        *out.3 = s.info;
        if s.done() {
            fo.copy_from_slice(o);
            self.finished = Some(EpisodeRecord {
                env: 0,
                ret: self.ret,
                length: self.length,
                terminated: s.terminated,
                terms: self.terms,
                step: 0,
            });
            self.ret = 0.0;
            self.length = 0;
            self.terms = [0.0; MAX_REWARD_TERMS];
            if let Err(e) = self.env.reset(None, o) {
                self.error = Some(e);
            }
        }
    }
}

/// `n` environments stepped together, in parallel across threads, with auto-reset.
///
/// Environment `i` is reset with seed `seed + i` by [`VecEnv::reset`] and afterwards with
/// its own continuing stream, so results depend only on the seed — never on the number of
/// threads (each environment is stepped by exactly one thread, into its own slices).
pub struct VecEnv {
    slots: Vec<Slot>,
    obs_dim: usize,
    act_dim: usize,
    pool: Option<rayon::ThreadPool>,
    obs_space: BoxSpace,
    act_space: BoxSpace,
    /// The latest observations (`n × obs_dim`), valid while `started`.
    current_obs: Vec<f32>,
    /// Whether `reset` succeeded and no step has failed since.
    started: bool,
    /// Transitions stepped so far (all environments).
    transitions: u64,
    /// Where finished episodes are copied, if anywhere.
    episode_log: Option<EpisodeLog>,
}

impl VecEnv {
    /// Wraps environments that share their spaces; `threads = 1` steps them in the calling
    /// thread.
    pub fn new(envs: Vec<Box<dyn Env>>, threads: usize) -> Result<VecEnv, EnvError> {
        let first = envs.first().ok_or(EnvError::Empty)?;
        let obs_space = first.observation_space().clone();
        let act_space = first.action_space().clone();
        for (index, e) in envs.iter().enumerate() {
            if e.observation_space() != &obs_space || e.action_space() != &act_space {
                return Err(EnvError::MismatchedSpaces { index });
            }
        }
        let threads = threads.clamp(1, envs.len());
        let pool = if threads > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|source| EnvError::Threads { threads, source })?,
            )
        } else {
            None
        };
        let n = envs.len();
        Ok(VecEnv {
            current_obs: vec![0.0; n * obs_space.dim()],
            started: false,
            transitions: 0,
            episode_log: None,
            obs_dim: obs_space.dim(),
            act_dim: act_space.dim(),
            slots: envs
                .into_iter()
                .map(|env| Slot {
                    env,
                    ret: 0.0,
                    length: 0,
                    terms: [0.0; MAX_REWARD_TERMS],
                    finished: None,
                    error: None,
                })
                .collect(),
            pool,
            obs_space,
            act_space,
        })
    }

    /// Tells every environment the learner's samples so far ([`Env::set_training_samples`]).
    pub fn set_training_samples(&mut self, samples: u64) {
        for slot in &mut self.slots {
            slot.env.set_training_samples(samples);
        }
    }

    /// Number of environments.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Always false (a VecEnv has at least one environment).
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The shared observation space.
    pub fn observation_space(&self) -> &BoxSpace {
        &self.obs_space
    }

    /// The shared action space.
    pub fn action_space(&self) -> &BoxSpace {
        &self.act_space
    }

    /// The latest observations (`n × obs_dim`: after [`VecEnv::reset`], then after each
    /// [`VecEnv::step`], auto-reset included), or `None` before the first reset or after a
    /// failed call. Learners use it to continue on a live VecEnv without resetting it.
    pub fn observations(&self) -> Option<&[f32]> {
        self.started.then_some(&self.current_obs[..])
    }

    /// The first environment (for its name, dt, reward-term names…).
    pub fn env(&self, i: usize) -> &dyn Env {
        self.slots[i].env.as_ref()
    }

    /// Copies every episode that finishes from now on into `log` (a run's per-episode log;
    /// its owner drains it).
    pub fn log_episodes(&mut self, log: EpisodeLog) {
        self.episode_log = Some(log);
    }

    /// Buffers sized for this VecEnv.
    pub fn make_step_buffers(&self) -> VecStep {
        VecStep::new(self.len(), self.obs_dim)
    }

    /// Resets every environment (`env i` with seed `seed + i`); writes `n × obs_dim`
    /// observations.
    #[track_caller]
    pub fn reset(&mut self, seed: u64, obs: &mut [f32]) -> Result<(), EnvError> {
        assert!(
            obs.len() == self.len() * self.obs_dim,
            "VecEnv::reset: obs buffer has {} entries, expected {}",
            obs.len(),
            self.len() * self.obs_dim
        );
        self.started = false;
        for (i, (slot, o)) in self.slots.iter_mut().zip(obs.chunks_mut(self.obs_dim)).enumerate() {
            slot.env.reset(Some(seed.wrapping_add(i as u64)), o)?;
            slot.ret = 0.0;
            slot.length = 0;
            slot.terms = [0.0; MAX_REWARD_TERMS];
        }
        self.current_obs.copy_from_slice(obs);
        self.started = true;
        Ok(())
    }

    /// Steps every environment with its slice of `actions` (`n × act_dim`). Finished
    /// episodes are reset at once (continuing each environment's random stream); their
    /// final observation goes to `out.final_obs` and their record to `out.episodes`.
    #[track_caller]
    pub fn step(&mut self, actions: &[f32], out: &mut VecStep) -> Result<(), EnvError> {
        let n = self.len();
        assert!(
            actions.len() == n * self.act_dim,
            "VecEnv::step: {} actions, expected {} × {}",
            actions.len(),
            n,
            self.act_dim
        );
        assert!(out.obs.len() == n * self.obs_dim, "VecEnv::step: buffers sized for another VecEnv");
        let (od, ad) = (self.obs_dim, self.act_dim);
        let VecStep { obs, rewards, terminated, truncated, final_obs, infos, episodes } = out;
        episodes.clear();
        match &self.pool {
            None => {
                for (i, slot) in self.slots.iter_mut().enumerate() {
                    let r = i * od..(i + 1) * od;
                    slot.step(
                        &actions[i * ad..(i + 1) * ad],
                        &mut obs[r.clone()],
                        &mut final_obs[r],
                        (&mut rewards[i], &mut terminated[i], &mut truncated[i], &mut infos[i]),
                    );
                }
            }
            Some(pool) => {
                use rayon::prelude::*;
                pool.install(|| {
                    self.slots
                        .par_iter_mut()
                        .zip(actions.par_chunks(ad))
                        .zip(obs.par_chunks_mut(od))
                        .zip(final_obs.par_chunks_mut(od))
                        .zip(rewards.par_iter_mut())
                        .zip(terminated.par_iter_mut())
                        .zip(truncated.par_iter_mut())
                        .zip(infos.par_iter_mut())
                        .for_each(|(((((((slot, a), o), fo), r), te), tr), inf)| {
                            slot.step(a, o, fo, (r, te, tr, inf))
                        });
                });
            }
        }
        self.transitions += self.slots.len() as u64;
        for (i, slot) in self.slots.iter_mut().enumerate() {
            if let Some(e) = slot.error.take() {
                self.started = false;
                return Err(e);
            }
            if let Some(mut rec) = slot.finished.take() {
                rec.env = i;
                rec.step = self.transitions;
                episodes.push(rec);
            }
        }
        if let Some(log) = self.episode_log.as_ref().filter(|_| !episodes.is_empty()) {
            log.lock().unwrap_or_else(|e| e.into_inner()).extend_from_slice(episodes);
        }
        self.current_obs.copy_from_slice(obs);
        Ok(())
    }
}
