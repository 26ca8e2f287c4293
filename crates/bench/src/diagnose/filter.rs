//! The filters the method judges signals through: the hydromechanics low-pass (two centred
//! moving averages) and the oscillation envelope, and a signal with its replay as judged.

use super::series::{Segment, Series};

/// Half-width of each of the two moving averages of the hydromechanics low-pass.
const LOW_PASS_HALF: usize = 2;
/// Window of the oscillation envelope [samples].
pub const ENVELOPE_WINDOW: usize = 20;

/// The hydromechanics low-pass: two centred 5-sample moving averages.
pub fn low_pass(e: &[f64]) -> Vec<f64> {
    moving_average(&moving_average(e, LOW_PASS_HALF), LOW_PASS_HALF)
}

/// RMS of the high-passed signal per window, at each window's first sample.
pub fn envelope(y: &[f64]) -> Vec<(usize, f64)> {
    let lp = low_pass(y);
    let hp: Vec<f64> = y.iter().zip(&lp).map(|(a, b)| a - b).collect();
    hp.chunks(ENVELOPE_WINDOW)
        .enumerate()
        .filter(|(_, c)| c.len() * 2 >= ENVELOPE_WINDOW)
        .map(|(i, c)| {
            (
                i * ENVELOPE_WINDOW,
                (c.iter().map(|v| v * v).sum::<f64>() / c.len() as f64).sqrt(),
            )
        })
        .collect()
}

/// The oscillation-envelope error per window, in the signal's unit, at each window's first
/// sample: measured RMS of the high-passed signal minus sqrt(model^2 + level^2), `level`
/// the noise's RMS there given the window's recorded readings; with that level.
pub fn envelope_gaps(
    y: &[f64],
    pred: &[f64],
    level: impl Fn(&[f64]) -> f64,
) -> Vec<(usize, f64, f64)> {
    envelope(y)
        .into_iter()
        .zip(envelope(pred))
        .map(|((k, em), (_, ep))| {
            let l = level(&y[k..(k + ENVELOPE_WINDOW).min(y.len())]);
            (k, em - ep.hypot(l), l)
        })
        .collect()
}

/// [`envelope_gaps`] per sample, each window's value held over its samples.
pub fn envelope_gap(y: &[f64], pred: &[f64], level: impl Fn(&[f64]) -> f64) -> Vec<f64> {
    let mut out = vec![0.0; y.len()];
    for (k, gap, _) in envelope_gaps(y, pred, level) {
        let end = (k + ENVELOPE_WINDOW).min(y.len());
        out[k..end].iter_mut().for_each(|v| *v = gap);
    }
    out
}

/// Centred moving average over +-half samples, shrinking at the ends.
pub fn moving_average(e: &[f64], half: usize) -> Vec<f64> {
    let n = e.len();
    let mut prefix = vec![0.0; n + 1];
    for k in 0..n {
        prefix[k + 1] = prefix[k] + e[k];
    }
    (0..n)
        .map(|k| {
            let lo = k.saturating_sub(half);
            let hi = (k + half + 1).min(n);
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

/// Centred running median over +-half samples, shrinking at the ends: it keeps a monotone
/// run (a ramp, a step) as it is and removes an oscillation whose period the window spans.
pub fn running_median(y: &[f64], half: usize) -> Vec<f64> {
    let n = y.len();
    let mut window = Vec::with_capacity(2 * half + 1);
    (0..n)
        .map(|k| {
            window.clear();
            window.extend_from_slice(&y[k.saturating_sub(half)..(k + half + 1).min(n)]);
            let mid = window.len() / 2;
            *window.select_nth_unstable_by(mid, f64::total_cmp).1
        })
        .collect()
}

/// A measured signal and its replay as the method judges them (see [`fits`]).
pub fn judged(series: &Series, segs: &[Segment], name: &str, pred: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let y = series.col(name);
    if name.starts_with('Q') {
        return (y.to_vec(), pred.to_vec());
    }
    let (mut ly, mut lm) = (vec![0.0; y.len()], vec![0.0; y.len()]);
    for s in segs {
        let (ys, ps) = (&y[s.start..s.end], &pred[s.start..s.end]);
        let e: Vec<f64> = ys.iter().zip(ps).map(|(a, b)| a - b).collect();
        let level = low_pass(ys);
        let judged = hydro_error(name, &e);
        for (k, (l, d)) in level.iter().zip(&judged).enumerate() {
            ly[s.start + k] = *l;
            lm[s.start + k] = l - d;
        }
    }
    (ly, lm)
}

/// A hydromechanics error over one segment as the method judges it: low-passed and, for `x`,
/// taken about its mean over the segment. A replay starts from an estimate of the recorded
/// displacement, and an integrator keeps that estimate's error as a constant offset through
/// the whole segment, the same for every model; a model is judged on the course it predicts
/// from there, as with the start displacement fitted by least squares.
pub fn hydro_error(name: &str, e: &[f64]) -> Vec<f64> {
    let mut out = low_pass(e);
    if name == "x" && !out.is_empty() {
        let mean = out.iter().sum::<f64>() / out.len() as f64;
        out.iter_mut().for_each(|v| *v -= mean);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error a wrong start displacement leaves (a constant offset, kept by the integrator
    /// through the segment) is not charged to `x`; a pressure offset is charged to `p`.
    #[test]
    fn a_constant_offset_is_judged_out_of_x_only() {
        let course = |k: usize| 2e-6 * (k as f64 * 0.05).sin();
        let e: Vec<f64> = (0..300).map(|k| 1e-4 + course(k)).collect();
        let x = hydro_error("x", &e);
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!(mean(&x).abs() < 1e-12);
        assert!(x.iter().all(|v| v.abs() < 1e-5), "{x:?}");
        let p = hydro_error("p", &e);
        assert!((mean(&p) - 1e-4).abs() < 1e-6);
    }

    /// A ramp with a step is kept as it is (away from the ends, where the window shrinks to
    /// one side); a tone whose period the window spans is removed.
    #[test]
    fn running_median_keeps_a_ramp_and_removes_a_tone() {
        let ramp: Vec<f64> = (0..200)
            .map(|k| k as f64 * 0.01 + if k > 120 { 1.0 } else { 0.0 })
            .collect();
        assert_eq!(running_median(&ramp, 10)[10..190], ramp[10..190]);
        let tone: Vec<f64> = (0..200)
            .map(|k| 2.0 + 0.1 * (2.0 * std::f64::consts::PI * k as f64 / 20.0).sin())
            .collect();
        let smooth = running_median(&tone, 10);
        assert!(
            smooth[10..190].iter().all(|v| (v - 2.0).abs() < 0.02),
            "{smooth:?}"
        );
    }
}
