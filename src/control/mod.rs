//! The dual-pump controller, sampled at 1 kHz like a bench controller (section 3):
//! the target flow, its split between the pumps by scheme, and the inner flow loops.

pub mod adaptive;
pub mod adrc;
pub mod pid;

use crate::pump::Pump;
use crate::variables::{Controller, MainCommand, Params, PidForm, Scheme};
use adaptive::{AdaptiveLaw, LawSettings};
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

/// The controller's parameters at its sample period, gathered by pump and with the
/// parameter-only coefficients (filters, Eq. 17, Eq. 24) computed once per parameter set
/// instead of at every sample. Built from the parameters held over a communication step
/// (`Simulator::advance`), so a parameter set between steps takes effect at the next one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    pid: [PidGains; 2],
    adrc: [AdrcGains; 2],
    law: LawSettings,
    /// Drive command limits uc_max1, uc_max2 [V].
    uc_max: [f64; 2],
}

impl Settings {
    /// Settings of a controller sampled every `ts` [s].
    pub fn new(p: &Params, ts: f64) -> Self {
        Settings {
            pid: Pump::BOTH.map(|pump| pid_gains(p, pump, ts)),
            adrc: Pump::BOTH.map(|pump| adrc_gains(p, pump, ts)),
            law: LawSettings::new(p, ts),
            uc_max: [p.uc_max1, p.uc_max2],
        }
    }
}

/// Target flow: the reference flow A v_ref plus a proportional position correction,
/// A (v_ref + K_pos e_x) [m^3/s] (ARCHITECTURE.md, "Main-pump command").
pub fn target_flow(p: &Params, m: &Measurement) -> f64 {
    p.A * (m.v_ref + p.K_pos * (m.x_ref - m.x))
}

/// Flow commands u1, u2 [m^3/s] of each scheme. In the adaptive scheme the main pump tracks
/// the reference flow A v_ref and the auxiliary pump alone answers the tracking error
/// (Table 1), unless `main_command = target`.
fn split(p: &Params, law: &mut AdaptiveLaw, s: &LawSettings, m: &Measurement) -> [f64; 2] {
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
            [u1, law.command(s, e_x, e_v, m.v_ref, u1)]
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
    pub fn sample(&mut self, p: &Params, s: &Settings, m: &Measurement) {
        self.u = split(p, &mut self.law, &s.law, m);
        for i in Pump::BOTH.map(Pump::index) {
            let (reference, measured, limit) = (self.u[i] * LPM, m.q[i] * LPM, s.uc_max[i]);
            self.uc[i] = match p.controller {
                Controller::Pid => self.pid[i].update(&s.pid[i], reference - measured, limit),
                Controller::Adrc => self.adrc[i].update(s.adrc[i], reference, measured, limit),
            };
        }
    }
}

fn pid_gains(p: &Params, pump: Pump, ts: f64) -> PidGains {
    let per_sample = p.pid_form == PidForm::PerSample;
    match pump {
        Pump::Main => PidGains::new(p.Kp1, p.Ki1, p.Kd1, per_sample, ts, p.tau_d),
        Pump::Aux => PidGains::new(p.Kp2, p.Ki2, p.Kd2, per_sample, ts, p.tau_d),
    }
}

fn adrc_gains(p: &Params, pump: Pump, ts: f64) -> AdrcGains {
    match pump {
        Pump::Main => AdrcGains {
            wc: p.wc1,
            beta1: p.beta1_1,
            beta2: p.beta2_1,
            b0: p.b0_1,
            ts,
        },
        Pump::Aux => AdrcGains {
            wc: p.wc2,
            beta1: p.beta1_2,
            beta2: p.beta2_2,
            b0: p.b0_2,
            ts,
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
        c.sample(&p, &Settings::new(&p, CONTROL_PERIOD), &m);
        assert_eq!(c.u, [target, 0.0]);
        p.scheme = Scheme::FixedSplit;
        c.sample(&p, &Settings::new(&p, CONTROL_PERIOD), &m);
        assert!((c.u[0] - 0.6 * target).abs() < 1e-15 && (c.u[1] - 0.4 * target).abs() < 1e-15);
        p.scheme = Scheme::Adaptive;
        p.main_command = MainCommand::Target;
        c.sample(&p, &Settings::new(&p, CONTROL_PERIOD), &m);
        assert_eq!(c.u[0], target);
        assert!(c.u[1] > 0.0 && c.u[1] <= target);
        p.main_command = MainCommand::Reference;
        c.sample(&p, &Settings::new(&p, CONTROL_PERIOD), &m);
        assert_eq!(c.u[0], p.A * 0.05);
        assert!(c.u[1] > 0.0 && c.u[1] <= c.u[0]);
    }
}
