//! Working-chamber pressure, Eq. (3)-(4):
//! dp/dt = beta_e / (V0 + s_dir A x) (Q1 + Q2 - A v - C_ip (p - p_t) - Q_rel(p)), s_dir = +1,
//! with the relief valve Q_rel = K_relief max(0, p - p_crack) and the entrained-air
//! effective bulk modulus (effect `entrained_air`).

use crate::plant::Terms;
use crate::variables::Params;

/// Atmospheric pressure [Pa].
pub const P_ATM: f64 = 101_325.0;
/// Polytropic index of entrained air.
pub const AIR_POLYTROPIC: f64 = 1.4;
/// Lowest gauge pressure the chamber can reach (vapour pressure) [Pa].
pub const P_MIN: f64 = -0.95 * P_ATM;

/// Chamber volume V = V0 + s_dir A x [m^3] (Eq. 3).
pub fn volume(p: &Params, x: f64) -> f64 {
    p.V0 + p.A * x
}

/// Effective bulk modulus [Pa]: beta_e, or with entrained air
/// 1/((1-th)/beta_e + th/(n P)), th = a (p0/P)^(1/n) / ((1-a) + a (p0/P)^(1/n)), P = p + p0.
pub fn bulk_modulus(p: &Params, pressure: f64) -> f64 {
    bulk_modulus_with(p, pressure, Terms::Effects)
}

/// [`bulk_modulus`], with the air term skipped for [`Terms::Plain`].
#[inline(always)]
fn bulk_modulus_with(p: &Params, pressure: f64, terms: Terms) -> f64 {
    if terms == Terms::Plain || p.air_fraction <= 0.0 {
        p.beta_e
    } else {
        with_air(p, pressure)
    }
}

/// The bulk modulus with entrained air (cold: the default plant has none).
#[cold]
#[inline(never)]
fn with_air(p: &Params, pressure: f64) -> f64 {
    let abs_p = (pressure + P_ATM).max(0.05 * P_ATM);
    let a = p.air_fraction;
    let expanded = a * (P_ATM / abs_p).powf(1.0 / AIR_POLYTROPIC);
    let theta = expanded / ((1.0 - a) + expanded);
    1.0 / ((1.0 - theta) / p.beta_e + theta / (AIR_POLYTROPIC * abs_p))
}

/// Leakage from the working chamber, C_ip (p - p_t) [m^3/s] (Eq. 4).
pub fn leakage(p: &Params, pressure: f64) -> f64 {
    p.C_ip * (pressure - p.p_t)
}

/// Relief-valve flow, K_relief max(0, p - p_crack) [m^3/s] (Eq. 4).
pub fn relief_flow(p: &Params, pressure: f64) -> f64 {
    p.K_relief * (pressure - p.p_crack).max(0.0)
}

/// Pressure rate dp/dt [Pa/s] for the total pump flow into the chamber (Eq. 4).
pub fn pressure_rate(p: &Params, pressure: f64, x: f64, v: f64, pump_flow: f64) -> f64 {
    pressure_rate_with(p, pressure, x, v, pump_flow, Terms::Effects)
}

/// [`pressure_rate`] with the terms of [`Terms`].
#[inline(always)]
pub(crate) fn pressure_rate_with(
    p: &Params,
    pressure: f64,
    x: f64,
    v: f64,
    pump_flow: f64,
    terms: Terms,
) -> f64 {
    let net = pump_flow - p.A * v - leakage(p, pressure) - relief_flow(p, pressure);
    bulk_modulus_with(p, pressure, terms) / volume(p, x) * net
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flow_balance_gives_steady_pressure() {
        // Pump flow = piston flow + leakage -> dp/dt = 0.
        let p = Params::default();
        let (pressure, v) = (4.0e6, 0.05);
        let q = p.A * v + p.C_ip * pressure;
        assert!(pressure_rate(&p, pressure, 0.3, v, q).abs() < 1e-6);
        // 1e-6 m^3/s surplus into V0 raises p by beta_e/V0 * 1e-6.
        let r = pressure_rate(&p, pressure, 0.0, v, q + 1e-6);
        assert!((r - p.beta_e / p.V0 * 1e-6).abs() < 1e-3 * r);
    }

    #[test]
    fn relief_opens_above_cracking_only() {
        let p = Params::default();
        assert_eq!(relief_flow(&p, p.p_crack - 1.0), 0.0);
        assert!((relief_flow(&p, p.p_crack + 1e5) - p.K_relief * 1e5).abs() < 1e-18);
    }

    #[test]
    fn entrained_air_softens_oil_at_low_pressure() {
        let p = Params {
            air_fraction: 0.01,
            ..Params::default()
        };
        let low = bulk_modulus(&p, 0.5e6);
        let high = bulk_modulus(&p, 10e6);
        assert!(
            low < 0.5 * p.beta_e && high < p.beta_e && high > 0.9 * p.beta_e,
            "{low} {high}"
        );
    }
}
