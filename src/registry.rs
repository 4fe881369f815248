//! Environments by name, for the CLI, the experiment runners and the examples: one table,
//! [`ROBOTS`], gives every robot environment its builder and, where it has them, its
//! controller preset and its residual (hybrid) preset.
//!
//! | name | environment | controller | hybrid `<name>-residual` |
//! |---|---|---|---|
//! | `pendulum` | Gymnasium's Pendulum-v1 ([`centaur_gym::pendulum::Pendulum`]) | — | — |
//! | `minitaur`, `minitaur-fast`, `minitaur-deterministic` | PyBullet's MinitaurBulletEnv-v0 ([`centaur_envs::MinitaurEnv`]; `-fast`: 3.3 ms physics steps; `-deterministic`: no randomisation) | Minitaur | trot 2 m/s steered ±1.5 m/s (rated 3.5 m/s), scale 0.25, exploration σ 0.3 |
//! | `ant`, `ant27` | Gymnasium Ant-v5 (`ant27`: the 27-d observation without contact forces) | Ant | trot 1 m/s steered ±0.5 m/s, scale 0.3, exploration σ 0.1 |
//! | `walker2d` | Gymnasium Walker2d-v5 | Walker2d | walk 1.0 m/s steered ±0.5 m/s (rated 1.5 m/s) at 0.6 of its period, scale 1.0 rising from 1/30 of it over 100k samples, exploration σ 0.3 (SAC, TD3, DDPG: the walk's own period, scale 0.1, no rise) |
//! | `humanoid` | Gymnasium Humanoid-v5 | Humanoid | walk 0.3 m/s steered ±0.1 m/s, scale 0.1, exploration σ 0.1 |
//! | `hopper`, `halfcheetah` | Gymnasium Hopper-, HalfCheetah-v5 | — | — |
//! | `gecko`, `modular-ant`, `spider` | Revolve2's modular robots of those names ([`centaur_envs::ModularEnv`]) | — | — |
//! | `modular:FILE.json` | a modular robot described in a JSON file ([`centaur_envs::Body::from_json`]) | — | — |

use std::path::{Path, PathBuf};

use centaur_envs::minitaur::MotorInverse;
use centaur_envs::{
    Body, LocomotionConfig, LocomotionEnv, MinitaurConfig, MinitaurEnv, ModularConfig, ModularEnv,
    ModularError, RobotEnv, RobotEnvError,
};
use centaur_gym::pendulum::Pendulum;
use centaur_gym::{Env, EnvError, VecEnv};
use centaur_mpc::{Command, ControllerConfig, Gait, LocomotionController};
use centaur_rl::AlgoKind;

use crate::hybrid::{BoundRamp, Exploration, HybridError, ResidualConfig, Steering};
use crate::residual::ResidualEnv;
use crate::settings::{EnvSettings, NotApplicable};

/// Builds a robot environment with `[env]` settings over its preset.
pub type BuildRobot = fn(&EnvSettings) -> Result<Box<dyn RobotEnv>, RegistryError>;

/// One robot environment: how to build it, and its presets.
pub struct RobotSpec {
    /// The name the CLI takes.
    pub name: &'static str,
    /// The environment with settings over its preset.
    pub build: BuildRobot,
    /// The controller preset (`None`: the robot has no controller).
    pub controller: Option<fn() -> ControllerConfig>,
    /// The residual preset of the hybrid for a learner kind: the command the controller
    /// follows, the residual's scale and its exploration (`None`: no hybrid). The robots
    /// whose best hybrid differs by learner (Walker2d's) tell them apart here.
    pub residual: Option<fn(AlgoKind) -> ResidualConfig>,
    /// The motor model the controller is told with these settings, read from the env's
    /// preset with the settings over it (`None`: the robot's actions are torques).
    pub controller_motor: fn(&EnvSettings) -> Option<MotorInverse>,
}

/// A Minitaur env with settings over `config`.
fn minitaur(config: MinitaurConfig, s: &EnvSettings) -> Result<Box<dyn RobotEnv>, RegistryError> {
    Ok(Box::new(MinitaurEnv::new(s.minitaur(config)?)?))
}

/// The motor a Minitaur's controller is told: `[env] motor_inverse` over the preset's.
fn minitaur_motor(preset: MinitaurConfig, s: &EnvSettings) -> Option<MotorInverse> {
    Some(s.motor_inverse.unwrap_or(preset.motor_inverse))
}

/// A robot whose actions are torques: its controller is told no motor model.
fn torque_actions(_: &EnvSettings) -> Option<MotorInverse> {
    None
}

/// A Gymnasium locomotion env with settings over `config`.
fn locomotion(config: LocomotionConfig, s: &EnvSettings) -> Result<Box<dyn RobotEnv>, RegistryError> {
    Ok(Box::new(LocomotionEnv::new(s.locomotion(config)?)?))
}

