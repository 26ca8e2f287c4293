//! Motor-pump units, Eq. (5)-(8): dQ/dt + a Q = (eta_v D b_u) u_c - (eta_v D b_p) p,
//! with flows that cannot go negative (check valve) and the diagnosis effect terms
//! (drive dead time, flow-rate limit, flow ripple).

use crate::plant::Terms;
use crate::variables::Params;
use std::f64::consts::PI;

/// The two motor-pump units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Pump {
    /// The large, slow main pump (number 1: `Q1`, `uc1`, `a1`, ...).
    Main,
    /// The small, fast auxiliary pump (number 2: `Q2`, `uc2`, `a2`, ...).
    Aux,
}

impl Pump {
    /// Both pumps, main first (the order of every per-pump array).
    pub const BOTH: [Pump; 2] = [Pump::Main, Pump::Aux];

    /// The number in variable names and in the contract's `"pump"`: 1 main, 2 auxiliary.
    pub const fn number(self) -> u8 {
        match self {
            Pump::Main => 1,
            Pump::Aux => 2,
        }
    }

    /// Position in per-pump arrays `[main, auxiliary]`.
    pub const fn index(self) -> usize {
        match self {
            Pump::Main => 0,
            Pump::Aux => 1,
        }
    }

    /// The pump numbered `n` (1 or 2).
    pub const fn from_number(n: u8) -> Option<Pump> {
        match n {
            1 => Some(Pump::Main),
            2 => Some(Pump::Aux),
            _ => None,
        }
    }

    /// The name of a per-pump variable: `stem` and the pump's number (`"b_u"` -> `"b_u1"`).
    pub fn name(self, stem: &str) -> String {
        format!("{stem}{}", self.number())
    }

    /// The pump's flow signal, `Q1` or `Q2`.
    pub const fn flow(self) -> &'static str {
        match self {
            Pump::Main => "Q1",
            Pump::Aux => "Q2",
        }
    }

    /// The pump's drive-command signal, `uc1` or `uc2`.
    pub const fn drive(self) -> &'static str {
        match self {
            Pump::Main => "uc1",
            Pump::Aux => "uc2",
        }
    }
}

/// Q (1 + r sin(2 pi f t + phi)) (cold: the default pumps have no ripple).
#[cold]
#[inline(never)]
fn rippled(q: f64, r: f64, f: f64, phi: f64, t: f64) -> f64 {
    q * (1.0 + r * (2.0 * PI * f * t + phi).sin())
}

/// The pump's number, as in messages ("pump 2").
impl std::fmt::Display for Pump {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{}", self.number())
    }
}

/// The parameters of one motor-pump unit, borrowed from [`Params`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PumpParams {
    /// Equivalent damping coefficient a [1/s] (Eq. 5).
    pub a: f64,
    /// Flow gain per volt, eta_v D b_u [m^3/s^2/V] (Eq. 7).
    pub k_u: f64,
    /// Flow loss per pascal, eta_v D b_p [m^3/s^2/Pa] (Eq. 7).
    pub k_p: f64,
    /// Drive-command saturation [V].
    pub uc_max: f64,
    /// Dead time of the drive [s]: the main drive's own t_d1 plus the `pump_dead_time`
    /// effect's delay1 (pump 1), delay2 (pump 2).
    pub delay: f64,
    /// |dQ/dt| limit [m^3/s^2], 0 = none (effect `pump_flow_limit`).
    pub rate_limit: f64,
    /// Relative ripple amplitude, frequency [Hz] and phase [rad] (effect `flow_ripple`).
    pub ripple: (f64, f64, f64),
}

impl PumpParams {
    /// Both pumps' parameters, `[main, auxiliary]`.
    pub fn both(p: &Params) -> [PumpParams; 2] {
        Pump::BOTH.map(|pump| PumpParams::of(p, pump))
    }

