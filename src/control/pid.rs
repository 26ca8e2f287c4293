//! Discrete PID flow controller of one pump (section 3.3), with conditional-integration
//! anti-windup and a first-order filtered derivative.
//!
//! Units (ARCHITECTURE.md, "Units of the paper's gains"): the flow error is taken in L/min
//! and the gains give millivolts, so the printed Kp1 = 800 means 0.8 V per L/min. In the
//! `per_second` form (the chosen reading, docs/reproduce.md) Ki and Kd are per second. In the
//! `per_sample` form the controller is the textbook discrete PID of a 1 kHz bench controller,
//! u_k = Kp e_k + Ki sum_j e_j + Kd (e_k - e_{k-1}): Ki1 = 0.10 per sample is 100 mV per
//! (L/min s), an integral time Kp1/Ki1 of 8000 samples = 8 s.

/// PID gains in the paper's units with the sample period and the derivative filter in the
/// form's unit of time, computed once per parameter set ([`PidGains::new`]) instead of at
/// every sample: Kp [mV/(L/min)]; per sample, Ki [mV/(L/min) per sample] and
/// Kd [mV/(L/min) per sample difference]; per second, Ki [mV/(L/min s)] and Kd [mV s/(L/min)].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidGains {
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
    /// Sample period in the form's unit of time: ts [s] per second, 1 per sample.
    dt: f64,
    /// Coefficient dt / (tau_d + dt) of the derivative's first-order filter.
    filter: f64,
}

impl PidGains {
    /// Gains of a controller sampled every `ts` [s] with derivative filter time constant
    /// `tau_d` [s], the integral and derivative counted in samples (`per_sample`) or in seconds.
    pub fn new(kp: f64, ki: f64, kd: f64, per_sample: bool, ts: f64, tau_d: f64) -> Self {
        // Per sample, the sum and the difference are those of a 1 kHz controller, i.e. the
        // per-second forms with the sample period taken as the unit of time.
        let dt = if per_sample { 1.0 } else { ts };
        let tau_d = if per_sample {
            tau_d / CONTROL_PERIOD
        } else {
            tau_d
        };
        PidGains {
            kp,
            ki,
            kd,
            dt,
            filter: dt / (tau_d + dt),
        }
    }
}

/// The controller's memory.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Pid {
    /// Integral of the flow error [L/min s].
    integral: f64,
    /// Filtered derivative of the flow error [L/min/s].
    derivative: f64,
    previous_error: Option<f64>,
}

const MV: f64 = 1e-3;

use super::CONTROL_PERIOD;

impl Pid {
    /// One controller sample: flow error [L/min] -> drive command [V] within [0, uc_max].
    #[inline(always)]
    pub fn update(&mut self, g: &PidGains, error: f64, uc_max: f64) -> f64 {
        let dt = g.dt;
        let raw_d = self.previous_error.map_or(0.0, |e0| (error - e0) / dt);
        self.previous_error = Some(error);
        self.derivative += g.filter * (raw_d - self.derivative);
        let output = |integral: f64| MV * (g.kp * error + g.ki * integral + g.kd * self.derivative);
        // Conditional integration: the error is integrated unless the output it gives is
        // saturated in the error's direction (then the output of the held integral applies).
        let integrated = self.integral + error * dt;
        let unclamped = output(integrated);
        let saturated_high = unclamped >= uc_max && error > 0.0;
        let saturated_low = unclamped <= 0.0 && error < 0.0;
        let command = if saturated_high || saturated_low {
            output(self.integral)
        } else {
            self.integral = integrated;
            unclamped
        };
        command.clamp(0.0, uc_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proportional_action_in_millivolts_per_lpm() {
        let mut pid = Pid::default();
        let g = PidGains::new(800.0, 0.0, 0.0, false, 1e-3, 0.01);
        assert!((pid.update(&g, 2.0, 10.0) - 1.6).abs() < 1e-12);
    }

    #[test]
    fn per_sample_gains_are_per_second_gains_times_the_sample_rate() {
        let (mut a, mut b) = (Pid::default(), Pid::default());
        let per_sample = PidGains::new(800.0, 0.1, 0.001, true, 1e-3, 0.01);
        let per_second = PidGains::new(800.0, 0.1 / 1e-3, 0.001 * 1e-3, false, 1e-3, 0.01);
        for k in 0..2000 {
            let e = 0.5 + (k as f64 * 0.01).sin();
            let (ua, ub) = (
                a.update(&per_sample, e, 10.0),
                b.update(&per_second, e, 10.0),
            );
            assert!((ua - ub).abs() < 1e-9, "sample {k}: {ua} vs {ub}");
        }
    }

    #[test]
    fn integrator_does_not_wind_up_in_saturation() {
        let mut pid = Pid::default();
        let g = PidGains::new(800.0, 1000.0, 0.0, false, 1e-3, 0.01);
        for _ in 0..10_000 {
            assert_eq!(pid.update(&g, 100.0, 10.0), 10.0);
        }
        // Once the error reverses, the output leaves saturation at once.
        assert!(pid.update(&g, -1.0, 10.0) < 10.0);
    }
}
