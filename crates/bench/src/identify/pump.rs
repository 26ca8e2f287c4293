//! Pump subsystem fit: the motor-pump unit i, Eq. (8),
//! dQ_i/dt = -a_i Q_i + (eta_vi D_i b_ui) u_ci - (eta_vi D_i b_pi) p,
//! replayed open-loop with the recording's drive command `uc_i` and pressure `p` (linearly
//! interpolated between samples, `uc_i` saturated and delayed as the plant does) against
//! its measured flow `Q_i`. eta_vi and D_i are known (pump data); a_i, b_ui, b_pi are fitted.
//!
//! The drive command is logged at the recording's rate while the flow controller acts at
//! 1 kHz: after a step of the flow reference, the controller's kick and its fast decay
//! (tens of ms) fall between samples and no interpolation of `uc_i` reproduces them. Such
//! stretches are found as sample-to-sample changes of `uc_i` above the larger of 6 robust
//! standard deviations of those changes and 1 % of the command's range; they are left out
//! of both steps, and the replayed flow is re-anchored to the measured one after each
//! (multiple shooting). When more than half of the intervals are such, nothing is left out
//! and the result says so.
//!
//! 1. Start: least squares on the integral form of Eq. (8) over 0.05 s windows in which the
//!    pump delivers (Q_i above 2 % of its peak, away from the check valve):
//!    Q(t_k+W) - Q(t_k) = -a int Q dt + k_u int u_c dt - k_p int p dt
//!    (integrating instead of differentiating keeps the flow sensor's noise down).
//! 2. Refinement: the project's one least-squares solver (`numerics::lm`) on the simulation
//!    (output) error of Q_i, in log-scaled parameters, from the better of the least-squares
//!    and the given values.
//!
//! Acceptance: the fitted values are used only when what the replay leaves is noise: the
//! residual's lag-one autocorrelation is below 0.25 (white sensor noise gives about 0, a
//! systematic misfit close to 1), or its RMSE is below 1e-3 of the flow's peak (a clean
//! recording). Otherwise Eq. 8 with the sampled command does not explain the flow (the
//! command varies faster than it is sampled, as the auxiliary pump's can under the
//! adaptive law, or the pump has physics Eq. 8 lacks) and the given values are kept; the
//! result says so.
//!
//! Ranges: the pump parameters are not published; each is searched within a factor 10
//! either side of its given value (of the least-squares value if the given one is zero).

use crate::numerics::bounds::{self, Bounds};
use crate::numerics::lm;
use crate::numerics::stats::{interpolate, median, noise_level, robust_sd, span};
use crate::recording::Recording;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use tbm_thrust::metrics::{self, Fit};
use tbm_thrust::ode;
use tbm_thrust::pump::{Pump, PumpParams};
use tbm_thrust::variables::{by_name, Kind, Params};

/// Solver step of the open-loop replay [s] (the controller period; 1/a_i >> 1 ms).
const SUBSTEP: f64 = 1e-3;
/// Length of a least-squares integration window [s].
const WINDOW_S: f64 = 0.05;
/// A window counts when the flow stays above this share of its peak.
const ACTIVE_SHARE: f64 = 0.02;
/// Search range: the given value times or divided by this factor.
const RANGE_FACTOR: f64 = 10.0;
/// The refinement's solver settings (unit coordinates: a step of 1e-4 moves a parameter by
/// about 0.05 % of its value).
const REFINEMENT: lm::Options = lm::Options {
    jacobian_step: 1e-4,
    max_iterations: 50,
    min_gain: 1e-10,
};
/// Accept a fit whose residual has a lag-one autocorrelation below this...
const ACCEPT_AUTOCORRELATION: f64 = 0.25;
/// ... or an RMSE below this share of the flow's peak.
const ACCEPT_RMSE_SHARE: f64 = 1e-3;
/// Floor of the flow's noise level relative to its peak (cost normalisation).
const NOISE_FLOOR: f64 = 1e-5;

/// The fitted pump.
#[derive(Clone, Debug, PartialEq)]
pub struct PumpFit {
    pub pump: Pump,
    /// Fitted parameters, `a{i}` [1/s], `b_u{i}` [rad/(s^2 V)], `b_p{i}` [rad/(s^2 Pa)].
    pub names: Vec<String>,
    pub values: Vec<f64>,
    /// Search range of each, same units.
    pub bounds: Vec<(f64, f64)>,
    /// Open-loop fit of `Q{i}` (R^2, RMSE [m^3/s], MAPE [%]).
    pub fit: Fit,
    /// Open-loop pump simulations run.
    pub simulations: usize,
    /// Samples left out after fast drive-command changes (see the module docs).
    pub excluded_samples: usize,
    /// Lag-one autocorrelation of the flow residual over the samples used.
    pub autocorrelation: f64,
    /// Whether the residual is noise (see the module docs), so that the fitted values are
    /// used; when false the given values are kept.
    pub accepted: bool,
}

