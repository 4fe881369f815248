//! Run specs: one TOML file holds everything a run is.
//!
//! A spec names the robot environment and the learner, the seeds and the budget, and in
//! its tables the robot's settings (`[env]`), the learner's hyperparameters (`[learner]`,
//! and `[hybrid_learner]` where the hybrid's differ) and the hybrid's setup, split along
//! its owners: `[hybrid]` (the residual law), `[controller]` (what the hybrid changes on
//! its controller) and `[exploration]` (the learner's initial noise per action part and its
//! schedule). Every key is optional but `schema`, `robot`, `algo` and `steps`; an absent key
//! keeps the robot's preset. `centaur compare --spec FILE`, `centaur train --spec FILE` and
//! `centaur spec FILE` take one, with `--set key.path=value` overrides on top (TOML values:
//! `--set controller.rated_speed=4.0`, `--set hybrid.parts='"residual"'` or, for a word,
//! `--set hybrid.parts=residual`).
//!
//! ```toml
//! schema = 1
//! robot = "minitaur"        # compare: a robot with a controller; train: any env name
//! algo = "ppo"
//! seeds = 5                 # default: 5
//! steps = 1_000_000
//! eval_every = 100_000      # default: 100,000 (0: at the end only)
//!
//! [env]                     # the robot's settings over its preset (crate::settings)
//! observe_body_state = true
//!
//! [learner]                 # over the robot's tuned settings (`base = "defaults"`: over
//! learning_rate = 3e-4      # the algorithm's defaults, as a `--config` file is)
//!
//! [hybrid]
//! residual_scale = 0.5
//! steering = { speed = 2.5, cadence = 0.75 }
//!
//! [controller]
//! speed = 3.0
//! rated_speed = 4.5
//! max_acceleration = 15.0
//!
//! [exploration]
//! residual = 0.15
//! steering = 1.0
//! ramp = { residual = 0.3 }
//! ```
//!
//! Resolution ([`RunSpec::resolve`]) turns a spec into a [`ResolvedSpec`]: every value
//! explicit (the learner's every hyperparameter, the hybrid's whole
//! [`ResidualConfig`]), validated once, with the key's path in every error. A run writes it
//! as `spec.json` (canonical JSON: fields in declared order, maps sorted, floats in their
//! round-trip form) with the Centaur version, and [`ResolvedSpec::identity`] hashes it;
//! [`ResolvedSpec::pure_identity`] is the same without the hybrid's tables, which pure RL
//! does not depend on.
//!
//! Refused before anything runs: an unknown key anywhere (named with its path), a key of
//! another robot's `[env]`, a hybrid table on an environment without a controller, a value
//! out of range (the key, the value and the range), a spec of a newer schema.

use std::path::Path;

use centaur_rl::{A2cConfig, AlgoConfig, AlgoKind, DdpgConfig, PpoConfig, SacConfig, SacV1Config, Td3Config};
use serde::{Deserialize, Serialize};

use crate::experiment::tuned_config;
use crate::hybrid::{BoundRamp, Exploration, ExplorationRamp, Fade, HybridError, ResidualConfig, Steering};
use crate::mpc::Gait;
use crate::registry::{EnvSource, RegistryError, residual_config_for};
use crate::settings::EnvSettings;

/// The spec format this Centaur reads and writes; a spec of a newer one is refused.
pub const SCHEMA_VERSION: u32 = 1;

/// The samples over which a ramp rises when neither the spec (or flag) nor the robot's
/// preset says.
pub const DEFAULT_RAMP_SAMPLES: u64 = 200_000;

/// The largest spec file read (1 MiB, as every config file).
pub const MAX_SPEC_BYTES: u64 = 1 << 20;

/// Seeds a spec may ask for (compare's range).
pub const SEEDS_RANGE: (u64, u64) = (1, 10_000);
/// Training steps per agent and seed.
pub const STEPS_RANGE: (u64, u64) = (1, 10_000_000_000);
/// The most deterministic evaluations during one run (`steps / eval_every`).
pub const MAX_EVALUATIONS: u64 = 1000;
/// The shortest interval between evaluations (steps): each evaluates `eval_episodes` whole
/// episodes, so one every few steps would cost far more than the training.
pub const MIN_EVAL_EVERY: u64 = 128;
/// Parallel environments per agent.
pub const ENVS_RANGE: (u64, u64) = (1, 4096);
/// Evaluation episodes per agent and seed.
pub const EVAL_EPISODES_RANGE: (u64, u64) = (1, 100_000);

/// Why a spec was refused.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// Not a spec: unreadable, not TOML, an unknown key, a value of the wrong type.
    #[error("{source_name}: {message}")]
    Parse {
        /// The file (or `--set`).
        source_name: String,
        /// What the parser said, with the key.
        message: String,
    },
    /// A value outside its range.
    #[error("{key} = {value}: must be {expected}")]
    Range {
        /// The key's path (`controller.rated_speed`).
        key: String,
        /// The value given.
        value: String,
        /// The range or the kind of value allowed.
        expected: String,
    },
    /// A spec written by a newer Centaur.
    #[error(
        "{source_name}: schema {found} is newer than this Centaur reads (schema {SCHEMA_VERSION}); update Centaur or write the spec for schema {SCHEMA_VERSION}"
    )]
    Newer {
        /// The file.
        source_name: String,
        /// Its schema.
        found: u32,
    },
    /// A `--set` that is not `key.path=value`.
    #[error("--set {0}: expected key.path=value (e.g. --set controller.rated_speed=4.0)")]
    BadSet(String),
    /// A hybrid table for an environment the hybrid does not run on.
    #[error("[{table}] sets the hybrid, and {reason}")]
    NotAHybrid {
        /// `hybrid`, `controller`, `exploration` or `hybrid_learner`.
        table: &'static str,
        /// Why the environment takes none.
        reason: String,
    },
    /// The environment (unknown, or `[env]` settings it does not take).
    #[error("{0}")]
    Env(#[from] RegistryError),
}

/// A spec as written: every key but `schema`, `robot`, `algo` and `steps` optional.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// The spec format ([`SCHEMA_VERSION`]).
    pub schema: u32,
    /// The environment: for `compare`, a robot with a controller (`minitaur`, `ant`, …);
    /// for `train`, any name `--env` takes (`minitaur-residual` trains the hybrid).
    pub robot: String,
    /// The learner: `ppo`, `a2c`, `sac`, `sac1`, `td3` or `ddpg`.
    pub algo: String,
    /// Seeds `0..seeds` (default: 5; `compare`'s; `train` trains one, `--seed`).
    pub seeds: Option<u64>,
    /// Training steps per agent and seed.
    pub steps: u64,
    /// Parallel environments per agent (default: 4 for PPO and A2C, 1 otherwise).
    pub envs: Option<u64>,
    /// Deterministic evaluation episodes per agent and seed (default: 10).
    pub eval_episodes: Option<u64>,
    /// Deterministic evaluations every this many training steps, 0: at the end only
    /// (default: 100,000).
    pub eval_every: Option<u64>,
    /// The robot's settings over its preset ([`EnvSettings`]; default: the preset).
    #[serde(default, skip_serializing_if = "EnvSettings::is_empty")]
    pub env: EnvSettings,
    /// The learner's hyperparameters: the fields of its config struct over the robot's
    /// tuned settings, or with `base = "defaults"` over the algorithm's defaults (default:
    /// the robot's tuned settings).
    pub learner: Option<toml::Table>,
    /// The hybrid's own hyperparameters, over `[learner]`'s resolved ones (`base =
    /// "defaults"`: over the algorithm's defaults, `"tuned"`: the robot's tuned ones;
    /// default: the hybrid learns with `[learner]`'s).
    pub hybrid_learner: Option<toml::Table>,
    /// The residual law.
    pub hybrid: Option<HybridTable>,
    /// What the hybrid changes on its controller.
    pub controller: Option<ControllerTable>,
    /// The learner's initial exploration per action part and its schedule.
    pub exploration: Option<ExplorationTable>,
}

