//! `[env]`: a robot environment's settings over its preset, from a run's TOML file.
//!
//! A run file holds the algorithm's hyperparameters at the top level and, optionally, an
//! `[env]` table of [`EnvSettings`]: any of the environment's reward weights, episode
//! length, control rate, randomisation, latency and observation options, each named as the
//! field of the environment's config it sets. Unknown keys are an error naming the key; a
//! key that the environment does not have (`healthy_reward` on the Minitaur) is an error
//! naming the keys it has; the values are then checked by the environment's own validation.
//!
//! ```toml
//! learning_rate = 3e-4      # the algorithm's settings (PpoConfig's fields)
//!
//! [env]                     # the Minitaur's, over MinitaurBulletEnv-v0's defaults
//! energy_weight = 0.0
//! drift_weight = 0.1
//! max_episode_steps = 500
//! randomize = false
//! ```
//!
//! | key | Minitaur | Gymnasium robots (Ant, Walker2d, …) | modular robots |
//! |---|---|---|---|
//! | `max_episode_steps`, `frame_skip` (the Minitaur's `action_repeat`) | ✓ | ✓ | ✓ |
//! | `joint_history`, `drop_base_orientation` (observation) | ✓ | ✓ | ✓ |
//! | `distance_weight`, `energy_weight`, `drift_weight`, `shake_weight`, `distance_limit`, `randomize`, `motor_strength`, `motor_inverse`, `latency`, `observation_noise_std`, `observe_body_state` | ✓ | | |
//! | `forward_reward_weight`, `contact_cost_weight`, `healthy_reward`, `terminate_when_unhealthy`, `healthy_z_range`, `healthy_angle_range` | | ✓ | |
//! | `ctrl_cost_weight`, `reset_noise_scale` | | ✓ | ✓ |
//! | `observation` (`"full"`, `"hinges_orientation"`, `"hinges"`) | | | ✓ |
//!
//! The Pendulum takes `max_episode_steps` only. Checkpoints and run records keep the
//! settings (an empty table is the preset).

use centaur_envs::minitaur::MotorInverse;
use centaur_envs::{LocomotionConfig, MinitaurConfig, ModularConfig, ModularObservation, PushSchedule};
use centaur_gym::pendulum::Pendulum;
use serde::{Deserialize, Serialize};

/// The `[env]` table: each `Some` field replaces the preset's value.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvSettings {
    /// Episode length (control steps).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_episode_steps: Option<usize>,
    /// Physics steps per control step (the Minitaur's `action_repeat`), 1 to
    /// [`centaur_envs::MAX_FRAME_SKIP`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame_skip: Option<usize>,
    /// Joint positions of the last `k` control steps appended to the observation, `k` at
    /// most [`centaur_envs::MAX_JOINT_HISTORY`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub joint_history: Option<usize>,
    /// Remove the base orientation from the observation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drop_base_orientation: Option<bool>,
    /// Minitaur: weight of the forward distance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance_weight: Option<f64>,
    /// Minitaur: weight of the energy term.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub energy_weight: Option<f64>,
    /// Minitaur: weight of the sideways drift penalty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_weight: Option<f64>,
    /// Minitaur: weight of the vertical shake penalty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shake_weight: Option<f64>,
    /// Minitaur: the episode ends beyond this distance from the origin (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance_limit: Option<f64>,
    /// Minitaur: randomise the robot at reset (`false`: the nominal robot).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub randomize: Option<bool>,
    /// Minitaur: motor strength drawn at every reset within `[low, high]`, a factor on
    /// every motor's torque (the randomisation's `motor_strength`; default `[1, 1]`, off as
    /// in v0; Tan et al. 2018 trained with it for sim-to-real). Needs the randomisation on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motor_strength: Option<[f64; 2]>,
    /// Minitaur: the motor model a controller's torques are turned into actions with,
    /// `"nominal"` (the default: the data sheet's) or `"drawn"` (the motor
    /// drawn at reset, the earlier default; [`centaur_envs::minitaur::MotorInverse`]).
    /// Changes the hybrid's reference action, so it is a task key, not a training-only one
    /// (the studies that rerun a trained hybrid tell its controller the same motor,
    /// `centaur_lab::experiment::TrainedWith`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motor_inverse: Option<MotorInverse>,
    /// Minitaur: control latency (s), 0 to [`centaur_envs::minitaur::MAX_LATENCY`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub latency: Option<f64>,
    /// Minitaur: observation noise, σ as a fraction of each entry's bound.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observation_noise_std: Option<f64>,
    /// Minitaur: append the body state to the observation (the CoM's velocity in the
    /// heading frame and its height; `MinitaurConfig::observe_body_state`), what a hybrid's
    /// policy observes with `--observe-state`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observe_body_state: Option<bool>,
    /// Gymnasium robots: weight of the forward velocity.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub forward_reward_weight: Option<f64>,
    /// Gymnasium and modular robots: weight of `Σ a²`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ctrl_cost_weight: Option<f64>,
    /// Gymnasium robots: weight of the contact cost.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_cost_weight: Option<f64>,
    /// Gymnasium robots: reward per healthy step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub healthy_reward: Option<f64>,
    /// Gymnasium robots: end the episode when unhealthy.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub terminate_when_unhealthy: Option<bool>,
    /// Gymnasium robots: healthy range of the torso height (m), `[low, high]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub healthy_z_range: Option<[f64; 2]>,
    /// Gymnasium robots (Walker2d, Hopper): healthy range of the torso angle (rad).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub healthy_angle_range: Option<[f64; 2]>,
    /// Gymnasium and modular robots: reset noise scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reset_noise_scale: Option<f64>,
    /// Modular robots: the observation set, `"full"`, `"hinges_orientation"` or `"hinges"`
    /// (the observation ablation; [`ModularObservation`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observation: Option<ModularObservation>,
    /// Every robot: periodic pushes on the base during each episode,
    /// `pushes = { force = 20.0, every = 2.0, duration = 0.1 }` (N, s, s;
    /// [`centaur_envs::PushSchedule`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pushes: Option<PushSchedule>,
}

