//! PyBullet's DC motor model (`motor.py`).

/// PyBullet's DC motor model (`motor.py`), per motor, in the motor frame.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MotorModel {
    /// Position gain on PWM (1/rad) (default: 1.0).
    pub kp: f64,
    /// Velocity gain on PWM (s/rad) (default: 0.02).
    pub kd: f64,
    /// Battery voltage (V) (default: 16.0).
    pub voltage: f64,
    /// Winding resistance (Ω) (default: 0.186).
    pub resistance: f64,
    /// Torque constant (N·m/A) (default: 0.0954).
    pub torque_constant: f64,
    /// Viscous damping (N·m·s/rad), added to the back-EMF constant (default: 0).
    pub viscous_damping: f64,
    /// Scale of the produced torque, for motor-strength randomisation (default: 1.0).
    pub strength: f64,
}

impl Default for MotorModel {
    fn default() -> Self {
        MotorModel {
            kp: 1.0,
            kd: 0.02,
            voltage: 16.0,
            resistance: 0.186,
            torque_constant: 0.0954,
            viscous_damping: 0.0,
            strength: 1.0,
        }
    }
}

/// Torque the "sensor" reports is clipped here (N·m).
pub const OBSERVED_TORQUE_LIMIT: f64 = 5.7;
/// Diode clipping of the net voltage (V).
const VOLTAGE_CLIPPING: f64 = 50.0;
const CURRENT_TABLE: [f64; 7] = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0];
const TORQUE_TABLE: [f64; 7] = [0.0, 1.0, 1.9, 2.45, 3.0, 3.25, 3.5];

impl MotorModel {
    /// Position control: `pwm = clip(−kp (q − q*) − kd q̇, −1, 1)`, then
    /// [`MotorModel::torque_from_pwm`]. Returns `(actual, observed)` torques.
    pub fn torque(&self, q_des: f64, q: f64, qd: f64) -> (f64, f64) {
        let pwm = (-self.kp * (q - q_des) - self.kd * qd).clamp(-1.0, 1.0);
        self.torque_from_pwm(pwm, qd)
    }

    /// `observed = clip(Kt·pwm·V/R, ±5.7)`; `V_net = clip(pwm V − (Kt + b) q̇, ±50)`;
    /// `I = V_net / R`; `actual = sign(I) · interp(|I|, current table, torque table)`.
    pub fn torque_from_pwm(&self, pwm: f64, qd: f64) -> (f64, f64) {
        let observed = (self.torque_constant * pwm * self.voltage / self.resistance)
            .clamp(-OBSERVED_TORQUE_LIMIT, OBSERVED_TORQUE_LIMIT);
        let v_net = (pwm * self.voltage - (self.torque_constant + self.viscous_damping) * qd)
            .clamp(-VOLTAGE_CLIPPING, VOLTAGE_CLIPPING);
        let current = v_net / self.resistance;
        let actual = current.signum() * interp(current.abs(), &CURRENT_TABLE, &TORQUE_TABLE);
        (actual * self.strength, observed)
    }
}

impl MotorModel {
    /// The PWM that produces the actual torque `tau` (motor frame) at motor velocity `qd`:
    /// the torque table inverted to a current, then `pwm = (I R + (Kt + b) q̇) / V`, clipped
    /// to [−1, 1] (torques beyond the table's 3.5 N·m saturate).
    pub fn pwm_for_torque(&self, tau: f64, qd: f64) -> f64 {
        let t = (tau / self.strength).abs().min(TORQUE_TABLE[TORQUE_TABLE.len() - 1]);
        let current = tau.signum() * interp(t, &TORQUE_TABLE, &CURRENT_TABLE);
        ((current * self.resistance + (self.torque_constant + self.viscous_damping) * qd) / self.voltage)
            .clamp(-1.0, 1.0)
    }

    /// The desired motor angle whose position control produces `tau` at `(q, qd)`:
    /// `q* = q + (pwm + kd q̇) / kp`.
    pub fn angle_for_torque(&self, tau: f64, q: f64, qd: f64) -> f64 {
        q + (self.pwm_for_torque(tau, qd) + self.kd * qd) / self.kp
    }
}

/// Piecewise-linear interpolation, clamped at the ends (numpy's `interp`).
fn interp(x: f64, xs: &[f64], ys: &[f64]) -> f64 {
    if x <= xs[0] {
        return ys[0];
    }
    for k in 1..xs.len() {
        if x <= xs[k] {
            let t = (x - xs[k - 1]) / (xs[k] - xs[k - 1]);
            return ys[k - 1] + t * (ys[k] - ys[k - 1]);
        }
    }
    ys[ys.len() - 1]
}
