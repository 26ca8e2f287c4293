//! The one ODE integrator of the workspace: a classic fourth-order Runge-Kutta step, generic
//! over the state (a scalar or a fixed-size vector). The plant (`plant.rs`) and every replay
//! of the bench tool (`crates/bench`: pump fits and the diagnosis replays) step with it.

/// A state RK4 can advance: a value with `y + h k` and `acc + c k`.
pub trait State: Copy {
    /// `self + h k`.
    fn add_scaled(&self, k: &Self, h: f64) -> Self;
    /// `self + c k`, with `c k` rounded first (the order of `y + h / 6 (k1 + 2 k2 + ...)`).
    fn accumulate(&self, k: &Self, c: f64) -> Self;
}

impl State for f64 {
    #[inline(always)]
    fn add_scaled(&self, k: &f64, h: f64) -> f64 {
        self + h * k
    }

    #[inline(always)]
    fn accumulate(&self, k: &f64, c: f64) -> f64 {
        self + c * k
    }
}

impl<const N: usize> State for [f64; N] {
    #[inline(always)]
    fn add_scaled(&self, k: &Self, h: f64) -> Self {
        std::array::from_fn(|i| self[i] + h * k[i])
    }

    #[inline(always)]
    fn accumulate(&self, k: &Self, c: f64) -> Self {
        std::array::from_fn(|i| self[i] + c * k[i])
    }
}

/// A right-hand side dy/dt = f(t, y): any closure `Fn(f64, &S) -> S`, or a type whose
/// `rates` is `#[inline(always)]` so that the four stages of a step share its loads (the
/// plant's, see `plant.rs`).
pub trait Rates<S> {
    fn rates(&self, t: f64, y: &S) -> S;
}

impl<S, F: Fn(f64, &S) -> S> Rates<S> for F {
    #[inline(always)]
    fn rates(&self, t: f64, y: &S) -> S {
        self(t, y)
    }
}

/// One classic RK4 step of dy/dt = f(t, y) from (t, y) over h [s]:
/// y + h / 6 (k1 + 2 k2 + 2 k3 + k4), the sum accumulated stage by stage in that order (the
/// same roundings as summing at the end, with one stage's slope live at a time).
#[inline(always)]
pub fn rk4<S: State>(f: &impl Rates<S>, t: f64, y: &S, h: f64) -> S {
    let k1 = f.rates(t, y);
    let sum = k1;
    let k2 = f.rates(t + 0.5 * h, &y.add_scaled(&k1, 0.5 * h));
    let sum = sum.accumulate(&k2, 2.0);
    let k3 = f.rates(t + 0.5 * h, &y.add_scaled(&k2, 0.5 * h));
    let sum = sum.accumulate(&k3, 2.0);
    let k4 = f.rates(t + h, &y.add_scaled(&k3, h));
    let sum = sum.accumulate(&k4, 1.0);
    y.add_scaled(&sum, h / 6.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponential_decay_to_fourth_order() {
        // dy/dt = -y: one step has local error h^5/120; ten steps of 0.1 reach e^-1 within 1e-6.
        let mut y = 1.0;
        for k in 0..10 {
            y = rk4(&|_, y: &f64| -y, k as f64 * 0.1, &y, 0.1);
        }
        assert!((y - (-1.0f64).exp()).abs() < 1e-6, "{y}");
    }

    #[test]
    fn vector_state_matches_the_scalar_componentwise() {
        // An oscillator x'' = -x as a 2-vector, against its exact solution at t = 1.
        let mut y = [1.0, 0.0];
        for k in 0..100 {
            y = rk4(&|_, y: &[f64; 2]| [y[1], -y[0]], k as f64 * 0.01, &y, 0.01);
        }
        assert!((y[0] - 1f64.cos()).abs() < 1e-9 && (y[1] + 1f64.sin()).abs() < 1e-9);
        let scalar = rk4(&|t, y: &f64| t - y, 0.3, &0.7, 0.05);
        let vector = rk4(&|t, y: &[f64; 1]| [t - y[0]], 0.3, &[0.7], 0.05);
        assert_eq!(scalar, vector[0]);
    }
}
