//! What a run changes in its robot's controller preset: [`ControllerOverrides`], validated
//! and applied in one place for the hybrid (a spec's `[controller]` table, through
//! [`super::ResidualConfig::controller_overrides`]) and for `centaur control`.

use centaur_mpc::{ControlMode, ControllerConfig, Gait};

use super::error::HybridError;

/// The controller settings a run overrides over its robot's preset. Each `None` (or
/// `false`) keeps the preset's value; a set one is checked against its range first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerOverrides {
    /// The gait the rating and the period scale apply to (the command's).
    pub gait: Gait,
    /// The gait's speed rating (m/s, in (0, [`MAX_RATED_SPEED`]]).
    pub rated_speed: Option<f64>,
    /// A factor on the gait's period (within [`PERIOD_SCALE_RANGE`]).
    pub period_scale: Option<f64>,
    /// The command ramp's acceleration (m/s², in (0, [`MAX_COMMAND_ACCELERATION`]]).
    pub max_acceleration: Option<f64>,
    /// The swing feet's apex height (m, within [`SWING_HEIGHT_RANGE`]).
    pub swing_height: Option<f64>,
    /// The MPC's period (s, within [`MPC_PERIOD_RANGE`]).
    pub mpc_period: Option<f64>,
    /// The cheap torque path ([`ControlMode::Cheap`]) instead of the whole-body QP.
    pub cheap_torques: bool,
}

impl ControllerOverrides {
    /// No override: the preset as it is, for `gait`.
    pub fn none(gait: Gait) -> ControllerOverrides {
        ControllerOverrides {
            gait,
            rated_speed: None,
            period_scale: None,
            max_acceleration: None,
            swing_height: None,
            mpc_period: None,
            cheap_torques: false,
        }
    }

    /// Every value set within its range, or [`HybridError::BadSetting`] naming it.
    pub fn validate(&self) -> Result<(), HybridError> {
        if let Some(value) = self.rated_speed {
            check_rated_speed(value)?;
        }
        if let Some(value) = self.period_scale {
            check_period_scale(value)?;
        }
        if let Some(value) = self.max_acceleration {
            check_max_acceleration(value)?;
        }
        if let Some(value) = self.swing_height {
            check_swing_height(value)?;
        }
        if let Some(value) = self.mpc_period {
            check_mpc_period(value)?;
        }
        Ok(())
    }

    /// `config` with every value set: the rating and the period scale of
    /// [`ControllerOverrides::gait`] (one `config` offers, not the stand, which has neither),
    /// the command ramp, the swing apex, the MPC period and the torque path. Validated first
    /// ([`ControllerOverrides::validate`]); `config` is unchanged on an error.
    pub fn apply(&self, config: &mut ControllerConfig) -> Result<(), HybridError> {
        self.validate()?;
        if let Some(value) = self.rated_speed {
            self.offered_gait(config, "rated_speed", value, "no rating: the stand has none")?;
        }
        if let Some(value) = self.period_scale {
            self.offered_gait(config, "period_scale", value, "a gait that steps: the stand has no period")?;
        }
        if let Some(value) = self.rated_speed {
            for o in config.gaits.iter_mut().filter(|o| o.gait == self.gait) {
                o.max_speed = value;
            }
        }
        if let Some(value) = self.period_scale {
            config.scale_period(self.gait, value);
        }
        if let Some(value) = self.max_acceleration {
            config.max_acceleration = value;
        }
        if let Some(value) = self.swing_height {
            config.swing_height = value;
        }
        if let Some(value) = self.mpc_period {
            config.mpc_period = value;
        }
        if self.cheap_torques {
            config.mode = ControlMode::Cheap;
        }
        Ok(())
    }

    /// The gait, for `part` (set to `value`) to change in `config`: one it offers, not the
    /// stand (`expected` says why not).
    fn offered_gait(
        &self,
        config: &ControllerConfig,
        part: &'static str,
        value: f64,
        expected: &'static str,
    ) -> Result<(), HybridError> {
        if self.gait == Gait::Stand {
            return Err(HybridError::BadSetting { part, value, expected });
        }
        config.offer(self.gait)?;
        Ok(())
    }
}

/// The largest rated speed accepted (m/s): far above any robot here.
pub const MAX_RATED_SPEED: f64 = 20.0;

fn check_rated_speed(value: f64) -> Result<(), HybridError> {
    if value.is_finite() && value > 0.0 && value <= MAX_RATED_SPEED {
        Ok(())
    } else {
        Err(HybridError::BadSetting { part: "rated_speed", value, expected: "a speed in (0, 20] m/s" })
    }
}

