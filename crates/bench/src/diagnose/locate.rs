//! Where and in which regime a mismatch sits: the weak-form (integral) equation errors of
//! each subsystem over short windows, so nothing noisy is differentiated (shown in the
//! report against time, velocity and pressure); the operating regimes of every sample; and
//! the time windows where a per-sample weight concentrates.

use super::effect::Subsystem;
use super::replay::{Bench, Load};
use crate::numerics::stats::quantile;
use tbm_thrust::chamber;
use tbm_thrust::cylinder;
use tbm_thrust::pump::{Pump, PumpParams};
use tbm_thrust::variables::Params;

/// Window of the weak-form residuals [s].
pub const WINDOW_S: f64 = 0.2;

/// One subsystem's equation error per window.
#[derive(Clone, Debug, PartialEq)]
pub struct EquationError {
    pub subsystem: Subsystem,
    /// Window centres [s] and mean residual over the window (N for mechanics, m^3/s for the
    /// chamber and pumps).
    pub time: Vec<f64>,
    pub residual: Vec<f64>,
    /// First sample of each window.
    pub start: Vec<usize>,
    pub unit: &'static str,
}

/// Weak-form residuals of Eq. (1) and Eq. (4), and of Eq. (8) for each replayable pump.
/// The force balance is only formed while the piston slides: at rest, static friction takes
/// any value up to breakaway.
pub fn equation_errors(
    bench: &Bench,
    params: &Params,
    load: Load,
    pumps: &[Pump],
) -> Vec<EquationError> {
    let w = ((WINDOW_S / bench.s.dt).round() as usize).max(2);
    let sliding = |k0: usize, k1: usize| bench.v[k0..=k1].iter().all(|v| v.abs() > V_SLIDING);
    let always = |_: usize, _: usize| true;
    let mut out = vec![
        windowed(bench, (Subsystem::Mechanics, "N"), w, sliding, |k0, k1| {
            mechanics(bench, params, load, k0, k1)
        }),
        windowed(bench, (Subsystem::Chamber, "m^3/s"), w, always, |k0, k1| {
            continuity(bench, params, k0, k1)
        }),
    ];
    for &i in pumps {
        out.push(windowed(
            bench,
            (Subsystem::Pump(i), "m^3/s^2"),
            w,
            always,
            |k0, k1| pump(bench, params, i, k0, k1),
        ));
    }
    out
}

/// Smoothed speed above which the piston counts as sliding [m/s].
const V_SLIDING: f64 = 1e-3;

