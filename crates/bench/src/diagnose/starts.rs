//! Starting values of each effect's parameters, read off the current model's out-of-fold
//! residuals so that the simulation-error fit starts in the right basin: a delay scan,
//! the flow slope the pump model reaches, a tone search, and a few physically spread
//! guesses where the cost is multimodal.

use super::effect::Effect;
use super::model::{Model, Prediction};
use super::replay::Bench;
use super::series::Segment;
use crate::numerics::lm::Spec;
use crate::numerics::stats::quantile;
use std::f64::consts::PI;

/// Starting values of the effect's own parameters (several when the cost is multimodal).
pub fn effect_starts(
    effect: Effect,
    bench: &Bench,
    model: &Model,
    pred: &Prediction,
    segs: &[Segment],
) -> Vec<Vec<f64>> {
    let f_c = model.params.F_c;
    match effect {
        Effect::StribeckFriction => grid(
            &[0.1, 0.2, 0.35, 0.5, 0.75, 1.0],
            &[1e-3, 2e-3, 4e-3, 8e-3, 1.6e-2],
            |e, v| vec![f_c * (1.0 + e), v],
        ),
        Effect::PressureDependentFriction => vec![vec![0.003], vec![0.01], vec![0.03]],
        Effect::PositionDependentLoad => vec![vec![-5e3], vec![5e3]],
        Effect::EntrainedAir => [1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2]
            .iter()
            .map(|a| vec![*a])
            .collect(),
        Effect::ReliefLeakage => {
            let p = moving_pressures(bench);
            grid(
                &[0.3, 0.5, 0.7, 0.8, 0.9, 0.95],
                &[1e-11, 5e-11, 2e-10],
                |q, k| vec![quantile(&p, q), k],
            )
        }
        Effect::PumpDeadTime(_) => {
            let grid: Vec<f64> = (1..=30).map(|i| i as f64 * 0.005).collect();
            vec![vec![scan(bench, model, effect, &grid, segs)]]
        }
        Effect::PumpFlowLimit(i) => {
            let peak = peak_rate(pred.get(i.flow()), bench.s.dt);
            let grid: Vec<f64> = (0..16).map(|i| peak * 0.8f64.powi(2 * i)).collect();
            vec![vec![scan(bench, model, effect, &grid, segs)]]
        }
        Effect::FlowRipple(i) => tone(bench, pred.get(i.flow()), i.flow())
            .into_iter()
            .collect(),
    }
}

/// Measured pressures while the piston moves [Pa].
pub fn moving_pressures(bench: &Bench) -> Vec<f64> {
    let p = bench.s.col("p");
    let moving: Vec<f64> = (0..p.len())
        .filter(|&k| bench.v[k].abs() > 1e-3)
        .map(|k| p[k])
        .collect();
    if moving.is_empty() {
        p.to_vec()
    } else {
        moving
    }
}

/// Largest sample-to-sample slope of a flow [m^3/s^2].
pub fn peak_rate(q: &[f64], dt: f64) -> f64 {
    q.windows(2)
        .map(|w| (w[1] - w[0]).abs() / dt)
        .fold(0.0, f64::max)
        .max(1e-9)
}

/// Every combination of two parameter lists.
fn grid(a: &[f64], b: &[f64], f: impl Fn(f64, f64) -> Vec<f64>) -> Vec<Vec<f64>> {
    a.iter()
        .flat_map(|&x| b.iter().map(move |&y| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect()
}

/// The value of a pump effect's single parameter on `grid` that best explains the pump's
/// flow with the other parameters held.
fn scan(bench: &Bench, model: &Model, effect: Effect, grid: &[f64], segs: &[Segment]) -> f64 {
    let name = effect.model_parameters()[0];
    let part = super::model::Part::of(effect);
    let cost = |v: f64| {
        let mut m = model.clone();
        m.params.set(name, v).expect("scan value within bounds");
        super::model::residuals(bench, &m, part, segs)
            .iter()
            .map(|r| r * r)
            .sum::<f64>()
    };
    grid.iter()
        .map(|&v| (v, cost(v)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(grid[0], |b| b.0)
}

/// The effect's parameters switched off (within the fit's bounds): every fit can fall back
/// to the model without the effect.
pub fn off_start(effect: Effect, specs: &[Spec]) -> Vec<f64> {
    let base = tbm_thrust::variables::Params::default();
    specs
        .iter()
        .map(|s| match effect {
            Effect::PumpFlowLimit(_) => s.bounds.hi,
            _ => base
                .get(s.name)
                .unwrap_or(0.0)
                .clamp(s.bounds.lo, s.bounds.hi),
        })
        .collect()
}

/// The strongest tone in the relative flow residual: [amplitude, frequency, phase].
fn tone(bench: &Bench, pred: &[f64], name: &str) -> Option<Vec<f64>> {
    let y = bench.s.col(name);
    let floor = 0.1 * pred.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let idx: Vec<usize> = (0..y.len()).filter(|&k| pred[k] > floor).collect();
    if idx.len() < 100 {
        return None;
    }
    let span = idx.len() as f64 * bench.s.dt;
    let nyquist = 0.5 / bench.s.dt;
    let df = 0.25 / span;
    let mut best = (0.0, 0.0, 0.0, 0.0);
    let mut f = super::plausible::min_ripple_frequency(span);
    while f < nyquist - 0.1 {
        let (gain, a, b) = tone_fit(bench, y, pred, &idx, f);
        if gain > best.0 {
            best = (gain, f, a, b);
        }
        f += df;
    }
    let (_, f, a, b) = best;
    // Q_pred (a sin wt + b cos wt) = Q_pred r sin(wt + phi).
    Some(vec![a.hypot(b), f, b.atan2(a)])
}

/// Least-squares fit of Q_pred (a sin + b cos) to the residual at frequency f:
/// (squared-error reduction, a, b).
fn tone_fit(bench: &Bench, y: &[f64], pred: &[f64], idx: &[usize], f: f64) -> (f64, f64, f64) {
    let (mut ss, mut sc, mut cc, mut rs, mut rc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &k in idx {
        let w = 2.0 * PI * f * bench.s.time(k);
        let (s, c) = (pred[k] * w.sin(), pred[k] * w.cos());
        let r = y[k] - pred[k];
        ss += s * s;
        sc += s * c;
        cc += c * c;
        rs += r * s;
        rc += r * c;
    }
    let det = ss * cc - sc * sc;
    if det <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let a = (rs * cc - rc * sc) / det;
    let b = (rc * ss - rs * sc) / det;
    (a * rs + b * rc, a, b)
}
