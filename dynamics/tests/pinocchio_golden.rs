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

use centaur_dynamics::{BaseKind, Model, UrdfOptions, UrdfWarning};

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
    let report = check_file(Path::new(&path), Some(cos_sin));
    eprintln!("{fixture}: worst relative difference from Pinocchio {:e}", report.worst);
}

/// `‖M q̈ + nle − τ‖∞ / ‖τ − nle‖∞` of one output case (the caller's joint order).
fn backward_error(g: &eval::CaseOut, tau: &[f64]) -> f64 {
    let ddq = g.ddq.as_ref().unwrap();
    let n = tau.len();
    let mut num = 0.0f64;
    let mut den = 1e-12f64;
    for r in 0..n {
        let mddq: f64 = (0..n).map(|c| g.m[r][c] * ddq[c]).sum();
        num = num.max((mddq + g.nle[r] - tau[r]).abs());
        den = den.max((tau[r] - g.nle[r]).abs());
    }
    num / den
}

/// What one fixture's comparison found.
struct Report {
    /// The fixture's input (paths made absolute).
    input: eval::Input,
    /// The fixture's provenance block.
    provenance: serde_json::Value,
    /// The loader's warnings.
    warnings: Vec<UrdfWarning>,
    /// Worst relative difference over every quantity and case.
    worst: f64,
    /// Cases whose ddq Pinocchio left out (a singular mass matrix).
    ddq_skipped: usize,
    /// Worst ddq difference and largest cond(M) over the cases where cond(M)·1e-15 > 1e-9
    /// (compared at cond(M)·1e-15, not in `worst`); zeros if none.
    ill_ddq: (f64, f64),
    /// nq and nv of Centaur's model.
    nq_nv: (usize, usize),
}

/// Compares `dyn_eval` with one fixture; `cos_sin` overrides the input's parametrisation.
fn check_file(path: &Path, cos_sin: Option<bool>) -> Report {
    let fixture = path.file_stem().unwrap().to_string_lossy().to_string();
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let doc: serde_json::Value = serde_json::from_str(&text).expect("fixture is JSON");
    let input: eval::Input = serde_json::from_value(doc["input"].clone()).expect("fixture input");
    let expected: eval::Output = serde_json::from_value(doc["output"].clone()).expect("fixture output");
    // Fixture paths are relative to the repository root.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut input = input;
    input.urdf = root.join(&input.urdf).display().to_string();
    if let Some(cos_sin) = cos_sin {
        input.continuous_as_cos_sin = cos_sin;
    }
    let (got, warnings) = eval::run(&input, &root).unwrap_or_else(|e| panic!("{fixture}: {e}"));
    assert_eq!(got.cases.len(), expected.cases.len());
    let mut worst = 0.0f64;
    let mut ddq_skipped = 0;
    let (mut ill_ddq, mut max_cond) = (0.0f64, 0.0f64);
    for (k, (g, e)) in got.cases.iter().zip(&expected.cases).enumerate() {
        let flat = |m: &Vec<Vec<f64>>| m.iter().flatten().copied().collect::<Vec<f64>>();
        let mut errs = vec![
            ("tau", rel(&g.tau, &e.tau)),
            ("nle", rel(&g.nle, &e.nle)),
            ("M", rel(&flat(&g.m), &flat(&e.m))),
            ("com", rel(&g.com, &e.com)),
            ("total_mass", rel(&[g.total_mass], &[e.total_mass])),
        ];
        match (&g.ddq, &e.ddq) {
            (Some(gd), Some(ed)) => {
                // Forward dynamics amplifies rounding by cond(M): on an ill-conditioned M
                // (iCub: up to 2.5e9) neither library is accurate to 1e-9, so the bar is
                // cond(M)·1e-15 there, and the backward error must be small regardless.
                let cond = doc["provenance"]["cond_M"][k].as_f64().unwrap_or(0.0);
                let raw = rel(gd, ed);
                if 1e-15 * cond > TOL {
                    ill_ddq = ill_ddq.max(raw);
                    max_cond = max_cond.max(cond);
                    assert!(
                        raw < 1e-15 * cond,
                        "{fixture} case {k}: ddq differs by {raw:e} at cond(M) {cond:e}"
                    );
                } else {
                    errs.push(("ddq", raw));
                }
                errs.push(("M ddq + nle − tau (backward error)", backward_error(g, &input.cases[k].tau)));
            }
            (_, None) => ddq_skipped += 1,
            (None, Some(_)) => panic!("{fixture} case {k}: ddq is not finite, Pinocchio's is"),
        }
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
            worst = worst.max(err_t).max(err_r);
            assert!(err_t < TOL && err_r < TOL, "{fixture} case {k} frame {name}: {err_t:e} / {err_r:e}");
        }
    }
    let base = if input.floating_base { BaseKind::Floating } else { BaseKind::Fixed };
    let options = UrdfOptions {
        continuous_as_cos_sin: input.continuous_as_cos_sin,
        accept_nonphysical_inertia: input.accept_nonphysical_inertia,
        ..UrdfOptions::default()
    };
    let model = Model::from_urdf_file_with(&input.urdf, base, options).expect("loaded above");
    Report {
        input,
        provenance: doc["provenance"].clone(),
        warnings,
        worst,
        ddq_skipped,
        ill_ddq: (ill_ddq, max_cond),
        nq_nv: (model.nq, model.nv),
    }
}

