//! Joint position limits in the whole-body QP. Walker2d stands with its hips and knees on
//! their upper limits (0 rad); a plan that drives them further is stopped by the
//! simulator's limits and the robot then falls (it did, within 1.5 s, before the QP knew
//! the limits).

mod common;

use centaur_mpc::{Command, LocomotionController};
use proptest::prelude::*;

/// The planned acceleration of every limited joint, with its bounds from the state
/// (`q̈_hi = 2 (q_max − q − q̇ h) / h²`, `q̈_lo` likewise, before any cap).
fn planned_vs_bounds(c: &LocomotionController, q: &[f64], v: &[f64], h: f64) -> Vec<(f64, f64, f64)> {
    let model = &c.robot().model;
    let qdd = c.planned_accelerations();
    let mut out = Vec::new();
    for (&iv, &iq) in c.robot().joint_v.iter().zip(&c.robot().joint_q) {
        let (lo, hi) = (model.lower_position_limit[iq], model.upper_position_limit[iq]);
        if !(lo.is_finite() && hi.is_finite()) {
            continue;
        }
        let drift = q[iq] + v[iv] * h;
        let upper = 2.0 * (hi - drift) / (h * h);
        let lower = 2.0 * (lo - drift) / (h * h);
        out.push((qdd[iv], lower, upper));
    }
    out
}

#[test]
fn walker2d_standing_on_its_limits_plans_no_acceleration_past_them() {
    let (model, cfg) = common::load("walker2d");
    let h = cfg.wbc.joint_limit_horizon;
    assert!(h > 0.0, "joint limits are on by default");
    let mut c = LocomotionController::new(&model, cfg.clone()).unwrap();
    let s = c.nominal_state();
    let on_limit: Vec<usize> = c
        .robot()
        .joint_v
        .iter()
        .zip(&c.robot().joint_q)
        .filter(|(_, iq)| s.q[**iq] == model.upper_position_limit[**iq])
        .map(|(iv, _)| *iv)
        .collect();
    assert_eq!(on_limit.len(), 4, "both hips and both knees rest on their upper limit");
    for k in 0..5 {
        c.tick(&s, &Command::stand(), 0.01 * k as f64);
        assert!(c.status().wbc_status.is_ok(), "{:?}", c.status().wbc_status);
        for &iv in &on_limit {
            let a = c.planned_accelerations()[iv];
            assert!(a <= 1e-9, "tick {k}: joint v{iv} on its upper limit planned q̈ = {a}");
        }
    }
    // Without the bounds the same plan drives a joint through its limit.
    let mut free_cfg = cfg;
    free_cfg.wbc.joint_limit_horizon = 0.0;
    let mut free = LocomotionController::new(&model, free_cfg).unwrap();
    free.tick(&s, &Command::stand(), 0.0);
    let worst = on_limit.iter().map(|&iv| free.planned_accelerations()[iv]).fold(f64::MIN, f64::max);
    assert!(worst > 0.1, "expected a plan past the limit without bounds, got q̈ = {worst}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Perturbed Walker2d states near the limits, joints moving towards them: every planned
    /// joint acceleration stays within its bounds.
    #[test]
    fn walker2d_plans_respect_the_limit_bounds(
        dq in prop::collection::vec(-0.3f64..0.02, 6),
        dv in prop::collection::vec(-1.0f64..1.0, 6),
    ) {
        let (model, cfg) = common::load("walker2d");
        let h = cfg.wbc.joint_limit_horizon;
        let mut c = LocomotionController::new(&model, cfg).unwrap();
        let mut s = c.nominal_state();
        for (k, (&iq, &iv)) in c.robot().joint_q.iter().zip(&c.robot().joint_v).enumerate() {
            s.q[iq] += dq[k];
            s.v[iv] += dv[k];
        }
        c.tick(&s, &Command::stand(), 0.0);
        prop_assert!(c.status().wbc_status.is_ok());
        if c.status().wbc_limit_relaxations == 0 {
            // A bound the caps do not touch holds exactly; a capped one still forbids any
            // acceleration towards (or further past) the limit.
            for (a, lo, hi) in planned_vs_bounds(&c, s.q.as_slice(), s.v.as_slice(), h) {
                prop_assert!(a <= hi.max(0.0) + 1e-6, "q̈ {} above its bound {}", a, hi);
                prop_assert!(a >= lo.min(0.0) - 1e-6, "q̈ {} below its bound {}", a, lo);
            }
        }
    }
}
