//! The floor a replay can reach on this recording, signal by signal, estimated from the
//! recording itself: the sensor noise of the compared signal (as the method judges it,
//! low-passed for the hydromechanics) plus what the noise of the recorded inputs and initial
//! states propagates into the replay. A held-out error well above this floor is a misfit,
//! whatever the candidate effects make of it (docs/diagnose.md, "The verdict").

use super::filter::low_pass;
use super::model::{predict, Model, Part};
use super::replay::Bench;
use super::series::{Segment, Series};
use crate::numerics::rng::{seeded, Draw};
use crate::numerics::stats::median;

/// A held-out RMSE above this multiple of its signal's reachable floor is a misfit: the
/// verdict cannot be `adequate` (docs/diagnose.md, "The verdict").
pub const FLOOR_MULTIPLE: f64 = 2.0;

/// Sensor columns whose noise is propagated (commands such as `uc_i` and `v_ref` are written
/// by the controller and are exact).
const SENSORS: [&str; 7] = ["x", "p", "Q1", "Q2", "v", "F_L", "p_t"];
/// Noise realisations averaged for the propagated part.
const REALISATIONS: u64 = 2;
/// Largest sample-to-sample correlation the noise estimate resolves.
const RHO_MAX: f64 = 0.9;

/// First-order (AR(1)) noise whose level may grow with the reading: standard deviation
/// sqrt(sigma^2 + (relative y)^2) at reading y (a pressure transducer's error is a share of
/// its range, a flow meter's a share of its reading) and successive-sample correlation rho.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Noise {
    /// The part independent of the reading [signal unit].
    pub sigma: f64,
    /// The part proportional to the reading [1].
    pub relative: f64,
    pub rho: f64,
}

impl Noise {
    const SILENT: Noise = Noise {
        sigma: 0.0,
        relative: 0.0,
        rho: 0.0,
    };

    /// Standard deviation at reading `y` [signal unit].
    pub fn at(&self, y: f64) -> f64 {
        self.sigma.hypot(self.relative * y)
    }
}

/// Fewest equal successive readings that show a meter held still (a flow meter at zero while
/// its pump idles): no noise there.
const STILL_RUN: usize = 5;

/// Whether each sample lies in a run of at least `STILL_RUN` equal readings.
fn held_still(y: &[f64]) -> Vec<bool> {
    let mut out = vec![false; y.len()];
    let mut start = 0;
    for k in 1..=y.len() {
        if k == y.len() || y[k] != y[start] {
            if k - start >= STILL_RUN {
                out[start..k].iter_mut().for_each(|v| *v = true);
            }
            start = k;
        }
    }
    out
}

/// Welch segment length [samples] of the noise spectrum.
const WELCH: usize = 128;
/// Lowest frequency of the noise fit, as a share of the Nyquist frequency: below it the
/// second difference has almost no noise power left and leakage of the signal dominates.
const LOWEST_SHARE: f64 = 0.1;

