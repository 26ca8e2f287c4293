//! Local stage of the default method: Levenberg-Marquardt (Marquardt 1963 scaling) on the
//! weighted residual vector of the cost, in the same unit coordinates as the global stage.
//! The Jacobian is taken by forward differences of 1e-3 (backward at the upper bound), its
//! n columns simulated in parallel. Parameters at a bound whose gradient points outwards are
//! held there (projected steps). Stops when an accepted step lowers J by less than 1e-7
//! relative, when the damping exceeds 1e8, or after 25 iterations.

use super::{Evaluator, Outcome};
use nalgebra::{DMatrix, DVector};

const STEP: f64 = 1e-3;
const MAX_ITERATIONS: usize = 25;
const REL_TOL: f64 = 1e-7;
const LAMBDA_MAX: f64 = 1e8;
/// Simulations for n parameters with one rejected trial per iteration: start, Jacobians
/// and trial steps (the progress bar's length; more rejected trials are only counted).
pub fn max_simulations(n: usize) -> usize {
    1 + MAX_ITERATIONS * (n + 2)
}

pub fn run(eval: &Evaluator, start: &[f64], start_cost: f64) -> Outcome {
    let n = eval.dim();
    let mut u = start.to_vec();
    let mut history = Vec::new();
    let Some(mut r) = eval.residuals(std::slice::from_ref(&u)).pop().flatten() else {
        return Outcome {
            best: u,
            cost: start_cost,
            history,
        };
    };
    let mut cost = sum_sq(&r);
    let mut lambda = 1e-3;
    'outer: for _ in 0..MAX_ITERATIONS {
        let steps: Vec<f64> = u
            .iter()
            .map(|&x| if x + STEP <= 1.0 { STEP } else { -STEP })
            .collect();
        let probes: Vec<Vec<f64>> = (0..n)
            .map(|j| {
                let mut p = u.clone();
                p[j] += steps[j];
                p
            })
            .collect();
        let columns = eval.residuals(&probes);
        let m = r.len();
        let mut jac = DMatrix::<f64>::zeros(m, n);
        for (j, col) in columns.into_iter().enumerate() {
            let Some(col) = col else { break 'outer };
            for i in 0..m {
                jac[(i, j)] = (col[i] - r[i]) / steps[j];
            }
        }
        let res = DVector::from_vec(r.clone());
        let jtj = jac.transpose() * &jac;
        let grad = jac.transpose() * &res;
        // Hold parameters at a bound when the descent direction -grad leaves the box.
        let free: Vec<bool> = (0..n)
            .map(|j| !((u[j] <= 0.0 && grad[j] > 0.0) || (u[j] >= 1.0 && grad[j] < 0.0)))
            .collect();
        loop {
            let mut a = jtj.clone();
            for j in 0..n {
                a[(j, j)] += lambda * jtj[(j, j)].max(1e-12);
                if !free[j] {
                    for k in 0..n {
                        a[(j, k)] = if j == k { 1.0 } else { 0.0 };
                        a[(k, j)] = if j == k { 1.0 } else { 0.0 };
                    }
                }
            }
            let rhs =
                DVector::from_iterator(n, (0..n).map(|j| if free[j] { -grad[j] } else { 0.0 }));
            let Some(delta) = a.lu().solve(&rhs) else {
                break 'outer;
            };
            let trial: Vec<f64> = (0..n).map(|j| (u[j] + delta[j]).clamp(0.0, 1.0)).collect();
            if trial.iter().zip(&u).all(|(a, b)| (a - b).abs() < 1e-12) {
                break 'outer;
            }
            match eval.residuals(std::slice::from_ref(&trial)).pop().flatten() {
                Some(r_new) if sum_sq(&r_new) < cost => {
                    let new_cost = sum_sq(&r_new);
                    let gain = (cost - new_cost) / cost.max(f64::MIN_POSITIVE);
                    u = trial;
                    r = r_new;
                    cost = new_cost;
                    history.push(cost);
                    eval.report(cost);
                    lambda = (lambda / 3.0).max(1e-12);
                    if gain < REL_TOL {
                        break 'outer;
                    }
                    break;
                }
                _ => {
                    lambda *= 4.0;
                    if lambda > LAMBDA_MAX {
                        break 'outer;
                    }
                }
            }
        }
    }
    Outcome {
        best: u,
        cost,
        history,
    }
}

fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}
