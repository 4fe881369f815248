//! Gymnasium's `Pendulum-v1` (gymnasium 1.4.0, `classic_control/pendulum.py`), the
//! learning tests' task: swing a pendulum up and hold it with a bounded torque.
//!
//! State `(θ, θ̇)` with θ = 0 upright. With `g = 10`, `m = l = 1`, `dt = 0.05`,
//! `u = clip(a, −2, 2)`:
//!
//! ```text
//! r      = −(norm(θ)² + 0.1 θ̇² + 0.001 u²)          (norm wraps θ to [−π, π))
//! θ̇'    = clip(θ̇ + (3g/(2l) sin θ + 3/(m l²) u) dt, −8, 8)
//! θ'     = θ + θ̇' dt
//! obs    = (cos θ', sin θ', θ̇')
//! ```
//!
//! Episodes start at θ ~ U[−π, π], θ̇ ~ U[−1, 1] and are truncated after 200 steps; they
//! never terminate. The state is `f64` (numpy's); observations are `f32`. The initial
//! state is drawn from Centaur's [`Rng`], so episodes differ from gymnasium's for the same
//! seed, but the dynamics agree to rounding (`tools/pendulum_crosscheck.py` replays
//! gymnasium trajectories; the `matches_gymnasium_trajectories` test checks them).

use crate::env::{Env, EnvError, Step, StepInfo, check_action, check_observation};
use crate::rng::Rng;
use crate::space::BoxSpace;

/// Maximum angular speed (rad/s).
pub const MAX_SPEED: f64 = 8.0;
/// Maximum torque (N·m).
pub const MAX_TORQUE: f64 = 2.0;
/// Time step (s).
pub const DT: f64 = 0.05;
/// Gymnasium's episode length (steps): [`Pendulum::max_episode_steps`]'s default.
pub const MAX_EPISODE_STEPS: usize = 200;

/// The pendulum swing-up task.
#[derive(Clone, Debug)]
pub struct Pendulum {
    /// Gravity (m/s², default 10).
    pub g: f64,
    /// Episode length (steps) after which `truncated` is set (default: 200, Gymnasium's;
    /// 0 is treated as 1).
    pub max_episode_steps: usize,
    theta: f64,
    theta_dot: f64,
    steps: usize,
    needs_reset: bool,
    rng: Rng,
    obs_space: BoxSpace,
    act_space: BoxSpace,
}

impl Default for Pendulum {
    fn default() -> Self {
        Pendulum::new()
    }
}

/// `((x + π) mod 2π) − π` with Python's floored modulo.
pub fn angle_normalize(x: f64) -> f64 {
    use std::f64::consts::PI;
    (x + PI).rem_euclid(2.0 * PI) - PI
}

impl Pendulum {
    /// Gymnasium's defaults (`g = 10`).
    pub fn new() -> Pendulum {
        Pendulum {
            g: 10.0,
            max_episode_steps: MAX_EPISODE_STEPS,
            theta: 0.0,
            theta_dot: 0.0,
            steps: 0,
            needs_reset: true,
            rng: Rng::seed_from_u64(0),
            obs_space: BoxSpace::new(vec![-1.0, -1.0, -MAX_SPEED as f32], vec![1.0, 1.0, MAX_SPEED as f32]),
            act_space: BoxSpace::symmetric(1, MAX_TORQUE as f32),
        }
    }

    /// The state `(θ, θ̇)`.
    pub fn state(&self) -> (f64, f64) {
        (self.theta, self.theta_dot)
    }

    /// Sets the state (for replaying reference trajectories) and writes its observation;
    /// the episode step counter restarts.
    #[track_caller]
    pub fn set_state(&mut self, theta: f64, theta_dot: f64, obs: &mut [f32]) {
        assert!(obs.len() == 3, "Pendulum::set_state: obs buffer has {} entries, expected 3", obs.len());
        self.theta = theta;
        self.theta_dot = theta_dot;
        self.steps = 0;
        self.needs_reset = false;
        self.observe(obs);
    }

    fn observe(&self, obs: &mut [f32]) {
        obs[0] = self.theta.cos() as f32;
        obs[1] = self.theta.sin() as f32;
        obs[2] = self.theta_dot as f32;
    }
}

impl Env for Pendulum {
    fn name(&self) -> &str {
        "pendulum"
    }

    fn observation_space(&self) -> &BoxSpace {
        &self.obs_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.act_space
    }

    fn max_episode_steps(&self) -> usize {
        self.max_episode_steps.max(1)
    }

    fn dt(&self) -> f64 {
        DT
    }