/// Robust estimate of a signal's noise from the spectrum of its second differences, which
/// cancel any signal that is smooth over three samples. The spectrum is a Welch estimate
/// (Hann windows of 128 samples, half overlapping) with the median over windows in every
/// bin, so that transients (load steps) do not count; an AR(1) noise shape
/// S(w) = sigma^2 (1 - rho^2) (2 - 2 cos w)^2 / (1 - 2 rho cos w + rho^2) is fitted to it
/// through the median over bins, so that tones (pump ripple, stick-slip near the oil-column
/// mode), which hold few bins, do not count either. The median of a periodogram bin is ln 2
/// times its mean.
///
/// The level may grow with the reading: with the colour fixed, every window's variance is
/// the median over its bins, and the windows are split at the median of their mean square
/// reading; the two halves' median variances against their median mean squares give the
/// absolute and the relative part (a straight line in the squared reading, neither part
/// negative). A noise that does not grow gives two halves alike, up to the spread of the
/// medians. Windows over which the reading does not change at all (a meter held at zero)
/// are left out.
pub fn noise(y: &[f64]) -> Noise {
    use std::f64::consts::{LN_2, PI};
    let d: Vec<f64> = y.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect();
    if d.len() < 2 * WELCH {
        return Noise::SILENT;
    }
    let window: Vec<f64> = (0..WELCH)
        .map(|k| 0.5 - 0.5 * (2.0 * PI * k as f64 / WELCH as f64).cos())
        .collect();
    let power: f64 = window.iter().map(|w| w * w).sum();
    let first = (WELCH as f64 * 0.5 * LOWEST_SHARE).ceil() as usize;
    let bins: Vec<usize> = (first..WELCH / 2).collect();
    // A meter that reads exactly the same value throughout a window (a flow meter at zero
    // while its pump idles) shows no noise there: such windows are no sample of it.
    let starts: Vec<usize> = (0..=d.len() - WELCH)
        .step_by(WELCH / 2)
        .filter(|&s| d[s..s + WELCH].iter().any(|v| *v != 0.0))
        .collect();
    if starts.len() < 2 {
        return Noise::SILENT;
    }
    // periodogram[bin][window]
    let periodogram: Vec<Vec<f64>> = bins
        .iter()
        .map(|&b| {
            let w = 2.0 * PI * b as f64 / WELCH as f64;
            let (cos, sin): (Vec<f64>, Vec<f64>) = (0..WELCH)
                .map(|k| ((w * k as f64).cos(), (w * k as f64).sin()))
                .unzip();
            starts
                .iter()
                .map(|&s| {
                    let (mut re, mut im) = (0.0, 0.0);
                    for k in 0..WELCH {
                        let v = window[k] * d[s + k];
                        re += v * cos[k];
                        im -= v * sin[k];
                    }
                    (re * re + im * im) / power
                })
                .collect()
        })
        .collect();
    let spectrum: Vec<f64> = periodogram.iter().map(|p| median_abs(p)).collect();
    let shape = |b: usize, rho: f64| {
        let c = (2.0 * PI * b as f64 / WELCH as f64).cos();
        (1.0 - rho * rho) * (2.0 - 2.0 * c).powi(2) / (1.0 - 2.0 * rho * c + rho * rho)
    };
    let mut best = (f64::INFINITY, 0.0, 0.0);
    for i in 0..=18 {
        let rho = RHO_MAX * i as f64 / 18.0;
        let ratios: Vec<f64> = bins
            .iter()
            .zip(&spectrum)
            .map(|(&b, p)| p / shape(b, rho))
            .collect();
        let level = median_abs(&ratios);
        if level <= 0.0 {
            return Noise::SILENT;
        }
        let logs: Vec<f64> = ratios.iter().map(|r| (r / level).ln()).collect();
        let spread = median_abs(&logs);
        if spread < best.0 {
            best = (spread, level / LN_2, rho);
        }
    }
    let (_, variance, rho) = best;
    // Every window's variance with the colour fixed, against its mean square reading.
    let mut windows: Vec<(f64, f64)> = starts
        .iter()
        .enumerate()
        .map(|(j, &s)| {
            let ratios: Vec<f64> = bins
                .iter()
                .zip(&periodogram)
                .map(|(&b, p)| p[j] / shape(b, rho))
                .collect();
            let reading = &y[s + 1..s + 1 + WELCH];
            let square = reading.iter().map(|v| v * v).sum::<f64>() / WELCH as f64;
            (square, median_abs(&ratios) / LN_2)
        })
        .collect();
    windows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (low, high) = windows.split_at(windows.len() / 2);
    let medians = |half: &[(f64, f64)]| {
        let (m, v): (Vec<f64>, Vec<f64>) = half.iter().copied().unzip();
        (median_abs(&m), median_abs(&v))
    };
    let ((m_lo, v_lo), (m_hi, v_hi)) = (medians(low), medians(high));
    let slope = if m_hi > m_lo {
        ((v_hi - v_lo) / (m_hi - m_lo)).max(0.0)
    } else {
        0.0
    };
    if slope == 0.0 {
        return Noise {
            sigma: variance.sqrt(),
            relative: 0.0,
            rho,
        };
    }
    let intercept = v_lo - slope * m_lo;
    if intercept >= 0.0 {
        return Noise {
            sigma: intercept.sqrt(),
            relative: slope.sqrt(),
            rho,
        };
    }
    // A line through both halves would need a negative absolute part (halves of nearly
    // the same reading make it steep by chance): the noise proportional to the reading
    // that fits both halves best.
    Noise {
        sigma: 0.0,
        relative: ((v_lo * m_lo + v_hi * m_hi) / (m_lo * m_lo + m_hi * m_hi)).sqrt(),
        rho,
    }
}

