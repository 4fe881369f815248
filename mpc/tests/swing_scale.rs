//! The swing apex scale (`LocomotionController::set_swing_height_scale`): each swing takes
//! the scale in force at its lift-off, so the foot's apex above lift-off scales with it,
//! a swing under way keeps its curve, and scale 1 is the controller as configured.

mod common;

use centaur_mpc::{Command, Gait, LocomotionController, SWING_SCALE_RANGE};

/// Ticks the Solo12's trot at its nominal (standing) state for 0.6 s at 1 kHz with the
/// swing scale `scale(t)` set before every tick; returns, per contact point, the highest its
/// swing targets rise above the foot (at a fixed state every swing lifts off and lands where
/// the foot stands, so this is the apex of its swings).
fn apex_per_foot(scale: impl Fn(f64) -> f64) -> Vec<f64> {
    let (model, cfg) = common::load("solo12");
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    let trot = Command::forward(0.3, Gait::Trot);
    let mut apex = vec![0.0f64; c.robot().n_contacts()];
    for k in 0..600 {
        let t = k as f64 * 1e-3;
        c.set_swing_height_scale(scale(t));
        c.tick(&s, &trot, t);
        let st = c.status();
        for (ci, a) in apex.iter_mut().enumerate() {
            if !st.contact[ci] {
                *a = a.max(st.foot_targets[ci][2] - st.foot_positions[ci][2]);
            }
        }
    }
    apex
}

#[test]
fn the_swing_apex_scales_with_the_scale_at_lift_off() {
    let own = apex_per_foot(|_| 1.0);
    assert!(own.iter().all(|&a| a > 0.02), "the trot swings its feet: {own:?}");
    let half = apex_per_foot(|_| 0.5);
    for (h, o) in half.iter().zip(&own) {
        assert!((h / o - 0.5).abs() < 0.02, "apex {h} at scale 0.5 against {o}");
    }
    // Out of range or not finite: clamped, or the configured height.
    let (low, high) = SWING_SCALE_RANGE;
    let clamped = apex_per_foot(|_| 10.0);
    for (c, o) in clamped.iter().zip(&own) {
        assert!((c / o - high).abs() < 0.03, "apex {c} at scale 10 against {o}");
    }
    assert_eq!(apex_per_foot(|_| f64::NAN), own);
    assert!(low > 0.0);
}

#[test]
fn a_swing_under_way_keeps_its_curve() {
    // The scale changes on every tick: the targets move only as the scale at each swing's
    // lift-off says, so a scale that alternates between 0.5 and 1.5 within every swing
    // gives the apex of one of the two, not a curve that jumps between them.
    let (model, cfg) = common::load("solo12");
    let mut c = LocomotionController::new(&model, cfg.clone()).unwrap();
    let mut held = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    let trot = Command::forward(0.3, Gait::Trot);
    let mut latched = 1.0;
    let mut was_stance = vec![true; c.robot().n_contacts()];
    for k in 0..600 {
        let t = k as f64 * 1e-3;
        let scale = if k % 2 == 0 { 0.5 } else { 1.5 };
        c.set_swing_height_scale(scale);
        // `held` gets the scale only at the ticks where a foot lifts off, as the latch does.
        c.tick(&s, &trot, t);
        let stance: Vec<bool> = c.status().contact.clone();
        if stance.iter().zip(&was_stance).any(|(now, was)| *was && !*now) {
            latched = scale;
        }
        held.set_swing_height_scale(latched);
        held.tick(&s, &trot, t);
        assert_eq!(c.status().foot_targets, held.status().foot_targets, "tick {k}");
        was_stance = stance;
    }
    assert_eq!(c.swing_height_scale(), 1.5);
    c.reset();
    assert_eq!(c.swing_height_scale(), 1.0);
}