/// A modular robot env with settings over `config`.
fn modular(config: ModularConfig, s: &EnvSettings) -> Result<Box<dyn RobotEnv>, RegistryError> {
    Ok(Box::new(ModularEnv::new(s.modular(config)?)?))
}

/// The Minitaur's hybrid: a quarter of the leg model's range around a 2 m/s trot whose
/// speed the policy steers within ±1.5 m/s, so to 3.5 m/s; the trot is rated 3.5 m/s here
/// (the controller's own rating is 2.5 m/s, where it clamped the steering:
/// the hybrid plateaued at ≈ 22.4 from 500k samples; rated 3.0 with ±1 m/s its IQM over 5
/// seeds was 25.3 at 1M and over 3 seeds 26.4 at 2M, below pure PPO's 26.8; rated 3.5 with
/// ±1.5 m/s 26.5 at 1M and 27.9 at 2M, with no falls at either; the controller alone trots
/// 3.0 m/s on 1 of 5 seeds, the residual holds it); a gentle start with σ 0.3 on the
/// residual (≈ 0.075 action units per joint) and 0.5 on the steering. On seed 0 of the
/// main example, rated 2.5, a ±0.5 m/s span reached 19.8 in 300k steps, ±1 m/s 21.8 (the
/// steering's gradient is twice as large).
fn minitaur_residual(_: AlgoKind) -> ResidualConfig {
    ResidualConfig {
        steering: Steering { speed: 1.5, ..Steering::OFF },
        exploration: Some(Exploration { residual: 0.3, steering: 0.5 }),
        rated_speed: Some(3.5),
        ..ResidualConfig::new(0.25, Command::forward(2.0, Gait::Trot))
    }
}

/// The Ant's hybrid: 30 % of the control range around a 1 m/s trot whose speed the policy
/// steers within ±0.5 m/s (the controller clamps it to the trot's 1.2 m/s rating); a gentle
/// start with σ 0.1 on the residual and 0.5 on the steering (its first rollout scores 98 % of
/// the controller alone, 75 % at the Minitaur's σ 0.3 on the residual).
fn ant_residual(_: AlgoKind) -> ResidualConfig {
    ResidualConfig {
        steering: Steering { speed: 0.5, ..Steering::OFF },
        exploration: Some(Exploration { residual: 0.1, steering: 0.5 }),
        ..ResidualConfig::new(0.3, Command::forward(1.0, Gait::Trot))
    }
}

/// Walker2d's hybrid: a residual bounded at half the action range (1.0 of [−1, 1]) around a
/// 1.0 m/s walk whose speed the policy steers within ±0.5 m/s, rated 1.5 m/s over the walk's
/// own 1.0 (commanded 1.25 and 1.5 m/s the walk stays up on seeds 0–4 at 0.99–1.03 m/s);
/// explored at σ 0.3 on the residual (the σ that learns to run) and 0.5 on the steering from
/// the start, with a gentle start from a **rising bound**: the residual's bound starts at
/// 1/30 of the scale (σ 0.3 × 0.033 = 0.01 action units, the gentle start of before) and
/// rises log-linearly to the full 1.0 over the first 100k training samples
/// ([`crate::hybrid::BoundRamp`]); and the walk's clock **at 0.6 of its period** (a 0.48 s
/// cycle for the walk's 0.8 s; [`ResidualConfig::period_scale`]): the controller's clock sets
/// the hybrid's cadence, and on the walk's own it ran at ≈ 2.9 m/s, every foot touching
/// down each 0.8 s, where pure PPO runs at 3.6–4.4 m/s with strides of 0.36–0.66 s.
/// 5 seeds × 1M: 4,773.7 with 2/50 falls at 3.89 m/s, above pure PPO's
/// 4,172.2 at every 100k budget; at 0.5 of the period the same 4,773.8 but its walk alone
/// falls in 13/50, at 0.7 4,614.8, at 0.8 4,219.6 with 10/50 falls, on the walk's own clock (the preset until then) 3,910.5 with 0/50, below pure PPO
/// from 800k. The faster walk alone is weaker (1,604.0, 2/50 falls, against 1,786.3 without
/// a fall on its own clock) and the hybrid falls below it at 100k–200k samples (README,
/// "Walker2d: the controller's clock sets the cadence"). The rising exploration (σ 0.01
/// rising to 0.3 over 100k on the same bound) scored 3,785.3 with 14/50
/// falls on the walk's own clock; with the residual bounded at 10 % of the range the walk
/// bounded the hybrid at ≈ 2,035 (1.0 m/s).
///
/// The off-policy learners (SAC, TD3, DDPG) take no gentle start from the exploration (they
/// explore with their own noise: a warm-up, an entropy bonus) and keep the bound of 0.1
/// (10 % of the range) without a rising bound: on `residual_sac_walker2d`'s 50k samples,
/// seed 0, SAC scored 1,291.4 with 4/10 falls on it and 569.3 with 10/10 on 1.0 (the
/// controller alone 1,786.6). Their preset is the walk (on its own clock), the steering and
/// the rating above with that bound.
fn walker2d_residual(kind: AlgoKind) -> ResidualConfig {
    let walk = ResidualConfig {
        steering: Steering { speed: 0.5, ..Steering::OFF },
        rated_speed: Some(1.5),
        ..ResidualConfig::new(1.0, Command::forward(1.0, Gait::Walk))
    };
    if kind.takes_exploration_std() {
        ResidualConfig {
            exploration: Some(Exploration { residual: 0.3, steering: 0.5 }),
            bound_ramp: Some(BoundRamp { from: 0.0333, samples: 100_000 }),
            period_scale: Some(0.6),
            ..walk
        }
    } else {
        ResidualConfig {
            scale: vec![0.1],
            exploration: Some(Exploration { residual: 0.01, steering: 0.5 }),
            ..walk
        }
    }
}