/// `[env]` keys that change only what a run trains on — perturbations drawn at reset or
/// during episodes — and not what its policies observe, do or are rewarded for: a policy
/// trained with them runs in the robot's preset environment as it is (the robustness study
/// and `embed_controller` take such runs, and runs with `motor_inverse`, whose motor they
/// tell the controller too, or `observe_body_state`, whose observation they give the
/// policies too, `centaur_lab::experiment::TrainedWith`; any other key is refused there).
pub const TRAINING_ONLY: [&str; 2] = ["motor_strength", "pushes"];

impl EnvSettings {
    /// The keys given that are not [`TRAINING_ONLY`]: those that change the task itself.
    pub fn task_keys(&self) -> Vec<&'static str> {
        self.given().into_iter().filter(|k| !TRAINING_ONLY.contains(k)).collect()
    }
}

/// A key of `[env]` that the environment does not have.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("[env] {key} does not apply to {env} (its keys: {})", keys.join(", "))]
pub struct NotApplicable {
    /// The key.
    pub key: &'static str,
    /// The kind of environment.
    pub env: &'static str,
    /// The keys it has.
    pub keys: Vec<&'static str>,
}

const COMMON: [&str; 5] =
    ["max_episode_steps", "frame_skip", "joint_history", "drop_base_orientation", "pushes"];
const MINITAUR: [&str; 11] = [
    "distance_weight",
    "energy_weight",
    "drift_weight",
    "shake_weight",
    "distance_limit",
    "randomize",
    "motor_strength",
    "motor_inverse",
    "latency",
    "observation_noise_std",
    "observe_body_state",
];
const LOCOMOTION: [&str; 8] = [
    "forward_reward_weight",
    "ctrl_cost_weight",
    "contact_cost_weight",
    "healthy_reward",
    "terminate_when_unhealthy",
    "healthy_z_range",
    "healthy_angle_range",
    "reset_noise_scale",
];
const MODULAR: [&str; 3] = ["ctrl_cost_weight", "reset_noise_scale", "observation"];

impl EnvSettings {
    /// Whether no setting is given (the preset as it is).
    pub fn is_empty(&self) -> bool {
        self.given().is_empty()
    }

