//! The one least-squares solver: Levenberg-Marquardt (Marquardt's diagonal scaling) on a
//! residual vector, in the unit coordinates of [`super::bounds`], with box bounds.
//!
//! - Jacobian by forward differences of `jacobian_step` (backward at the upper bound); the
//!   columns are one batch, which the caller evaluates in parallel.
//! - Bounds: a parameter at a bound whose gradient points out of the box is held there for the
//!   iteration (projected step); every trial point is clamped into the box.
//! - Damping lambda starts at 1e-3, is divided by 3 after an accepted step (down to 1e-12) and
//!   multiplied by 4 after a rejected one; the solve stops when lambda exceeds 1e8, when an
//!   accepted step lowers the cost by less than `min_gain` relative, when a step no longer
//!   moves, or after `max_iterations` Jacobians.
//!
//! Used by identify's local stage (`identify::fit`) and pump fit (`identify::pump`, through
//! [`minimize`]) and by diagnose's fits (`diagnose::model::fit`) through [`fit`].

use super::bounds::{self, Bounds, Scale};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use tbm_thrust::variables::by_name;

const LAMBDA_START: f64 = 1e-3;
const LAMBDA_MIN: f64 = 1e-12;
const LAMBDA_MAX: f64 = 1e8;
const LAMBDA_DOWN: f64 = 3.0;
const LAMBDA_UP: f64 = 4.0;
/// Floor of a diagonal entry of J^T J in the Marquardt scaling.
const DIAGONAL_FLOOR: f64 = 1e-12;
/// A trial closer than this to the current point (unit coordinates) ends the solve.
const NO_MOVE: f64 = 1e-12;

/// Stop rules and the finite-difference step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Forward-difference step in unit coordinates.
    pub jacobian_step: f64,
    /// Most Jacobians (iterations).
    pub max_iterations: usize,
    /// Stop after an accepted step that lowers the cost by less than this share.
    pub min_gain: f64,
}

impl Options {
    /// Residual evaluations for n parameters when each iteration rejects one trial: start,
    /// Jacobians and trials (for progress bars; more rejected trials are only counted).
    pub fn typical_evaluations(&self, n: usize) -> usize {
        1 + self.max_iterations * (n + 2)
    }
}

/// Residual vectors at a batch of points in unit coordinates, in the batch's order; None
/// where the residuals could not be computed (a failed simulation).
pub type Batch<'a> = dyn Fn(&[Vec<f64>]) -> Vec<Option<Vec<f64>>> + Sync + 'a;

/// The outcome, in unit coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    pub u: Vec<f64>,
    /// Sum of squared residuals at `u` (+inf when the start failed).
    pub cost: f64,
    /// Cost after each accepted step.
    pub history: Vec<f64>,
    /// Residual evaluations used.
    pub evaluations: usize,
}

/// Minimises |r(u)|^2 over the unit box from `start` (see the module docs).
pub fn minimize(residuals: &Batch, start: &[f64], opts: &Options) -> Solution {
    let mut s = Solution {
        u: start.to_vec(),
        cost: f64::INFINITY,
        history: Vec::new(),
        evaluations: 1,
    };
    let Some(mut r) = residuals(std::slice::from_ref(&s.u)).pop().flatten() else {
        return s;
    };
    s.cost = sum_sq(&r);
    if s.u.is_empty() {
        return s;
    }
    let mut lambda = LAMBDA_START;
    for _ in 0..opts.max_iterations {
        let Some(jac) = jacobian(residuals, &s.u, &r, opts.jacobian_step) else {
            break;
        };
        s.evaluations += s.u.len();
        let Some((u, r_new, gain)) = damped_step(residuals, &jac, &r, &mut s, &mut lambda) else {
            break;
        };
        s.u = u;
        r = r_new;
        if gain < opts.min_gain {
            break;
        }
    }
    s
}