/// The Humanoid's hybrid: 10 % of the control range around a 0.3 m/s walk whose speed the
/// policy steers within ±0.1 m/s (the walk is rated 0.5 m/s); a gentle start with σ 0.1 on
/// the residual and 0.5 on the steering. With 30 % the hybrid fell in 2 of 20 evaluation
/// episodes at 57k samples (seeds 0–1, PPO's defaults), with 10 % in none (both level with
/// the controller alone at 200k). Until the controller walked it was 30 %
/// around standing (stepping in place), at PPO's own exploration.
fn humanoid_residual(_: AlgoKind) -> ResidualConfig {
    ResidualConfig {
        steering: Steering { speed: 0.1, ..Steering::OFF },
        exploration: Some(Exploration { residual: 0.1, steering: 0.5 }),
        ..ResidualConfig::new(0.1, Command::forward(0.3, Gait::Walk))
    }
}

/// Every robot environment with its builder and presets.
pub const ROBOTS: &[RobotSpec] = &[
    RobotSpec {
        name: "minitaur",
        build: |s| minitaur(MinitaurConfig::default(), s),
        controller: Some(ControllerConfig::minitaur),
        residual: Some(minitaur_residual),
        controller_motor: |s| minitaur_motor(MinitaurConfig::default(), s),
    },
    RobotSpec {
        name: "minitaur-fast",
        build: |s| minitaur(MinitaurConfig::fast(), s),
        controller: Some(ControllerConfig::minitaur),
        residual: Some(minitaur_residual),
        controller_motor: |s| minitaur_motor(MinitaurConfig::fast(), s),
    },
    RobotSpec {
        name: "minitaur-deterministic",
        build: |s| minitaur(MinitaurConfig::deterministic(), s),
        controller: Some(ControllerConfig::minitaur),
        residual: Some(minitaur_residual),
        controller_motor: |s| minitaur_motor(MinitaurConfig::deterministic(), s),
    },
    RobotSpec {
        name: "ant",
        build: |s| locomotion(LocomotionConfig::ant(), s),
        controller: Some(ControllerConfig::ant),
        residual: Some(ant_residual),
        controller_motor: torque_actions,
    },
    RobotSpec {
        name: "ant27",
        build: |s| locomotion(LocomotionConfig::ant_27d(), s),
        controller: Some(ControllerConfig::ant),
        residual: Some(ant_residual),
        controller_motor: torque_actions,
    },
    RobotSpec {
        name: "walker2d",
        build: |s| locomotion(LocomotionConfig::walker2d(), s),
        controller: Some(ControllerConfig::walker2d),
        residual: Some(walker2d_residual),
        controller_motor: torque_actions,
    },
    RobotSpec {
        name: "hopper",
        build: |s| locomotion(LocomotionConfig::hopper(), s),
        controller: None,
        residual: None,
        controller_motor: torque_actions,
    },
    RobotSpec {
        name: "halfcheetah",
        build: |s| locomotion(LocomotionConfig::half_cheetah(), s),
        controller: None,
        residual: None,
        controller_motor: torque_actions,
    },
    RobotSpec {
        name: "humanoid",
        build: |s| locomotion(LocomotionConfig::humanoid(), s),
        controller: Some(ControllerConfig::humanoid),
        residual: Some(humanoid_residual),
        controller_motor: torque_actions,
    },
    RobotSpec {
        name: "gecko",
        build: |s| modular(ModularConfig::gecko(), s),
        controller: None,
        residual: None,
        controller_motor: torque_actions,
    },
    RobotSpec {
        name: "modular-ant",
        build: |s| modular(ModularConfig::ant(), s),
        controller: None,
        residual: None,
        controller_motor: torque_actions,
    },
    RobotSpec {
        name: "spider",
        build: |s| modular(ModularConfig::spider(), s),
        controller: None,
        residual: None,
        controller_motor: torque_actions,
    },
];

