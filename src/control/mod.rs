//! The dual-pump controller, sampled at 1 kHz like a bench controller (section 3):
//! the target flow, its split between the pumps by scheme, and the inner flow loops.

pub mod adaptive;
pub mod adrc;
pub mod pid;

use crate::pump::Pump;
use crate::variables::{Controller, MainCommand, Params, PidForm, Scheme};
use adaptive::AdaptiveLaw;
use adrc::{Adrc, AdrcGains};
use pid::{Pid, PidGains};

/// m^3/s to L/min, the flow unit of the inner flow loops (PID and ADRC gains).
pub use crate::units::LPM;

/// Controller sample period [s] (1 kHz).
pub const CONTROL_PERIOD: f64 = 1e-3;

/// What the controller measures at a sample (SI).
#[derive(Clone, Copy, Debug)]
pub struct Measurement {
    pub x: f64,
    pub v: f64,
    /// Measured pump flows [m^3/s].
    pub q: [f64; 2],
    pub x_ref: f64,
    pub v_ref: f64,
}

/// State of the dual-pump controller.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DualPumpController {
    pid: [Pid; 2],
    adrc: [Adrc; 2],
    pub law: AdaptiveLaw,
    /// Commanded pump flows u1, u2 [m^3/s].
    pub u: [f64; 2],
    /// Motor drive commands uc1, uc2 [V].
    pub uc: [f64; 2],
}

/// Target flow: the reference flow A v_ref plus a proportional position correction,
/// A (v_ref + K_pos e_x) [m^3/s] (ARCHITECTURE.md, "Main-pump command").
pub fn target_flow(p: &Params, m: &Measurement) -> f64 {
    p.A * (m.v_ref + p.K_pos * (m.x_ref - m.x))
}

/// Flow commands u1, u2 [m^3/s] of each scheme. In the adaptive scheme the main pump tracks
/// the reference flow A v_ref and the auxiliary pump alone answers the tracking error
/// (Table 1), unless `main_command = target`.
fn split(p: &Params, law: &mut AdaptiveLaw, m: &Measurement, ts: f64) -> [f64; 2] {
    let target = target_flow(p, m).max(0.0);
    match p.scheme {
        Scheme::Single => [target, 0.0],
        Scheme::FixedSplit => [p.split_main * target, (1.0 - p.split_main) * target],
        Scheme::Adaptive => {
            let u1 = match p.main_command {
                MainCommand::Reference => (p.A * m.v_ref).max(0.0),
                MainCommand::Target => target,
            };
            let (e_x, e_v) = (m.x_ref - m.x, m.v_ref - m.v);
            [u1, law.command(p, e_x, e_v, m.v_ref, u1, ts)]
        }
    }
}

impl DualPumpController {
    pub fn new(p: &Params) -> Self {
        DualPumpController {
            pid: Default::default(),
            adrc: Default::default(),
            law: AdaptiveLaw::new(p),
            u: [0.0; 2],
            uc: [0.0; 2],
        }
    }

    /// One controller sample: updates u and uc from the measurement.
    pub fn sample(&mut self, p: &Params, m: &Measurement, ts: f64) {
        self.u = split(p, &mut self.law, m, ts);
        let uc_max = [p.uc_max1, p.uc_max2];
        for pump in Pump::BOTH {
            let (i, limit) = (pump.index(), uc_max[pump.index()]);
            let (reference, measured) = (self.u[i] * LPM, m.q[i] * LPM);
            self.uc[i] = match p.controller {
                Controller::Pid => {
                    let error = reference - measured;
                    self.pid[i].update(pid_gains(p, pump), error, ts, p.tau_d, limit)
                }
                Controller::Adrc => {
                    self.adrc[i].update(adrc_gains(p, pump), reference, measured, ts, limit)
                }
            };
        }
    }
}

fn pid_gains(p: &Params, pump: Pump) -> PidGains {
    let per_sample = p.pid_form == PidForm::PerSample;
    match pump {
        Pump::Main => PidGains {
            kp: p.Kp1,
            ki: p.Ki1,
            kd: p.Kd1,
            per_sample,
        },
        Pump::Aux => PidGains {
            kp: p.Kp2,
            ki: p.Ki2,
            kd: p.Kd2,
            per_sample,
        },
    }
}

fn adrc_gains(p: &Params, pump: Pump) -> AdrcGains {
    match pump {
        Pump::Main => AdrcGains {
            wc: p.wc1,
            beta1: p.beta1_1,
            beta2: p.beta2_1,
            b0: p.b0_1,
        },
        Pump::Aux => AdrcGains {
            wc: p.wc2,
            beta1: p.beta1_2,
            beta2: p.beta2_2,
            b0: p.b0_2,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meas(e_x: f64) -> Measurement {
        Measurement {
            x: 0.1,
            v: 0.05,
            q: [0.0; 2],
            x_ref: 0.1 + e_x,
            v_ref: 0.05,
        }
    }

    #[test]
    fn schemes_split_the_target_flow() {
        let mut p = Params::default();
        let m = meas(0.001);
        let target = target_flow(&p, &m);
        assert!((target - p.A * (0.05 + p.K_pos * 0.001)).abs() < 1e-15);
        p.scheme = Scheme::Single;
        let mut c = DualPumpController::new(&p);
        c.sample(&p, &m, CONTROL_PERIOD);
        assert_eq!(c.u, [target, 0.0]);
        p.scheme = Scheme::FixedSplit;
        c.sample(&p, &m, CONTROL_PERIOD);
        assert!((c.u[0] - 0.6 * target).abs() < 1e-15 && (c.u[1] - 0.4 * target).abs() < 1e-15);
        p.scheme = Scheme::Adaptive;
        p.main_command = MainCommand::Target;
        c.sample(&p, &m, CONTROL_PERIOD);
        assert_eq!(c.u[0], target);
        assert!(c.u[1] > 0.0 && c.u[1] <= target);
        p.main_command = MainCommand::Reference;
        c.sample(&p, &m, CONTROL_PERIOD);
        assert_eq!(c.u[0], p.A * 0.05);
        assert!(c.u[1] > 0.0 && c.u[1] <= c.u[0]);
    }
}