    pub fn of(p: &Params, pump: Pump) -> PumpParams {
        match pump {
            Pump::Main => PumpParams {
                a: p.a1,
                k_u: p.eta_v1 * p.D1 * p.b_u1,
                k_p: p.eta_v1 * p.D1 * p.b_p1,
                uc_max: p.uc_max1,
                delay: p.t_d1 + p.delay1,
                rate_limit: p.rate_limit1,
                ripple: (p.ripple_amp1, p.ripple_freq1, p.ripple_phase1),
            },
            Pump::Aux => PumpParams {
                a: p.a2,
                k_u: p.eta_v2 * p.D2 * p.b_u2,
                k_p: p.eta_v2 * p.D2 * p.b_p2,
                uc_max: p.uc_max2,
                delay: p.delay2,
                rate_limit: p.rate_limit2,
                ripple: (p.ripple_amp2, p.ripple_freq2, p.ripple_phase2),
            },
        }
    }

    /// Drive command clamped to what the drive can apply, 0 <= u_c <= uc_max [V].
    #[inline]
    pub fn saturate(&self, uc: f64) -> f64 {
        uc.clamp(0.0, self.uc_max)
    }

    /// Flow rate dQ/dt [m^3/s^2] (Eq. 8), held at zero while a check valve blocks reverse flow.
    /// Inlined across crates: diagnose's pump replay calls it at every Runge-Kutta stage.
    #[inline]
    pub fn flow_rate(&self, q: f64, uc: f64, pressure: f64) -> f64 {
        let mut dq = -self.a * q + self.k_u * uc - self.k_p * pressure;
        if self.rate_limit > 0.0 {
            dq = dq.clamp(-self.rate_limit, self.rate_limit);
        }
        if q <= 0.0 && dq < 0.0 {
            0.0
        } else {
            dq
        }
    }

    /// Flow delivered to the chamber at time t: Q (1 + r sin(2 pi f t + phi)) [m^3/s].
    pub fn delivered(&self, q: f64, t: f64) -> f64 {
        self.delivered_with(q, t, Terms::Effects)
    }

    /// [`PumpParams::delivered`], with the ripple skipped for [`Terms::Plain`].
    #[inline(always)]
    pub fn delivered_with(&self, q: f64, t: f64, terms: Terms) -> f64 {
        let (r, f, phi) = self.ripple;
        if terms == Terms::Plain || r == 0.0 {
            q
        } else {
            rippled(q, r, f, phi, t)
        }
    }

    /// Steady flow for a constant command and pressure, (k_u u_c - k_p p)/a >= 0 [m^3/s].
    pub fn steady_flow(&self, uc: f64, pressure: f64) -> f64 {
        ((self.k_u * uc - self.k_p * pressure) / self.a).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pumps_are_numbered_as_in_the_variable_names() {
        for pump in Pump::BOTH {
            assert_eq!(Pump::from_number(pump.number()), Some(pump));
            assert_eq!(Pump::BOTH[pump.index()], pump);
            assert_eq!(pump.name("Q"), pump.flow());
            assert_eq!(pump.name("uc"), pump.drive());
        }
        assert_eq!(
            (Pump::Aux.name("b_u"), Pump::from_number(3)),
            ("b_u2".into(), None)
        );
        let p = Params::default();
        assert_eq!(PumpParams::of(&p, Pump::Aux).a, p.a2);
    }

    #[test]
    fn steady_state_of_eq8() {
        let pp = PumpParams::of(&Params::default(), Pump::Main);
        let q = pp.steady_flow(5.0, 4e6);
        assert!(pp.flow_rate(q, 5.0, 4e6).abs() < 1e-12);
    }

    #[test]
    fn flow_never_goes_negative_and_rate_limit_holds() {
        let mut p = Params::default();
        let pp = PumpParams::of(&p, Pump::Aux);
        assert_eq!(pp.flow_rate(0.0, 0.0, 5e6), 0.0);
        p.rate_limit2 = 1e-4;
        let pp = PumpParams::of(&p, Pump::Aux);
        assert_eq!(pp.flow_rate(0.0, 10.0, 0.0), 1e-4);
        assert_eq!(pp.saturate(12.0), 10.0);
        assert_eq!(pp.saturate(-1.0), 0.0);
    }
}