/// Median of |values| (0 for none).
fn median_abs(values: &[f64]) -> f64 {
    let a: Vec<f64> = values.iter().map(|v| v.abs()).collect();
    if a.is_empty() {
        0.0
    } else {
        median(&a)
    }
}

/// RMS of AR(1) noise of unit variance after the hydromechanics low-pass (interior samples).
fn low_pass_gain(rho: f64) -> f64 {
    // Two centred 5-sample moving averages: a 9-tap triangle (1 2 3 4 5 4 3 2 1) / 25.
    let h: Vec<f64> = (1..=9)
        .map(|i: i32| (5 - (i - 5).abs()) as f64 / 25.0)
        .collect();
    let mut v = 0.0;
    for (i, a) in h.iter().enumerate() {
        for (j, b) in h.iter().enumerate() {
            v += a * b * rho.powi((i as i32 - j as i32).abs());
        }
    }
    v.sqrt()
}

/// The reachable floor of one judged signal [signal unit].
#[derive(Clone, Debug, PartialEq)]
pub struct Floor {
    pub signal: &'static str,
    /// The compared signal's own sensor noise, as judged.
    pub sensor: f64,
    /// RMS of the replay's change when the recorded inputs and initial states carry another
    /// realisation of their estimated noise.
    pub propagated: f64,
    /// RMS of the replay's change when the sampled inputs (drive commands, pump flows, load)
    /// are read the other way between samples (`Bench::other_reading`): what the sampling leaves
    /// unknown.
    pub sampling: f64,
    /// The same three parts' variance at every sample of the record (0 outside the part's
    /// segments) [signal unit^2]: the sensor noise at the sample's reading, the squared
    /// changes of the perturbed replay and of the replay with
    /// the inputs read the other way there. Its mean over the segments is
    /// `total()^2`; the sampling part concentrates in fast transients.
    pub variance: Vec<f64>,
}

impl Floor {
    /// sqrt(sensor^2 + propagated^2 + sampling^2).
    pub fn total(&self) -> f64 {
        self.sensor.hypot(self.propagated).hypot(self.sampling)
    }

    /// The floor's RMS over `samples` [signal unit].
    pub fn over(&self, samples: &[usize]) -> f64 {
        if samples.is_empty() {
            return self.total();
        }
        (samples.iter().map(|&k| self.variance[k]).sum::<f64>() / samples.len() as f64).sqrt()
    }
}