/// Why an environment could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RegistryError {
    /// No environment has this name.
    #[error("unknown environment `{name}` (available: {})", env_names().join(", "))]
    UnknownEnv {
        /// The name asked for.
        name: String,
    },
    /// The robot has no controller (so no hybrid either).
    #[error("`{name}` has no controller (controllers exist for {})", controlled_names().join(", "))]
    NoController {
        /// The environment.
        name: String,
    },
    /// The robot environment could not be built.
    #[error(transparent)]
    RobotEnv(#[from] RobotEnvError),
    /// `modular:` with no file after it.
    #[error("`modular:` needs the body file after the colon: modular:FILE.json")]
    NoBodyFile,
    /// A modular robot's body file cannot be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// A modular robot's body file describes no valid body.
    #[error("{path}: {source}")]
    Body {
        /// The file.
        path: PathBuf,
        /// Why.
        source: ModularError,
    },
    /// The hybrid could not be put together.
    #[error(transparent)]
    Hybrid(#[from] HybridError),
    /// An `[env]` setting the environment does not have.
    #[error(transparent)]
    Settings(#[from] NotApplicable),
    /// The environments refused to start.
    #[error("environment `{name}`: {source}")]
    Env {
        /// The environment.
        name: String,
        /// Cause.
        source: EnvError,
    },
}

/// Every name [`make_env`] takes (`modular:FILE.json` aside).
pub fn env_names() -> Vec<String> {
    let mut names = vec!["pendulum".to_string()];
    names.extend(ROBOTS.iter().map(|r| r.name.to_string()));
    names.extend(ROBOTS.iter().filter(|r| r.residual.is_some()).map(|r| format!("{}-residual", r.name)));
    names.push("modular:FILE.json".to_string());
    names
}

/// The robot environments with a controller.
pub fn controlled_names() -> Vec<&'static str> {
    ROBOTS.iter().filter(|r| r.controller.is_some()).map(|r| r.name).collect()
}

/// The robot of a name (`modular:FILE.json` has no entry).
pub fn robot(name: &str) -> Option<&'static RobotSpec> {
    ROBOTS.iter().find(|r| r.name == name)
}

/// The configuration of a modular robot environment: a preset (`gecko`, `modular-ant`,
/// `spider`) or `modular:FILE.json`, a body read from a file and named after it; `None` for
/// other names.
pub fn modular_config(name: &str) -> Result<Option<ModularConfig>, RegistryError> {
    match name.strip_prefix("modular:") {
        Some(file) => modular_file_config(file).map(Some),
        None => Ok(ModularConfig::preset(name)),
    }
}

/// The largest body file `modular:FILE.json` reads (16 MiB): a larger file (or an endless
/// one such as `/dev/zero`) is refused before it fills memory.
pub const MAX_BODY_BYTES: u64 = 16 << 20;

/// The text of a body file, bounded by [`MAX_BODY_BYTES`].
fn read_body_file(path: &Path) -> Result<String, RegistryError> {
    use std::io::Read;
    if path.as_os_str().is_empty() {
        return Err(RegistryError::NoBodyFile);
    }
    let io = |source| RegistryError::Io { path: path.to_path_buf(), source };
    let mut text = String::new();
    std::fs::File::open(path).map_err(io)?.take(MAX_BODY_BYTES + 1).read_to_string(&mut text).map_err(io)?;
    if text.len() as u64 > MAX_BODY_BYTES {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("body file larger than {} MiB", MAX_BODY_BYTES >> 20),
        )));
    }
    Ok(text)
}

/// The configuration of a modular body given as JSON `text` (from `path`, which names it).
fn modular_text_config(path: &Path, text: &str) -> Result<ModularConfig, RegistryError> {
    // A byte-order mark (which some editors write) is not JSON; it is skipped.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let body =
        Body::from_json(text).map_err(|source| RegistryError::Body { path: path.to_path_buf(), source })?;
    let stem = path.file_stem().map_or("modular".to_string(), |s| s.to_string_lossy().into_owned());
    Ok(ModularConfig::new(&stem, body))
}

/// The configuration of `modular:FILE.json`: the body read from `file`, named after it.
fn modular_file_config(file: &str) -> Result<ModularConfig, RegistryError> {
    let path = PathBuf::from(file);
    modular_text_config(&path, &read_body_file(&path)?)
}

/// An environment name with everything it needs from disk read once, at the start: a run
/// builds all its environments (training, evaluation) from this, so changing or deleting a
/// `modular:FILE.json` mid-run changes nothing, and the body travels with the run record
/// and the checkpoint.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvSource {
    name: String,
    body: Option<String>,
    settings: EnvSettings,
    /// The learner a hybrid `<robot>-residual` is built for: its residual preset
    /// ([`residual_config_for`]); PPO's unless [`EnvSource::for_learner`] says otherwise.
    learner: AlgoKind,
    /// A hybrid's setup given whole (a run spec's, a run's record), replacing the learner's
    /// preset ([`EnvSource::with_residual`]).
    residual: Option<ResidualConfig>,
}