/// Which parts of the hybrid's action are on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Parts {
    /// The joint residual and the command steering of the robot's preset.
    #[default]
    Both,
    /// The joint residual only (steering off).
    Residual,
    /// The command steering only (no joint residual).
    Command,
}

/// `[hybrid]`: the residual law.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HybridTable {
    /// Bound of the joint residual, action units, one value for every entry.
    pub residual_scale: Option<f64>,
    /// Which parts are on (default: both).
    pub parts: Option<Parts>,
    /// Spans of the command steering.
    pub steering: Option<SteeringTable>,
    /// Append the reference action to the observation.
    pub include_reference: Option<bool>,
    /// Append the controller's measured body state to the observation.
    pub observe_state: Option<bool>,
    /// A safety fade as the body sinks (see [`Fade`]).
    pub fade: Option<Fade>,
    /// A rising residual bound.
    pub bound_ramp: Option<RampTable>,
}

/// `[hybrid.steering]`: each span of [`Steering`], the preset's where absent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SteeringTable {
    /// Forward-speed span, m/s (0: off).
    pub speed: Option<f64>,
    /// Yaw-rate span, rad/s (0: off).
    pub yaw_rate: Option<f64>,
    /// Cadence span, a fraction in [0, 0.75].
    pub cadence: Option<f64>,
    /// Duty-factor span, a fraction in [0, 0.3].
    pub duty: Option<f64>,
    /// Swing-height span, a fraction in [0, 0.75].
    pub swing: Option<f64>,
    /// Foothold span, m in [0, 0.1].
    pub foothold: Option<f64>,
}

/// A ramp over the first training samples: `from` (the bound's start fraction, or the
/// exploration's end σ as `residual`) and `samples`; `off = true` removes the preset's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RampTable {
    /// The bound ramp's start, a fraction of the scale in (0, 1].
    pub from: Option<f64>,
    /// The exploration ramp's end σ, policy units.
    pub residual: Option<f64>,
    /// Training samples over which it rises (default: the preset ramp's, else
    /// [`DEFAULT_RAMP_SAMPLES`]).
    pub samples: Option<u64>,
    /// No ramp, whatever the preset (default: false).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub off: bool,
}

/// How the controller computes its torques.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Torques {
    /// The whole-body QP.
    #[default]
    Wbc,
    /// Stance legs `τ = −J_cᵀ f_MPC`, swing legs Cartesian PD.
    Cheap,
}

/// `[controller]`: what the hybrid (and its controller-alone baseline) changes on the
/// robot's controller preset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerTable {
    /// The gait, one the robot offers.
    pub gait: Option<Gait>,
    /// Forward speed commanded at zero steering, m/s.
    pub speed: Option<f64>,
    /// Yaw rate commanded at zero steering, rad/s.
    pub yaw_rate: Option<f64>,
    /// CoM height, m (the gait's own where absent).
    pub body_height: Option<f64>,
    /// The rated speed of the gait, m/s.
    pub rated_speed: Option<f64>,
    /// Multiplies the gait's period, in [0.25, 4].
    pub period_scale: Option<f64>,
    /// The command ramp, m/s² in (0, 20].
    pub max_acceleration: Option<f64>,
    /// The swing apex height, m in [0.01, 0.3].
    pub swing_height: Option<f64>,
    /// How often the MPC solves, s in [0.005, 0.2].
    pub mpc_period: Option<f64>,
    /// The torque path (default: the whole-body QP).
    pub torques: Option<Torques>,
}

/// `[exploration]`: the learner's initial exploration per action part (PPO and A2C) and its
/// schedule.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExplorationTable {
    /// Initial σ of the joint residual, policy units.
    pub residual: Option<f64>,
    /// Initial σ of the steering, policy units.
    pub steering: Option<f64>,
    /// A rising exploration floor of the joint residual (`residual`: its end σ).
    pub ramp: Option<RampTable>,
    /// Off-policy learners warm up with the hybrid's own exploration around the controller.
    pub warmup_with_policy: Option<bool>,
}

/// The hybrid's three tables, applied over a preset in one place: by a spec and by the
/// command line's flags (which are sugar for these tables).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HybridTables {
    /// `[hybrid]`.
    pub hybrid: HybridTableFields,
    /// `[controller]`.
    pub controller: ControllerTable,
    /// `[exploration]`.
    pub exploration: ExplorationTable,
}

/// The fields of [`HybridTable`] as a `Copy` value (its steering spans inline).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HybridTableFields {
    /// See [`HybridTable::residual_scale`].
    pub residual_scale: Option<f64>,
    /// See [`HybridTable::parts`].
    pub parts: Option<Parts>,
    /// See [`HybridTable::steering`].
    pub steering: SteeringTable,
    /// See [`HybridTable::include_reference`].
    pub include_reference: Option<bool>,
    /// See [`HybridTable::observe_state`].
    pub observe_state: Option<bool>,
    /// See [`HybridTable::fade`].
    pub fade: Option<Fade>,
    /// See [`HybridTable::bound_ramp`].
    pub bound_ramp: Option<RampTable>,
}

impl From<&HybridTable> for HybridTableFields {
    fn from(t: &HybridTable) -> Self {
        HybridTableFields {
            residual_scale: t.residual_scale,
            parts: t.parts,
            steering: t.steering.unwrap_or_default(),
            include_reference: t.include_reference,
            observe_state: t.observe_state,
            fade: t.fade,
            bound_ramp: t.bound_ramp,
        }
    }
}

impl HybridTables {
    /// Whether any table sets anything.
    pub fn is_empty(&self) -> bool {
        *self == HybridTables::default()
    }