    /// The keys given, in declaration order.
    pub fn given(&self) -> Vec<&'static str> {
        let s = self;
        let flags = [
            ("max_episode_steps", s.max_episode_steps.is_some()),
            ("frame_skip", s.frame_skip.is_some()),
            ("joint_history", s.joint_history.is_some()),
            ("drop_base_orientation", s.drop_base_orientation.is_some()),
            ("distance_weight", s.distance_weight.is_some()),
            ("energy_weight", s.energy_weight.is_some()),
            ("drift_weight", s.drift_weight.is_some()),
            ("shake_weight", s.shake_weight.is_some()),
            ("distance_limit", s.distance_limit.is_some()),
            ("randomize", s.randomize.is_some()),
            ("motor_strength", s.motor_strength.is_some()),
            ("motor_inverse", s.motor_inverse.is_some()),
            ("latency", s.latency.is_some()),
            ("observation_noise_std", s.observation_noise_std.is_some()),
            ("observe_body_state", s.observe_body_state.is_some()),
            ("forward_reward_weight", s.forward_reward_weight.is_some()),
            ("ctrl_cost_weight", s.ctrl_cost_weight.is_some()),
            ("contact_cost_weight", s.contact_cost_weight.is_some()),
            ("healthy_reward", s.healthy_reward.is_some()),
            ("terminate_when_unhealthy", s.terminate_when_unhealthy.is_some()),
            ("healthy_z_range", s.healthy_z_range.is_some()),
            ("healthy_angle_range", s.healthy_angle_range.is_some()),
            ("reset_noise_scale", s.reset_noise_scale.is_some()),
            ("observation", s.observation.is_some()),
            ("pushes", s.pushes.is_some()),
        ];
        flags.into_iter().filter(|(_, given)| *given).map(|(k, _)| k).collect()
    }

    /// Refuses a key outside `COMMON ∪ own` for an environment of kind `env`.
    fn only(&self, env: &'static str, own: &[&'static str]) -> Result<(), NotApplicable> {
        let keys: Vec<&'static str> = COMMON.iter().chain(own).copied().collect();
        match self.given().into_iter().find(|k| !keys.contains(k)) {
            Some(key) => Err(NotApplicable { key, env, keys }),
            None => Ok(()),
        }
    }

    /// The Pendulum with these settings: only `max_episode_steps` applies.
    pub fn pendulum(&self, mut p: Pendulum) -> Result<Pendulum, NotApplicable> {
        const KEYS: [&str; 1] = ["max_episode_steps"];
        if let Some(key) = self.given().into_iter().find(|k| !KEYS.contains(k)) {
            return Err(NotApplicable { key, env: "the Pendulum", keys: KEYS.to_vec() });
        }
        if let Some(n) = self.max_episode_steps {
            p.max_episode_steps = n;
        }
        Ok(p)
    }

    /// The Minitaur's config with these settings.
    pub fn minitaur(&self, mut c: MinitaurConfig) -> Result<MinitaurConfig, NotApplicable> {
        self.only("the Minitaur", &MINITAUR)?;
        let s = self;
        set(&mut c.max_episode_steps, s.max_episode_steps);
        set(&mut c.action_repeat, s.frame_skip);
        set(&mut c.obs.joint_history, s.joint_history);
        set(&mut c.obs.drop_base_orientation, s.drop_base_orientation);
        set(&mut c.distance_weight, s.distance_weight);
        set(&mut c.energy_weight, s.energy_weight);
        set(&mut c.drift_weight, s.drift_weight);
        set(&mut c.shake_weight, s.shake_weight);
        set(&mut c.distance_limit, s.distance_limit);
        set(&mut c.latency, s.latency);
        set(&mut c.observation_noise_std, s.observation_noise_std);
        set(&mut c.observe_body_state, s.observe_body_state);
        set(&mut c.pushes, s.pushes.map(Some));
        set(&mut c.motor_inverse, s.motor_inverse);
        match s.randomize {
            Some(false) => c.randomization = None,
            Some(true) if c.randomization.is_none() => c.randomization = Some(Default::default()),
            _ => {}
        }
        if let Some([low, high]) = s.motor_strength {
            // A range drawn at reset means nothing without the randomisation: refused, not
            // dropped (the env's validation checks the range itself).
            let Some(r) = c.randomization.as_mut() else {
                let keys = COMMON.iter().chain(&MINITAUR).copied().filter(|k| *k != "motor_strength");
                return Err(NotApplicable {
                    key: "motor_strength",
                    env: "the Minitaur without its randomisation (randomize = false, or minitaur-deterministic: add randomize = true)",
                    keys: keys.collect(),
                });
            };
            r.motor_strength = (low, high);
        }
        Ok(c)
    }

    /// A Gymnasium robot's config with these settings.
    pub fn locomotion(&self, mut c: LocomotionConfig) -> Result<LocomotionConfig, NotApplicable> {
        self.only("a Gymnasium robot", &LOCOMOTION)?;
        let s = self;
        set(&mut c.max_episode_steps, s.max_episode_steps);
        set(&mut c.frame_skip, s.frame_skip);
        set(&mut c.obs.joint_history, s.joint_history);
        set(&mut c.obs.drop_base_orientation, s.drop_base_orientation);
        set(&mut c.forward_reward_weight, s.forward_reward_weight);
        set(&mut c.ctrl_cost_weight, s.ctrl_cost_weight);
        set(&mut c.contact_cost_weight, s.contact_cost_weight);
        set(&mut c.healthy_reward, s.healthy_reward);
        set(&mut c.terminate_when_unhealthy, s.terminate_when_unhealthy);
        set(&mut c.healthy_z_range, s.healthy_z_range.map(|[a, b]| (a, b)));
        set(&mut c.healthy_angle_range, s.healthy_angle_range.map(|[a, b]| (a, b)));
        set(&mut c.reset_noise_scale, s.reset_noise_scale);
        set(&mut c.pushes, s.pushes.map(Some));
        Ok(c)
    }

    /// A modular robot's config with these settings.
    pub fn modular(&self, mut c: ModularConfig) -> Result<ModularConfig, NotApplicable> {
        self.only("a modular robot", &MODULAR)?;
        let s = self;
        set(&mut c.max_episode_steps, s.max_episode_steps);
        set(&mut c.frame_skip, s.frame_skip);
        set(&mut c.obs.joint_history, s.joint_history);
        set(&mut c.obs.drop_base_orientation, s.drop_base_orientation);
        set(&mut c.ctrl_cost_weight, s.ctrl_cost_weight);
        set(&mut c.reset_noise_scale, s.reset_noise_scale);
        set(&mut c.observation, s.observation);
        set(&mut c.pushes, s.pushes.map(Some));
        Ok(c)
    }
}

