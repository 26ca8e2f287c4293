//! Linear ADRC flow controller of one pump (section 4.2, Table 8): a second-order extended
//! state observer of the first-order pump (Eq. 8) estimates the flow z1 and the total
//! disturbance z2; the control law cancels z2 and places the loop at the control bandwidth.
//!
//! Units: flow in L/min, time in s, command in V, so the printed estimated input gains
//! b0 = 58.5 and 37.5 are in (L/min)/s per V.

/// ADRC settings of one pump (Table 8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdrcGains {
    /// Control bandwidth [rad/s].
    pub wc: f64,
    /// ESO gains [1/s], [1/s^2].
    pub beta1: f64,
    pub beta2: f64,
    /// Estimated input gain [(L/min)/s per V].
    pub b0: f64,
    /// Sample period [s].
    pub ts: f64,
}

/// Observer states and the last applied command.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Adrc {
    /// Estimated flow [L/min].
    z1: f64,
    /// Estimated total disturbance [(L/min)/s].
    z2: f64,
    /// Last command actually applied [V].
    u: f64,
}

impl Adrc {
    /// One sample: reference and measured flow [L/min] -> drive command [V] in [0, uc_max].
    pub fn update(&mut self, g: AdrcGains, reference: f64, measured: f64, uc_max: f64) -> f64 {
        let ts = g.ts;
        let e = self.z1 - measured;
        self.z1 += ts * (self.z2 + g.b0 * self.u - g.beta1 * e);
        self.z2 += ts * (-g.beta2 * e);
        self.u = ((g.wc * (reference - self.z1) - self.z2) / g.b0).clamp(0.0, uc_max);
        self.u
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn observer_tracks_a_first_order_plant_without_steady_error() {
        // Plant dQ/dt = -a Q + b u - d: ADRC removes the steady error a PID P-term leaves.
        let g = AdrcGains {
            wc: 15.0,
            beta1: 90.0,
            beta2: 2025.0,
            b0: 58.5,
            ts: 1e-3,
        };
        let (a, b, d) = (6.0, 50.0, 20.0);
        let (mut q, mut c) = (0.0, Adrc::default());
        for _ in 0..5000 {
            let u = c.update(g, 10.0, q, 10.0);
            q += g.ts * (-a * q + b * u - d);
        }
        assert!((q - 10.0).abs() < 1e-3, "q = {q}");
    }
}