impl PumpFit {
    /// One sentence on the outcome, for reports.
    pub fn summary(&self) -> String {
        if self.accepted {
            format!(
                "pump {p}: Eq. 8 fitted to Q{p}, residual RMSE {:.3e} m^3/s with lag-one autocorrelation {:.2} ({} samples after fast drive-command changes left out)",
                self.fit.rmse,
                self.autocorrelation,
                self.excluded_samples,
                p = self.pump
            )
        } else {
            format!(
                "pump {p}: Eq. 8 with the recorded uc{p} leaves a systematic residual on Q{p} (RMSE {:.3e} m^3/s, lag-one autocorrelation {:.2}): the command varies faster than it is sampled or the pump has physics Eq. 8 lacks; {} kept as given",
                self.fit.rmse,
                self.autocorrelation,
                self.names.join(", "),
                p = self.pump
            )
        }
    }
}

/// Why a pump's checks were skipped; `Display` gives the note for reports.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PumpSkipped {
    #[error("no `{}` column: pump {pump} checks skipped ({} kept as given)", pump.drive(), kept(*pump))]
    NoDriveCommand { pump: Pump },
    #[error("`{}` or `{}` stays at zero: pump {pump} idle, its checks skipped ({} kept as given)", pump.flow(), pump.drive(), kept(*pump))]
    Idle { pump: Pump },
}

/// The pump's parameters of Eq. (8), `a{i}`, `b_u{i}`, `b_p{i}`.
fn parameter_names(pump: Pump) -> Vec<String> {
    ["a", "b_u", "b_p"].map(|n| pump.name(n)).to_vec()
}

/// The pump's parameters of Eq. (8) as a list, for notes.
fn kept(pump: Pump) -> String {
    parameter_names(pump).join(", ")
}

/// The recording's data for pump i.
struct PumpData<'a> {
    time: &'a [f64],
    q: &'a [f64],
    uc: &'a [f64],
    p: &'a [f64],
    /// Interval k (t_k to t_k+1) holds a fast drive-command change.
    fast: Vec<bool>,
}

impl PumpData<'_> {
    /// Whether sample j enters the cost: not the first, not at the end of a fast interval,
    /// not re-anchored.
    fn counts(&self, j: usize) -> bool {
        j > 0 && !self.fast[j - 1] && !self.anchor(j)
    }

    /// Whether the replay restarts from the measured flow at sample j (after a fast stretch).
    fn anchor(&self, j: usize) -> bool {
        j > 0 && self.fast[j - 1] && !self.fast.get(j).copied().unwrap_or(false)
    }
}

/// Intervals with fast drive-command changes (see the module docs); none when they are
/// the majority.
fn fast_intervals(uc: &[f64]) -> Vec<bool> {
    let d: Vec<f64> = uc.windows(2).map(|w| w[1] - w[0]).collect();
    let m = median(&d);
    let sd = robust_sd(&d);
    let range = span(uc);
    let threshold = (6.0 * sd).max(0.01 * range);
    let fast: Vec<bool> = d.iter().map(|x| (x - m).abs() > threshold).collect();
    if 2 * fast.iter().filter(|&&f| f).count() > fast.len() {
        vec![false; fast.len()]
    } else {
        fast
    }
}

