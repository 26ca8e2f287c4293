//! Physical plausibility and replication of a candidate's parameters: the value must lie
//! in the range where the effect is physical and visible in this recording, and the fits
//! on the two halves of the data must agree (a two-resample stand-in for the research
//! note's bootstrap inclusion frequency).

use super::effect::Effect;
use super::model::{CrossFit, Prediction};
use super::replay::Bench;
use super::starts::{moving_pressures, peak_rate};
use crate::numerics::stats::quantile;

/// The verdict with the reasons for a rejection.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Verdict {
    pub ok: bool,
    pub reasons: Vec<String>,
}

/// Judges the two fold fits of `effect`.
pub fn plausible(effect: Effect, bench: &Bench, fit: &CrossFit, current: &Prediction) -> Verdict {
    let names = effect.model_parameters();
    let val = |f: usize, i: usize| fit.folds[f].get(names[i]);
    let both = |i: usize| [val(0, i), val(1, i)];
    let mut reasons = Vec::new();
    let mut need = |cond: bool, why: String| {
        if !cond {
            reasons.push(why);
        }
    };
    match effect {
        Effect::StribeckFriction => {
            let f_c = fit.folds[0].params.F_c;
            let excess = both(0).map(|f| f - f_c);
            need(
                excess.iter().all(|e| *e >= 0.05 * f_c),
                format!("breakaway excess {excess:.0?} N below 5 % of F_c"),
            );
            // A hump, not an offset: the excess must have decayed to under half at the
            // typical sliding speed, or it is a raised friction level (F_c or mu).
            let typical = typical_speed(bench);
            need(
                both(1).iter().all(|v| *v >= 2e-4 && (-(typical / v).powi(2)).exp() <= 0.5),
                format!(
                    "v_s {:.4?} m/s: the excess has not decayed to half at the typical sliding speed {:.1} mm/s (a friction offset, not a Stribeck hump)",
                    both(1),
                    typical * 1e3
                ),
            );
            need(
                ratio(excess) <= 2.5,
                format!("halves disagree: F_s - F_c = {excess:.0?} N"),
            );
        }
        Effect::PressureDependentFriction => {
            let mu = both(0);
            need(
                mu.iter().all(|m| (0.002..=0.15).contains(m)),
                format!("mu {mu:.4?} outside 0.002-0.15"),
            );
            need(ratio(mu) <= 2.0, format!("halves disagree: mu = {mu:.4?}"));
        }
        Effect::PositionDependentLoad => {
            let k = both(0);
            let x = bench.s.col("x");
            let travel = x.iter().fold(f64::MIN, |a, &b| a.max(b))
                - x.iter().fold(f64::MAX, |a, &b| a.min(b));
            need(
                k.iter().all(|k| k.abs() * travel >= 100.0),
                format!("k {k:.0?} N/m changes the load by less than 100 N over {travel:.3} m"),
            );
            need(
                k[0] * k[1] > 0.0 && ratio(k.map(f64::abs)) <= 2.0,
                format!("halves disagree: k = {k:.0?} N/m"),
            );
        }
        Effect::EntrainedAir => {
            let a = both(0);
            pressure_span(
                bench,
                "an air fraction cannot be told from a lower beta_e",
                &mut need,
            );
            need(
                a.iter().all(|a| (1e-4..=0.1).contains(a)),
                format!("air fraction {a:.5?} outside 1e-4-0.1"),
            );
            need(
                ratio(a) <= 3.0,
                format!("halves disagree: air fraction = {a:.5?}"),
            );
        }
        Effect::ReliefLeakage => relief(bench, [both(0), both(1)], &mut need),
        Effect::PumpDeadTime(_) => {
            let d = both(0);
            need(
                d.iter().all(|d| (0.008..=0.3).contains(d)),
                format!("delay {d:.4?} s outside 8-300 ms"),
            );
            need(
                (d[0] - d[1]).abs() <= bench.s.dt.max(0.5 * d[0].max(d[1])),
                format!("halves disagree: delay = {d:.4?} s"),
            );
        }
        Effect::PumpFlowLimit(i) => {
            let r = both(0);
            let peak = peak_rate(current.get(i.flow()), bench.s.dt);
            need(
                r.iter().all(|r| *r <= 0.8 * peak),
                format!(
                    "rate limit {} m^3/s^2 does not bind (model peak {peak:.2e})",
                    sci(r)
                ),
            );
            need(
                ratio(r) <= 2.0,
                format!("halves disagree: rate limit = {}", sci(r)),
            );
        }
        Effect::FlowRipple(_) => {
            let (amp, f) = (both(0), both(1));
            let nyquist = 0.5 / bench.s.dt;
            need(
                amp.iter().all(|a| (0.003..=0.3).contains(a)),
                format!("ripple amplitude {amp:.4?} outside 0.3-30 %"),
            );
            let lowest = min_ripple_frequency(bench.s.len() as f64 * bench.s.dt);
            need(
                f.iter().all(|f| *f >= lowest && *f < nyquist - 0.3),
                format!("ripple frequency {f:.2?} Hz below {lowest:.1} Hz (a slow trend, not a pump ripple) or at the Nyquist edge"),
            );
            need(
                (f[0] - f[1]).abs() <= 0.2 && ratio(amp) <= 1.5,
                format!("halves disagree: {amp:.4?}, {f:.2?} Hz"),
            );
        }
    }
    Verdict {
        ok: reasons.is_empty(),
        reasons,
    }
}

