//! The hyperparameters the examples and `centaur compare` use when the user gives none,
//! as typed presets of the learners' configs.

use centaur_rl::{AlgoConfig, AlgoKind, DdpgConfig, PpoConfig, SacConfig, SacV1Config, Td3Config};

/// The settings for `kind` on `env` when the user gives none: [`PpoConfig::minitaur`] for
/// PPO on the Minitaur, the `locomotion()` presets (5,000 random steps first) for SAC, TD3
/// and DDPG on the other robots, else the algorithm's defaults.
pub fn tuned_config(env: &str, kind: AlgoKind) -> AlgoConfig {
    let minitaur = env.starts_with("minitaur");
    match kind {
        AlgoKind::Ppo if minitaur => AlgoConfig::Ppo(PpoConfig::minitaur()),
        AlgoKind::Sac if !minitaur => AlgoConfig::Sac(SacConfig::locomotion()),
        AlgoKind::SacV1 if !minitaur => AlgoConfig::SacV1(SacV1Config::locomotion()),
        AlgoKind::Td3 if !minitaur => AlgoConfig::Td3(Td3Config::locomotion()),
        AlgoKind::Ddpg if !minitaur => AlgoConfig::Ddpg(DdpgConfig::locomotion()),
        _ => AlgoConfig::default_for(kind),
    }
}