/// Tries damped steps from `s` until one lowers the cost: returns the new point, its
/// residuals and the relative gain (cost and history updated), or None when the damping
/// runs out or the step stops moving.
fn damped_step(
    residuals: &Batch,
    jac: &DMatrix<f64>,
    r: &[f64],
    s: &mut Solution,
    lambda: &mut f64,
) -> Option<(Vec<f64>, Vec<f64>, f64)> {
    let n = s.u.len();
    let jtj = jac.transpose() * jac;
    let grad = jac.transpose() * DVector::from_column_slice(r);
    let free: Vec<bool> = (0..n)
        .map(|j| !((s.u[j] <= 0.0 && grad[j] > 0.0) || (s.u[j] >= 1.0 && grad[j] < 0.0)))
        .collect();
    while *lambda <= LAMBDA_MAX {
        let Some(delta) = solve_damped(&jtj, &grad, &free, *lambda) else {
            *lambda *= LAMBDA_UP;
            continue;
        };
        let trial: Vec<f64> = (0..n)
            .map(|j| (s.u[j] + delta[j]).clamp(0.0, 1.0))
            .collect();
        if trial.iter().zip(&s.u).all(|(a, b)| (a - b).abs() < NO_MOVE) {
            return None;
        }
        s.evaluations += 1;
        match residuals(std::slice::from_ref(&trial)).pop().flatten() {
            Some(r_new) if sum_sq(&r_new) < s.cost => {
                let cost = sum_sq(&r_new);
                let gain = (s.cost - cost) / s.cost.max(f64::MIN_POSITIVE);
                s.cost = cost;
                s.history.push(cost);
                *lambda = (*lambda / LAMBDA_DOWN).max(LAMBDA_MIN);
                return Some((trial, r_new, gain));
            }
            _ => *lambda *= LAMBDA_UP,
        }
    }
    None
}

/// The step of (J^T J + lambda diag(J^T J)) delta = -g with the held parameters fixed.
fn solve_damped(
    jtj: &DMatrix<f64>,
    grad: &DVector<f64>,
    free: &[bool],
    lambda: f64,
) -> Option<DVector<f64>> {
    let n = free.len();
    let mut a = jtj.clone();
    for j in 0..n {
        a[(j, j)] += lambda * jtj[(j, j)].max(DIAGONAL_FLOOR);
        if !free[j] {
            for k in 0..n {
                let e = if j == k { 1.0 } else { 0.0 };
                a[(j, k)] = e;
                a[(k, j)] = e;
            }
        }
    }
    let rhs = DVector::from_iterator(n, (0..n).map(|j| if free[j] { -grad[j] } else { 0.0 }));
    a.lu().solve(&rhs)
}

/// Forward-difference Jacobian at `u` (residuals `r0`), its columns as one batch.
fn jacobian(residuals: &Batch, u: &[f64], r0: &[f64], step: f64) -> Option<DMatrix<f64>> {
    let steps: Vec<f64> = u
        .iter()
        .map(|&x| if x + step <= 1.0 { step } else { -step })
        .collect();
    let probes: Vec<Vec<f64>> = (0..u.len())
        .map(|j| {
            let mut p = u.to_vec();
            p[j] += steps[j];
            p
        })
        .collect();
    let mut jac = DMatrix::zeros(r0.len(), u.len());
    for (j, col) in residuals(&probes).into_iter().enumerate() {
        let col = col?;
        for (i, (a, b)) in col.iter().zip(r0).enumerate() {
            jac[(i, j)] = (a - b) / steps[j];
        }
    }
    Some(jac)
}

fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// A named free parameter of a fit: the name of the variable table (or of a fitted
/// quantity) and its search range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spec {
    pub name: &'static str,
    pub bounds: Bounds,
}

impl Spec {
    pub const fn linear(name: &'static str, lo: f64, hi: f64) -> Spec {
        Spec {
            name,
            bounds: Bounds::linear(lo, hi),
        }
    }