impl EnvSource {
    /// Reads what `name` needs (the body file of `modular:FILE.json`, checked) and checks
    /// that the name exists by making one environment.
    pub fn read(name: &str) -> Result<EnvSource, RegistryError> {
        let body = match name.strip_prefix("modular:") {
            Some(file) => Some(read_body_file(Path::new(file))?),
            None => None,
        };
        let source = EnvSource::with_body(name, body);
        source.make()?;
        Ok(source)
    }

    /// The same environment built for learners of `kind`: a hybrid `<robot>-residual` takes
    /// that learner's residual preset ([`residual_config_for`]; the other environments do not
    /// depend on the learner). Checked by making one.
    pub fn for_learner(self, kind: AlgoKind) -> Result<EnvSource, RegistryError> {
        let source = EnvSource { learner: kind, ..self };
        source.make()?;
        Ok(source)
    }

    /// The learner the environment is built for ([`EnvSource::for_learner`]).
    pub fn learner(&self) -> AlgoKind {
        self.learner
    }

    /// The setup of the hybrid this source builds: the one given by
    /// [`EnvSource::with_residual`], else the learner's preset (`None`: not a hybrid).
    pub fn residual(&self) -> Option<ResidualConfig> {
        let robot = self.name.strip_suffix("-residual")?;
        self.residual.clone().or_else(|| residual_config_for(robot, self.learner).ok())
    }

    /// The same hybrid `<robot>-residual` with `residual` as its setup instead of the
    /// learner's preset, checked by making one; refused for an environment that is not a
    /// hybrid.
    pub fn with_residual(self, residual: ResidualConfig) -> Result<EnvSource, RegistryError> {
        if self.name.strip_suffix("-residual").and_then(robot).and_then(|r| r.residual).is_none() {
            return Err(RegistryError::NoController { name: self.name.clone() });
        }
        let source = EnvSource { residual: Some(residual), ..self };
        source.make()?;
        Ok(source)
    }

    /// The same environment with `[env]` settings over its preset, checked by making one.
    pub fn with_settings(self, settings: EnvSettings) -> Result<EnvSource, RegistryError> {
        let source = EnvSource { settings, ..self };
        source.make()?;
        Ok(source)
    }

    /// The `[env]` settings.
    pub fn settings(&self) -> &EnvSettings {
        &self.settings
    }

    /// A source whose body text was read before (a run record's); `body` is ignored for
    /// names other than `modular:FILE.json`, which requires it.
    pub fn with_body(name: &str, body: Option<String>) -> EnvSource {
        let body = if name.starts_with("modular:") { body } else { None };
        EnvSource {
            name: name.to_string(),
            body,
            settings: EnvSettings::default(),
            learner: AlgoKind::Ppo,
            residual: None,
        }
    }

    /// The environment's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The body text of `modular:FILE.json` as read at the start.
    pub fn body(&self) -> Option<&str> {
        self.body.as_deref()
    }

    /// A fresh environment (as [`make_env`], with the body read at the start).
    pub fn make(&self) -> Result<Box<dyn Env>, RegistryError> {
        match (self.name.strip_prefix("modular:"), &self.body) {
            (Some(file), Some(text)) => {
                Ok(modular(modular_text_config(Path::new(file), text)?, &self.settings)?)
            }
            (Some(file), None) => Err(RegistryError::Io {
                path: PathBuf::from(file),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "the run records no body for this file",
                ),
            }),
            (None, _) => match (&self.residual, self.name.strip_suffix("-residual")) {
                (Some(residual), Some(robot)) => {
                    Ok(Box::new(make_residual_env_with(robot, residual.clone(), &self.settings)?))
                }
                _ => make_env_for(&self.name, &self.settings, self.learner),
            },
        }
    }

    /// `n` fresh environments stepped on `threads` threads.
    pub fn make_vec(&self, n: usize, threads: usize) -> Result<VecEnv, RegistryError> {
        let envs = (0..n).map(|_| self.make()).collect::<Result<Vec<_>, _>>()?;
        VecEnv::new(envs, threads).map_err(|source| RegistryError::Env { name: self.name.clone(), source })
    }
}

/// A robot environment by name; `max_episode_steps` overrides the default length.
pub fn make_robot_env(
    name: &str,
    max_episode_steps: Option<usize>,
) -> Result<Box<dyn RobotEnv>, RegistryError> {
    make_robot_env_with(name, &EnvSettings { max_episode_steps, ..EnvSettings::default() })
}

/// A robot environment by name with `[env]` settings over its preset.
pub fn make_robot_env_with(name: &str, settings: &EnvSettings) -> Result<Box<dyn RobotEnv>, RegistryError> {
    if let Some(file) = name.strip_prefix("modular:") {
        return modular(modular_file_config(file)?, settings);
    }
    let spec = robot(name).ok_or_else(|| RegistryError::UnknownEnv { name: name.to_string() })?;
    (spec.build)(settings)
}

