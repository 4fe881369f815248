//! The robustness study: the three agents of a run (the hybrid, pure RL, the controller
//! alone) evaluated deterministically under perturbations the field reports for hybrids —
//! lateral pushes of 1, 2 and 4 N·s, base mass ±20 %, ground friction 0.5 and 1.5 and motor
//! strength ±20 % — with survival and return per condition ([`run_robustness`]).
//!
//! Every condition fixes one quantity and keeps the rest of the env's randomisation as in
//! training (the Minitaur draws its base mass within ±20 % and its foot friction within
//! 0.8–1.5 at every reset, so ±20 % mass is the edge of the training range and friction 0.5
//! lies outside it). Pushes last 0.1 s from t = 3 s, to +y in even episodes and −y in odd.
//!
//! The hybrid is evaluated with the setup its run was trained with: options that differ from
//! the one its `experiment.json` records (a rating, a steering span, the parts) are refused.
//! Agents trained observing the body state (`[env] observe_body_state`) observe it here too.

use std::path::PathBuf;

use centaur_envs::minitaur::{MinitaurRandomization, MotorInverse};
use centaur_envs::{MinitaurConfig, MinitaurEnv, RobotEnv};
use centaur_gym::Env;
use centaur_mpc::LocomotionController;
use centaur_rl::{Policy, RlError};
use serde::Serialize;

use super::evaluation::{Driver, EpisodePush, evaluate_pushed};
use super::options::ExperimentError;
use super::runner::{check_trained_with, recorded_hybrid};
use super::summary::AgentStats;
use crate::hybrid::{ActionMapping, HybridError, ResidualConfig};
use crate::registry::controller_config;
use crate::residual::ResidualEnv;

/// One perturbation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Condition {
    /// The env as in training.
    Nominal,
    /// A lateral push of this impulse (N·s), 0.1 s long.
    Push(f64),
    /// The base's mass times this factor.
    BaseMass(f64),
    /// Foot–ground friction coefficient.
    Friction(f64),
    /// Motor strength times this factor.
    MotorStrength(f64),
}

impl Condition {
    /// The study's conditions, in table order.
    pub fn standard() -> Vec<Condition> {
        use Condition::*;
        vec![
            Nominal,
            Push(1.0),
            Push(2.0),
            Push(4.0),
            BaseMass(0.8),
            BaseMass(1.2),
            Friction(0.5),
            Friction(1.5),
            MotorStrength(0.8),
            MotorStrength(1.2),
        ]
    }

    /// A table label.
    pub fn label(&self) -> String {
        match self {
            Condition::Nominal => "nominal".into(),
            Condition::Push(j) => format!("push {j} N·s"),
            Condition::BaseMass(f) => format!("base mass {:+.0} %", (f - 1.0) * 100.0),
            Condition::Friction(mu) => format!("friction {mu}"),
            Condition::MotorStrength(f) => format!("motor strength {:+.0} %", (f - 1.0) * 100.0),
        }
    }

    /// The Minitaur configuration of this condition.
    fn minitaur(&self) -> MinitaurConfig {
        let mut r = MinitaurRandomization::default();
        match *self {
            Condition::Nominal | Condition::Push(_) => {}
            Condition::BaseMass(f) => r.base_mass_error = (f - 1.0, f - 1.0),
            Condition::Friction(mu) => r.foot_friction = (mu, mu),
            Condition::MotorStrength(f) => r.motor_strength = (f, f),
        }
        MinitaurConfig { randomization: Some(r), ..MinitaurConfig::default() }
    }

    fn push(&self) -> Option<EpisodePush> {
        match *self {
            Condition::Push(j) => Some(EpisodePush { at: 3.0, force: j / 0.1, duration: 0.1 }),
            _ => None,
        }
    }
}

/// What to evaluate.
#[derive(Clone, Debug)]
pub struct RobustnessOptions {
    /// Robot environment (the study covers `minitaur`).
    pub env: String,
    /// A run directory of [`super::run_experiment`] (`hybrid/checkpoint`, `pure_rl/checkpoint`).
    pub run: PathBuf,
    /// The hybrid's setup it was trained with.
    pub residual: ResidualConfig,
    /// Deterministic episodes per agent and condition.
    pub episodes: usize,
    /// First evaluation seed.
    pub seed: u64,
    /// The conditions.
    pub conditions: Vec<Condition>,
    /// The motor model the controller's torques are turned into actions with, for the
    /// controller alone and inside the hybrid (`None`: the one the run was trained with,
    /// [`super::TrainedWith::controller_motor`]; [`MotorInverse::Nominal`]: the data
    /// sheet's, as a controller on the robot would know it; [`MotorInverse::Drawn`]: the
    /// motor drawn at reset, strength included, the earlier default).
    pub motor_inverse: Option<MotorInverse>,
}

/// The three agents under one condition.
#[derive(Clone, Debug, Serialize)]
pub struct RobustnessRow {
    /// The condition.
    pub condition: Condition,
    /// Its label.
    pub label: String,
    /// Residual RL on the controller.
    pub hybrid: AgentStats,
    /// RL alone.
    pub pure_rl: AgentStats,
    /// The controller alone.
    pub controller: AgentStats,
}