    pub const fn log(name: &'static str, lo: f64, hi: f64) -> Spec {
        Spec {
            name,
            bounds: Bounds::log(lo, hi),
        }
    }

    /// A parameter of the variable table over its declared `search` range.
    pub fn searched(name: &'static str, scale: Scale) -> Spec {
        let (lo, hi) = by_name(name)
            .and_then(|v| v.search)
            .unwrap_or_else(|| panic!("`{name}` has a search range in variables.toml"));
        Spec {
            name,
            bounds: Bounds { lo, hi, scale },
        }
    }
}

/// Minimises |r(values)|^2 from the physical `start` within the specs' bounds, with a
/// residual function of physical values whose Jacobian columns run in parallel (rayon).
/// Returns the physical values and the solution.
pub fn fit(
    specs: &[Spec],
    start: &[f64],
    residuals: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    opts: &Options,
) -> (Vec<f64>, Solution) {
    let b: Vec<Bounds> = specs.iter().map(|s| s.bounds).collect();
    let batch = |points: &[Vec<f64>]| -> Vec<Option<Vec<f64>>> {
        points
            .par_iter()
            .map(|u| Some(residuals(&bounds::to_phys(&b, u))))
            .collect()
    };
    let sol = minimize(&batch, &bounds::to_unit(&b, start), opts);
    (bounds::to_phys(&b, &sol.u), sol)
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPTS: Options = Options {
        jacobian_step: 1e-4,
        max_iterations: 100,
        min_gain: 1e-12,
    };

    #[test]
    fn fits_an_exponential_decay() {
        // y = A exp(-k t): A linear, k log-scaled.
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 3.0 * (-0.7 * t).exp()).collect();
        let specs = [Spec::linear("A", 0.0, 10.0), Spec::log("k", 1e-3, 10.0)];
        let f = |p: &[f64]| -> Vec<f64> {
            t.iter()
                .zip(&y)
                .map(|(t, y)| p[0] * (-p[1] * t).exp() - y)
                .collect()
        };
        let (v, sol) = fit(&specs, &[1.0, 0.05], &f, &OPTS);
        assert!(
            (v[0] - 3.0).abs() < 1e-4 && (v[1] - 0.7).abs() < 1e-4,
            "{v:?} {sol:?}"
        );
    }

    /// Nothing to fit (every parameter of a pump held as given): the start comes back with
    /// its cost.
    #[test]
    fn no_parameters_return_the_start() {
        let f = |_: &[f64]| vec![3.0, 4.0];
        let (v, sol) = fit(&[], &[], &f, &OPTS);
        assert!(v.is_empty());
        assert_eq!(sol.cost, 25.0);
    }

    #[test]
    fn respects_bounds_and_holds_a_parameter_at_its_bound() {
        // The optimum of the first parameter lies outside the box; the second is free.
        let specs = [Spec::linear("a", 0.0, 1.0), Spec::linear("b", -1.0, 1.0)];
        let f = |p: &[f64]| vec![p[0] - 5.0, p[1] - 0.25, 0.1 * (p[0] - p[1])];
        let (v, _) = fit(&specs, &[0.5, 0.0], &f, &OPTS);
        assert!((v[0] - 1.0).abs() < 1e-12, "{v:?}");
        assert!((v[1] - 0.2574).abs() < 1e-3, "{v:?}");
    }

    #[test]
    fn search_ranges_come_from_the_variable_table() {
        let s = Spec::searched("beta_e", Scale::Log);
        assert_eq!(s.bounds, Bounds::log(1e8, 1e10));
    }

    #[test]
    fn a_failed_start_returns_the_start() {
        let batch = |points: &[Vec<f64>]| vec![None; points.len()];
        let sol = minimize(&batch, &[0.3], &OPTS);
        assert_eq!(
            (sol.u, sol.cost, sol.evaluations),
            (vec![0.3], f64::INFINITY, 1)
        );
    }
}