    fn reward_term_names(&self) -> &'static [&'static str] {
        &["angle", "velocity", "torque"]
    }

    fn config_text(&self) -> Option<String> {
        Some(format!("{{\"g\": {:?}, \"max_episode_steps\": {}}}", self.g, self.max_episode_steps))
    }

    fn reset(&mut self, seed: Option<u64>, obs: &mut [f32]) -> Result<(), EnvError> {
        check_observation(&self.obs_space, obs)?;
        if let Some(s) = seed {
            self.rng = Rng::seed_from_u64(s);
        }
        self.theta = self.rng.range(-std::f64::consts::PI, std::f64::consts::PI);
        self.theta_dot = self.rng.range(-1.0, 1.0);
        self.steps = 0;
        self.needs_reset = false;
        self.observe(obs);
        Ok(())
    }

    /// Torques outside `[−2, 2]` are clipped.
    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> Result<Step, EnvError> {
        check_action(&self.act_space, action)?;
        check_observation(&self.obs_space, obs)?;
        if self.needs_reset {
            return Err(EnvError::NeedsReset);
        }
        // gymnasium keeps u as a float32 scalar, and numpy 2 (NEP 50) evaluates
        // `python float * float32` in float32: the torque terms are rounded to f32 before
        // they meet the f64 state, as here.
        let u32 = action[0].clamp(-MAX_TORQUE as f32, MAX_TORQUE as f32);
        let (th, thdot) = (self.theta, self.theta_dot);
        let (l, m) = (1.0, 1.0);
        let angle = angle_normalize(th).powi(2);
        let velocity = 0.1 * thdot * thdot;
        let torque = (0.001f32 * (u32 * u32)) as f64;
        let new_thdot = (thdot
            + (3.0 * self.g / (2.0 * l) * th.sin() + ((3.0 / (m * l * l)) as f32 * u32) as f64) * DT)
            .clamp(-MAX_SPEED, MAX_SPEED);
        self.theta = th + new_thdot * DT;
        self.theta_dot = new_thdot;
        self.steps += 1;
        self.observe(obs);
        let truncated = self.steps >= self.max_episode_steps.max(1);
        if truncated {
            self.needs_reset = true;
        }
        let mut info = StepInfo::default();
        info.reward_terms[..3].copy_from_slice(&[-angle, -velocity, -torque]);
        info.energy = (u32 as f64 * new_thdot).abs() * DT;
        Ok(Step { reward: -(angle + velocity + torque), terminated: false, truncated, info })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_step_by_hand() {
        // θ = π/2, θ̇ = 0, u = 1: cost = (π/2)² + 0 + 0.001 = 2.4684011;
        // θ̇' = (15 · 1 + 3 · 1) · 0.05 = 0.9; θ' = π/2 + 0.045.
        let mut env = Pendulum::new();
        let mut obs = [0.0f32; 3];
        env.set_state(std::f64::consts::FRAC_PI_2, 0.0, &mut obs);
        let s = env.step(&[1.0], &mut obs).unwrap();
        assert!((s.reward + 2.468_401_1).abs() < 1e-6, "{}", s.reward);
        let (th, thd) = env.state();
        assert!((thd - 0.9).abs() < 1e-12 && (th - (std::f64::consts::FRAC_PI_2 + 0.045)).abs() < 1e-12);
        assert_eq!(obs[2], 0.9);
        // Torque clipped to 2: torque cost 0.001 · 4 (in f32, as numpy: 0.004 ± 2e-10).
        let s2 = env.step(&[5.0], &mut obs).unwrap();
        assert!((s2.info.reward_terms[2] + 0.004).abs() < 1e-9);
    }

    #[test]
    fn truncates_after_200_steps_and_needs_reset() {
        let mut env = Pendulum::new();
        let mut obs = [0.0f32; 3];
        assert!(matches!(env.step(&[0.0], &mut obs), Err(EnvError::NeedsReset)));
        env.reset(Some(3), &mut obs).unwrap();
        for k in 1..=200 {
            let s = env.step(&[0.0], &mut obs).unwrap();
            assert!(!s.terminated);
            assert_eq!(s.truncated, k == 200);
        }
        assert!(matches!(env.step(&[0.0], &mut obs), Err(EnvError::NeedsReset)));
        assert!(matches!(env.step(&[f32::NAN], &mut obs), Err(EnvError::NonFiniteAction { index: 0, .. })));
        assert!(matches!(
            env.step(&[0.0, 1.0], &mut obs),
            Err(EnvError::ActionLength { expected: 1, got: 2 })
        ));
    }

    /// Replays `tests/fixtures/pendulum_gymnasium.json` (written by
    /// `tools/pendulum_crosscheck.py` from gymnasium 1.4.0): same initial states, same
    /// actions (uniform in [−3, 3], so clipping is exercised), same observations and rewards.
    #[test]
    fn matches_gymnasium_trajectories() {
        let fixture: serde_json::Value =
            serde_json::from_str(include_str!("../tests/fixtures/pendulum_gymnasium.json")).unwrap();
        let episodes = fixture["episodes"].as_array().unwrap();
        assert_eq!(episodes.len(), 3);
        let f = |v: &serde_json::Value| v.as_f64().unwrap();
        let mut env = Pendulum::new();
        let mut obs = [0.0f32; 3];
        for ep in episodes {
            env.set_state(f(&ep["theta0"]), f(&ep["theta_dot0"]), &mut obs);
            for (o, want) in obs.iter().zip(ep["obs0"].as_array().unwrap()) {
                assert!((*o as f64 - f(want)).abs() < 1e-6);
            }
            let actions = ep["actions"].as_array().unwrap();
            for (t, a) in actions.iter().enumerate() {
                let s = env.step(&[f(a) as f32], &mut obs).unwrap();
                assert!(
                    (s.reward - f(&ep["rewards"][t])).abs() < 1e-12,
                    "step {t}: {} vs {}",
                    s.reward,
                    ep["rewards"][t]
                );
                for (o, want) in obs.iter().zip(ep["obs"][t].as_array().unwrap()) {
                    assert!((*o as f64 - f(want)).abs() < 1e-5, "step {t}: obs {obs:?} vs {}", ep["obs"][t]);
                }
                assert_eq!(s.truncated, ep["truncated"][t].as_bool().unwrap());
            }
        }
    }

    #[test]
    fn angle_normalize_like_python() {
        use std::f64::consts::PI;
        assert!((angle_normalize(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((angle_normalize(-3.0 * PI / 2.0) - PI / 2.0).abs() < 1e-12);
        assert!((angle_normalize(PI) + PI).abs() < 1e-12); // Python: (2π % 2π) − π = −π
    }
}