/// Median smoothed speed while the piston slides [m/s].
fn typical_speed(bench: &Bench) -> f64 {
    let moving: Vec<f64> = bench
        .v
        .iter()
        .map(|v| v.abs())
        .filter(|v| *v > 1e-3)
        .collect();
    if moving.is_empty() {
        1e-3
    } else {
        quantile(&moving, 0.5)
    }
}

/// Least pressure span (5th to 95th percentile of the recording) over which a
/// pressure-shaped chamber effect can be told from the nominal constants [Pa].
const PRESSURE_SPAN: f64 = 1e6;

fn pressure_span(bench: &Bench, why: &str, need: &mut impl FnMut(bool, String)) {
    let p = bench.s.col("p");
    let span = quantile(p, 0.95) - quantile(p, 0.05);
    need(
        span >= PRESSURE_SPAN,
        format!(
            "the recorded pressure spans only {:.2} MPa (5-95 %): {why}",
            span / 1e6
        ),
    );
}

fn relief(bench: &Bench, v: [[f64; 2]; 2], need: &mut impl FnMut(bool, String)) {
    let (p_crack, k) = (v[0], v[1]);
    pressure_span(
        bench,
        "a cracking characteristic cannot be told from leakage plus a flow offset",
        need,
    );
    let p = moving_pressures(bench);
    let p_top = quantile(&p, 0.98);
    let mean_flow = bench.q_in.iter().map(|q| q.abs()).sum::<f64>() / bench.q_in.len() as f64;
    need(
        p_crack
            .iter()
            .all(|c| *c < p_top && *c > quantile(&p, 0.02)),
        format!(
            "cracking pressure {} Pa outside the recorded pressures",
            sci(p_crack)
        ),
    );
    let leak: Vec<f64> = (0..2)
        .map(|f| k[f] * (p_top - p_crack[f]).max(0.0))
        .collect();
    need(
        leak.iter().all(|l| *l >= 0.01 * mean_flow),
        format!(
            "relief flow {} m^3/s below 1 % of the mean flow",
            sci([leak[0], leak[1]])
        ),
    );
    need(
        (p_crack[0] - p_crack[1]).abs() <= 0.5e6,
        format!("halves disagree: p_crack = {} Pa", sci(p_crack)),
    );
}

/// Lowest frequency a pump ripple can have [Hz]: a piston pump's pulsation runs at
/// (pistons x shaft speed), several hertz even at crawl speed, and a tone must repeat at
/// least 20 times in the recording to be a tone rather than a slow trend.
pub fn min_ripple_frequency(duration: f64) -> f64 {
    2f64.max(20.0 / duration)
}

/// Two values in scientific notation, "[a, b]".
fn sci(v: [f64; 2]) -> String {
    format!("[{:.3e}, {:.3e}]", v[0], v[1])
}

/// Ratio of the larger to the smaller of two positive values (infinite if either is not).
fn ratio(v: [f64; 2]) -> f64 {
    let (lo, hi) = (v[0].min(v[1]), v[0].max(v[1]));
    if lo > 0.0 {
        hi / lo
    } else {
        f64::INFINITY
    }
}