    /// `preset` with what the tables change. Only the ramps can be refused here (samples
    /// without a start where the preset has no ramp); the values are checked by
    /// [`check_residual`].
    pub fn apply(&self, mut preset: ResidualConfig) -> Result<ResidualConfig, SpecError> {
        let (h, c, e) = (&self.hybrid, &self.controller, &self.exploration);
        if let Some(s) = h.residual_scale {
            preset.scale = vec![s];
        }
        let st = &h.steering;
        let spans = [
            (st.speed, &mut preset.steering.speed),
            (st.yaw_rate, &mut preset.steering.yaw_rate),
            (st.cadence, &mut preset.steering.cadence),
            (st.duty, &mut preset.steering.duty),
            (st.swing, &mut preset.steering.swing),
            (st.foothold, &mut preset.steering.foothold),
        ];
        for (given, field) in spans {
            if let Some(v) = given {
                *field = v;
            }
        }
        match h.parts.unwrap_or_default() {
            Parts::Both => {}
            Parts::Residual => preset.steering = Steering::OFF,
            Parts::Command => preset.joint_residual = false,
        }
        if let Some(v) = h.include_reference {
            preset.include_reference = v;
        }
        if let Some(v) = h.observe_state {
            preset.include_state = v;
        }
        if let Some(f) = h.fade {
            preset.fade = Some(f);
        }
        if let Some(r) = h.bound_ramp {
            let samples = |preset: Option<u64>| r.samples.or(preset).unwrap_or(DEFAULT_RAMP_SAMPLES);
            if r.residual.is_some() {
                return Err(range(
                    "hybrid.bound_ramp.residual",
                    "set",
                    "absent: a bound ramp starts at `from`",
                ));
            }
            preset.bound_ramp = match (r.off, r.from, preset.bound_ramp) {
                (true, None, _) if r.samples.is_none() => None,
                (true, ..) => {
                    return Err(range("hybrid.bound_ramp.off", "true", "alone (no from or samples)"));
                }
                (false, Some(from), old) => {
                    Some(BoundRamp { from, samples: samples(old.map(|o| o.samples)) })
                }
                (false, None, Some(old)) => {
                    Some(BoundRamp { from: old.from, samples: samples(Some(old.samples)) })
                }
                (false, None, None) => {
                    return Err(range(
                        "hybrid.bound_ramp.from",
                        "absent",
                        "given (the preset has no bound ramp)",
                    ));
                }
            };
        }
        if let Some(g) = c.gait {
            preset.command.gait = g;
        }
        if let Some(v) = c.speed {
            preset.command.forward_velocity = v;
        }
        if let Some(v) = c.yaw_rate {
            preset.command.yaw_rate = v;
        }
        if c.body_height.is_some() {
            preset.command.body_height = c.body_height;
        }
        let overrides = [
            (c.rated_speed, &mut preset.rated_speed),
            (c.period_scale, &mut preset.period_scale),
            (c.max_acceleration, &mut preset.max_acceleration),
            (c.swing_height, &mut preset.swing_height),
            (c.mpc_period, &mut preset.mpc_period),
        ];
        for (given, field) in overrides {
            if given.is_some() {
                *field = given;
            }
        }
        if let Some(t) = c.torques {
            preset.cheap_torques = t == Torques::Cheap;
        }
        if e.residual.is_some() || e.steering.is_some() {
            let old = preset.exploration.unwrap_or(Exploration { residual: 1.0, steering: 1.0 });
            preset.exploration = Some(Exploration {
                residual: e.residual.unwrap_or(old.residual),
                steering: e.steering.unwrap_or(old.steering),
            });
        }
        if let Some(r) = e.ramp {
            let samples = |preset: Option<u64>| r.samples.or(preset).unwrap_or(DEFAULT_RAMP_SAMPLES);
            if r.from.is_some() {
                return Err(range(
                    "exploration.ramp.from",
                    "set",
                    "absent: an exploration ramp ends at `residual`",
                ));
            }
            preset.exploration_ramp = match (r.off, r.residual, preset.exploration_ramp) {
                (true, None, _) if r.samples.is_none() => None,
                (true, ..) => {
                    return Err(range("exploration.ramp.off", "true", "alone (no residual or samples)"));
                }
                (false, Some(residual), old) => {
                    Some(ExplorationRamp { residual, samples: samples(old.map(|o| o.samples)) })
                }
                (false, None, Some(old)) => {
                    Some(ExplorationRamp { residual: old.residual, samples: samples(Some(old.samples)) })
                }
                (false, None, None) => {
                    return Err(range(
                        "exploration.ramp.residual",
                        "absent",
                        "given (the preset has no exploration ramp)",
                    ));
                }
            };
        }
        if let Some(v) = e.warmup_with_policy {
            preset.warmup_with_policy = v;
        }
        Ok(preset)
    }
}

fn range(key: &str, value: impl ToString, expected: impl ToString) -> SpecError {
    SpecError::Range { key: key.to_string(), value: value.to_string(), expected: expected.to_string() }
}

/// The one range check of a spec's own counts: `value` of `key` within `[low, high]`.
pub fn check_count(key: &str, value: u64, (low, high): (u64, u64)) -> Result<u64, SpecError> {
    if (low..=high).contains(&value) { Ok(value) } else { Err(range(key, value, format!("{low} to {high}"))) }
}

/// The spec key a [`ResidualConfig`] part is set by (`steering.cadence` →
/// `hybrid.steering.cadence`).
fn spec_key(part: &str) -> String {
    let key = match part {
        "exploration_ramp.residual" => "exploration.ramp.residual",
        "exploration_ramp.samples" => "exploration.ramp.samples",
        "command.yaw_rate" => "controller.yaw_rate",
        "rated_speed" | "period_scale" | "max_acceleration" | "swing_height" | "mpc_period" => {
            return format!("controller.{part}");
        }
        p if p.starts_with("exploration.") => p,
        p => return format!("hybrid.{p}"),
    };
    key.to_string()
}

/// Checks a hybrid's whole setup with the robot's controller (the ranges of every part,
/// the command against the gait's offer and rating), naming the spec key of what is wrong.
pub fn check_residual(robot: &str, residual: &ResidualConfig) -> Result<(), SpecError> {
    let named = |e: HybridError| match e {
        // Floats in their shortest round-trip form (`1e308`, not 309 digits).
        HybridError::BadSetting { part, value, expected } => {
            range(&spec_key(part), format!("{value:?}"), expected)
        }
        HybridError::BadScale { value } => {
            range("hybrid.residual_scale", format!("{value:?}"), "a finite bound ≥ 0")
        }
        HybridError::NothingToLearn => {
            range("hybrid.parts", "command", "a part with something to learn (the steering is off)")
        }
        other => SpecError::Env(RegistryError::from(other)),
    };
    residual.validate(1).map_err(named)?;
    let mut config = crate::registry::controller_config(robot)?;
    residual.rate_controller(&mut config).map_err(named)
}

/// What a spec is resolved for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    /// `centaur compare`: pure RL, the hybrid and the controller alone on one robot.
    Compare,
    /// `centaur train`: one agent on one environment (`<robot>-residual`: the hybrid).
    Train,
}