/// The motor model the controller of robot environment `name` is told with `settings`
/// ([`centaur_envs::MinitaurConfig::motor_inverse`], the Minitaur's: its controller's torques
/// become motor commands through it). `None`: a robot whose actions are torques.
pub fn controller_motor(name: &str, settings: &EnvSettings) -> Option<MotorInverse> {
    robot(name).and_then(|spec| (spec.controller_motor)(settings))
}

/// The controller preset of a robot environment.
pub fn controller_config(name: &str) -> Result<ControllerConfig, RegistryError> {
    robot(name)
        .and_then(|r| r.controller)
        .map(|preset| preset())
        .ok_or_else(|| RegistryError::NoController { name: name.to_string() })
}

/// The residual preset of a robot environment's hybrid for PPO (and A2C), the learner the
/// presets are tuned with; [`residual_config_for`] gives another learner's.
pub fn residual_config(name: &str) -> Result<ResidualConfig, RegistryError> {
    residual_config_for(name, AlgoKind::Ppo)
}

/// The residual preset of a robot environment's hybrid for learners of `kind` (Walker2d's
/// off-policy learners keep a narrower bound: [`RobotSpec::residual`]).
pub fn residual_config_for(name: &str, kind: AlgoKind) -> Result<ResidualConfig, RegistryError> {
    robot(name)
        .and_then(|r| r.residual)
        .map(|preset| preset(kind))
        .ok_or_else(|| RegistryError::NoController { name: name.to_string() })
}

/// The hybrid of a robot environment: the env, its controller preset and `residual`.
pub fn make_residual_env(name: &str, residual: ResidualConfig) -> Result<ResidualEnv, RegistryError> {
    make_residual_env_with(name, residual, &EnvSettings::default())
}

/// The hybrid of a robot environment with `[env]` settings over the robot's preset.
pub fn make_residual_env_with(
    name: &str,
    residual: ResidualConfig,
    settings: &EnvSettings,
) -> Result<ResidualEnv, RegistryError> {
    let mut config = controller_config(name)?;
    residual.rate_controller(&mut config)?;
    let env = make_robot_env_with(name, settings)?;
    let controller = LocomotionController::new(env.model(), config).map_err(HybridError::from)?;
    Ok(ResidualEnv::new(env, controller, residual)?)
}

/// A fresh environment by name: `pendulum`, a robot, `modular:FILE.json`, or a hybrid
/// `<robot>-residual` with the robot's residual preset for PPO ([`make_env_for`]: another
/// learner's).
pub fn make_env(name: &str) -> Result<Box<dyn Env>, RegistryError> {
    make_env_with(name, &EnvSettings::default())
}

/// [`make_env`] with `[env]` settings over the preset (only `max_episode_steps` for the
/// Pendulum).
pub fn make_env_with(name: &str, settings: &EnvSettings) -> Result<Box<dyn Env>, RegistryError> {
    make_env_for(name, settings, AlgoKind::Ppo)
}

/// [`make_env_with`] for learners of `kind`: a hybrid `<robot>-residual` takes that
/// learner's residual preset ([`residual_config_for`]).
pub fn make_env_for(
    name: &str,
    settings: &EnvSettings,
    kind: AlgoKind,
) -> Result<Box<dyn Env>, RegistryError> {
    if name == "pendulum" {
        if settings.max_episode_steps == Some(0) {
            let message = "max_episode_steps must be positive".to_string();
            return Err(RobotEnvError::InvalidConfig { config: "Pendulum", message }.into());
        }
        return Ok(Box::new(settings.pendulum(Pendulum::new())?));
    }
    if let Some(robot) = name.strip_suffix("-residual")
        && self::robot(robot).is_some_and(|r| r.residual.is_some())
    {
        return Ok(Box::new(make_residual_env_with(robot, residual_config_for(robot, kind)?, settings)?));
    }
    Ok(make_robot_env_with(name, settings)?)
}

