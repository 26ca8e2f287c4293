//! Levenberg-Marquardt on a residual vector with forward-difference Jacobians, box bounds
//! and log-scaled positive parameters (the simulation-error refinement of the research
//! note's step 5).

use nalgebra::{DMatrix, DVector};

/// One free parameter: name, bounds in physical units, log scaling for positive scales.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spec {
    pub name: &'static str,
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
}

impl Spec {
    pub const fn linear(name: &'static str, lo: f64, hi: f64) -> Spec {
        Spec {
            name,
            lo,
            hi,
            log: false,
        }
    }

    pub const fn log(name: &'static str, lo: f64, hi: f64) -> Spec {
        Spec {
            name,
            lo,
            hi,
            log: true,
        }
    }

    /// Physical value to the optimiser's unit coordinate (0..1 over the bounds).
    fn to_unit(self, v: f64) -> f64 {
        let v = v.clamp(self.lo, self.hi);
        if self.log {
            (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }

    fn to_phys(self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        if self.log {
            (self.lo.ln() + u * (self.hi.ln() - self.lo.ln())).exp()
        } else {
            self.lo + u * (self.hi - self.lo)
        }
    }
}

/// Result of a minimisation.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// Physical parameter values.
    pub values: Vec<f64>,
    /// Half the sum of squared residuals.
    pub cost: f64,
    /// Residual evaluations used.
    pub evaluations: usize,
}

/// Minimises 0.5 |r(values)|^2 from `start` within the specs' bounds.
pub fn minimize(
    specs: &[Spec],
    start: &[f64],
    residuals: &dyn Fn(&[f64]) -> Vec<f64>,
    max_iter: usize,
) -> Solution {
    let phys =
        |u: &[f64]| -> Vec<f64> { specs.iter().zip(u).map(|(s, &u)| s.to_phys(u)).collect() };
    let cost_of = |r: &[f64]| 0.5 * r.iter().map(|v| v * v).sum::<f64>();
    let mut u: Vec<f64> = specs
        .iter()
        .zip(start)
        .map(|(s, &v)| s.to_unit(v))
        .collect();
    let mut r = residuals(&phys(&u));
    let mut cost = cost_of(&r);
    let mut evaluations = 1;
    let mut lambda = 1e-3;
    for _ in 0..max_iter {
        let jac = jacobian(&u, &r, &|u: &[f64]| residuals(&phys(u)));
        evaluations += u.len();
        let jt = jac.transpose();
        let jtj = &jt * &jac;
        let g = &jt * DVector::from_column_slice(&r);
        let mut improved = false;
        while lambda < 1e10 {
            let mut a = jtj.clone();
            for i in 0..u.len() {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(step) = a.lu().solve(&(-&g)) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = u
                .iter()
                .zip(step.iter())
                .map(|(a, d)| (a + d).clamp(0.0, 1.0))
                .collect();
            let rt = residuals(&phys(&trial));
            evaluations += 1;
            let ct = cost_of(&rt);
            if ct < cost {
                let gain = (cost - ct) / cost.max(f64::MIN_POSITIVE);
                u = trial;
                r = rt;
                cost = ct;
                lambda = (lambda / 3.0).max(1e-9);
                improved = gain > 1e-4;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    Solution {
        values: phys(&u),
        cost,
        evaluations,
    }
}

/// Forward-difference Jacobian in unit coordinates (step away from the upper bound).
fn jacobian(u: &[f64], r0: &[f64], f: &dyn Fn(&[f64]) -> Vec<f64>) -> DMatrix<f64> {
    const H: f64 = 1e-4;
    let mut jac = DMatrix::zeros(r0.len(), u.len());
    for j in 0..u.len() {
        let mut up = u.to_vec();
        let h = if u[j] + H > 1.0 { -H } else { H };
        up[j] += h;
        let r = f(&up);
        for (i, (a, b)) in r.iter().zip(r0).enumerate() {
            jac[(i, j)] = (a - b) / h;
        }
    }
    jac
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_an_exponential_decay() {
        // y = A exp(-k t): A linear, k log-scaled.
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 3.0 * (-0.7 * t).exp()).collect();
        let specs = [Spec::linear("A", 0.0, 10.0), Spec::log("k", 1e-3, 10.0)];
        let f = |p: &[f64]| {
            t.iter()
                .zip(&y)
                .map(|(t, y)| p[0] * (-p[1] * t).exp() - y)
                .collect()
        };
        let sol = minimize(&specs, &[1.0, 0.05], &f, 100);
        assert!(
            (sol.values[0] - 3.0).abs() < 1e-4 && (sol.values[1] - 0.7).abs() < 1e-4,
            "{:?}",
            sol
        );
    }

    #[test]
    fn respects_bounds() {
        let specs = [Spec::linear("a", 0.0, 1.0)];
        let f = |p: &[f64]| vec![p[0] - 5.0];
        let sol = minimize(&specs, &[0.5], &f, 50);
        assert!((sol.values[0] - 1.0).abs() < 1e-9);
    }
}