/// Fits pump `pump`. The error says why its checks were skipped (no `uc_i` column, or the
/// pump stays idle).
pub fn fit_pump(rec: &Recording, base: &Params, pump: Pump) -> Result<PumpFit, PumpSkipped> {
    let names = parameter_names(pump);
    let (q_name, uc_name) = (pump.flow(), pump.drive());
    let Some(uc) = rec.column(uc_name) else {
        return Err(PumpSkipped::NoDriveCommand { pump });
    };
    let data = PumpData {
        time: &rec.time,
        q: rec.column(q_name).expect("required column"),
        uc,
        p: rec.column("p").expect("required column"),
        fast: fast_intervals(uc),
    };
    let used: Vec<usize> = (0..data.q.len()).filter(|&j| data.counts(j)).collect();
    let q_peak = data.q.iter().cloned().fold(0.0, f64::max);
    if q_peak <= 0.0 || data.uc.iter().all(|&u| u <= 0.0) {
        return Err(PumpSkipped::Idle { pump });
    }
    let gain = base.get(&pump.name("eta_v")).expect("pump parameter")
        * base.get(&pump.name("D")).expect("pump parameter");
    let given: Vec<f64> = names
        .iter()
        .map(|n| base.get(n).expect("pump parameter"))
        .collect();
    let ls = least_squares(&data, &PumpParams::of(base, pump), q_peak)
        .map(|[a, k_u, k_p]| vec![a, k_u / gain, k_p / gain])
        .unwrap_or_else(|| given.clone());

    let fitted = search_ranges(&names, &given, &ls);
    // Each residual in units of the flow's noise, scaled so that the cost is about 1 when
    // the replay fits to the noise.
    let weight =
        1.0 / (noise_level(data.q).max(NOISE_FLOOR * q_peak) * (used.len().max(1) as f64).sqrt());
    let residual = |u: &[f64]| -> Vec<f64> {
        let q = simulate(&with_values(base, pump, &fitted, u), &data);
        used.iter().map(|&j| (q[j] - data.q[j]) * weight).collect()
    };
    let to_unit =
        |x: &[f64]| -> Vec<f64> { fitted.iter().map(|(i, _, b)| b.to_unit(x[*i])).collect() };
    let solution = refine(&residual, [to_unit(&ls), to_unit(&given)]);
    let best = solution.u;
    let values = bounds::to_phys(&fitted.iter().map(|f| f.2).collect::<Vec<_>>(), &best);
    let q_model = simulate(&with_values(base, pump, &fitted, &best), &data);
    let fit = metrics::fit(&pick(data.q, &used), &pick(&q_model, &used));
    let residual: Vec<f64> = used.iter().map(|&j| data.q[j] - q_model[j]).collect();
    let autocorrelation = lag_one_autocorrelation(&residual);
    Ok(PumpFit {
        pump,
        names: fitted.iter().map(|(_, n, _)| n.clone()).collect(),
        values,
        bounds: fitted.iter().map(|(_, _, b)| (b.lo, b.hi)).collect(),
        fit,
        simulations: 2 + solution.evaluations,
        excluded_samples: data.q.len() - used.len(),
        autocorrelation,
        accepted: autocorrelation < ACCEPT_AUTOCORRELATION || fit.rmse < ACCEPT_RMSE_SHARE * q_peak,
    })
}

/// The log-scaled search range of each parameter of `names` that has a positive given value
/// (else least-squares value, of `ls`): a factor `RANGE_FACTOR` either side, within the
/// variable table's bounds. A parameter with neither stays fixed.
fn search_ranges(names: &[String], given: &[f64], ls: &[f64]) -> Vec<(usize, String, Bounds)> {
    let mut fitted = Vec::new();
    for (i, name) in names.iter().enumerate() {
        let centre = if given[i] > 0.0 { given[i] } else { ls[i] };
        if centre > 0.0 && centre.is_finite() {
            let (min, max) = table_bounds(name);
            let range = (
                (centre / RANGE_FACTOR).max(min),
                (centre * RANGE_FACTOR).min(max),
            );
            if range.0 > 0.0 && range.0 < range.1 {
                fitted.push((i, name.clone(), Bounds::log(range.0, range.1)));
            }
        }
    }
    fitted
}

/// The refinement: the solver from the better of `starts` (the least-squares and the given
/// values, unit coordinates) on the flow residual.
fn refine(residual: &(dyn Fn(&[f64]) -> Vec<f64> + Sync), starts: [Vec<f64>; 2]) -> lm::Solution {
    let cost = |u: &[f64]| residual(u).iter().map(|r| r * r).sum::<f64>();
    let [u_ls, u_given] = starts;
    let start = if cost(&u_ls) <= cost(&u_given) {
        u_ls
    } else {
        u_given
    };
    let batch = |points: &[Vec<f64>]| -> Vec<Option<Vec<f64>>> {
        points.par_iter().map(|u| Some(residual(u))).collect()
    };
    lm::minimize(&batch, &start, &REFINEMENT)
}

