//! Loads URDF files as Centaur's dynamics would and says what it made of them: the model's
//! size and mass, and every warning of the loader (what it repaired, ignored or dropped).
//!
//! ```text
//! cargo run --release -p centaur-dynamics --example urdf_check -- [--fixed] [--strict]
//!     [--accept-nonphysical-inertia] [--cos-sin] FILE.urdf...
//! ```
//!
//! Exit status 1 if any file is refused (the error says why and where).

use std::process::ExitCode;

use centaur_dynamics::{BaseKind, Model, UrdfOptions};

fn main() -> ExitCode {
    let mut options = UrdfOptions::default();
    let mut base = BaseKind::Floating;
    let mut files = Vec::new();
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "--fixed" => base = BaseKind::Fixed,
            "--strict" => options.strict = true,
            "--accept-nonphysical-inertia" => options.accept_nonphysical_inertia = true,
            "--cos-sin" => options.continuous_as_cos_sin = true,
            "-h" | "--help" => {
                eprintln!(
                    "usage: urdf_check [--fixed] [--strict] [--accept-nonphysical-inertia] [--cos-sin] FILE.urdf..."
                );
                return ExitCode::SUCCESS;
            }
            s if s.starts_with("--") => {
                eprintln!("urdf_check: unknown option {s} (see --help)");
                return ExitCode::from(2);
            }
            _ => files.push(arg),
        }
    }
    if files.is_empty() {
        eprintln!("urdf_check: no URDF file given (see --help)");
        return ExitCode::from(2);
    }
    let mut refused = 0;
    for file in &files {
        match Model::from_urdf_file_with(file, base, options) {
            Ok(m) => {
                println!(
                    "{file}: loaded, nq {} nv {}, {} joints, {} frames, {:.4} kg, {} warning(s)",
                    m.nq,
                    m.nv,
                    m.njoints() - 1,
                    m.frames.len(),
                    m.total_mass(),
                    m.load_warnings.len()
                );
                for w in &m.load_warnings {
                    println!("  warning: {w}");
                }
            }
            Err(e) => {
                refused += 1;
                println!("refused: {e}");
            }
        }
    }
    if refused > 0 { ExitCode::FAILURE } else { ExitCode::SUCCESS }
}
