//! The foothold offset (`LocomotionController::set_foothold_offset`): each swing takes the
//! offset in force at its lift-off and lands that far ahead along the heading, a swing
//! under way keeps its foothold, and offset 0 is the controller as configured, to the bit.

mod common;

use centaur_mpc::{Command, Gait, LocomotionController, MAX_FOOTHOLD_OFFSET};

/// Ticks the Solo12's trot at its nominal (standing) state for 0.6 s at 1 kHz with the
/// offset `offset(t)` set before every tick; returns every tick's footholds of the feet in
/// swing (contact point, foothold), in order.
fn swing_footholds(offset: impl Fn(f64) -> f64) -> Vec<(usize, [f64; 3])> {
    let (model, cfg) = common::load("solo12");
    let mut c = LocomotionController::new(&model, cfg).unwrap();
    let s = c.nominal_state();
    let trot = Command::forward(0.3, Gait::Trot);
    let mut out = Vec::new();
    for k in 0..600 {
        let t = k as f64 * 1e-3;
        c.set_foothold_offset(offset(t));
        c.tick(&s, &trot, t);
        let st = c.status();
        for ci in 0..st.contact.len() {
            if !st.contact[ci] {
                out.push((ci, st.footholds[ci]));
            }
        }
    }
    out
}

#[test]
fn every_swing_lands_the_offset_ahead_along_the_heading() {
    let own = swing_footholds(|_| 0.0);
    assert!(own.len() > 100, "the trot swings its feet: {} swing ticks", own.len());
    // The nominal state faces +x: 4 cm forward moves every foothold by (0.04, 0, 0).
    let ahead = swing_footholds(|_| 0.04);
    assert_eq!(ahead.len(), own.len());
    for ((ci, a), (cj, o)) in ahead.iter().zip(&own) {
        assert_eq!(ci, cj);
        assert!((a[0] - o[0] - 0.04).abs() < 1e-12 && (a[1] - o[1]).abs() < 1e-12, "{a:?} against {o:?}");
        assert_eq!(a[2], o[2]);
    }
    // Out of range: clamped; not finite: none.
    for ((_, a), (_, o)) in swing_footholds(|_| -1.0).iter().zip(&own) {
        assert!((a[0] - o[0] + MAX_FOOTHOLD_OFFSET).abs() < 1e-12, "{a:?} against {o:?}");
    }
    assert_eq!(swing_footholds(|_| f64::NAN), own);
}

#[test]
fn a_swing_under_way_keeps_its_foothold_and_reset_clears_the_offset() {
    // The offset alternates on every tick: each swing's foothold moves only as the offset at
    // its lift-off says (the MPC's look-ahead for the legs in stance follows the offset in
    // force, so only the swing footholds are compared).
    let (model, cfg) = common::load("solo12");
    let mut c = LocomotionController::new(&model, cfg.clone()).unwrap();
    let s = c.nominal_state();
    let trot = Command::forward(0.3, Gait::Trot);
    let n = c.robot().n_contacts();
    let mut latched = vec![0.0f64; n];
    let mut was_stance = vec![true; n];
    let mut own = LocomotionController::new(&model, cfg).unwrap();
    let mut swings = 0;
    for k in 0..600 {
        let t = k as f64 * 1e-3;
        let offset = if k % 2 == 0 { -0.03 } else { 0.05 };
        c.set_foothold_offset(offset);
        c.tick(&s, &trot, t);
        own.tick(&s, &trot, t);
        let (st, base) = (c.status(), own.status());
        for ci in 0..n {
            if was_stance[ci] && !st.contact[ci] {
                latched[ci] = offset;
            }
            if !st.contact[ci] {
                swings += 1;
                let d = st.footholds[ci][0] - base.footholds[ci][0];
                assert!(
                    (d - latched[ci]).abs() < 1e-12,
                    "tick {k}, foot {ci}: moved {d}, latched {}",
                    latched[ci]
                );
            }
            was_stance[ci] = st.contact[ci];
        }
    }
    assert!(swings > 100);
    assert_eq!(c.foothold_offset(), 0.05);
    c.reset();
    assert_eq!(c.foothold_offset(), 0.0);
}
