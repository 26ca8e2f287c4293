//! Adaptive compensation law of the auxiliary pump, section 3.1, Eq. (14)-(26).
//!
//! Units (ARCHITECTURE.md, "Units of the paper's gains"): the errors are taken in the
//! bench's units, mm, mm/s and mm/s^2 (also in e_total, Eq. 23); the displacement channel
//! gives L/s and the velocity and acceleration channels L/min, so Table 5's k_x0 = 0.25 is
//! 0.25 (L/s)/mm = 0.25 m^2/s, k_v0 = 0.22 (L/min)/(mm/s) = 1.15 A and
//! k_a0 = 0.02 (L/min)/(mm/s^2) = 0.10 s A.

use crate::units::LPM;
use crate::variables::Params;

/// Metres to the law's length unit (mm).
pub const LENGTH_UNIT: f64 = 1e3;
/// Flow unit of the displacement, velocity and acceleration channels of Eq. (19) in m^3/s:
/// L/s, L/min, L/min.
pub const CHANNEL_FLOW: [f64; 3] = [1e-3, 1.0 / LPM, 1.0 / LPM];

/// Error features of one sample, in the law's units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Errors {
    /// e_x = x_ref - x (Eq. 14).
    pub x: f64,
    /// e_v = v_ref - v (Eq. 15).
    pub v: f64,
    /// e_a = d e_v / dt (Eq. 16), filtered.
    pub a: f64,
    /// High-frequency part of e_v (Eq. 18).
    pub v_hp: f64,
}

/// The law's parameters at its sample period, with the parameter-only coefficients computed
/// once per parameter set ([`LawSettings::new`]) instead of at every sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LawSettings {
    /// Sample period ts [s].
    ts: f64,
    /// ts / (tau_d + ts): coefficient of the velocity and acceleration error filters.
    filter: f64,
    /// ts / eta_p: coefficient of the low-pass of Eq. (17).
    low_pass: f64,
    /// ts / tau_sw: relaxation of the micro-gating factor per sample, Eq. (24).
    relax: f64,
    /// Learning rates Gamma, leakages sigma and nominal gains k0 of k_x, k_v, k_a (Eq. 20-22).
    gamma: [f64; 3],
    sigma: [f64; 3],
    k0: [f64; 3],
    /// eps_total of Eq. (23).
    eps_total: f64,
    /// Relative target-speed change that gates, and the gate's floor (Eq. 24).
    sw_threshold: f64,
    g_min: f64,
}

impl LawSettings {
    pub fn new(p: &Params, ts: f64) -> Self {
        LawSettings {
            ts,
            filter: ts / (p.tau_d + ts),
            low_pass: ts / p.eta_p,
            relax: ts / p.tau_sw,
            gamma: [p.Gamma_x, p.Gamma_v, p.Gamma_a],
            sigma: [p.sigma_x, p.sigma_v, p.sigma_a],
            k0: [p.k_x0, p.k_v0, p.k_a0],
            eps_total: p.eps_total,
            sw_threshold: p.sw_threshold,
            g_min: p.g_min,
        }
    }
}

/// The law's memory: gains, filters and micro-gating.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AdaptiveLaw {
    /// Gains k_x, k_v, k_a (Eq. 20-22).
    pub k: [f64; 3],
    /// Low-frequency velocity error e_v_lp (Eq. 17).
    e_v_lp: f64,
    /// Filtered velocity error (the bench differentiates the LVDT, then filters) [mm/s].
    e_v: f64,
    /// Filtered acceleration error and the previous velocity error.
    e_a: f64,
    e_v_prev: Option<f64>,
    /// Micro-gating factor (Eq. 24) and the target speed it last reacted to.
    pub g_sw: f64,
    v_hold: f64,
}

impl AdaptiveLaw {
    pub fn new(p: &Params) -> Self {
        AdaptiveLaw {
            k: [p.k_x0, p.k_v0, p.k_a0],
            e_v_lp: 0.0,
            e_v: 0.0,
            e_a: 0.0,
            e_v_prev: None,
            g_sw: 1.0,
            v_hold: 0.0,
        }
    }

    /// Error features from SI errors e_x [m], e_v [m/s] (Eq. 14-18).
    pub fn errors(&mut self, s: &LawSettings, e_x: f64, e_v: f64) -> Errors {
        let ex = e_x * LENGTH_UNIT;
        self.e_v += s.filter * (e_v * LENGTH_UNIT - self.e_v);
        let ev = self.e_v;
        let raw_a = self.e_v_prev.map_or(0.0, |e0| (ev - e0) / s.ts);
        self.e_v_prev = Some(ev);
        self.e_a += s.filter * (raw_a - self.e_a);
        // Eq. (17): first-order low-pass with time constant eta_p; Eq. (18): e_v_hp = e_v - e_v_lp.
        self.e_v_lp += s.low_pass * (ev - self.e_v_lp);
        Errors {
            x: ex,
            v: ev,
            a: self.e_a,
            v_hp: ev - self.e_v_lp,
        }
    }