/// The range of a period scale: a quarter to four times the gait's period.
pub const PERIOD_SCALE_RANGE: (f64, f64) = (0.25, 4.0);

fn check_period_scale(value: f64) -> Result<(), HybridError> {
    check_within("period_scale", value, PERIOD_SCALE_RANGE, "a factor in [0.25, 4]")
}

/// `value` of `part` finite and within `[low, high]`, or [`HybridError::BadSetting`] saying
/// what is `expected`.
fn check_within(
    part: &'static str,
    value: f64,
    (low, high): (f64, f64),
    expected: &'static str,
) -> Result<(), HybridError> {
    if value.is_finite() && (low..=high).contains(&value) {
        Ok(())
    } else {
        Err(HybridError::BadSetting { part, value, expected })
    }
}

/// The range of a swing height (m): 1 to 30 cm, a swing every legged robot here can make;
/// a height in centimetres (7 for 0.07) is refused.
pub const SWING_HEIGHT_RANGE: (f64, f64) = (0.01, 0.3);

fn check_swing_height(value: f64) -> Result<(), HybridError> {
    check_within("swing_height", value, SWING_HEIGHT_RANGE, "a height in [0.01, 0.3] m")
}

/// The range of an MPC period (s): from every 5 ms (faster than any robot here is
/// controlled, so the MPC then runs every tick) to every 0.2 s (the presets' MPC horizons
/// cover at least 0.3 s, so the plan in use never runs out between solves); a period in
/// milliseconds (60 for 0.06) is refused.
pub const MPC_PERIOD_RANGE: (f64, f64) = (0.005, 0.2);

fn check_mpc_period(value: f64) -> Result<(), HybridError> {
    check_within("mpc_period", value, MPC_PERIOD_RANGE, "a period in [0.005, 0.2] s")
}

/// The largest command acceleration accepted (m/s²): twice gravity, beyond what feet on
/// the ground can push.
pub const MAX_COMMAND_ACCELERATION: f64 = 20.0;

fn check_max_acceleration(value: f64) -> Result<(), HybridError> {
    if value.is_finite() && value > 0.0 && value <= MAX_COMMAND_ACCELERATION {
        Ok(())
    } else {
        Err(HybridError::BadSetting {
            part: "max_acceleration",
            value,
            expected: "an acceleration in (0, 20] m/s²",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each override changes its value only, for the gait named; a value out of range or a
    /// stand rated or period-scaled is refused naming the part, the preset unchanged.
    #[test]
    fn each_override_changes_its_value_and_a_bad_one_leaves_the_preset() {
        let preset = crate::registry::controller_config("minitaur").unwrap();
        let mut c = preset.clone();
        ControllerOverrides::none(Gait::Trot).apply(&mut c).unwrap();
        assert_eq!(format!("{c:?}"), format!("{preset:?}"));
        let all = ControllerOverrides {
            rated_speed: Some(4.5),
            period_scale: Some(0.5),
            max_acceleration: Some(15.0),
            swing_height: Some(0.05),
            mpc_period: Some(0.02),
            cheap_torques: true,
            ..ControllerOverrides::none(Gait::Trot)
        };
        all.apply(&mut c).unwrap();
        let trot = |c: &ControllerConfig| *c.offer(Gait::Trot).unwrap();
        assert_eq!(trot(&c).max_speed, 4.5);
        assert_eq!(trot(&c).period_scale, trot(&preset).period_scale * 0.5);
        assert_eq!((c.max_acceleration, c.swing_height, c.mpc_period), (15.0, 0.05, 0.02));
        assert_eq!(c.mode, ControlMode::Cheap);
        let bad = [
            (ControllerOverrides { rated_speed: Some(0.0), ..all }, "rated_speed"),
            (ControllerOverrides { period_scale: Some(5.0), ..all }, "period_scale"),
            (ControllerOverrides { max_acceleration: Some(f64::NAN), ..all }, "max_acceleration"),
            (ControllerOverrides { swing_height: Some(7.0), ..all }, "swing_height"),
            (ControllerOverrides { mpc_period: Some(60.0), ..all }, "mpc_period"),
            (ControllerOverrides { gait: Gait::Stand, ..all }, "rated_speed"),
            (ControllerOverrides { gait: Gait::Stand, rated_speed: None, ..all }, "period_scale"),
        ];
        for (o, part) in bad {
            let mut c = preset.clone();
            match o.apply(&mut c) {
                Err(HybridError::BadSetting { part: p, .. }) => assert_eq!(p, part, "{o:?}"),
                other => panic!("{o:?}: {other:?}"),
            }
            assert_eq!(format!("{c:?}"), format!("{preset:?}"));
        }
        assert_eq!(bad.len(), 7);
    }
}