/// The residual `f` over consecutive windows of `w` samples where `keep` holds.
fn windowed(
    bench: &Bench,
    (subsystem, unit): (Subsystem, &'static str),
    w: usize,
    keep: impl Fn(usize, usize) -> bool,
    f: impl Fn(usize, usize) -> f64,
) -> EquationError {
    let n = bench.s.len();
    let start: Vec<usize> = (0..n.saturating_sub(w))
        .step_by(w)
        .filter(|&k| keep(k, k + w))
        .collect();
    let residual: Vec<f64> = start.iter().map(|&k| f(k, k + w)).collect();
    let time = start
        .iter()
        .map(|&k| bench.s.time(k) + 0.5 * w as f64 * bench.s.dt)
        .collect();
    EquationError {
        subsystem,
        time,
        residual,
        start,
        unit,
    }
}

/// Trapezoidal integral of g(k) over samples k0..=k1 [unit * s].
fn integral(bench: &Bench, k0: usize, k1: usize, g: impl Fn(usize) -> f64) -> f64 {
    (k0..k1).map(|k| 0.5 * (g(k) + g(k + 1)) * bench.s.dt).sum()
}

/// Mean force residual of Eq. (1) over a window [N]:
/// (m (v1 - v0) - int(A (p - p_t) - F_L - F_f(v, p) - k x) dt) / T, with b int v dt = b (x1 - x0).
fn mechanics(bench: &Bench, p: &Params, load: Load, k0: usize, k1: usize) -> f64 {
    let s = bench.s;
    let (x, pr) = (s.col("x"), s.col("p"));
    let f_l = |k: usize| match (load, s.get("F_L")) {
        (Load::Constant(f), _) => f,
        (_, Some(f)) => f[k],
        _ => 0.0,
    };
    let t = (k1 - k0) as f64 * s.dt;
    let drive = integral(bench, k0, k1, |k| {
        cylinder::hydraulic_force(p, pr[k]) - cylinder::load_force(p, f_l(k), x[k])
    });
    let dry = integral(bench, k0, k1, |k| {
        bench.v[k].signum() * cylinder::dry_friction(p, bench.v[k].abs(), pr[k])
    });
    let viscous = p.b * (x[k1] - x[k0]);
    (p.m * (bench.v[k1] - bench.v[k0]) - (drive - dry - viscous)) / t
}

/// Mean flow residual of Eq. (4) over a window [m^3/s]:
/// (int(Q1 + Q2 - C_ip (p - p_t) - Q_rel) dt - A (x1 - x0) - int V/beta dp) / T.
fn continuity(bench: &Bench, p: &Params, k0: usize, k1: usize) -> f64 {
    let s = bench.s;
    let (x, pr) = (s.col("x"), s.col("p"));
    let t = (k1 - k0) as f64 * s.dt;
    let inflow = integral(bench, k0, k1, |k| {
        bench.q_in[k] - chamber::leakage(p, pr[k]) - chamber::relief_flow(p, pr[k])
    });
    let compression: f64 = (k0..k1)
        .map(|k| {
            let pm = 0.5 * (pr[k] + pr[k + 1]);
            chamber::volume(p, 0.5 * (x[k] + x[k + 1])) / chamber::bulk_modulus(p, pm)
                * (pr[k + 1] - pr[k])
        })
        .sum();
    (inflow - p.A * (x[k1] - x[k0]) - compression) / t
}

/// Mean residual of Eq. (8) over a window [m^3/s^2]: ((Q1 - Q0) - int(dQ/dt model) dt) / T.
fn pump(bench: &Bench, p: &Params, i: Pump, k0: usize, k1: usize) -> f64 {
    let s = bench.s;
    let pp = PumpParams::of(p, i);
    let q = s.col(i.flow());
    let uc = bench.drive(p, i);
    let pr = s.col("p");
    let t = (k1 - k0) as f64 * s.dt;
    let model = integral(bench, k0, k1, |k| {
        let t = s.time(k);
        let state = q[k] / pp.delivered(1.0, t);
        pp.flow_rate(state, pp.saturate(s.at(&uc, t - pp.delay)), pr[k])
    });
    ((q[k1] - q[k0]) - model) / t
}

/// Operating-regime labels of every sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Regimes {
    pub labels: Vec<(&'static str, Vec<bool>)>,
}

/// Speeds [m/s] separating standstill, low speed and normal motion.
const V_REST: f64 = 3e-4;
const V_LOW: f64 = 5e-3;
/// How long a start-up, load step or speed change lasts as a regime [s].
const AFTER: f64 = 1.5;

impl Regimes {
    pub fn of(bench: &Bench) -> Regimes {
        let s = bench.s;
        let n = s.len();
        let v = &bench.v;
        let p = s.col("p");
        let moving: Vec<f64> = (0..n)
            .filter(|&k| v[k].abs() > V_REST)
            .map(|k| p[k])
            .collect();
        let moving = if moving.is_empty() {
            p.to_vec()
        } else {
            moving
        };
        let (p_lo, p_hi) = (quantile(&moving, 0.2), quantile(&moving, 0.8));
        let after = (AFTER / s.dt).round() as usize;
        let starts = spread(
            &(0..n)
                .map(|k| k > 0 && v[k].abs() > V_REST && v[k - 1].abs() <= V_REST)
                .collect::<Vec<_>>(),
            after,
        );
        let load_steps = spread(&super::series::unsettled(s, &["F_L"], 0.05, 0.0), after);
        let command = if s.has("v_ref") { "v_ref" } else { "uc1" };
        let speed_changes = spread(&super::series::unsettled(s, &[command], 0.1, 0.0), after);
        let labels = vec![
            ("start-up", starts),
            ("load step", load_steps),
            ("speed change", speed_changes),
            ("standstill", (0..n).map(|k| v[k].abs() <= V_REST).collect()),
            (
                "low speed",
                (0..n)
                    .map(|k| v[k].abs() > V_REST && v[k].abs() < V_LOW)
                    .collect(),
            ),
            (
                "high pressure",
                (0..n).map(|k| p[k] >= p_hi && p_hi > p_lo).collect(),
            ),
            (
                "low pressure",
                (0..n).map(|k| p[k] <= p_lo && p_hi > p_lo).collect(),
            ),
        ];
        Regimes { labels }
    }

    /// The regimes that carry a weighted mismatch out of proportion to their time share,
    /// in words, e.g. "start-up, low speed (64 % of the mismatch in 12 % of the time)".
    pub fn describe(&self, weight: &[f64]) -> String {
        let total: f64 = weight.iter().sum();
        if total <= 0.0 {
            return "throughout".into();
        }
        let mut hits: Vec<(&str, f64, f64)> = self
            .labels
            .iter()
            .map(|(name, mask)| {
                let (share, time) = share_and_time(mask, weight, total);
                (*name, share, time)
            })
            .filter(|(_, share, time)| *share >= 0.3 && *share >= 1.3 * time)
            .collect();
        hits.sort_by(|a, b| b.1.total_cmp(&a.1));
        hits.truncate(2);
        if hits.is_empty() {
            return "throughout".into();
        }
        let union: Vec<bool> = (0..weight.len())
            .map(|k| {
                hits.iter()
                    .any(|(name, _, _)| self.labels.iter().any(|(l, m)| l == name && m[k]))
            })
            .collect();
        let (share, time) = share_and_time(&union, weight, total);
        let names: Vec<&str> = hits.iter().map(|h| h.0).collect();
        format!(
            "{} ({:.0} % of the mismatch in {:.0} % of the time)",
            names.join(", "),
            100.0 * share,
            100.0 * time
        )
    }
}

/// The share of the total weight inside `mask`, and the share of the samples it covers.
fn share_and_time(mask: &[bool], weight: &[f64], total: f64) -> (f64, f64) {
    let inside: f64 = mask
        .iter()
        .zip(weight)
        .filter(|(m, _)| **m)
        .map(|(_, w)| w)
        .sum();
    let time = mask.iter().filter(|m| **m).count() as f64 / mask.len() as f64;
    (inside / total, time)
}

/// Marks `after` samples following every marked sample.
fn spread(marks: &[bool], after: usize) -> Vec<bool> {
    let mut out = vec![false; marks.len()];
    for (k, _) in marks.iter().enumerate().filter(|(_, m)| **m) {
        out[k..(k + after).min(marks.len())]
            .iter_mut()
            .for_each(|o| *o = true);
    }
    out
}

/// Time intervals [s] where a per-sample weight concentrates: the weight smoothed over
/// 0.5 s above a fifth of its peak, merged, the `max` heaviest first.
pub fn windows(bench: &Bench, weight: &[f64], max: usize) -> Vec<[f64; 2]> {
    let half = (0.25 / bench.s.dt).round() as usize;
    let smooth = super::filter::moving_average(weight, half);
    let peak = smooth.iter().fold(0.0f64, |a, &b| a.max(b));
    if peak <= 0.0 {
        return Vec::new();
    }
    let mut runs: Vec<(usize, usize, f64)> = Vec::new();
    let mut k = 0;
    while k < smooth.len() {
        if smooth[k] > 0.2 * peak {
            let start = k;
            while k < smooth.len() && smooth[k] > 0.2 * peak {
                k += 1;
            }
            runs.push((start, k - 1, weight[start..k].iter().sum()));
        }
        k += 1;
    }
    runs.sort_by(|a, b| b.2.total_cmp(&a.2));
    runs.truncate(max);
    runs.sort_by_key(|r| r.0);
    runs.iter()
        .map(|r| [round2(bench.s.time(r.0)), round2(bench.s.time(r.1))])
        .collect()
}

fn round2(t: f64) -> f64 {
    (t * 100.0).round() / 100.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_marks_what_follows() {
        assert_eq!(
            spread(&[false, true, false, false, false], 2),
            vec![false, true, true, false, false]
        );
    }
}
