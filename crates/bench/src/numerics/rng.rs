//! The one family of seeded random numbers: ChaCha8 (`rand_chacha`), reproducible from a
//! u64 seed on every platform, with the draws the bench tool needs.

use rand::{Rng as _, SeedableRng};
use std::f64::consts::PI;

/// The generator of every random draw (GA, DE, synthetic recordings, test noise).
pub type Rng = rand_chacha::ChaCha8Rng;

/// A generator seeded with `seed`.
pub fn seeded(seed: u64) -> Rng {
    Rng::seed_from_u64(seed)
}

/// Draws on top of the generator.
pub trait Draw {
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64;

    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Log-uniform in [lo, hi) (lo, hi > 0).
    fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }

    /// Standard normal (Box-Muller).
    fn normal(&mut self) -> f64 {
        let u = self.unit().max(1e-300);
        let v = self.unit();
        (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
    }

    /// `n` samples of coloured Gaussian noise of standard deviation 1: AR(1) with
    /// successive-sample correlation `rho` (a bench sensor's filtered noise).
    fn coloured(&mut self, n: usize, rho: f64) -> Vec<f64>
    where
        Self: Sized,
    {
        let gain = (1.0 - rho * rho).sqrt();
        let mut e = self.normal();
        (0..n)
            .map(|_| {
                let out = e;
                e = rho * e + gain * self.normal();
                out
            })
            .collect()
    }
}

impl Draw for Rng {
    fn unit(&mut self) -> f64 {
        self.gen::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coloured_noise_has_unit_variance_and_its_correlation() {
        let e = seeded(3).coloured(50_000, 0.5);
        let var = e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64;
        let lag1 = e.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / e.len() as f64;
        assert!(
            (var - 1.0).abs() < 0.05 && (lag1 / var - 0.5).abs() < 0.03,
            "{var} {lag1}"
        );
    }

    #[test]
    fn reproducible_and_roughly_normal() {
        let (mut a, mut b) = (seeded(7), seeded(7));
        assert_eq!(a.unit(), b.unit());
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| a.normal()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
        let r = a.log_range(1e-3, 1e3);
        assert!((1e-3..1e3).contains(&r));
    }
}
