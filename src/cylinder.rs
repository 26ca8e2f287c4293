//! Piston mechanics, Eq. (1)-(2): m dv/dt = A (p - p_t) - F_L - b v - F_c sgn(v), dx/dt = v,
//! with a stick model so that a piston at rest stays at rest until the driving force exceeds
//! the breakaway friction, and with the diagnosis effect terms (Stribeck friction,
//! pressure-dependent friction, position-dependent load).

use crate::plant::Terms;
use crate::variables::Params;

/// Whether the piston sticks or slides, and in which direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Motion {
    /// At rest; velocity held at exactly zero.
    Stuck,
    /// Sliding; the sign (+1 extend, -1 retract) is frozen over one solver step.
    Sliding(i8),
}

/// Hydraulic force on the piston, A (p - p_t) [N] (Eq. 1).
pub fn hydraulic_force(p: &Params, pressure: f64) -> f64 {
    p.A * (pressure - p.p_t)
}

/// External load with the position-dependent term, F_L + k_load x [N].
pub fn load_force(p: &Params, f_load: f64, x: f64) -> f64 {
    f_load + p.k_load * x
}

/// Friction force magnitude at speed |v| without the viscous part [N]:
/// F_c + (F_s - F_c) exp(-(|v|/v_s)^2) + mu A |p| (stribeck_friction, pressure_dependent_friction).
pub fn dry_friction(p: &Params, speed: f64, pressure: f64) -> f64 {
    dry_friction_with(p, speed, pressure, Terms::Effects)
}

/// [`dry_friction`], with the Stribeck and pressure terms skipped for [`Terms::Plain`]
/// (where mu = 0, so that the pressure term adds exactly zero).
#[inline(always)]
fn dry_friction_with(p: &Params, speed: f64, pressure: f64, terms: Terms) -> f64 {
    let peak = p.F_s - p.F_c;
    let stribeck = if terms == Terms::Effects && peak > 0.0 {
        stribeck_hump(peak, speed, p.v_s)
    } else {
        0.0
    };
    match terms {
        Terms::Effects => p.F_c + stribeck + p.mu * p.A * pressure.abs(),
        Terms::Plain => p.F_c + stribeck,
    }
}

/// The Stribeck term (F_s - F_c) exp(-(|v|/v_s)^2) [N]. Out of line and cold, like every
/// effect term the default plant does not use, so that the solver's default path keeps its
/// values in registers (see ARCHITECTURE.md, "Numerics").
#[cold]
#[inline(never)]
fn stribeck_hump(peak: f64, speed: f64, v_s: f64) -> f64 {
    peak * (-(speed / v_s).powi(2)).exp()
}

/// Total friction force opposing a motion of direction `dir` at velocity `v` [N] (Eq. 1).
pub fn friction(p: &Params, dir: f64, v: f64, pressure: f64) -> f64 {
    friction_with(p, dir, v, pressure, Terms::Effects)
}

#[inline(always)]
fn friction_with(p: &Params, dir: f64, v: f64, pressure: f64, terms: Terms) -> f64 {
    dir * dry_friction_with(p, v.abs(), pressure, terms) + p.b * v
}

/// Acceleration while sliding in direction `dir` [m/s^2] (Eq. 1).
pub fn acceleration(p: &Params, dir: f64, x: f64, v: f64, pressure: f64, f_load: f64) -> f64 {
    acceleration_with(p, dir, x, v, pressure, f_load, Terms::Effects)
}

/// [`acceleration`] with the terms of [`Terms`].
#[inline(always)]
pub(crate) fn acceleration_with(
    p: &Params,
    dir: f64,
    x: f64,
    v: f64,
    pressure: f64,
    f_load: f64,
    terms: Terms,
) -> f64 {
    let drive = hydraulic_force(p, pressure) - load_force(p, f_load, x);
    (drive - friction_with(p, dir, v, pressure, terms)) / p.m
}

/// Direction in which a stuck piston breaks away, or None if friction (or an end stop)
/// still holds it. Breakaway needs |drive| > F_c (or F_s) + mu A |p|.
pub fn breakaway(p: &Params, x: f64, pressure: f64, f_load: f64) -> Option<i8> {
    let drive = hydraulic_force(p, pressure) - load_force(p, f_load, x);
    let holding = dry_friction(p, 0.0, pressure);
    if drive > holding && x < p.x_max {
        Some(1)
    } else if drive < -holding && x > 0.0 {
        Some(-1)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn piston_holds_until_force_exceeds_coulomb_friction() {
        let p = Params::default();
        let f_load = 12_000.0;
        let p_hold = f_load / p.A;
        // 499 N of net drive is held by 500 N of Coulomb friction; 501 N is not.
        assert_eq!(breakaway(&p, 0.1, p_hold + 499.0 / p.A, f_load), None);
        assert_eq!(breakaway(&p, 0.1, p_hold + 501.0 / p.A, f_load), Some(1));
        assert_eq!(breakaway(&p, 0.1, p_hold - 501.0 / p.A, f_load), Some(-1));
        // At the retracted end stop a retracting force is taken by the stop.
        assert_eq!(breakaway(&p, 0.0, 0.0, f_load), None);
    }

    #[test]
    fn steady_sliding_force_balance() {
        // At constant v the pressure balances load, Coulomb and viscous friction (Eq. 1).
        let p = Params::default();
        let v = 0.05;
        let pressure = (12_000.0 + p.F_c + p.b * v) / p.A;
        assert!(acceleration(&p, 1.0, 0.2, v, pressure, 12_000.0).abs() < 1e-9);
    }

    #[test]
    fn stribeck_peak_only_near_zero_speed() {
        let p = Params {
            F_s: 800.0,
            ..Params::default()
        };
        assert!((dry_friction(&p, 0.0, 0.0) - 800.0).abs() < 1e-9);
        assert!((dry_friction(&p, 10.0 * p.v_s, 0.0) - p.F_c).abs() < 1e-6);
    }
}
