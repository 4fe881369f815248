//! Cross-check tool: evaluates rigid-body algorithms on cases given in Pinocchio's
//! conventions and prints the results as JSON, so users can compare libraries.
//!
//! ```text
//! cargo run --release -p centaur-dynamics --example dyn_eval -- cases.json
//! ```
//!
//! Input: `{"urdf": path, "floating_base": bool, "joint_names": [1-dof joints in the order of
//! q/v/a/tau], "frames": [link names], "cases": [{"q", "v", "a", "tau"}]}`. With a floating
//! base, `q = [x, y, z, qx, qy, qz, qw, joints…]` and `v = [base linear, base angular (both in
//! the root-link frame), joint rates…]`; gravity (0, 0, −9.81).
//! Output: `{"cases": [{"tau": rnea(q,v,a), "nle": rnea(q,v,0), "M": rows, "ddq":
//! aba(q,v,tau), "com", "total_mass", "frames": {link: {"translation", "rotation"}}}]}`.
//! The URDF path is taken relative to the working directory, else to the cases file.
//! Optional input field `"continuous_as_cos_sin": true` loads continuous joints as
//! `(cos θ, sin θ)` joints, as Pinocchio does; `q` still gives one angle per joint.
//! Optional `"accept_nonphysical_inertia": true` keeps bodies whose inertia no rigid body can
//! have, as Pinocchio does (the loader refuses them by default). `"ddq"` is `null` where the
//! mass matrix is singular. What the loader repaired, ignored or dropped is printed on
//! stderr, one `dyn_eval: warning: …` line each.

mod eval;

use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: dyn_eval CASES.json");
        return ExitCode::from(2);
    };
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("dyn_eval: cannot read {path}: {e}");
            return ExitCode::FAILURE;
        }
    };
    let input: eval::Input = match serde_json::from_str(&text) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("dyn_eval: {path} is not a valid cases file: {e}");
            return ExitCode::FAILURE;
        }
    };
    let base_dir = Path::new(&path).parent().unwrap_or(Path::new("."));
    match eval::run(&input, base_dir) {
        Ok((out, warnings)) => match serde_json::to_string(&out) {
            Ok(s) => {
                for w in &warnings {
                    eprintln!("dyn_eval: warning: {}: {w}", input.urdf);
                }
                println!("{s}");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("dyn_eval: cannot encode the output: {e}");
                ExitCode::FAILURE
            }
        },
        Err(e) => {
            eprintln!("dyn_eval: {e}");
            ExitCode::FAILURE
        }
    }
}