fn set<T>(field: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *field = v;
    }
}

/// Splits a run file's TOML `text` into its `[env]` table and the rest (the algorithm's
/// settings; `None` when the file has no `[env]`, so that the algorithm's parser reports
/// line numbers); `Err` is the TOML parser's or the `[env]` table's message.
pub fn split_run_toml(text: &str) -> Result<(EnvSettings, Option<toml::Table>), String> {
    let mut table: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
    let Some(env) = table.remove("env") else {
        return Ok((EnvSettings::default(), None));
    };
    let settings = EnvSettings::deserialize(env).map_err(|e| format!("[env]: {e}"))?;
    Ok((settings, Some(table)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_apply_to_their_robots_and_are_refused_elsewhere() {
        let (s, rest) = split_run_toml(
            "gamma = 0.99\n[env]\nenergy_weight = 0.0\nmax_episode_steps = 50\nrandomize = false\n",
        )
        .unwrap();
        assert_eq!(rest.unwrap().get("gamma").and_then(|v| v.as_float()), Some(0.99));
        let m = s.minitaur(MinitaurConfig::default()).unwrap();
        assert_eq!((m.energy_weight, m.max_episode_steps, m.randomization), (0.0, 50, None));
        assert_eq!(m.distance_weight, MinitaurConfig::default().distance_weight);
        let e = s.locomotion(LocomotionConfig::ant()).unwrap_err();
        assert_eq!(e.key, "energy_weight");
        assert!(e.to_string().contains("healthy_reward"), "{e}");
        assert_eq!(s.pendulum(Pendulum::new()).unwrap_err().key, "energy_weight");
        assert_eq!(EnvSettings::default().pendulum(Pendulum::new()).unwrap().max_episode_steps, 200);
        let (s, _) = split_run_toml("[env]\nmax_episode_steps = 50\n").unwrap();
        assert_eq!(s.pendulum(Pendulum::new()).unwrap().max_episode_steps, 50);

        let (s, _) = split_run_toml("[env]\nhealthy_reward = 5.0\nhealthy_z_range = [0.3, 1.0]\n").unwrap();
        let ant = s.locomotion(LocomotionConfig::ant()).unwrap();
        assert_eq!((ant.healthy_reward, ant.healthy_z_range), (5.0, (0.3, 1.0)));
        assert_eq!(s.minitaur(MinitaurConfig::default()).unwrap_err().key, "healthy_reward");

        assert!(split_run_toml("[env]\nhealthy_rewrd = 5.0\n").unwrap_err().contains("healthy_rewrd"));
        // Motor strength drawn at reset: into the randomisation; refused without it and on
        // other robots; a bad range is the env's to refuse.
        let (s, _) = split_run_toml("[env]\nmotor_strength = [0.8, 1.2]\n").unwrap();
        let m = s.minitaur(MinitaurConfig::default()).unwrap();
        assert_eq!(m.randomization.unwrap().motor_strength, (0.8, 1.2));
        assert_eq!(s.locomotion(LocomotionConfig::ant()).unwrap_err().key, "motor_strength");
        let (s, _) = split_run_toml("[env]\nmotor_strength = [0.8, 1.2]\nrandomize = false\n").unwrap();
        let e = s.minitaur(MinitaurConfig::default()).unwrap_err();
        assert!(e.key == "motor_strength" && e.to_string().contains("randomize = false"), "{e}");
        // The deterministic Minitaur (no randomisation): refused as it is, taken with it on.
        let deterministic = MinitaurConfig { randomization: None, ..MinitaurConfig::default() };
        let (s, _) = split_run_toml("[env]\nmotor_strength = [0.8, 1.2]\n").unwrap();
        assert!(s.minitaur(deterministic.clone()).unwrap_err().to_string().contains("randomize = true"));
        let (s, _) = split_run_toml("[env]\nmotor_strength = [0.8, 1.2]\nrandomize = true\n").unwrap();
        assert_eq!(s.minitaur(deterministic).unwrap().randomization.unwrap().motor_strength, (0.8, 1.2));
        // The controller's motor inverse: by name, the Minitaur's only, a task key.
        let (s, _) = split_run_toml("[env]\nmotor_inverse = \"drawn\"\n").unwrap();
        assert_eq!(s.minitaur(MinitaurConfig::default()).unwrap().motor_inverse, MotorInverse::Drawn);
        assert_eq!(s.task_keys(), ["motor_inverse"]);
        assert_eq!(s.locomotion(LocomotionConfig::ant()).unwrap_err().key, "motor_inverse");
        assert!(split_run_toml("[env]\nmotor_inverse = \"exact\"\n").unwrap_err().contains("exact"));
        // The body state in the observation: the Minitaur's only, a task key (it changes
        // what the policy observes), recorded in the env's config only where on.
        let (s, _) = split_run_toml("[env]\nobserve_body_state = true\n").unwrap();
        let m = s.minitaur(MinitaurConfig::default()).unwrap();
        assert!(m.observe_body_state);
        assert!(serde_json::to_string(&m).unwrap().contains("\"observe_body_state\":true"));
        assert!(!serde_json::to_string(&MinitaurConfig::default()).unwrap().contains("observe_body_state"));
        assert_eq!(s.task_keys(), ["observe_body_state"]);
        assert_eq!(s.locomotion(LocomotionConfig::ant()).unwrap_err().key, "observe_body_state");
        // Every training-only key is a key some robot has.
        for k in TRAINING_ONLY {
            assert!(COMMON.contains(&k) || MINITAUR.contains(&k), "{k}");
        }
        for bad in ["[0.0, 1.0]", "[1.2, 0.8]", "[0.8, inf]"] {
            let (s, _) = split_run_toml(&format!("[env]\nmotor_strength = {bad}\n")).unwrap();
            let m = s.minitaur(MinitaurConfig::default()).unwrap();
            let e = m.validate().unwrap_err().to_string();
            assert!(e.contains("motor_strength"), "{bad}: {e}");
        }
        assert!(split_run_toml("[env]\nmax_episode_steps = -3\n").is_err());
        assert_eq!(split_run_toml("gamma = 0.9\n").unwrap(), (EnvSettings::default(), None));
        // The modular observation ablation: a set by name, refused on other robots.
        let (s, _) =
            split_run_toml("[env]\nobservation = \"hinges_orientation\"\njoint_history = 2\n").unwrap();
        let gecko = s.modular(ModularConfig::gecko()).unwrap();
        assert_eq!((gecko.observation, gecko.obs.joint_history), (ModularObservation::HingesOrientation, 2));
        assert_eq!(s.locomotion(LocomotionConfig::ant()).unwrap_err().key, "observation");
        assert!(split_run_toml("[env]\nobservation = \"velocities\"\n").unwrap_err().contains("velocities"));
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<EnvSettings>(&json).unwrap(), s);
        // The settings travel through JSON (run records, checkpoints) unchanged.
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<EnvSettings>(&json).unwrap(), s);
        // Pushes: one key for every robot (not the Pendulum), its fields named.
        let (s, _) =
            split_run_toml("[env]\npushes = { force = 20.0, every = 2.0, duration = 0.1 }\n").unwrap();
        let pushes = Some(PushSchedule { force: 20.0, every: 2.0, duration: 0.1 });
        assert_eq!(s.minitaur(MinitaurConfig::default()).unwrap().pushes, pushes);
        assert_eq!(s.locomotion(LocomotionConfig::walker2d()).unwrap().pushes, pushes);
        assert_eq!(s.modular(ModularConfig::gecko()).unwrap().pushes, pushes);
        assert_eq!(s.pendulum(Pendulum::new()).unwrap_err().key, "pushes");
        assert_eq!(serde_json::from_str::<EnvSettings>(&serde_json::to_string(&s).unwrap()).unwrap(), s);
        let e = split_run_toml("[env]\npushes = { force = 20.0, every = 2.0, length = 0.1 }\n").unwrap_err();
        assert!(e.contains("length"), "{e}");
    }
}