/// A spec with every value explicit, as a run records it (`spec.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResolvedSpec {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// The environment.
    pub robot: String,
    /// The learner's name.
    pub algo: String,
    /// Seeds `0..seeds`.
    pub seeds: u64,
    /// Training steps per agent and seed.
    pub steps: u64,
    /// Parallel environments per agent.
    pub envs: usize,
    /// Evaluation episodes per agent and seed.
    pub eval_episodes: usize,
    /// Evaluations every this many steps (0: at the end only).
    pub eval_every: u64,
    /// `[env]`.
    pub env: EnvSettings,
    /// Every hyperparameter of the learner (its config struct).
    pub learner: serde_json::Value,
    /// The hybrid's own hyperparameters where they differ from `learner`'s.
    pub hybrid_learner: Option<serde_json::Value>,
    /// The hybrid's whole setup (`None`: no hybrid).
    pub hybrid: Option<ResidualConfig>,
}

/// What a run writes as `spec.json`: the resolved spec and the Centaur that resolved it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpecRecord {
    /// The resolved spec.
    #[serde(flatten)]
    pub spec: ResolvedSpec,
    /// [`ResolvedSpec::identity`].
    pub identity: String,
    /// The Centaur version that wrote it.
    pub centaur_version: String,
}

impl ResolvedSpec {
    /// Checks a resolved spec read back from a run (`run.json`, `spec.json`, which a user
    /// may have edited): a known learner whose settings parse and validate, the hybrid's setup
    /// in range. The accessors below may then be called.
    pub fn check(&self) -> Result<(), SpecError> {
        let kind =
            AlgoKind::from_name(&self.algo).ok_or_else(|| range("algo", &self.algo, "a learner's name"))?;
        for (key, value) in
            [("learner", Some(&self.learner)), ("hybrid_learner", self.hybrid_learner.as_ref())]
        {
            if let Some(v) = value {
                let config = typed(kind, v)
                    .map_err(|message| SpecError::Parse { source_name: format!("[{key}]"), message })?;
                config.validate().map_err(|e| SpecError::Parse {
                    source_name: format!("[{key}]"),
                    message: e.to_string(),
                })?;
            }
        }
        if let Some(residual) = &self.hybrid {
            let robot = self.robot.strip_suffix("-residual").unwrap_or(&self.robot);
            check_residual(robot, residual)?;
        }
        Ok(())
    }

    /// The learner's kind.
    pub fn kind(&self) -> AlgoKind {
        AlgoKind::from_name(&self.algo).expect("a resolved spec names a known learner")
    }

    /// The learner's settings, typed.
    pub fn learner_config(&self) -> AlgoConfig {
        typed(self.kind(), &self.learner).expect("a resolved spec's learner parses")
    }

    /// The hybrid's own settings, typed (`None`: the learner's).
    pub fn hybrid_learner_config(&self) -> Option<AlgoConfig> {
        let v = self.hybrid_learner.as_ref()?;
        Some(typed(self.kind(), v).expect("a resolved spec's hybrid learner parses"))
    }

    /// Canonical JSON: fields in declared order, maps sorted, floats round-trip.
    pub fn canonical_json(&self) -> String {
        serde_json::to_string(self).expect("a resolved spec serialises")
    }

    /// The run's identity: FNV-1a (64 bit) of [`ResolvedSpec::canonical_json`] less the
    /// number of seeds, in hex (every seed's run depends on its seed alone, so a comparison
    /// extended with more seeds keeps its identity).
    pub fn identity(&self) -> String {
        let without_seeds = ResolvedSpec { seeds: 0, ..self.clone() };
        format!("{:016x}", fnv1a(without_seeds.canonical_json().as_bytes()))
    }

    /// Pure RL's identity: the same spec without the hybrid's setup and learner.
    pub fn pure_identity(&self) -> String {
        ResolvedSpec { hybrid: None, hybrid_learner: None, ..self.clone() }.identity()
    }

    /// What a run writes as `spec.json`.
    pub fn record(&self) -> SpecRecord {
        SpecRecord {
            spec: self.clone(),
            identity: self.identity(),
            centaur_version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }

    /// `spec.json`'s text.
    pub fn record_json(&self) -> String {
        serde_json::to_string_pretty(&self.record()).expect("a spec record serialises") + "\n"
    }
}

/// The identity of a canonical JSON value: FNV-1a (64 bit) of its text, in hex. Objects
/// are written with their keys sorted (`serde_json`'s map), floats in their shortest
/// round-trip form, so equal values have equal identities on every platform.
pub fn identity_of(value: &serde_json::Value) -> String {
    format!("{:016x}", fnv1a(value.to_string().as_bytes()))
}

/// The first key path where two canonical JSON values differ, as
/// `path: recorded …, given …` (`None`: equal). Keys are visited in sorted order; a key in
/// one value only is a difference (`absent` on the other side).
pub fn first_difference(recorded: &serde_json::Value, given: &serde_json::Value) -> Option<String> {
    fn walk(path: &str, r: Option<&serde_json::Value>, g: Option<&serde_json::Value>) -> Option<String> {
        use serde_json::Value::{Array, Object};
        let sub = |k: &str| if path.is_empty() { k.to_string() } else { format!("{path}.{k}") };
        match (r, g) {
            (Some(Object(r)), Some(Object(g))) => {
                let mut keys: Vec<&String> = r.keys().chain(g.keys()).collect();
                keys.sort();
                keys.dedup();
                keys.into_iter().find_map(|k| walk(&sub(k), r.get(k), g.get(k)))
            }
            (Some(Array(r)), Some(Array(g))) if r.len() == g.len() => r
                .iter()
                .zip(g)
                .enumerate()
                .find_map(|(i, (r, g))| walk(&format!("{path}[{i}]"), Some(r), Some(g))),
            (r, g) if r == g => None,
            (r, g) => {
                let show = |v: Option<&serde_json::Value>| v.map_or("absent".to_string(), |v| v.to_string());
                Some(format!("{path}: recorded {}, given {}", show(r), show(g)))
            }
        }
    }
    walk("", Some(recorded), Some(given))
}

/// FNV-1a, 64 bit: a stable hash (the same on every platform and Rust version).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// The learner's config struct as JSON.
pub fn learner_value(c: &AlgoConfig) -> serde_json::Value {
    let v = match c {
        AlgoConfig::Ppo(c) => serde_json::to_value(c),
        AlgoConfig::A2c(c) => serde_json::to_value(c),
        AlgoConfig::Sac(c) => serde_json::to_value(c),
        AlgoConfig::SacV1(c) => serde_json::to_value(c),
        AlgoConfig::Td3(c) => serde_json::to_value(c),
        AlgoConfig::Ddpg(c) => serde_json::to_value(c),
    };
    v.expect("a learner's config serialises")
}

fn typed(kind: AlgoKind, v: &serde_json::Value) -> Result<AlgoConfig, String> {
    fn de<T: serde::de::DeserializeOwned>(v: &serde_json::Value) -> Result<T, String> {
        T::deserialize(v).map_err(|e| e.to_string())
    }
    Ok(match kind {
        AlgoKind::Ppo => AlgoConfig::Ppo(de::<PpoConfig>(v)?),
        AlgoKind::A2c => AlgoConfig::A2c(de::<A2cConfig>(v)?),
        AlgoKind::Sac => AlgoConfig::Sac(de::<SacConfig>(v)?),
        AlgoKind::SacV1 => AlgoConfig::SacV1(de::<SacV1Config>(v)?),
        AlgoKind::Td3 => AlgoConfig::Td3(de::<Td3Config>(v)?),
        AlgoKind::Ddpg => AlgoConfig::Ddpg(de::<DdpgConfig>(v)?),
    })
}

/// `table`'s keys over `base` (a learner's config struct), checked by the struct's own
/// parser (unknown keys are an error naming the key) and its validation.
fn learner_over(
    kind: AlgoKind,
    base: &AlgoConfig,
    table: &toml::Table,
    key: &str,
) -> Result<AlgoConfig, SpecError> {
    let mut value = learner_value(base);
    let object = value.as_object_mut().expect("a learner's config is a table");
    for (k, v) in table {
        let v = serde_json::to_value(v).map_err(|e| range(&format!("{key}.{k}"), v, e))?;
        object.insert(k.clone(), v);
    }
    let config = typed(kind, &value)
        .map_err(|message| SpecError::Parse { source_name: format!("[{key}]"), message })?;
    config
        .validate()
        .map_err(|e| SpecError::Parse { source_name: format!("[{key}]"), message: e.to_string() })?;
    Ok(config)
}

/// Where a table's keys are laid over ([`RunSpec::learner`]'s `base`).
fn learner_base(table: &mut toml::Table, key: &str, default: &str) -> Result<String, SpecError> {
    match table.remove("base") {
        None => Ok(default.to_string()),
        Some(toml::Value::String(s)) => Ok(s),
        Some(other) => Err(range(
            &format!("{key}.base"),
            other,
            "\"tuned\", \"defaults\" or, for hybrid_learner, \"learner\"",
        )),
    }
}

impl RunSpec {
    /// A spec from its TOML text (`source_name` names it in errors).
    pub fn parse(text: &str, source_name: &str) -> Result<RunSpec, SpecError> {
        let table: toml::Table = toml::from_str(text)
            .map_err(|e| SpecError::Parse { source_name: source_name.into(), message: e.to_string() })?;
        Self::from_table(table, source_name)
    }