/// `n` copies of an environment stepped on `threads` threads.
pub fn make_vec_env(name: &str, n: usize, threads: usize) -> Result<VecEnv, RegistryError> {
    let envs = (0..n.max(1)).map(|_| make_env(name)).collect::<Result<Vec<_>, _>>()?;
    VecEnv::new(envs, threads).map_err(|source| RegistryError::Env { name: name.to_string(), source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_body_height_beyond_the_robots_reach_is_refused() {
        let preset = residual_config("minitaur").unwrap();
        let with = |h: f64| {
            let command = Command { body_height: Some(h), ..preset.command };
            make_residual_env("minitaur", ResidualConfig { command, ..preset.clone() })
        };
        // The screened heights (README, "Where the hybrid's gait tops out") build.
        assert!(with(0.21).is_ok() && with(0.24).is_ok());
        let refused = |h: f64| with(h).err().unwrap_or_else(|| panic!("{h} accepted")).to_string();
        for bad in [20.0, 0.01] {
            let err = refused(bad);
            assert!(err.contains("body_height") && err.contains("standing CoM height"), "{err}");
        }
        for bad in [f64::INFINITY, f64::NAN, -0.2] {
            assert!(refused(bad).contains("body_height"), "{bad}");
        }
    }

    /// `rated_speed` reaches the controller the hybrid runs; a bad one is an error, not a
    /// silently kept preset.
    #[test]
    fn a_hybrids_rated_speed_reaches_its_controller() {
        let preset = residual_config("minitaur").unwrap();
        let env = make_residual_env("minitaur", ResidualConfig { rated_speed: Some(2.8), ..preset.clone() })
            .unwrap();
        assert_eq!(env.controller().config().offer(centaur_mpc::Gait::Trot).unwrap().max_speed, 2.8);
        let env = make_residual_env("minitaur", preset.clone()).unwrap();
        assert_eq!(env.controller().config().offer(centaur_mpc::Gait::Trot).unwrap().max_speed, 3.5);
        let env =
            make_residual_env("minitaur", ResidualConfig { rated_speed: None, ..preset.clone() }).unwrap();
        assert_eq!(env.controller().config().offer(centaur_mpc::Gait::Trot).unwrap().max_speed, 2.5);
        let bad =
            make_residual_env("minitaur", ResidualConfig { rated_speed: Some(f64::NAN), ..preset.clone() });
        assert!(bad.is_err_and(|e| e.to_string().contains("rated_speed")));
        // The command ramp too.
        let env =
            make_residual_env("minitaur", ResidualConfig { max_acceleration: Some(6.0), ..preset.clone() })
                .unwrap();
        assert_eq!(env.controller().config().max_acceleration, 6.0);
        assert_eq!(
            make_residual_env("minitaur", preset).unwrap().controller().config().max_acceleration,
            3.0
        );
    }

    /// The motor each robot's controller is told comes from its own preset with the
    /// settings over it: the Minitaur presets are told the env's motor (`[env]
    /// motor_inverse` wins), the torque-actuated robots none.
    #[test]
    fn controller_motor_reads_each_robots_preset() {
        let drawn = EnvSettings { motor_inverse: Some(MotorInverse::Drawn), ..EnvSettings::default() };
        let presets = [
            ("minitaur", MinitaurConfig::default()),
            ("minitaur-fast", MinitaurConfig::fast()),
            ("minitaur-deterministic", MinitaurConfig::deterministic()),
        ];
        for (name, preset) in presets {
            let built = EnvSettings::default().minitaur(preset.clone()).unwrap();
            assert_eq!(controller_motor(name, &EnvSettings::default()), Some(built.motor_inverse), "{name}");
            assert_eq!(controller_motor(name, &drawn), Some(MotorInverse::Drawn), "{name}");
        }
        for r in ROBOTS.iter().filter(|r| !r.name.starts_with("minitaur")) {
            assert_eq!(controller_motor(r.name, &EnvSettings::default()), None, "{}", r.name);
        }
        assert_eq!(controller_motor("minitaur-nonesuch", &EnvSettings::default()), None);
    }

    #[test]
    fn every_robot_has_one_entry_and_hybrids_need_a_controller() {
        for (k, r) in ROBOTS.iter().enumerate() {
            assert!(ROBOTS[k + 1..].iter().all(|o| o.name != r.name), "{} twice", r.name);
            assert!(
                r.residual.is_none() || r.controller.is_some(),
                "{}: a hybrid without a controller",
                r.name
            );
        }
    }

    /// Walker2d's hybrid differs by learner: PPO and A2C get the 1.0 bound rising from 1/30
    /// of it on the walk at 0.6 of its period, the off-policy learners the 0.1 bound without
    /// a rise on the walk's own period (the walk, steering and rating the same); every other robot's preset is the same for every learner, and
    /// `residual_config` is PPO's.
    #[test]
    fn the_residual_preset_is_chosen_per_learner_where_it_differs() {
        let ppo = residual_config_for("walker2d", AlgoKind::Ppo).unwrap();
        assert_eq!(residual_config("walker2d").unwrap(), ppo);
        assert_eq!(residual_config_for("walker2d", AlgoKind::A2c).unwrap(), ppo);
        assert_eq!(
            (ppo.scale.clone(), ppo.bound_ramp.is_some(), ppo.period_scale),
            (vec![1.0], true, Some(0.6))
        );
        for kind in [AlgoKind::Sac, AlgoKind::SacV1, AlgoKind::Td3, AlgoKind::Ddpg] {
            let off = residual_config_for("walker2d", kind).unwrap();
            let exploration = Some(Exploration { residual: 0.01, steering: 0.5 });
            assert_eq!(
                off,
                ResidualConfig {
                    scale: vec![0.1],
                    exploration,
                    bound_ramp: None,
                    period_scale: None,
                    ..ppo.clone()
                }
            );
            off.validate(6).unwrap();
        }
        for spec in ROBOTS.iter().filter(|r| r.residual.is_some() && r.name != "walker2d") {
            for kind in AlgoKind::ALL {
                assert_eq!(
                    residual_config_for(spec.name, kind).unwrap(),
                    residual_config(spec.name).unwrap()
                );
            }
        }
        // The source carries the learner to the hybrid it builds.
        let source = EnvSource::read("walker2d-residual").unwrap().for_learner(AlgoKind::Sac).unwrap();
        assert_eq!(source.residual().unwrap().scale, vec![0.1]);
        let text = source.make().unwrap().config_text().unwrap();
        assert!(text.contains(r#""scale":[0.1]"#), "{text}");
        assert_eq!(EnvSource::read("walker2d").unwrap().residual(), None);
    }

    /// The two name lists this table replaced disagreed: `minitaur-deterministic` got the
    /// default residual scale 0.3 instead of the Minitaur's 0.25.
    #[test]
    fn regression_minitaur_deterministic_has_the_minitaur_residual() {
        let m = residual_config("minitaur").unwrap();
        assert_eq!(residual_config("minitaur-deterministic").unwrap(), m);
        assert_eq!(residual_config("minitaur-fast").unwrap(), m);
        assert_eq!(m.scale, vec![0.25]);
        assert_eq!(residual_config("ant27").unwrap(), residual_config("ant").unwrap());
    }

    #[test]
    fn unknown_and_uncontrolled_names_are_typed_errors() {
        assert!(matches!(make_env("nope"), Err(RegistryError::UnknownEnv { .. })));
        assert!(matches!(controller_config("hopper"), Err(RegistryError::NoController { .. })));
        assert!(matches!(make_env("modular:"), Err(RegistryError::NoBodyFile)));
        assert!(matches!(EnvSource::read("modular:"), Err(RegistryError::NoBodyFile)));
        // A byte-order mark before the JSON is skipped (reliability probe).
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/modular/snake.json");
        let text = format!("\u{feff}{}", std::fs::read_to_string(path).unwrap());
        let with_bom = modular_text_config(Path::new("snake.json"), &text).unwrap();
        assert_eq!(with_bom, modular_text_config(Path::new("snake.json"), &text[3..]).unwrap());
        assert!(matches!(make_env("hopper-residual"), Err(RegistryError::UnknownEnv { .. })));
        let msg = controller_config("gecko").unwrap_err().to_string();
        assert!(msg.contains("minitaur") && msg.contains("walker2d"), "{msg}");
    }

    #[test]
    fn every_robot_env_name_builds() {
        for r in ROBOTS {
            let env = make_robot_env(r.name, Some(10)).unwrap();
            assert_eq!(env.max_episode_steps(), 10, "{}", r.name);
        }
        assert!(matches!(make_robot_env("cartpole", None), Err(RegistryError::UnknownEnv { .. })));
    }

    #[test]
    fn modular_robots_load_from_json_files() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/modular/snake.json");
        let env = make_robot_env(&format!("modular:{path}"), Some(7)).unwrap();
        assert_eq!(env.name(), "snake");
        assert_eq!(env.action_space().dim(), 4);
        assert_eq!(env.max_episode_steps(), 7);
        assert!(matches!(make_robot_env("modular:/no/such/body.json", None), Err(RegistryError::Io { .. })));
        let dir = std::env::temp_dir().join(format!("centaur-modular-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("bad.json");
        std::fs::write(&bad, r#"{"kind": "core", "back": {"kind": "brick", "back": {"kind": "brick"}}}"#)
            .unwrap();
        match make_robot_env(&format!("modular:{}", bad.display()), None) {
            Err(RegistryError::Body { source, .. }) => {
                assert!(matches!(source, ModularError::NoSuchFace { kind: "brick", .. }), "{source}")
            }
            Err(other) => panic!("{other}"),
            Ok(_) => panic!("a brick has no back face"),
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Regression (reliability probe, data loss 3): the body file was read three times in
    /// a run; an `EnvSource` reads it once, and an endless file is refused.
    #[test]
    fn an_env_source_reads_its_body_once() {
        let dir = std::env::temp_dir().join(format!("centaur-source-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("snake.json");
        let snake = include_str!("../assets/modular/snake.json");
        std::fs::write(&file, snake).unwrap();
        let name = format!("modular:{}", file.display());
        let source = EnvSource::read(&name).unwrap();
        assert_eq!(source.body(), Some(snake));
        std::fs::remove_file(&file).unwrap();
        let env = source.make().unwrap();
        assert_eq!(env.action_space().dim(), 4);
        assert_eq!(source.make_vec(2, 1).unwrap().len(), 2);
        assert!(matches!(EnvSource::with_body(&name, None).make(), Err(RegistryError::Io { .. })));
        assert!(EnvSource::with_body("pendulum", Some("ignored".into())).body().is_none());
        assert!(matches!(EnvSource::read("gecko-typo"), Err(RegistryError::UnknownEnv { .. })));
        if Path::new("/dev/zero").exists() {
            match EnvSource::read("modular:/dev/zero") {
                Err(RegistryError::Io { source, .. }) => assert!(source.to_string().contains("larger than")),
                other => panic!("{other:?}"),
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