/// Evaluates the run's three agents under every condition.
pub fn run_robustness(opts: &RobustnessOptions) -> Result<Vec<RobustnessRow>, ExperimentError> {
    if opts.env != "minitaur" {
        return Err(ExperimentError::NotCovered {
            study: "the robustness study",
            supported: "minitaur",
            env: opts.env.clone(),
        });
    }
    // The run is checked against the setup it recorded; `opts.residual` may differ from it
    // where the caller overrode a value on purpose (`centaur robustness` warns then), and
    // today's controller preset from the one it ran on (warned about here).
    let (_, checked) = recorded_hybrid(&opts.run)?;
    let trained = check_trained_with(&opts.run, &checked)?;
    if let Some(difference) = &trained.controller_changed {
        eprintln!(
            "warning: {}: its hybrid was trained on another controller preset than today's ({difference}); evaluating it on today's",
            opts.run.display()
        );
    }
    let motor_inverse = opts.motor_inverse.or(trained.controller_motor).unwrap_or_default();
    let mut controller_cfg = controller_config(&opts.env)?;
    opts.residual.rate_controller(&mut controller_cfg)?;
    let load = |agent: &str| Policy::load(&opts.run.join(agent).join("checkpoint")).map_err(RlError::from);
    let (pure_policy, hybrid_policy) = (load("pure_rl")?, load("hybrid")?);
    let observe_body_state = trained.observe_body_state;
    let robot = |c: &Condition| -> Result<Box<dyn RobotEnv>, ExperimentError> {
        Ok(Box::new(MinitaurEnv::new(MinitaurConfig { motor_inverse, observe_body_state, ..c.minitaur() })?))
    };
    let controller = |env: &dyn RobotEnv| -> Result<LocomotionController, ExperimentError> {
        Ok(LocomotionController::new(env.model(), controller_cfg.clone()).map_err(HybridError::from)?)
    };
    opts.conditions
        .iter()
        .map(|c| {
            let run = |mut d: Driver| evaluate_pushed(&mut d, opts.episodes, opts.seed, None, c.push());
            let env = robot(c)?;
            let ctrl = controller(env.as_ref())?;
            let hybrid_env = ResidualEnv::new(env, ctrl, opts.residual.clone())?;
            fits(&hybrid_policy, &hybrid_env)?;
            let hybrid = run(Driver::Hybrid { env: Box::new(hybrid_env), policy: hybrid_policy.clone() })?;
            let pure_env = robot(c)?;
            fits(&pure_policy, pure_env.as_ref())?;
            let pure_rl = run(Driver::Pure { env: pure_env, policy: pure_policy.clone() })?;
            let env = robot(c)?;
            let ctrl = controller(env.as_ref())?;
            let mapping = ActionMapping::new(env.as_ref(), &ctrl)?;
            let controller = run(Driver::Controller {
                env,
                controller: Box::new(ctrl),
                mapping,
                command: opts.residual.command,
            })?;
            Ok(RobustnessRow { condition: *c, label: c.label(), hybrid, pure_rl, controller })
        })
        .collect()
}

/// Refuses a policy trained for other dimensions (e.g. a hybrid trained with another
/// `--parts` or steering than the study is given).
fn fits(policy: &Policy, env: &dyn Env) -> Result<(), ExperimentError> {
    let needed = (env.observation_space().dim(), env.action_space().dim());
    if (policy.obs_dim(), policy.act_dim()) != needed {
        return Err(HybridError::PolicyShape { policy: (policy.obs_dim(), policy.act_dim()), needed }.into());
    }
    Ok(())
}

/// The study's table in Markdown: survival (episodes without a fall) and mean return of the
/// three agents per condition.
pub fn robustness_table(rows: &[RobustnessRow]) -> String {
    let cell = |s: &AgentStats| format!("{}/{} · {:.2}", s.episodes - s.falls, s.episodes, s.return_mean);
    let mut t = String::from(
        "| condition | hybrid: survived · return | pure RL: survived · return | controller alone: survived · return |\n|---|---:|---:|---:|\n",
    );
    for r in rows {
        t += &format!(
            "| {} | {} | {} | {} |\n",
            r.label,
            cell(&r.hybrid),
            cell(&r.pure_rl),
            cell(&r.controller)
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_condition_fixes_one_quantity_and_keeps_the_training_randomisation() {
        let train = MinitaurRandomization::default();
        let r = |c: Condition| c.minitaur().randomization.unwrap();
        assert_eq!(r(Condition::Nominal), train);
        assert_eq!(r(Condition::Push(2.0)), train);
        let m = r(Condition::BaseMass(1.2));
        assert!((m.base_mass_error.0 - 0.2).abs() < 1e-12 && m.base_mass_error.0 == m.base_mass_error.1);
        assert_eq!(MinitaurRandomization { base_mass_error: train.base_mass_error, ..m }, train);
        assert_eq!(r(Condition::Friction(0.5)).foot_friction, (0.5, 0.5));
        assert_eq!(r(Condition::MotorStrength(0.8)).motor_strength, (0.8, 0.8));
        // 4 N·s: 40 N for 0.1 s from t = 3 s.
        assert_eq!(Condition::Push(4.0).push(), Some(EpisodePush { at: 3.0, force: 40.0, duration: 0.1 }));
        assert_eq!(Condition::Friction(0.5).push(), None);
        let labels: Vec<String> = Condition::standard().iter().map(Condition::label).collect();
        assert_eq!(labels[0], "nominal");
        assert!(labels.contains(&"motor strength -20 %".to_string()), "{labels:?}");
    }
}