    /// A spec from its TOML file, read with the size bound of every config file, with
    /// `--set` overrides applied before it is typed.
    pub fn read(path: &Path, sets: &[String]) -> Result<RunSpec, SpecError> {
        let source_name = path.display().to_string();
        let text = crate::rundir::read_text_bounded(path, MAX_SPEC_BYTES)
            .map_err(|e| SpecError::Parse { source_name: source_name.clone(), message: e.to_string() })?;
        let mut table: toml::Table = toml::from_str(&text)
            .map_err(|e| SpecError::Parse { source_name: source_name.clone(), message: e.to_string() })?;
        for set in sets {
            apply_set(&mut table, set)?;
        }
        Self::from_table(table, &source_name)
    }

    /// A spec from its TOML table (`source_name` names it in errors).
    pub fn from_table(table: toml::Table, source_name: &str) -> Result<RunSpec, SpecError> {
        // The schema first, so that a newer spec is named as such rather than by the first
        // key this Centaur does not know.
        match table.get("schema") {
            Some(toml::Value::Integer(n)) if *n > i64::from(SCHEMA_VERSION) => {
                return Err(SpecError::Newer {
                    source_name: source_name.into(),
                    found: (*n).min(u32::MAX as i64) as u32,
                });
            }
            Some(toml::Value::Integer(n)) if *n < 1 => {
                return Err(range("schema", n, format!("1 to {SCHEMA_VERSION}")));
            }
            Some(toml::Value::Integer(_)) => {}
            Some(other) => return Err(range("schema", other, format!("an integer, 1 to {SCHEMA_VERSION}"))),
            None => {
                return Err(SpecError::Parse {
                    source_name: source_name.into(),
                    message: format!(
                        "missing `schema = {SCHEMA_VERSION}` (a run spec starts with its schema)"
                    ),
                });
            }
        }
        RunSpec::deserialize(toml::Value::Table(table))
            .map_err(|e| SpecError::Parse { source_name: source_name.into(), message: e.to_string() })
    }

    /// What the spec is most naturally for: a robot with a controller is compared, any
    /// other environment (and `<robot>-residual`, the hybrid alone) is trained.
    pub fn purpose(&self) -> Purpose {
        let kind = AlgoKind::from_name(&self.algo).unwrap_or(AlgoKind::Ppo);
        if !self.robot.ends_with("-residual") && residual_config_for(&self.robot, kind).is_ok() {
            Purpose::Compare
        } else {
            Purpose::Train
        }
    }

    /// The hybrid's tables as one value.
    pub fn hybrid_tables(&self) -> HybridTables {
        HybridTables {
            hybrid: self.hybrid.as_ref().map(HybridTableFields::from).unwrap_or_default(),
            controller: self.controller.unwrap_or_default(),
            exploration: self.exploration.unwrap_or_default(),
        }
    }

    /// Every value explicit and checked, for `purpose`: the learner over its base, the
    /// hybrid's setup over the robot's preset, the counts in range, the `[env]` settings
    /// checked by building the environment once.
    pub fn resolve(&self, purpose: Purpose) -> Result<ResolvedSpec, SpecError> {
        self.resolve_with(purpose, &HybridTables::default())
    }