    /// Gain update, Eq. (20)-(23).
    pub fn update_gains(&mut self, s: &LawSettings, e: &Errors) {
        let e_total = s.eps_total + e.x * e.x + e.v * e.v + e.a * e.a; // Eq. (23)
        let feature = [e.x, e.v, e.a];
        let ts = s.ts;
        for (i, (k, f)) in self.k.iter_mut().zip(feature).enumerate() {
            *k += s.gamma[i] * f * e.v_hp / e_total * ts - s.sigma[i] * (*k - s.k0[i]) * ts;
        }
    }

    /// Micro-gating, Eq. (24): drops to g_min when the target speed changes by more than
    /// sw_threshold (20 %) and relaxes towards 1 with time constant tau_sw.
    pub fn gate(&mut self, s: &LawSettings, v_ref: f64) -> f64 {
        let change = (v_ref - self.v_hold).abs();
        if change > s.sw_threshold * self.v_hold.abs() && change > f64::EPSILON {
            self.g_sw = s.g_min;
            self.v_hold = v_ref;
        } else {
            self.g_sw += s.relax * (1.0 - self.g_sw);
        }
        self.g_sw
    }

    /// One sample of the law: the auxiliary-pump flow command u2 [m^3/s] (Eq. 19, 25, 26),
    /// limited to 0 <= u2 <= u1.
    #[inline(always)]
    pub fn command(&mut self, s: &LawSettings, e_x: f64, e_v: f64, v_ref: f64, u1: f64) -> f64 {
        let e = self.errors(s, e_x, e_v);
        let channels = [e.x, e.v_hp, e.a];
        let u2_ref: f64 = (0..3)
            .map(|i| self.k[i] * channels[i] * CHANNEL_FLOW[i])
            .sum(); // Eq. (19), m^3/s
        self.update_gains(s, &e);
        let g = self.gate(s, v_ref);
        (g * u2_ref).clamp(0.0, u1.max(0.0)) // Eq. (25)-(26)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gain_update_matches_a_hand_computation() {
        let p = Params::default();
        let mut law = AdaptiveLaw::new(&p);
        law.k = [0.3, 0.2, 0.05];
        let e = Errors {
            x: 2.0,
            v: 10.0,
            a: 50.0,
            v_hp: 4.0,
        };
        let ts = 1e-3;
        law.update_gains(&LawSettings::new(&p, ts), &e);
        let e_total = 1.0 + 4.0 + 100.0 + 2500.0;
        let kx = 0.3 + 5.2 * 2.0 * 4.0 / e_total * ts - 0.28 * (0.3 - 0.25) * ts;
        let kv = 0.2 + 4.0 * 10.0 * 4.0 / e_total * ts - 0.22 * (0.2 - 0.22) * ts;
        let ka = 0.05 + 0.8 * 50.0 * 4.0 / e_total * ts - 0.10 * (0.05 - 0.02) * ts;
        for (got, want) in law.k.iter().zip([kx, kv, ka]) {
            assert!((got - want).abs() < 1e-15, "{got} vs {want}");
        }
    }

    #[test]
    fn micro_gating_drops_on_speed_change_and_relaxes() {
        let p = Params::default();
        let (mut law, s) = (AdaptiveLaw::new(&p), LawSettings::new(&p, 1e-3));
        assert_eq!(law.gate(&s, 0.05), 0.75); // start from rest: a step change
        let mut g = 0.0;
        for _ in 0..150 {
            g = law.gate(&s, 0.05);
        }
        // After one time constant: 1 - 0.25 (1 - 1/150)^150 ~ 1 - 0.25 e^-1.
        assert!((g - (1.0 - 0.25 * (1.0f64 - 1.0 / 150.0).powi(150))).abs() < 1e-12);
        assert!(law.gate(&s, 0.055) > 0.9, "a 10 % change does not gate");
        assert_eq!(law.gate(&s, 0.07), 0.75, "a 40 % change gates");
    }

    #[test]
    fn command_is_limited_to_main_pump_command() {
        let p = Params::default();
        let (mut law, s) = (AdaptiveLaw::new(&p), LawSettings::new(&p, 1e-3));
        let u1 = 1e-4;
        assert_eq!(law.command(&s, 0.1, 0.5, 0.05, u1), u1);
        assert_eq!(law.command(&s, -0.1, -0.5, 0.05, u1), 0.0);
    }
}
