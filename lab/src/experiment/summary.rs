//! How the agents did: [`AgentStats`] per agent, [`ExperimentSummary`] for the three, its
//! Markdown table.

use serde::{Deserialize, Serialize};

/// Cost of transport `E / (m g d)`: `energy` (J) the actuators spent carrying `model`'s total
/// mass a forward `distance` (m); `None` below 1 cm (standing, or moving back). The
/// evaluations' [`AgentStats::cost_of_transport`] and `centaur control`'s
/// ([`crate::control::ControlSummary::cost_of_transport`]).
pub fn cost_of_transport(energy: f64, model: &centaur_dynamics::Model, distance: f64) -> Option<f64> {
    (distance > 0.01).then(|| energy / (model.total_mass() * model.gravity.norm().max(1e-9) * distance))
}

/// How an agent did over the evaluation episodes (and its training cost).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct AgentStats {
    /// Mean episode return.
    pub return_mean: f64,
    /// Standard deviation of the episode return.
    pub return_std: f64,
    /// Mean forward speed (m/s).
    pub mean_speed: f64,
    /// Episodes that ended by a fall.
    pub falls: usize,
    /// Evaluation episodes.
    pub episodes: usize,
    /// Cost of transport `E / (m g d)` (None if the agent did not move forward).
    pub cost_of_transport: Option<f64>,
    /// Mean energy per episode (J).
    pub energy_mean: f64,
    /// Torque RMS over steps and actuators (N·m).
    pub torque_rms: f64,
    /// Mean episode length (steps).
    pub length_mean: f64,
    /// Training environment steps (0 for the controller).
    pub env_steps: u64,
    /// Training wall-clock seconds (0 for the controller).
    pub wall_seconds: f64,
}

/// A deterministic evaluation of a learner at a training budget.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BudgetEval {
    /// Training environment steps done.
    pub env_steps: u64,
    /// Training wall-clock seconds so far (evaluations excluded).
    pub wall_seconds: f64,
    /// Mean evaluation return.
    pub return_mean: f64,
    /// Evaluation episodes that ended by a fall.
    pub falls: usize,
    /// Evaluation episodes.
    pub episodes: usize,
}

/// The three agents of an experiment.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ExperimentSummary {
    /// Residual RL on the controller.
    pub hybrid: AgentStats,
    /// RL alone.
    pub pure_rl: AgentStats,
    /// The controller alone.
    pub controller: AgentStats,
    /// The hybrid's evaluations during training, the final one last.
    pub hybrid_budgets: Vec<BudgetEval>,
    /// Pure RL's evaluations during training, the final one last.
    pub pure_budgets: Vec<BudgetEval>,
}

impl ExperimentSummary {
    /// The evaluation table in Markdown: return, forward speed, falls, energy, cost of
    /// transport and torque RMS of the three agents.
    pub fn markdown_table(&self) -> String {
        let row = |name: &str, s: &AgentStats| {
            let cot = s.cost_of_transport.map_or("—".to_string(), |c| format!("{c:.2}"));
            format!(
                "| {name} | {:.2} ± {:.2} | {:.3} | {}/{} | {:.1} | {cot} | {:.2} |\n",
                s.return_mean, s.return_std, s.mean_speed, s.falls, s.episodes, s.energy_mean, s.torque_rms
            )
        };
        let mut t = String::from(
            "| agent | return | mean forward speed (m/s) | falls | energy / episode (J) | cost of transport | torque RMS (N·m) |\n|---|---:|---:|---:|---:|---:|---:|\n",
        );
        t += &row("hybrid (residual RL on the controller)", &self.hybrid);
        t += &row("pure RL", &self.pure_rl);
        t += &row("controller alone", &self.controller);
        t
    }
}
