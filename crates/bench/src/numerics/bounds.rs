//! A bounded parameter in unit coordinates: u in [0, 1] mapped linearly or logarithmically
//! onto [lo, hi]. Every optimiser of the bench tool (GA, DE, Levenberg-Marquardt, compass
//! search) works in these coordinates.

/// How the unit interval maps onto the range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Linear,
    /// Logarithmic: for positive ranges spanning decades.
    Log,
}

/// A range [lo, hi] in the parameter's unit with its scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub lo: f64,
    pub hi: f64,
    pub scale: Scale,
}

impl Bounds {
    pub const fn linear(lo: f64, hi: f64) -> Bounds {
        Bounds {
            lo,
            hi,
            scale: Scale::Linear,
        }
    }

    pub const fn log(lo: f64, hi: f64) -> Bounds {
        Bounds {
            lo,
            hi,
            scale: Scale::Log,
        }
    }

    /// Physical value to unit coordinate (clamped into the range first).
    pub fn to_unit(self, v: f64) -> f64 {
        let v = v.clamp(self.lo, self.hi);
        match self.scale {
            Scale::Linear => (v - self.lo) / (self.hi - self.lo),
            Scale::Log => (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln()),
        }
    }

    /// Unit coordinate to physical value (u clamped into [0, 1], the value into the range).
    pub fn to_phys(self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        match self.scale {
            Scale::Linear => self.lo + u * (self.hi - self.lo),
            Scale::Log => (self.lo.ln() + u * (self.hi.ln() - self.lo.ln()))
                .exp()
                .clamp(self.lo, self.hi),
        }
    }
}

/// Unit coordinates of `values` in `bounds` (same order).
pub fn to_unit(bounds: &[Bounds], values: &[f64]) -> Vec<f64> {
    bounds
        .iter()
        .zip(values)
        .map(|(b, &v)| b.to_unit(v))
        .collect()
}

/// Physical values of unit coordinates `u` in `bounds` (same order).
pub fn to_phys(bounds: &[Bounds], u: &[f64]) -> Vec<f64> {
    bounds.iter().zip(u).map(|(b, &u)| b.to_phys(u)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_clamping() {
        let lin = Bounds::linear(-2.0, 6.0);
        let log = Bounds::log(1e-13, 5e-12);
        assert_eq!(lin.to_unit(2.0), 0.5);
        assert_eq!(lin.to_phys(0.25), 0.0);
        assert!((log.to_phys(log.to_unit(3.822e-13)) / 3.822e-13 - 1.0).abs() < 1e-12);
        assert!((log.to_phys(0.5) - (1e-13f64 * 5e-12).sqrt()).abs() < 1e-25);
        assert_eq!((lin.to_unit(9.0), lin.to_phys(-1.0)), (1.0, -2.0));
        assert_eq!((log.to_phys(1.0), log.to_phys(0.0)), (5e-12, 1e-13));
    }
}