    /// [`RunSpec::resolve`] with the command line's hybrid flags ([`HybridTables`]) applied
    /// after the spec's own tables: a flag given overrides the spec's key.
    pub fn resolve_with(&self, purpose: Purpose, flags: &HybridTables) -> Result<ResolvedSpec, SpecError> {
        let kind = AlgoKind::from_name(&self.algo).ok_or_else(|| {
            let names: Vec<&str> = AlgoKind::ALL.iter().map(|k| k.name()).collect();
            range("algo", &self.algo, format!("one of {}", names.join(", ")))
        })?;
        let seeds = check_count("seeds", self.seeds.unwrap_or(5), SEEDS_RANGE)?;
        let steps = check_count("steps", self.steps, STEPS_RANGE)?;
        let on_policy = matches!(kind, AlgoKind::Ppo | AlgoKind::A2c);
        let envs =
            check_count("envs", self.envs.unwrap_or(if on_policy { 4 } else { 1 }), ENVS_RANGE)? as usize;
        let eval_episodes =
            check_count("eval_episodes", self.eval_episodes.unwrap_or(10), EVAL_EPISODES_RANGE)? as usize;
        let eval_every = check_count("eval_every", self.eval_every.unwrap_or(100_000), (0, STEPS_RANGE.1))?;
        let fewest = MIN_EVAL_EVERY.max(steps.div_ceil(MAX_EVALUATIONS));
        if eval_every > 0 && eval_every < fewest {
            return Err(range(
                "eval_every",
                eval_every,
                format!(
                    "0 (at the end only) or at least {fewest} steps ({MIN_EVAL_EVERY}, and at most {MAX_EVALUATIONS} evaluations a run)"
                ),
            ));
        }
        // The robot the hybrid runs on: `compare`'s robot, or the robot of `train`'s
        // `<robot>-residual`; `train` on any other name trains pure RL, without a hybrid.
        let robot = match (purpose, self.robot.strip_suffix("-residual")) {
            (Purpose::Compare, Some(r)) => {
                return Err(range(
                    "robot",
                    &self.robot,
                    format!("the robot, `{r}`: compare trains both its pure RL and its hybrid"),
                ));
            }
            (Purpose::Compare, None) => Some(self.robot.as_str()),
            (Purpose::Train, hybrid) => hybrid,
        };
        if purpose == Purpose::Train && self.hybrid_learner.is_some() {
            return Err(SpecError::NotAHybrid {
                table: "hybrid_learner",
                reason: "train trains one agent: its hyperparameters go in [learner]".into(),
            });
        }
        let preset = match robot {
            Some(r) => residual_config_for(r, kind).map(|p| (r, p)),
            None => Err(RegistryError::NoController { name: self.robot.clone() }),
        };
        let tables = self.hybrid_tables();
        let hybrid = match preset {
            Ok((robot, preset)) => {
                let residual = flags.apply(tables.apply(preset)?)?;
                check_residual(robot, &residual)?;
                Some(residual)
            }
            Err(_) => {
                let table = [
                    (self.hybrid.is_some(), "hybrid"),
                    (self.controller.is_some(), "controller"),
                    (self.exploration.is_some(), "exploration"),
                    (self.hybrid_learner.is_some(), "hybrid_learner"),
                    (!flags.is_empty(), "hybrid"),
                ]
                .into_iter()
                .find_map(|(given, t)| given.then_some(t));
                if let Some(table) = table {
                    let reason = match purpose {
                        Purpose::Train if self.robot.ends_with("-residual") => {
                            format!("`{}` has no controller", self.robot)
                        }
                        Purpose::Train => format!(
                            "train on `{}` trains pure RL (its hybrid, where the robot has a controller, is `{}-residual`)",
                            self.robot, self.robot
                        ),
                        Purpose::Compare => format!("`{}` has no controller", self.robot),
                    };
                    return Err(SpecError::NotAHybrid { table, reason });
                }
                None
            }
        };
        // The environment and its settings, checked by building it once.
        EnvSource::read(&self.robot)?.for_learner(kind)?.with_settings(self.env.clone())?;
        let tuned = tuned_config(&self.robot, kind);
        let learner = match &self.learner {
            None => tuned.clone(),
            Some(t) => {
                let mut t = t.clone();
                let base = match learner_base(&mut t, "learner", "tuned")?.as_str() {
                    "tuned" => tuned.clone(),
                    "defaults" => AlgoConfig::default_for(kind),
                    other => return Err(range("learner.base", other, "\"tuned\" or \"defaults\"")),
                };
                learner_over(kind, &base, &t, "learner")?
            }
        };
        let hybrid_learner = match &self.hybrid_learner {
            None => None,
            Some(t) => {
                let mut t = t.clone();
                let base = match learner_base(&mut t, "hybrid_learner", "learner")?.as_str() {
                    "learner" => learner.clone(),
                    "tuned" => tuned,
                    "defaults" => AlgoConfig::default_for(kind),
                    other => {
                        return Err(range(
                            "hybrid_learner.base",
                            other,
                            "\"learner\", \"tuned\" or \"defaults\"",
                        ));
                    }
                };
                Some(learner_over(kind, &base, &t, "hybrid_learner")?)
            }
        };
        Ok(ResolvedSpec {
            schema: SCHEMA_VERSION,
            robot: self.robot.clone(),
            algo: kind.name().to_string(),
            seeds,
            steps,
            envs,
            eval_episodes,
            eval_every,
            env: self.env.clone(),
            learner: learner_value(&learner),
            hybrid_learner: hybrid_learner.as_ref().map(learner_value),
            hybrid,
        })
    }
}

/// The counts a command's flags give over a spec's (`None`: the spec's).
#[derive(Clone, Copy, Debug, Default)]
pub struct CountFlags {
    /// `--seeds`.
    pub seeds: Option<u64>,
    /// `--steps`.
    pub steps: Option<u64>,
    /// `--envs`.
    pub envs: Option<u64>,
    /// `--eval-episodes`.
    pub eval_episodes: Option<u64>,
    /// `--eval-every`.
    pub eval_every: Option<u64>,
}

impl RunSpec {
    /// The spec a command runs without `--spec`: `robot`, `algo` and `steps` from its flags,
    /// a run file's `[env]` and learner keys (`--config`, see [`run_file_tables`]) and the
    /// hybrid's own learner keys (`--hybrid-config`, which may hold no `[env]`: the settings
    /// are every agent's).
    pub fn from_flags(
        robot: &str,
        algo: AlgoKind,
        steps: u64,
        config: Option<&Path>,
        hybrid_config: Option<&Path>,
    ) -> Result<RunSpec, String> {
        // Read as `centaur train` reads a run file (the same bound, the same messages).
        let tables = |path: &Path| {
            let text = crate::rundir::read_text_bounded(path, MAX_SPEC_BYTES).map_err(|e| match e {
                crate::rundir::ReadError::Io(source) => format!("{}: {source}", path.display()),
                other => format!("config {}: {other}", path.display()),
            })?;
            run_file_tables(&text, &path.display().to_string()).map_err(|e| e.to_string())
        };
        let mut spec = RunSpec {
            schema: SCHEMA_VERSION,
            robot: robot.to_string(),
            algo: algo.name().to_string(),
            steps,
            ..RunSpec::default()
        };
        if let Some(path) = config {
            let (settings, learner) = tables(path)?;
            spec.env = settings;
            spec.learner = Some(learner);
        }
        if let Some(path) = hybrid_config {
            let (settings, learner) = tables(path)?;
            if !settings.is_empty() {
                return Err(format!(
                    "{}: --hybrid-config takes the hybrid's hyperparameters only; the robot's [env] settings go in --config, for all three agents",
                    path.display()
                ));
            }
            spec.hybrid_learner = Some(learner);
        }
        Ok(spec)
    }