/// Adds `d`'s squares from `start` on to `acc`'s entry for `name` (created at the record's
/// length `n`), scaled by `scale`.
fn accumulate(
    acc: &mut Vec<(&'static str, Vec<f64>)>,
    name: &'static str,
    n: usize,
    start: usize,
    d: &[f64],
    scale: f64,
) {
    let slot = match acc.iter().position(|s| s.0 == name) {
        Some(i) => i,
        None => {
            acc.push((name, vec![0.0; n]));
            acc.len() - 1
        }
    };
    for (v, d) in acc[slot].1[start..start + d.len()].iter_mut().zip(d) {
        *v += scale * d * d;
    }
}

/// The floor of every signal the parts predict, each part replayed with `models[i]`.
pub fn floors(series: &Series, parts: &[(Part, Model, Vec<Segment>)]) -> Vec<Floor> {
    let bench = Bench::new(series);
    let mut other = Bench::new(series);
    other.other_reading = true;
    let noises: Vec<(&str, Noise, Vec<bool>)> = SENSORS
        .iter()
        .filter_map(|&n| series.get(n).map(|y| (n, noise(y), held_still(y))))
        .collect();
    let n = series.len();
    let mut out = Vec::new();
    for (part, model, segs) in parts {
        let hydro = *part == Part::Hydro;
        let judged = |d: Vec<f64>| if hydro { low_pass(&d) } else { d };
        // Squared changes per sample: of the perturbed replays (mean over realisations) and
        // of the replay with the inputs read the other way.
        let mut propagated: Vec<(&'static str, Vec<f64>)> = Vec::new();
        let mut sampling: Vec<(&'static str, Vec<f64>)> = Vec::new();
        let reference: Vec<_> = segs
            .iter()
            .map(|seg| predict(&bench, model, *part, *seg))
            .collect();
        for (seg, a) in segs.iter().zip(&reference) {
            let b = predict(&other, model, *part, *seg);
            for ((name, pa), (_, pb)) in a.iter().zip(&b) {
                let d = judged(pa.iter().zip(pb).map(|(a, b)| a - b).collect());
                accumulate(&mut sampling, name, n, seg.start, &d, 1.0);
            }
        }
        for r in 0..REALISATIONS {
            let mut rng = seeded(0x5EED_F100 + r);
            let mut perturbed = series.clone();
            for (name, nz, still) in &noises {
                let y = series.col(name);
                let e = rng.coloured(y.len(), nz.rho);
                perturbed.set_column(
                    name,
                    (0..y.len())
                        .map(|k| y[k] + if still[k] { 0.0 } else { nz.at(y[k]) * e[k] })
                        .collect(),
                );
            }
            let noisy = Bench::new(&perturbed);
            for (seg, a) in segs.iter().zip(&reference) {
                let b = predict(&noisy, model, *part, *seg);
                for ((name, pa), (_, pb)) in a.iter().zip(&b) {
                    let d = judged(pa.iter().zip(pb).map(|(a, b)| a - b).collect());
                    accumulate(
                        &mut propagated,
                        name,
                        n,
                        seg.start,
                        &d,
                        1.0 / REALISATIONS as f64,
                    );
                }
            }
        }
        let samples: Vec<usize> = segs.iter().flat_map(|s| s.start..s.end).collect();
        let mean = |v: &[f64]| {
            (samples.iter().map(|&k| v[k]).sum::<f64>() / samples.len().max(1) as f64).sqrt()
        };
        for (name, prop) in propagated {
            let (nz, still) = noises
                .iter()
                .find(|(n, _, _)| *n == name)
                .map_or((Noise::SILENT, None), |x| (x.1, Some(&x.2)));
            let gain = if hydro { low_pass_gain(nz.rho) } else { 1.0 };
            let y = series.col(name);
            let held = sampling
                .iter()
                .find(|s| s.0 == name)
                .map_or(vec![0.0; n], |s| s.1.clone());
            let sensor: Vec<f64> = (0..n)
                .map(|k| {
                    if still.is_some_and(|s| s[k]) {
                        0.0
                    } else {
                        (nz.at(y[k]) * gain).powi(2)
                    }
                })
                .collect();
            let mut variance = vec![0.0; n];
            for &k in &samples {
                variance[k] = sensor[k] + prop[k] + held[k];
            }
            out.push(Floor {
                signal: name,
                sensor: mean(&sensor),
                propagated: mean(&prop),
                sampling: mean(&held),
                variance,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    /// RMS of the noise over the readings `y` [signal unit].
    fn rms(nz: &super::Noise, y: &[f64]) -> f64 {
        (y.iter().map(|&v| nz.at(v).powi(2)).sum::<f64>() / y.len() as f64).sqrt()
    }

    use super::*;

    #[test]
    fn noise_level_and_colour_of_ar1_on_a_parabola() {
        for rho in [0.0, 0.3, 0.6] {
            let mut rng = seeded(11);
            let e = rng.coloured(20_000, rho);
            let y: Vec<f64> = e
                .iter()
                .enumerate()
                .map(|(k, e)| 1e-6 * (k as f64).powi(2) + 0.5 * e)
                .collect();
            let nz = noise(&y);
            assert!(
                (rms(&nz, &y) - 0.5).abs() < 0.05 && (nz.rho - rho).abs() < 0.1,
                "{rho}: {nz:?}"
            );
        }
    }

    #[test]
    fn noise_that_grows_with_the_reading() {
        // A flow that ramps between 0.1 and 1 with 1 % of the reading as noise: the RMS over
        // the record is that of the readings, not that of the quiet half.
        let mut rng = seeded(13);
        let y: Vec<f64> = (0..6000)
            .map(|k| {
                let q = 0.55 + 0.45 * (2.0 * std::f64::consts::PI * k as f64 / 3000.0).sin();
                q * (1.0 + 0.01 * rng.normal())
            })
            .collect();
        let nz = noise(&y);
        let truth = (y.iter().map(|q| (0.01 * q).powi(2)).sum::<f64>() / y.len() as f64).sqrt();
        assert!((rms(&nz, &y) / truth - 1.0).abs() < 0.15, "{nz:?}");
        assert!((nz.relative - 0.01).abs() < 0.002, "{nz:?}");
    }

    #[test]
    fn a_tone_is_not_taken_for_noise() {
        // A 2 % ripple at 18 Hz (sampled at 100 Hz) on a flow with 1 % white noise.
        let mut rng = seeded(12);
        let y: Vec<f64> = (0..3000)
            .map(|k| {
                let t = k as f64 * 0.01;
                1.0 + 0.02 * (2.0 * std::f64::consts::PI * 18.0 * t).sin() + 0.01 * rng.normal()
            })
            .collect();
        let nz = noise(&y);
        assert!((rms(&nz, &y) - 0.01).abs() < 0.002, "{nz:?}");
    }

    #[test]
    fn a_meter_held_at_zero_is_no_sample_of_its_noise() {
        // A flow meter that reads exactly zero for 70 % of the record (its pump idles) and
        // a flow with 2 % noise otherwise: the noise is read off the delivering windows.
        let mut rng = seeded(14);
        let y: Vec<f64> = (0..10_000)
            .map(|k| {
                if k < 7000 {
                    0.0
                } else {
                    1.0 + 0.02 * rng.normal()
                }
            })
            .collect();
        let nz = noise(&y);
        assert!((nz.at(1.0) - 0.02).abs() < 0.004, "{nz:?}");
        let still = held_still(&y);
        assert!(still[..7000].iter().all(|s| *s) && !still[7000..].iter().any(|s| *s));
    }

    /// An effect-free load-step programme at 500 Hz (tune seed 122): every load step falls
    /// between two samples, and the replay, which holds the recorded load, steps at the next
    /// one. The floor's sampling part reads the load the other way (interpolated), so the
    /// pressure's excess at the steps is within the floor and the recording is adequate.
    #[test]
    fn a_load_step_between_samples_is_part_of_the_floor() {
        use crate::diagnose::{diagnose, prepare::prepare, series::Series};
        use crate::synth::{BenchScenario, Case, LoopFamily, Variation};
        use tbm_thrust::{Controller, Params, Scheme};
        let variation = Variation {
            sample_period: 0.002,
            time_offset: 1.71,
            noise_scale: 0.62,
            absent: vec![],
            family: LoopFamily::PI,
            main_tau: 0.31,
            main_size: 0.53,
            aux_tau: 0.069,
            aux_size: 1.86,
            magnitude: 0.86,
            relief_in_plateau: true,
        };
        let case = Case {
            controller: Controller::Adrc,
            substeps: 3,
            jitter: 8.8e-5,
            variation: Some(variation),
            ..Case::new(BenchScenario::LoadSteps, Scheme::FixedSplit, vec![], 122)
        };
        let series = Series::generated(&case);
        let prepared = prepare(&series, &Params::default()).expect("prepares");
        let p = prepared.floors.iter().find(|f| f.signal == "p").expect("p");
        assert!(
            p.sampling > p.sensor,
            "sampling {} Pa, sensor {} Pa",
            p.sampling,
            p.sensor
        );
        let d = diagnose(&series, &Params::default()).expect("runs");
        assert_eq!(d.verdict(), "adequate", "{:?}", d.notes);
    }

    #[test]
    fn low_pass_gain_of_white_noise() {
        assert!((low_pass_gain(0.0) - (85.0f64 / 625.0).sqrt()).abs() < 1e-12);
        assert!(low_pass_gain(0.6) > low_pass_gain(0.0));
    }
}
