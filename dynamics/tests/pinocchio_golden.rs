//! Golden values from Pinocchio 4.1 (pip `pin`) on published URDFs.
//!
//! The fixtures in `tests/fixtures/pinocchio/` were written by
//! `tools/pinocchio/gen_fixtures.py` (provenance inside each file): the input is exactly a
//! `dyn_eval` cases file, the output is what Pinocchio computed for it. This test runs the
//! same code as the `dyn_eval` example and requires agreement to 1e-9 relative
//! (‖ours − pinocchio‖∞ / ‖pinocchio‖∞ per quantity and case).

#[path = "../examples/dyn_eval/eval.rs"]
mod eval;

use std::path::Path;

const TOL: f64 = 1e-9;

fn rel(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "length mismatch");
    let num = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    let den = b.iter().map(|y| y.abs()).fold(1e-12, f64::max);
    num / den
}

fn check(fixture: &str) {
    check_with(fixture, false);
}

/// `cos_sin`: load continuous joints as (cos θ, sin θ) joints, as Pinocchio itself does.
fn check_with(fixture: &str, cos_sin: bool) {
    let path = format!("{}/tests/fixtures/pinocchio/{fixture}.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let doc: serde_json::Value = serde_json::from_str(&text).expect("fixture is JSON");
    let input: eval::Input = serde_json::from_value(doc["input"].clone()).expect("fixture input");
    let expected: eval::Output = serde_json::from_value(doc["output"].clone()).expect("fixture output");
    // Fixture paths are relative to the repository root.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut input = input;
    input.urdf = root.join(&input.urdf).display().to_string();
    input.continuous_as_cos_sin = cos_sin;
    let got = eval::run(&input, &root).unwrap_or_else(|e| panic!("{fixture}: {e}"));
    assert_eq!(got.cases.len(), expected.cases.len());
    let mut worst = 0.0f64;
    for (k, (g, e)) in got.cases.iter().zip(&expected.cases).enumerate() {
        let flat = |m: &Vec<Vec<f64>>| m.iter().flatten().copied().collect::<Vec<f64>>();
        let errs = [
            ("tau", rel(&g.tau, &e.tau)),
            ("nle", rel(&g.nle, &e.nle)),
            ("M", rel(&flat(&g.m), &flat(&e.m))),
            ("ddq", rel(&g.ddq, &e.ddq)),
            ("com", rel(&g.com, &e.com)),
            ("total_mass", rel(&[g.total_mass], &[e.total_mass])),
        ];
        for (what, err) in errs {
            worst = worst.max(err);
            assert!(err < TOL, "{fixture} case {k}: {what} differs from Pinocchio by {err:e}");
        }
        assert_eq!(g.frames.len(), e.frames.len(), "{fixture}: frame count");
        for (name, ef) in &e.frames {
            let gf = g.frames.get(name).unwrap_or_else(|| panic!("{fixture}: frame {name} missing"));
            let et = ef.translation;
            let err_t = rel(&gf.translation, &et);
            let err_r = rel(&gf.rotation.concat(), &ef.rotation.concat());
            assert!(err_t < TOL && err_r < TOL, "{fixture} case {k} frame {name}: {err_t:e} / {err_r:e}");
        }
    }
    eprintln!("{fixture}: worst relative difference from Pinocchio {worst:e}");
}

#[test]
fn solo12_matches_pinocchio() {
    check("solo12");
}

#[test]
fn minitaur_matches_pinocchio() {
    check("minitaur");
}

/// The same fixture with the Minitaur's 8 continuous joints parametrised as Pinocchio
/// parametrises them, `q = (cos θ, sin θ)` (nq 31).
#[test]
fn minitaur_with_cos_sin_joints_matches_pinocchio() {
    check_with("minitaur", true);
}

#[test]
fn talos_reduced_matches_pinocchio() {
    check("talos_reduced");
}

#[test]
fn ur5_matches_pinocchio() {
    check("ur5_robot");
}
