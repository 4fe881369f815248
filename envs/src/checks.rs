//! Range checks of configuration fields that name the field, its value and what it must be,
//! shared by the environments' `validate` methods.

use crate::error::RobotEnvError;

/// Most physics steps per control step (`frame_skip`, the Minitaur's `action_repeat`): the
/// 4 Hz control rate of the modular robots is 50; more is no control at all.
pub const MAX_FRAME_SKIP: usize = 1000;

/// Most past control steps an observation may append (`ObsOptions::joint_history`).
pub const MAX_JOINT_HISTORY: usize = 100;

/// The checks of one configuration type (its name goes into every error).
pub(crate) struct Fields(pub(crate) &'static str);

impl Fields {
    fn err(&self, field: &str, value: impl std::fmt::Debug, expected: &str) -> RobotEnvError {
        RobotEnvError::config(self.0, format!("{field} = {value:?}: expected {expected}"))
    }

    /// A finite number.
    pub(crate) fn finite(&self, field: &str, v: f64) -> Result<(), RobotEnvError> {
        if v.is_finite() { Ok(()) } else { Err(self.err(field, v, "a finite number")) }
    }

    /// A finite number ≥ 0.
    pub(crate) fn non_negative(&self, field: &str, v: f64) -> Result<(), RobotEnvError> {
        if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(self.err(field, v, "a finite number ≥ 0")) }
    }

    /// A number ≥ 0 or infinite (no cap).
    pub(crate) fn cap(&self, field: &str, v: f64) -> Result<(), RobotEnvError> {
        if v >= 0.0 { Ok(()) } else { Err(self.err(field, v, "a number ≥ 0 (inf: no cap)")) }
    }

    /// A finite number in `[0, max]`.
    pub(crate) fn at_most(&self, field: &str, v: f64, max: f64, expected: &str) -> Result<(), RobotEnvError> {
        if v.is_finite() && (0.0..=max).contains(&v) { Ok(()) } else { Err(self.err(field, v, expected)) }
    }

    /// A finite number in `(0, max]`.
    pub(crate) fn positive(
        &self,
        field: &str,
        v: f64,
        max: f64,
        expected: &str,
    ) -> Result<(), RobotEnvError> {
        if v.is_finite() && v > 0.0 && v <= max { Ok(()) } else { Err(self.err(field, v, expected)) }
    }

    /// A count in `[1, max]`.
    pub(crate) fn count(&self, field: &str, n: usize, max: usize) -> Result<(), RobotEnvError> {
        if (1..=max).contains(&n) { Ok(()) } else { Err(self.err(field, n, &format!("1 to {max}"))) }
    }

    /// A range `(low, high)` with `low ≤ high`, neither NaN (either may be infinite: no bound).
    pub(crate) fn range(&self, field: &str, (low, high): (f64, f64)) -> Result<(), RobotEnvError> {
        if low <= high {
            Ok(())
        } else {
            Err(self.err(field, [low, high], "[low, high] with low ≤ high, not NaN"))
        }
    }

    /// The shared observation options' history length (`obs.joint_history`).
    pub(crate) fn joint_history(&self, k: usize) -> Result<(), RobotEnvError> {
        if k <= MAX_JOINT_HISTORY {
            Ok(())
        } else {
            Err(self.err("joint_history", k, &format!("0 to {MAX_JOINT_HISTORY}")))
        }
    }
}
