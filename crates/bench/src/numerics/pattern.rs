//! Compass search (a pattern search) in unit coordinates, for a cost that is piecewise
//! constant at the scale of a finite-difference step, so that a gradient sees nothing:
//! from the current point, step by `h` up and down along each coordinate, move to the
//! lowest point polled if it lowers the cost, halve `h` when none does, stop below
//! `min_step`.

use super::bounds::{to_phys, to_unit, Bounds};

/// The lowest point found from `start` (physical values in `bounds`) and its cost.
pub fn compass(
    bounds: &[Bounds],
    start: &[f64],
    cost: &dyn Fn(&[f64]) -> f64,
    step: f64,
    min_step: f64,
) -> (Vec<f64>, f64) {
    let mut u = to_unit(bounds, start);
    let mut best = cost(&to_phys(bounds, &u));
    let mut h = step;
    while h >= min_step {
        let polled = (0..u.len())
            .flat_map(|i| [-h, h].map(|d| (i, d)))
            .filter_map(|(i, d)| {
                let mut p = u.clone();
                p[i] = (p[i] + d).clamp(0.0, 1.0);
                (p[i] != u[i]).then(|| (cost(&to_phys(bounds, &p)), p))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match polled {
            Some((c, p)) if c < best => (best, u) = (c, p),
            _ => h /= 2.0,
        }
    }
    (to_phys(bounds, &u), best)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A staircase bowl: flat at every finite-difference step, its minimum at (0.3, 2.0).
    #[test]
    fn finds_the_minimum_of_a_staircase() {
        let bounds = [Bounds::linear(0.0, 1.0), Bounds::log(0.1, 10.0)];
        let stair = |v: f64| (v * 50.0).floor() / 50.0;
        let cost = |v: &[f64]| stair(v[0] - 0.3).powi(2) + stair((v[1] / 2.0).ln()).powi(2);
        let (v, c) = compass(&bounds, &[0.8, 0.2], &cost, 0.1, 1e-3);
        assert!(
            (v[0] - 0.3).abs() < 0.03 && (v[1] / 2.0 - 1.0).abs() < 0.05,
            "{v:?}"
        );
        assert!(c < 1e-3, "{c}");
    }
}
