//! Starting values of each effect's parameters, read off the current model's out-of-fold
//! residuals so that the simulation-error fit starts in the right basin: a delay scan,
//! the flow slope the pump model reaches, a tone search, and a few physically spread
//! guesses where the cost is multimodal.

use super::effect::Effect;
use super::model::{Model, Prediction};
use super::replay::Bench;
use super::series::Segment;
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
        Effect::StribeckFriction => vec![vec![1.4 * f_c, 3e-3], vec![2.0 * f_c, 1e-2]],
        Effect::PressureDependentFriction => vec![vec![0.01]],
        Effect::PositionDependentLoad => vec![vec![1e3]],
        Effect::EntrainedAir => vec![vec![2e-3], vec![2e-2]],
        Effect::ReliefLeakage => {
            let p = moving_pressures(bench);
            [0.5, 0.8, 0.95]
                .iter()
                .map(|&q| vec![quantile(&p, q), 5e-11])
                .collect()
        }
        Effect::PumpDeadTime(i) => vec![vec![best_delay(bench, model, i, segs)]],
        Effect::PumpFlowLimit(i) => {
            let peak = peak_rate(pred.get(flow_name(i)), bench.s.dt);
            vec![vec![0.3 * peak], vec![0.7 * peak]]
        }
        Effect::FlowRipple(i) => tone(bench, pred.get(flow_name(i)), flow_name(i))
            .into_iter()
            .collect(),
    }
}

pub fn flow_name(pump: u8) -> &'static str {
    if pump == 1 {
        "Q1"
    } else {
        "Q2"
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

pub fn quantile(values: &[f64], q: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// Largest sample-to-sample slope of a flow [m^3/s^2].
pub fn peak_rate(q: &[f64], dt: f64) -> f64 {
    q.windows(2)
        .map(|w| (w[1] - w[0]).abs() / dt)
        .fold(0.0, f64::max)
        .max(1e-9)
}

/// The dead time [s] on a 5 ms grid up to 150 ms that best explains the pump's flow with
/// the other pump parameters held.
fn best_delay(bench: &Bench, model: &Model, pump: u8, segs: &[Segment]) -> f64 {
    let name = Effect::PumpDeadTime(pump).model_parameters()[0];
    let cost = |d: f64| {
        let mut m = model.clone();
        m.params.set(name, d).expect("delay within bounds");
        super::model::residuals(bench, &m, super::model::Part::Pump(pump), segs)
            .iter()
            .map(|r| r * r)
            .sum::<f64>()
    };
    (0..=30)
        .map(|i| i as f64 * 0.005)
        .map(|d| (d, cost(d)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0.0, |b| b.0)
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
    let mut f = 0.2;
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