/// The warnings of a model in a table cell: counts by kind.
fn summarise(warnings: &[UrdfWarning]) -> String {
    let mut kinds: Vec<(&str, usize)> = Vec::new();
    for w in warnings {
        let kind = match w {
            UrdfWarning::Reread { .. } => "re-read",
            UrdfWarning::Dropped { .. } => "shape dropped",
            UrdfWarning::Ignored { .. } => "tags ignored",
            UrdfWarning::MimicIgnored { .. } => "mimic ignored",
            UrdfWarning::ZeroMassWithInertia { .. } => "zero mass, inertia kept",
            UrdfWarning::NonPhysicalLinkMerged { .. } => "non-physical link merged",
            UrdfWarning::NonPhysicalBodyKept { .. } => "non-physical body kept",
            UrdfWarning::SingularMassMatrix { .. } => "massless dof",
        };
        match kinds.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, n)) => *n += 1,
            None => kinds.push((kind, 1)),
        }
    }
    if kinds.is_empty() {
        return "—".into();
    }
    kinds.iter().map(|(k, n)| format!("{k} ×{n}")).collect::<Vec<_>>().join(", ")
}

/// Every published robot of the corpus (`assets/corpus/`, listed by
/// `tools/pinocchio/corpus.py`) loads and agrees with Pinocchio to 1e-9 relative on random
/// states. Run with `-- --nocapture` to print the README's corpus table.
#[test]
fn published_robot_corpus_matches_pinocchio() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pinocchio/corpus");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    paths.sort();
    let mut rows = Vec::new();
    let mut sources = std::collections::BTreeSet::new();
    let mut default_loaded = Vec::new();
    for path in &paths {
        let r = check_file(path, None);
        let name = r.provenance["robot"].as_str().unwrap().to_string();
        let source = r.provenance["source"].as_str().unwrap().to_string();
        let opts = if r.input.accept_nonphysical_inertia { " ¹" } else { "" };
        let base = if r.input.floating_base { "floating" } else { "fixed" };
        let mut ddq = if r.ddq_skipped > 0 {
            format!(" (ddq undefined, singular M, in {} of 3 cases)", r.ddq_skipped)
        } else {
            String::new()
        };
        if r.ill_ddq.1 > 0.0 {
            ddq += &format!(" (ddq {:.1e} at cond(M) {:.1e})", r.ill_ddq.0, r.ill_ddq.1);
        }
        rows.push(format!(
            "| {name}{opts} | {source}: `{}` | {base} | {} / {} | {} | {:.1e}{ddq} |",
            r.provenance["source_path"].as_str().unwrap(),
            r.nq_nv.0,
            r.nq_nv.1,
            summarise(&r.warnings),
            r.worst
        ));
        if !r.input.accept_nonphysical_inertia {
            sources.insert(source.split(' ').next().unwrap().to_string());
            default_loaded.push(name);
        }
    }
    eprintln!(
        "| robot | source | base | nq / nv | loader warnings | worst relative difference from Pinocchio |"
    );
    eprintln!("|---|---|---|---:|---|---:|");
    for row in &rows {
        eprintln!("{row}");
    }
    assert!(default_loaded.len() >= 30, "{} robots load with the default options", default_loaded.len());
    assert!(sources.len() >= 2, "sources: {sources:?}");
    // TIAGo is the Apache-2.0 TIAGo Pro: example-robot-data's older TIAGo files are
    // CC BY-NC-ND (assets/corpus/PROVENANCE.md).
    for must in ["go1", "anymal_c", "hyq", "bolt", "icub", "tiago_pro"] {
        assert!(default_loaded.iter().any(|n| n == must), "{must} is not in the corpus");
    }
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