/// Lag-one autocorrelation of a residual (0 for white noise; 0 for a constant one).
fn lag_one_autocorrelation(r: &[f64]) -> f64 {
    let mean = r.iter().sum::<f64>() / r.len().max(1) as f64;
    let var: f64 = r.iter().map(|v| (v - mean).powi(2)).sum();
    if var <= 0.0 {
        return 0.0;
    }
    r.windows(2)
        .map(|w| (w[0] - mean) * (w[1] - mean))
        .sum::<f64>()
        / var
}

fn pick(v: &[f64], idx: &[usize]) -> Vec<f64> {
    idx.iter().map(|&j| v[j]).collect()
}

/// The variable table's bounds of a real parameter.
fn table_bounds(name: &str) -> (f64, f64) {
    match by_name(name).map(|v| v.kind) {
        Some(Kind::Real { min, max, .. }) => (min, max),
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    }
}

/// Pump i of `base` with the fitted parameters at unit coordinates `u`.
fn with_values(
    base: &Params,
    pump: Pump,
    fitted: &[(usize, String, Bounds)],
    u: &[f64],
) -> PumpParams {
    let mut p = base.clone();
    for ((_, name, b), &u) in fitted.iter().zip(u) {
        p.set(name, b.to_phys(u))
            .expect("range within the table's bounds");
    }
    PumpParams::of(&p, pump)
}

/// Open-loop replay of Eq. (8) from the first measured flow, re-anchored to the measured
/// flow after each fast stretch; returns the delivered flow at every sample [m^3/s].
fn simulate(pp: &PumpParams, d: &PumpData) -> Vec<f64> {
    let drive = |t: f64| pp.saturate(interpolate(d.time, d.uc, t - pp.delay));
    let mut q = d.q[0].max(0.0);
    let mut out = Vec::with_capacity(d.time.len());
    out.push(pp.delivered(q, d.time[0]));
    for k in 0..d.time.len() - 1 {
        let (t0, t1) = (d.time[k], d.time[k + 1]);
        let pressure = |t: f64| d.p[k] + (t - t0) / (t1 - t0) * (d.p[k + 1] - d.p[k]);
        let f = |t: f64, q: f64| pp.flow_rate(q, drive(t), pressure(t));
        let m = ((t1 - t0) / SUBSTEP).ceil().max(1.0) as usize;
        let h = (t1 - t0) / m as f64;
        for j in 0..m {
            let t = t0 + j as f64 * h;
            q = ode::rk4(&|t, q: &f64| f(t, *q), t, &q, h).max(0.0);
        }
        if d.anchor(k + 1) {
            q = d.q[k + 1].max(0.0);
        }
        out.push(pp.delivered(q, t1));
    }
    out
}

/// Least squares on the integral form of Eq. (8): (a, k_u, k_p), or None when too few
/// windows have the pump delivering.
fn least_squares(d: &PumpData, pp: &PumpParams, q_peak: f64) -> Option<[f64; 3]> {
    let n = d.time.len();
    let dt = median(&d.time.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>());
    let w = ((WINDOW_S / dt).round() as usize).max(2);
    let drive: Vec<f64> = d
        .time
        .iter()
        .map(|&t| pp.saturate(interpolate(d.time, d.uc, t - pp.delay)))
        .collect();
    let mut rows: Vec<[f64; 3]> = Vec::new();
    let mut y = Vec::new();
    for k in 0..n.saturating_sub(w) {
        if d.q[k..=k + w].iter().any(|&q| q < ACTIVE_SHARE * q_peak)
            || d.fast[k..k + w].iter().any(|&f| f)
        {
            continue;
        }
        let t = &d.time[k..=k + w];
        let int = |v: &[f64]| crate::numerics::stats::trapezoid(t, &v[k..=k + w]);
        rows.push([-int(d.q), int(&drive), -int(d.p)]);
        y.push(d.q[k + w] - d.q[k]);
    }
    if rows.len() < 10 {
        return None;
    }
    // Columns scaled to unit norm for conditioning.
    let mut a = DMatrix::from_fn(rows.len(), 3, |i, j| rows[i][j]);
    let scale: Vec<f64> = (0..3)
        .map(|j| a.column(j).norm().max(f64::MIN_POSITIVE))
        .collect();
    for (j, s) in scale.iter().enumerate() {
        a.column_mut(j).unscale_mut(*s);
    }
    let theta = a.svd(true, true).solve(&DVector::from_vec(y), 1e-12).ok()?;
    let est = [
        theta[0] / scale[0],
        theta[1] / scale[1],
        theta[2] / scale[2],
    ];
    est.iter().all(|v| v.is_finite()).then_some(est)
}
