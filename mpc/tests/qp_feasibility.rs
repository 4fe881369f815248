//! QP feasibility: the MPC and the whole-body QP are feasible while standing and in every
//! phase of every gait on each robot, also for perturbed states (base tilt, height,
//! velocity, joint offsets).

mod common;

use common::{Perturbation, perturbation, perturbed};

use centaur_dynamics::Model;
use centaur_mpc::{Command, ControllerConfig, Gait, LocomotionController, QpStatus};
use proptest::prelude::*;

/// Runs one gait cycle (plus a bit) and checks every QP status.
fn check_cycle(name: &str, model: &Model, cfg: &ControllerConfig, gait: Gait, p: &Perturbation) {
    let mut c = LocomotionController::new(model, cfg.clone()).unwrap();
    let state = perturbed(&c, p);
    let cmd = Command::forward(0.3, gait);
    // The gait in force (a humanoid told to stand steps in place), its period scaled.
    let run = cfg.gait_for(gait);
    let period = centaur_mpc::GaitPattern::new(run, c.robot().n_legs).map_or(0.5, |g| g.period)
        * cfg.gait_period_scale;
    let steps = (period / 0.025).ceil() as usize + 1;
    for k in 0..steps {
        let t = k as f64 * 0.025;
        c.tick(&state, &cmd, t);
        let s = c.status();
        assert!(s.mpc_status.is_ok(), "{name} {gait:?} φ = {:.2} {p:?}: MPC {:?}", s.phase, s.mpc_status);
        if s.wbc_status != QpStatus::NotRun {
            assert!(s.wbc_status.is_ok(), "{name} {gait:?} φ = {:.2} {p:?}: WBC {:?}", s.phase, s.wbc_status);
        }
        assert!(c.command().tau.iter().all(|x| x.is_finite()));
    }
}

fn gaits_for(c: &ControllerConfig) -> Vec<Gait> {
    Gait::ALL.into_iter().filter(|g| g.supported(c.robot.n_legs)).collect()
}

#[test]
fn feasible_standing_and_in_every_phase_of_every_gait() {
    let zero = Perturbation { joint_seed: 1, ..Perturbation::default() };
    for (name, _, _) in common::ROBOTS {
        let (model, cfg) = common::load(name);
        for gait in gaits_for(&cfg) {
            check_cycle(name, &model, &cfg, gait, &zero);
        }
    }
}

macro_rules! perturbed_feasibility {
    ($test:ident, $robot:expr) => {
        proptest! {
            #![proptest_config(ProptestConfig { cases: 6, ..ProptestConfig::default() })]
            #[test]
            fn $test(p in perturbation(), g in 0usize..7) {
                let (model, cfg) = common::load($robot);
                let gaits = gaits_for(&cfg);
                let gait = gaits[g % gaits.len()];
                check_cycle($robot, &model, &cfg, gait, &p);
            }
        }
    };
}

perturbed_feasibility!(perturbed_states_feasible_solo12, "solo12");
perturbed_feasibility!(perturbed_states_feasible_ant, "ant");
perturbed_feasibility!(perturbed_states_feasible_walker2d, "walker2d");
perturbed_feasibility!(perturbed_states_feasible_humanoid, "humanoid");
perturbed_feasibility!(perturbed_states_feasible_minitaur, "minitaur");

#[test]
fn clarabel_wbc_backend_is_feasible_too() {
    // The Clarabel backend with exact cones, Solo12 trotting.
    let (model, mut cfg) = common::load("solo12");
    cfg.wbc.backend = centaur_mpc::QpBackend::Clarabel;
    cfg.wbc.friction = centaur_mpc::FrictionModel::Cone;
    let zero = Perturbation {
        roll: 0.05,
        pitch: -0.05,
        dz: -0.01,
        v: [0.1, 0.0, 0.0],
        w: [0.0; 3],
        joint_offset: 0.05,
        joint_seed: 3,
    };
    for gait in [Gait::Stand, Gait::Trot, Gait::Bound] {
        check_cycle("solo12/clarabel", &model, &cfg, gait, &zero);
    }
}
