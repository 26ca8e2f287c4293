//! The noise of a recorded signal, estimated from the recording itself (the spectrum of its
//! second differences), and what the method's filters leave of it: the hydromechanics
//! low-pass (the sensor part of the reachable floor, `floor.rs`) and the high-pass under the
//! oscillation envelope (the envelope's noise level, `replay.rs`).

use super::filter::low_pass;
use crate::numerics::stats::median;

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
    pub const SILENT: Noise = Noise {
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
pub fn held_still(y: &[f64]) -> Vec<bool> {
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
/// are left out. Last, the estimate is bounded by the second differences' own spread
/// ([`within_differences`]).
pub fn noise(y: &[f64]) -> Noise {
    within_differences(spectral(y), y)
}

/// Most the spectral estimate may stand above what [`within_differences`] shows before the
/// spectrum is taken to have read signal: the two agree on noise over a smooth signal (the
/// test below), a tone or stick-slip raises the time-domain side only, and on the 400
/// generated evaluation recordings the spectrum stood more than twice above it on 12 of
/// their 2 000 noisy columns, in 10 recordings at 50 or 100 Hz, where the bound came nearer
/// the generator's own noise (docs/diagnose.md, "The reachable floor").
const SPECTRAL_EXCESS_MAX: f64 = 2.0;

/// The spectral estimate scaled down to what the second differences themselves show, where
/// it stands more than `SPECTRAL_EXCESS_MAX` times above it. Each second difference over
/// the samples not held still is divided by the spectral estimate's level at its reading
/// (so a noise that grows with the reading, a flow meter's near a stopped pump, counts
/// alike at every reading); if the estimate is right, those ratios spread as the second
/// difference of unit AR(1) noise does, sqrt(6 - 8 rho + 2 rho^2), and their median absolute
/// deviation, which signal in a minority of the samples does not move, says by how much it
/// is off. The noise cannot spread the second differences more than they are spread. At
/// low rates the spectral fit can read signal as noise: every fifth sample of a 100 Hz
/// recording (20 Hz) gave the displacement's noise as 0.31 mm plus 0.07 % of the reading
/// (against 0.02 mm at 100 Hz), bounded 0.029 mm plus 0.007 %.
fn within_differences(spectral: Noise, y: &[f64]) -> Noise {
    let still = held_still(y);
    let ratios: Vec<f64> = (1..y.len().saturating_sub(1))
        .filter(|&k| !(still[k - 1] || still[k] || still[k + 1]))
        .filter_map(|k| {
            let level = spectral.at(y[k]);
            (level > 0.0).then(|| (y[k + 1] - 2.0 * y[k] + y[k - 1]) / level)
        })
        .collect();
    let centre = median(&ratios);
    let spread: Vec<f64> = ratios.iter().map(|r| r - centre).collect();
    let rho = spectral.rho;
    let unit = (6.0 - 8.0 * rho + 2.0 * rho * rho).sqrt();
    let scale = 1.4826 * median_abs(&spread) / unit;
    if scale <= 0.0 || scale * SPECTRAL_EXCESS_MAX >= 1.0 {
        return spectral;
    }
    Noise {
        sigma: spectral.sigma * scale,
        relative: spectral.relative * scale,
        rho,
    }
}

/// The spectral estimate of [`noise`].
fn spectral(y: &[f64]) -> Noise {
    let d: Vec<f64> = y.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect();
    if d.len() < 2 * WELCH {
        return Noise::SILENT;
    }
    let first = (WELCH as f64 * 0.5 * LOWEST_SHARE).ceil() as usize;
    let bins: Vec<usize> = (first..WELCH / 2).collect();
    let starts = welch_starts(&d);
    if starts.len() < 2 {
        return Noise::SILENT;
    }
    let periodogram = periodogram(&d, &starts, &bins);
    let spectrum: Vec<f64> = periodogram.iter().map(|p| median_abs(p)).collect();
    let Some(rho) = colour(&bins, &spectrum) else {
        return Noise::SILENT;
    };
    let variance = level(&bins, &spectrum, rho) / std::f64::consts::LN_2;
    // Every window's variance with the colour fixed, against its mean square reading.
    let mut windows: Vec<(f64, f64)> = starts
        .iter()
        .enumerate()
        .map(|(j, &s)| {
            let window: Vec<f64> = periodogram.iter().map(|p| p[j]).collect();
            let reading = &y[s + 1..s + 1 + WELCH];
            let square = reading.iter().map(|v| v * v).sum::<f64>() / WELCH as f64;
            (square, level(&bins, &window, rho) / std::f64::consts::LN_2)
        })
        .collect();
    windows.sort_by(|a, b| a.0.total_cmp(&b.0));
    over_reading(&windows, variance, rho)
}

/// The first sample of each Welch window (half-overlapping) of the second differences `d`.
/// A meter that reads exactly the same value throughout a window (a flow meter at zero while
/// its pump idles) shows no noise there: such windows are no sample of it.
fn welch_starts(d: &[f64]) -> Vec<usize> {
    (0..=d.len() - WELCH)
        .step_by(WELCH / 2)
        .filter(|&s| d[s..s + WELCH].iter().any(|v| *v != 0.0))
        .collect()
}

/// The Hann-windowed power of `d` at each of `bins` (of a `WELCH`-sample transform) in each
/// window starting at `starts`: `periodogram[bin][window]`.
fn periodogram(d: &[f64], starts: &[usize], bins: &[usize]) -> Vec<Vec<f64>> {
    use std::f64::consts::PI;
    let window: Vec<f64> = (0..WELCH)
        .map(|k| 0.5 - 0.5 * (2.0 * PI * k as f64 / WELCH as f64).cos())
        .collect();
    let power: f64 = window.iter().map(|w| w * w).sum();
    bins.iter()
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
        .collect()
}

/// The spectrum of the second differences of AR(1) noise of unit variance and correlation
/// `rho` at `bin`.
fn ar1_shape(bin: usize, rho: f64) -> f64 {
    let c = (2.0 * std::f64::consts::PI * bin as f64 / WELCH as f64).cos();
    (1.0 - rho * rho) * (2.0 - 2.0 * c).powi(2) / (1.0 - 2.0 * rho * c + rho * rho)
}

/// The median of `spectrum` over the AR(1) shape of correlation `rho` at `bins`.
fn level(bins: &[usize], spectrum: &[f64], rho: f64) -> f64 {
    let ratios: Vec<f64> = bins
        .iter()
        .zip(spectrum)
        .map(|(&b, p)| p / ar1_shape(b, rho))
        .collect();
    median_abs(&ratios)
}

/// The correlation, on a grid of 19 up to `RHO_MAX`, whose AR(1) shape the spectrum follows
/// best (the least median log-spread about its level); None for a silent spectrum.
fn colour(bins: &[usize], spectrum: &[f64]) -> Option<f64> {
    let mut best = (f64::INFINITY, 0.0);
    for i in 0..=18 {
        let rho = RHO_MAX * i as f64 / 18.0;
        let level = level(bins, spectrum, rho);
        if level <= 0.0 {
            return None;
        }
        let logs: Vec<f64> = bins
            .iter()
            .zip(spectrum)
            .map(|(&b, p)| (p / ar1_shape(b, rho) / level).ln())
            .collect();
        let spread = median_abs(&logs);
        if spread < best.0 {
            best = (spread, rho);
        }
    }
    Some(best.1)
}

/// The noise's absolute part and its part proportional to the reading, from each window's
/// (mean square reading, variance) sorted by the reading: a line through the medians of the
/// lower and the upper half; `variance` over all windows when the level does not grow.
fn over_reading(windows: &[(f64, f64)], variance: f64, rho: f64) -> Noise {
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

/// The impulse response of the hydromechanics low-pass (`filter::low_pass`), every tap.
fn low_pass_taps() -> Vec<f64> {
    let mut impulse = vec![0.0; 33];
    impulse[16] = 1.0;
    low_pass(&impulse)
}

/// RMS of AR(1) noise of unit variance through the filter of `taps`.
fn ar1_gain(taps: &[f64], rho: f64) -> f64 {
    let mut v = 0.0;
    for (i, a) in taps.iter().enumerate() {
        for (j, b) in taps.iter().enumerate() {
            v += a * b * rho.powi((i as i32 - j as i32).abs());
        }
    }
    v.sqrt()
}

/// RMS of AR(1) noise of unit variance after the hydromechanics low-pass (interior samples).
pub fn low_pass_gain(rho: f64) -> f64 {
    ar1_gain(&low_pass_taps(), rho)
}

/// RMS of AR(1) noise of unit variance after the high-pass under the oscillation envelope
/// (the signal minus its low-pass, `filter::envelope`).
fn high_pass_gain(rho: f64) -> f64 {
    let mut taps = low_pass_taps();
    taps.iter_mut().for_each(|t| *t = -*t);
    let centre = taps.len() / 2;
    taps[centre] += 1.0;
    ar1_gain(&taps, rho)
}

/// The noise level of the oscillation envelope of one signal: what its sensor noise alone
/// leaves in a window's RMS of the high-passed signal (`filter::envelope`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvelopeNoise {
    noise: Noise,
    /// [`high_pass_gain`] at the noise's colour.
    gain: f64,
}

impl EnvelopeNoise {
    /// The level estimated from the recorded signal `y`.
    pub fn of(y: &[f64]) -> Self {
        let noise = noise(y);
        EnvelopeNoise {
            noise,
            gain: high_pass_gain(noise.rho),
        }
    }

    /// The noise's RMS after the high-pass over a window of readings `y` [signal unit]
    /// (the level at the window's mean square reading; floored above zero).
    pub fn level(&self, y: &[f64]) -> f64 {
        let square = y.iter().map(|v| v * v).sum::<f64>() / y.len().max(1) as f64;
        (self.noise.at(square.sqrt()) * self.gain).max(1e-12)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::filter::envelope_gaps;
    use crate::numerics::rng::{seeded, Draw};

    /// RMS of the noise over the readings `y` [signal unit].
    fn rms(nz: &Noise, y: &[f64]) -> f64 {
        (y.iter().map(|&v| nz.at(v).powi(2)).sum::<f64>() / y.len() as f64).sqrt()
    }

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

    /// The second differences bound the spectral estimate: one that claims five times the
    /// noise they show is scaled down to it (its shape kept), one within
    /// `SPECTRAL_EXCESS_MAX` of it stands.
    #[test]
    fn the_noise_cannot_exceed_what_the_second_differences_show() {
        let mut rng = seeded(15);
        let y: Vec<f64> = (0..3000)
            .map(|k| 1e-3 * k as f64 + 1e-6 * (k as f64).powi(2) + 2e-5 * rng.normal())
            .collect();
        let claim = |sigma: f64, relative: f64| Noise {
            sigma,
            relative,
            rho: 0.0,
        };
        let bounded = within_differences(claim(1e-4, 0.0), &y);
        assert!((bounded.sigma / 2e-5 - 1.0).abs() < 0.1, "{bounded:?}");
        let shaped = within_differences(claim(5e-5, 5e-5), &y);
        assert!(
            (shaped.relative / shaped.sigma - 1.0).abs() < 1e-9,
            "{shaped:?}"
        );
        let levels: Vec<f64> = y.iter().map(|&v| shaped.at(v)).collect();
        assert!((median(&levels) / 2e-5 - 1.0).abs() < 0.1, "{shaped:?}");
        let within = claim(3e-5, 0.0);
        assert_eq!(within_differences(within, &y), within);
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

    #[test]
    fn low_pass_gain_of_white_noise() {
        assert!((low_pass_gain(0.0) - (85.0f64 / 625.0).sqrt()).abs() < 1e-12);
        assert!(low_pass_gain(0.6) > low_pass_gain(0.0));
    }

    /// A recording of a piston held still: its `x` white noise only. The envelope's level
    /// is the noise's windowed RMS, so a smooth replay leaves no envelope error on average,
    /// and a replay that chatters at 0.6 times the noise (as a stick-slip replay at low speed
    /// does) makes the envelope error larger, not smaller.
    #[test]
    fn a_chattering_replay_matches_noise_no_better_than_a_smooth_one() {
        let sigma = 1e-5;
        let mut rng = seeded(21);
        let y: Vec<f64> = (0..20_000).map(|_| 0.5 + sigma * rng.normal()).collect();
        let level = EnvelopeNoise::of(&y);
        let smooth = vec![0.5; y.len()];
        let chatter: Vec<f64> = (0..y.len())
            .map(|k| 0.5 + 0.6 * sigma * (2.0 * std::f64::consts::PI * 0.23 * k as f64).sin())
            .collect();
        let error = |pred: &[f64]| {
            let gaps = envelope_gaps(&y, pred, |w| level.level(w));
            let mean = gaps.iter().map(|g| g.1).sum::<f64>() / gaps.len() as f64;
            let square = gaps.iter().map(|g| g.1 * g.1).sum::<f64>() / gaps.len() as f64;
            (mean, square)
        };
        let (mean, smooth_square) = error(&smooth);
        assert!(
            mean.abs() < 0.03 * sigma,
            "mean gap {mean:e} of noise {sigma:e}"
        );
        let (_, chatter_square) = error(&chatter);
        assert!(
            chatter_square > smooth_square,
            "chatter {chatter_square:e} against smooth {smooth_square:e}"
        );
    }
}