    /// The spec with the counts the flags give over its own.
    pub fn with_counts(mut self, flags: CountFlags) -> RunSpec {
        self.seeds = flags.seeds.or(self.seeds);
        self.steps = flags.steps.unwrap_or(self.steps);
        self.envs = flags.envs.or(self.envs);
        self.eval_episodes = flags.eval_episodes.or(self.eval_episodes);
        self.eval_every = flags.eval_every.or(self.eval_every);
        self
    }
}

/// A run file (`--config FILE`: the learner's keys over its defaults, an optional `[env]`)
/// as a spec's `[env]` settings and `[learner]` table (`base = "defaults"`), so that a
/// command given a run file resolves as the same spec.
pub fn run_file_tables(text: &str, source_name: &str) -> Result<(EnvSettings, toml::Table), SpecError> {
    let parse = |message| SpecError::Parse { source_name: source_name.to_string(), message };
    let (settings, rest) = crate::settings::split_run_toml(text).map_err(parse)?;
    let mut learner = match rest {
        Some(t) => t,
        None => toml::from_str(text).map_err(|e: toml::de::Error| parse(e.to_string()))?,
    };
    learner.insert("base".into(), toml::Value::String("defaults".into()));
    Ok((settings, learner))
}

/// Applies one `--set key.path=value` to a spec's table: the value is read as TOML
/// (`4.0`, `true`, `"trot"`, `{ from = 0.1 }`), else taken as a string (`trot`); the
/// tables on the path are created where missing.
pub fn apply_set(table: &mut toml::Table, set: &str) -> Result<(), SpecError> {
    let (path, value) = set.split_once('=').ok_or_else(|| SpecError::BadSet(set.to_string()))?;
    let path = path.trim();
    let keys: Vec<&str> = path.split('.').collect();
    if keys.iter().any(|k| k.is_empty() || !k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')) {
        return Err(SpecError::BadSet(set.to_string()));
    }
    let value = value.trim();
    let parsed = toml::from_str::<toml::Table>(&format!("v = {value}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(value.to_string()));
    let (last, parents) = keys.split_last().expect("split gives at least one key");
    let mut at = table;
    for (i, k) in parents.iter().enumerate() {
        let entry = at.entry(k.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        at = match entry {
            toml::Value::Table(t) => t,
            _ => {
                return Err(SpecError::Parse {
                    source_name: format!("--set {set}"),
                    message: format!("`{}` is a value, not a table", keys[..=i].join(".")),
                });
            }
        };
    }
    at.insert(last.to_string(), parsed);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(text: &str) -> Result<RunSpec, SpecError> {
        RunSpec::parse(text, "test.toml")
    }

    const MINITAUR: &str = "schema = 1\nrobot = \"minitaur\"\nalgo = \"ppo\"\nsteps = 100_000\n";

    #[test]
    fn a_set_is_read_as_toml_else_as_a_word_and_makes_its_tables() {
        let mut t = toml::Table::new();
        apply_set(&mut t, "controller.rated_speed=4.0").unwrap();
        apply_set(&mut t, "hybrid.steering.speed = 2").unwrap();
        apply_set(&mut t, "controller.gait=bound").unwrap();
        apply_set(&mut t, "hybrid.fade={ start = 0.1, end = 0.2 }").unwrap();
        assert_eq!(t["controller"]["rated_speed"].as_float(), Some(4.0));
        assert_eq!(t["hybrid"]["steering"]["speed"].as_integer(), Some(2));
        assert_eq!(t["controller"]["gait"].as_str(), Some("bound"));
        assert_eq!(t["hybrid"]["fade"]["end"].as_float(), Some(0.2));
        for bad in ["controller.rated_speed", "=3", "a..b=1", "a b=1"] {
            assert!(matches!(apply_set(&mut t, bad), Err(SpecError::BadSet(_))), "{bad}");
        }
        // A value cannot become a table.
        assert!(apply_set(&mut t, "controller.rated_speed.x=1").is_err());
    }

    /// The first difference is found on either side, by key path, in sorted key order;
    /// equal values have equal identities, key order aside.
    #[test]
    fn the_first_difference_is_named_by_its_key_path() {
        use serde_json::json;
        let a = json!({"b": {"x": 1.0, "y": [1, 2]}, "a": 1});
        assert_eq!(first_difference(&a, &a), None);
        let b = json!({"a": 1, "b": {"x": 1.0, "y": [1, 3]}});
        assert_eq!(first_difference(&a, &b).as_deref(), Some("b.y[1]: recorded 2, given 3"));
        let c = json!({"a": 1, "b": {"x": 1.0, "y": [1, 2], "z": true}});
        assert_eq!(first_difference(&a, &c).as_deref(), Some("b.z: recorded absent, given true"));
        assert_eq!(first_difference(&c, &a).as_deref(), Some("b.z: recorded true, given absent"));
        let d = json!({"a": 1, "b": {"x": 1.0, "y": [1]}});
        assert_eq!(first_difference(&a, &d).as_deref(), Some("b.y: recorded [1,2], given [1]"));
        let reordered = json!({"a": 1, "b": {"y": [1, 2], "x": 1.0}});
        assert_eq!(identity_of(&a), identity_of(&reordered));
        assert_ne!(identity_of(&a), identity_of(&b));
    }

    #[test]
    fn a_spec_needs_its_schema_and_refuses_a_newer_one() {
        let e = spec("robot = \"minitaur\"\nalgo = \"ppo\"\nsteps = 1\n").unwrap_err();
        assert!(e.to_string().contains("schema = 1"), "{e}");
        let e = spec(&MINITAUR.replace("schema = 1", "schema = 7")).unwrap_err();
        assert!(matches!(e, SpecError::Newer { found: 7, .. }), "{e}");
        // A newer spec is named as such, not by the key this Centaur does not know.
        let e = spec(&(MINITAUR.replace("schema = 1", "schema = 2") + "new_key = 1\n")).unwrap_err();
        assert!(matches!(e, SpecError::Newer { found: 2, .. }), "{e}");
        assert!(matches!(spec(&MINITAUR.replace("schema = 1", "schema = 0")), Err(SpecError::Range { .. })));
    }

    #[test]
    fn unknown_keys_are_refused_with_their_table() {
        for (extra, key) in [
            ("stepz = 1\n", "stepz"),
            ("[hybrid]\nresidual_scal = 0.1\n", "residual_scal"),
            ("[hybrid.steering]\nsped = 1.0\n", "sped"),
            ("[controller]\nrated = 1.0\n", "rated"),
            ("[exploration.ramp]\nresidual = 0.3\nsample = 1\n", "sample"),
        ] {
            let e = spec(&(MINITAUR.to_string() + extra)).unwrap_err();
            assert!(e.to_string().contains(key), "{extra}: {e}");
        }
        let e = spec(&(MINITAUR.to_string() + "[learner]\nlearning_rat = 1.0\n"))
            .unwrap()
            .resolve(Purpose::Compare);
        assert!(e.unwrap_err().to_string().contains("[learner]: unknown field `learning_rat`"));
    }

    #[test]
    fn values_out_of_range_name_their_key_path() {
        for (extra, key) in [
            ("[controller]\nrated_speed = 40.0\n", "controller.rated_speed"),
            ("[controller]\nswing_height = 7.0\n", "controller.swing_height"),
            ("[controller]\nmax_acceleration = 0.0\n", "controller.max_acceleration"),
            ("[controller]\nmpc_period = 60.0\n", "controller.mpc_period"),
            ("[controller]\nperiod_scale = 9.0\n", "controller.period_scale"),
            ("[hybrid.steering]\ncadence = 0.9\n", "hybrid.steering.cadence"),
            ("[hybrid]\nresidual_scale = -1.0\n", "hybrid.residual_scale"),
            ("[exploration]\nresidual = 0.0\n", "exploration.residual"),
            ("envs = 0\n", "envs"),
            ("seeds = 0\n", "seeds"),
            ("eval_episodes = 1_000_000_000_000\n", "eval_episodes"),
            ("eval_every = 1\n", "eval_every"),
        ] {
            let text = if extra.starts_with('[') {
                MINITAUR.to_string() + extra
            } else {
                extra.to_string() + MINITAUR
            };
            match spec(&text).unwrap().resolve(Purpose::Compare) {
                Err(SpecError::Range { key: k, .. }) => assert_eq!(k, key, "{extra}"),
                other => panic!("{extra}: {other:?}"),
            }
        }
    }

    #[test]
    fn hybrid_tables_are_refused_where_there_is_no_hybrid() {
        let pendulum = "schema = 1\nrobot = \"pendulum\"\nalgo = \"sac\"\nsteps = 1000\n";
        let e =
            spec(&(pendulum.to_string() + "[controller]\nspeed = 1.0\n")).unwrap().resolve(Purpose::Train);
        assert!(matches!(e, Err(SpecError::NotAHybrid { table: "controller", .. })), "{e:?}");
        // Pure RL on a robot with a controller: the hybrid is `<robot>-residual`.
        let e = spec(&(MINITAUR.to_string() + "[hybrid]\nresidual_scale = 0.1\n"))
            .unwrap()
            .resolve(Purpose::Train);
        assert!(e.unwrap_err().to_string().contains("minitaur-residual"));
        let pure = spec(MINITAUR).unwrap().resolve(Purpose::Train).unwrap();
        assert_eq!(pure.hybrid, None);
        let hybrid = spec(&MINITAUR.replace("\"minitaur\"", "\"minitaur-residual\"")).unwrap();
        assert!(hybrid.resolve(Purpose::Train).unwrap().hybrid.is_some());
        assert!(hybrid.resolve(Purpose::Compare).is_err(), "compare takes the robot");
        // A key of another robot's [env].
        let e = spec(&(MINITAUR.to_string() + "[env]\nhealthy_reward = 1.0\n"))
            .unwrap()
            .resolve(Purpose::Compare);
        assert!(e.unwrap_err().to_string().contains("healthy_reward"));
    }

    #[test]
    fn the_identity_follows_every_value_but_the_number_of_seeds() {
        let base = spec(MINITAUR).unwrap().resolve(Purpose::Compare).unwrap();
        let more_seeds =
            spec(&("seeds = 9\n".to_string() + MINITAUR)).unwrap().resolve(Purpose::Compare).unwrap();
        assert_eq!(base.identity(), more_seeds.identity());
        let faster = spec(&(MINITAUR.to_string() + "[controller]\nspeed = 0.5\n"))
            .unwrap()
            .resolve(Purpose::Compare)
            .unwrap();
        assert_ne!(base.identity(), faster.identity());
        // Pure RL does not depend on the hybrid's setup.
        assert_eq!(base.pure_identity(), faster.pure_identity());
        let lr = spec(&(MINITAUR.to_string() + "[learner]\nlearning_rate = 1e-4\n"))
            .unwrap()
            .resolve(Purpose::Compare)
            .unwrap();
        assert_ne!(base.pure_identity(), lr.pure_identity());
        // The record reads back to the same spec, bit for bit.
        let record: SpecRecord = serde_json::from_str(&faster.record_json()).unwrap();
        assert_eq!(record.spec, faster);
        assert_eq!(record.identity, faster.identity());
        assert_eq!(record.spec.learner_config(), faster.learner_config());
    }

    /// Regression (the accessors' `expect`s): a resolved spec read back from an edited
    /// record is checked, and a bad one refused with its key, before anything uses it.
    #[test]
    fn an_edited_resolved_spec_is_refused_not_trusted() {
        let good = spec(MINITAUR).unwrap().resolve(Purpose::Compare).unwrap();
        good.check().unwrap();
        let e = ResolvedSpec { algo: "foo".into(), ..good.clone() }.check().unwrap_err();
        assert!(matches!(&e, SpecError::Range { key, .. } if key == "algo"), "{e}");
        let mut bad_learner = good.clone();
        bad_learner.learner["gamma"] = serde_json::json!(2.0);
        assert!(bad_learner.check().unwrap_err().to_string().contains("gamma"));
        let mut bad_hybrid = good.clone();
        bad_hybrid.hybrid.as_mut().unwrap().rated_speed = Some(f64::NAN);
        let e = bad_hybrid.check().unwrap_err();
        assert!(matches!(&e, SpecError::Range { key, .. } if key == "controller.rated_speed"), "{e}");
    }

    #[test]
    fn the_learner_lays_over_the_tuned_settings_or_the_defaults() {
        let tuned = spec(&(MINITAUR.to_string() + "[learner]\nlearning_rate = 1e-4\n")).unwrap();
        let AlgoConfig::Ppo(c) = tuned.resolve(Purpose::Compare).unwrap().learner_config() else { panic!() };
        assert_eq!((c.learning_rate, c.gamma), (1e-4, PpoConfig::minitaur().gamma));
        let defaults =
            spec(&(MINITAUR.to_string() + "[learner]\nbase = \"defaults\"\nlearning_rate = 1e-4\n")).unwrap();
        let AlgoConfig::Ppo(c) = defaults.resolve(Purpose::Compare).unwrap().learner_config() else {
            panic!()
        };
        assert_eq!((c.learning_rate, c.gamma), (1e-4, PpoConfig::default().gamma));
        // The hybrid's own learner lays over [learner]'s.
        let own = spec(&(MINITAUR.to_string() + "[learner]\ngamma = 0.9\n[hybrid_learner]\nn_steps = 512\n"))
            .unwrap();
        let r = own.resolve(Purpose::Compare).unwrap();
        let AlgoConfig::Ppo(h) = r.hybrid_learner_config().unwrap() else { panic!() };
        assert_eq!((h.gamma, h.n_steps), (0.9, 512));
    }

    #[test]
    fn ramps_take_the_presets_samples_and_can_be_switched_off() {
        let with = |extra: &str| spec(&(MINITAUR.to_string() + extra)).unwrap().resolve(Purpose::Compare);
        let r = with("[exploration]\nresidual = 0.1\nramp = { residual = 0.3 }\n").unwrap().hybrid.unwrap();
        assert_eq!(
            r.exploration_ramp,
            Some(ExplorationRamp { residual: 0.3, samples: DEFAULT_RAMP_SAMPLES })
        );
        let r = with("[hybrid]\nbound_ramp = { from = 0.1, samples = 5000 }\n").unwrap().hybrid.unwrap();
        assert_eq!(r.bound_ramp, Some(BoundRamp { from: 0.1, samples: 5000 }));
        let r = with("[hybrid]\nbound_ramp = { off = true }\n").unwrap().hybrid.unwrap();
        assert_eq!(r.bound_ramp, None);
        assert!(with("[hybrid]\nbound_ramp = { samples = 5000 }\n").is_err(), "no start, no preset ramp");
        assert!(with("[hybrid]\nbound_ramp = { off = true, from = 0.1 }\n").is_err());
    }

    #[test]
    fn every_spec_in_configs_resolves() {
        let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("configs");
        let mut resolved = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            if !text.lines().any(|l| l.starts_with("schema")) {
                continue;
            }
            let spec = RunSpec::read(&path, &[]).unwrap_or_else(|e| panic!("{e}"));
            spec.resolve(spec.purpose()).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            resolved += 1;
        }
        assert!(resolved >= 1, "the specs in configs/ were resolved ({resolved})");
    }
}
