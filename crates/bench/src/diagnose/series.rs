//! The recording on a uniform time grid, with what the diagnosis derives from it: smoothed
//! displacement and velocity, noise levels, and the blocked split into segments and folds.

use super::error::Error;
use super::note::Note;
use crate::numerics::stats::interpolate_uniform;
use std::collections::BTreeMap;

/// Signals on a uniform grid t_k = t0 + k dt (SI units).
#[derive(Clone, Debug)]
pub struct Series {
    pub t0: f64,
    /// Sample period [s].
    pub dt: f64,
    /// Named columns, all of the grid's length.
    columns: BTreeMap<String, Vec<f64>>,
    /// What was resampled or could not be used.
    pub notes: Vec<Note>,
}

/// The columns the diagnosis reads.
pub const USED: [&str; 12] = [
    "x", "p", "Q1", "Q2", "v", "uc1", "uc2", "u1", "u2", "F_L", "p_t", "v_ref",
];
/// Fewest samples the diagnosis works with (4 s at 100 Hz).
pub const MIN_SAMPLES: usize = 400;

impl Series {
    /// The series of a generated case (for tests).
    #[cfg(test)]
    pub fn generated(case: &crate::synth::Case) -> Series {
        let csv = crate::synth::generate(case).expect("case generates").csv;
        let rec = crate::recording::Recording::parse(&csv, "bench").expect("parses");
        Series::from_recording(&rec).expect("grid")
    }

    /// Builds the grid from (possibly unevenly sampled) columns; `get(name)` gives a column
    /// at the sample times `time`. Uneven sampling is resampled linearly at the median step.
    pub fn from_columns(
        time: &[f64],
        get: impl Fn(&str) -> Option<Vec<f64>>,
    ) -> Result<Series, Error> {
        if time.len() < MIN_SAMPLES {
            return Err(Error::TooFewSamples {
                samples: time.len(),
                min: MIN_SAMPLES,
            });
        }
        let (t0, dt, deviation) = grid_fit(time);
        let mut notes = Vec::new();
        let mut columns = BTreeMap::new();
        if deviation <= JITTER_SHARE * dt {
            // A uniform grid whose stamps jitter (a logger clock): the samples belong on it.
            if deviation > 0.01 * dt {
                notes.push(Note::Jitter {
                    deviation_s: deviation,
                    step_s: dt,
                });
            }
            for name in USED {
                if let Some(values) = get(name) {
                    columns.insert(name.to_string(), values);
                }
            }
        } else {
            let mut steps: Vec<f64> = time.windows(2).map(|w| w[1] - w[0]).collect();
            steps.sort_by(f64::total_cmp);
            let dt = steps[steps.len() / 2];
            let n = ((time[time.len() - 1] - time[0]) / dt).floor() as usize + 1;
            let grid: Vec<f64> = (0..n).map(|k| time[0] + k as f64 * dt).collect();
            notes.push(Note::Resampled { step_s: dt });
            for name in USED {
                if let Some(values) = get(name) {
                    columns.insert(name.to_string(), resample(time, &values, &grid));
                }
            }
            return Series::checked(time[0], dt, columns, notes);
        }
        Series::checked(t0, dt, columns, notes)
    }

    fn checked(
        t0: f64,
        dt: f64,
        columns: BTreeMap<String, Vec<f64>>,
        notes: Vec<Note>,
    ) -> Result<Series, Error> {
        for name in ["x", "p", "Q1", "Q2"] {
            if !columns.contains_key(name) {
                return Err(Error::MissingColumn(name));
            }
        }
        Ok(Series {
            t0,
            dt,
            columns,
            notes,
        })
    }

    /// The grid of a checked recording; its reader's notes come along.
    pub fn from_recording(rec: &crate::recording::Recording) -> Result<Series, Error> {
        let mut s = Series::from_columns(&rec.time, |n| rec.column(n).map(<[f64]>::to_vec))
            .map_err(|e| Error::Recording {
                source_name: rec.source.clone(),
                error: Box::new(e),
            })?;
        // The reader's note on uneven sampling describes its own replay; this grid's own note
        // (resampling) replaces it.
        let mut notes: Vec<Note> = rec
            .notes()
            .iter()
            .filter(|n| !matches!(n, crate::recording::Note::UnevenSampling { .. }))
            .cloned()
            .map(Note::Reader)
            .collect();
        notes.append(&mut s.notes);
        s.notes = notes;
        Ok(s)
    }

    pub fn len(&self) -> usize {
        self.columns["x"].len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn time(&self, k: usize) -> f64 {
        self.t0 + k as f64 * self.dt
    }

    pub fn times(&self) -> Vec<f64> {
        (0..self.len()).map(|k| self.time(k)).collect()
    }

    pub fn has(&self, name: &str) -> bool {
        self.columns.contains_key(name)
    }

    /// A column; panics for a required column that is absent (checked at construction).
    pub fn col(&self, name: &str) -> &[f64] {
        self.columns
            .get(name)
            .map(Vec::as_slice)
            .unwrap_or_else(|| panic!("column `{name}` checked at construction"))
    }

    pub fn get(&self, name: &str) -> Option<&[f64]> {
        self.columns.get(name).map(Vec::as_slice)
    }

    /// Replaces (or adds) a column of the grid's length.
    pub fn set_column(&mut self, name: &str, values: Vec<f64>) {
        assert_eq!(values.len(), self.len(), "column `{name}` on the grid");
        self.columns.insert(name.to_string(), values);
    }

    /// A column held from each sample to the next (zero-order hold) at time t.
    pub fn held(&self, values: &[f64], t: f64) -> f64 {
        // Truncation after max(0) is the floor (see `interpolate_uniform`).
        let k = ((t - self.t0) / self.dt + 1e-9).max(0.0) as usize;
        values[k.min(values.len() - 1)]
    }

    /// Linear interpolation of a column at time t (held beyond the ends).
    pub fn at(&self, values: &[f64], t: f64) -> f64 {
        interpolate_uniform(self.t0, self.dt, values, t)
    }
}

/// Largest deviation of the stamps from a uniform grid, as a share of its step, below which
/// the samples are taken to lie on the grid (logger jitter rather than uneven sampling).
const JITTER_SHARE: f64 = 0.25;

/// Least-squares uniform grid through the stamps: (start, step, largest deviation) [s].
fn grid_fit(time: &[f64]) -> (f64, f64, f64) {
    let n = time.len() as f64;
    let mean_k = (n - 1.0) / 2.0;
    let mean_t = time.iter().sum::<f64>() / n;
    let (mut skt, mut skk) = (0.0, 0.0);
    for (k, t) in time.iter().enumerate() {
        let dk = k as f64 - mean_k;
        skt += dk * (t - mean_t);
        skk += dk * dk;
    }
    let dt = skt / skk;
    let t0 = mean_t - dt * mean_k;
    let deviation = time
        .iter()
        .enumerate()
        .map(|(k, t)| (t - t0 - k as f64 * dt).abs())
        .fold(0.0, f64::max);
    (t0, dt, deviation)
}

/// Linear resampling of (time, values) onto `grid`.
fn resample(time: &[f64], values: &[f64], grid: &[f64]) -> Vec<f64> {
    let mut j = 0;
    grid.iter()
        .map(|&t| {
            while j + 2 < time.len() && time[j + 1] < t {
                j += 1;
            }
            let (t0, t1) = (time[j], time[j + 1]);
            let f = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
            values[j] + f * (values[j + 1] - values[j])
        })
        .collect()
}

/// Savitzky-Golay quadratic fit over +-half samples: (value, slope per sample) at every k.
pub fn local_quadratic(y: &[f64], half: usize) -> Vec<(f64, f64)> {
    let n = y.len();
    (0..n)
        .map(|k| {
            let lo = k.saturating_sub(half);
            let hi = (k + half).min(n - 1);
            fit_quadratic(&y[lo..=hi], k - lo)
        })
        .collect()
}

/// Least-squares quadratic through `y` (unit spacing) evaluated at index `at`: (value, slope).
fn fit_quadratic(y: &[f64], at: usize) -> (f64, f64) {
    let m = y.len();
    if m < 3 {
        return (y[at], if m == 2 { y[1] - y[0] } else { 0.0 });
    }
    let mut s = [0.0f64; 5];
    let mut r = [0.0f64; 3];
    for (i, &v) in y.iter().enumerate() {
        let u = i as f64 - at as f64;
        let mut pw = 1.0;
        for (j, sj) in s.iter_mut().enumerate() {
            *sj += pw;
            if j < 3 {
                r[j] += pw * v;
            }
            pw *= u;
        }
    }
    let a = nalgebra::Matrix3::new(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
    match a.lu().solve(&nalgebra::Vector3::new(r[0], r[1], r[2])) {
        Some(c) => (c[0], c[1]),
        None => (y[at], 0.0),
    }
}

/// Smoothed velocity from displacement [m/s] (local quadratic over +-`half` samples).
pub fn velocity(s: &Series, half: usize) -> Vec<f64> {
    local_quadratic(s.col("x"), half)
        .iter()
        .map(|(_, d)| d / s.dt)
        .collect()
}

/// Causal quadratic fit over the `len` samples up to and including k: (value, slope per
/// sample) at k. Used for replay initial states, which must not see what follows a step.
pub fn backward_quadratic(y: &[f64], len: usize) -> Vec<(f64, f64)> {
    (0..y.len())
        .map(|k| {
            let lo = (k + 1).saturating_sub(len);
            fit_quadratic(&y[lo..=k], k - lo)
        })
        .collect()
}

/// The end value of the straight line through `y` and how far its quadratic term stands
/// from zero, in standard errors under white noise of level `sigma`; none for fewer than
/// five samples.
pub fn line_end(y: &[f64], sigma: f64) -> Option<(f64, f64)> {
    let n = y.len();
    if n < 5 {
        return None;
    }
    let nf = n as f64;
    let mid = (nf - 1.0) / 2.0;
    let p2 = |i: usize| (i as f64 - mid).powi(2) - (nf * nf - 1.0) / 12.0;
    let p2_norm = nf * (nf * nf - 1.0) * (nf * nf - 4.0) / 180.0;
    let c2 = y.iter().enumerate().map(|(i, v)| v * p2(i)).sum::<f64>() / p2_norm;
    let mean = y.iter().sum::<f64>() / nf;
    let slope = y
        .iter()
        .enumerate()
        .map(|(i, v)| v * (i as f64 - mid))
        .sum::<f64>()
        / (nf * (nf * nf - 1.0) / 12.0);
    Some((mean + slope * mid, c2.abs() * p2_norm.sqrt() / sigma))
}

/// Largest sample-to-sample slope of a flow [m^3/s^2].
pub fn peak_rate(q: &[f64], dt: f64) -> f64 {
    q.windows(2)
        .map(|w| (w[1] - w[0]).abs() / dt)
        .fold(0.0, f64::max)
        .max(1e-9)
}

/// One contiguous stretch simulated from the recorded state at its start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// First and one-past-last sample index.
    pub start: usize,
    pub end: usize,
    /// Fold 0 or 1 (alternating), for blocked two-fold cross-fitting.
    pub fold: usize,
}

/// Contiguous segments of about `length` seconds, alternating between two folds. A
/// boundary that falls where `unsettled[k]` (just after an input step) moves forward to
/// the first settled sample, so that no replay starts from a state caught mid-transient.
pub fn segments(n: usize, dt: f64, length: f64, unsettled: &[bool]) -> Vec<Segment> {
    let count = ((n as f64 * dt / length).round() as usize).max(2);
    let mut bounds: Vec<usize> = (0..=count).map(|i| i * n / count).collect();
    let max_shift = (0.5 / dt).round() as usize;
    for b in bounds.iter_mut().take(count).skip(1) {
        let limit = (*b + max_shift).min(n - 1);
        while *b < limit && unsettled.get(*b).copied().unwrap_or(false) {
            *b += 1;
        }
    }
    bounds.dedup();
    bounds
        .windows(2)
        .enumerate()
        .map(|(i, w)| Segment {
            start: w[0],
            end: w[1],
            fold: i % 2,
        })
        .collect()
}

/// Samples within `settle` seconds after a step of any of the given input columns (a
/// change between samples larger than `share` of the column's range).
pub fn unsettled(s: &Series, columns: &[&str], share: f64, settle: f64) -> Vec<bool> {
    let n = s.len();
    let hold = (settle / s.dt).round() as usize;
    let mut out = vec![false; n];
    for name in columns {
        let Some(y) = s.get(name) else { continue };
        let range = crate::numerics::stats::span(y);
        for k in 1..n {
            if (y[k] - y[k - 1]).abs() > share * range && range > 0.0 {
                out[k - 1..(k + hold).min(n)]
                    .iter_mut()
                    .for_each(|u| *u = true);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_fit_recovers_slope_of_a_parabola() {
        let y: Vec<f64> = (0..50)
            .map(|k| 0.5 * (k as f64).powi(2) + 3.0 * k as f64)
            .collect();
        for (k, (v, d)) in local_quadratic(&y, 4).iter().enumerate() {
            assert!(
                (v - y[k]).abs() < 1e-6 && (d - (k as f64 + 3.0)).abs() < 1e-6,
                "{k}"
            );
        }
    }

    /// `line_end`'s curvature is in standard errors: over white noise its square averages
    /// one; a bend of ten noise levels across 100 samples (z about 7.5) stands out; an
    /// exact line's end is its last value.
    #[test]
    fn line_end_reads_a_line_and_measures_its_bend() {
        use crate::numerics::rng::{seeded, Draw};
        let (sigma, n) = (0.1, 100);
        let mut rng = seeded(5);
        let z2 = (0..400)
            .map(|_| {
                let y: Vec<f64> = rng.coloured(n, 0.0).iter().map(|e| sigma * e).collect();
                line_end(&y, sigma).expect("five samples").1.powi(2)
            })
            .sum::<f64>()
            / 400.0;
        let line: Vec<f64> = (0..n).map(|k| 1.0 + 0.01 * k as f64).collect();
        let (end, straight) = line_end(&line, sigma).expect("five samples");
        let bent: Vec<f64> = (0..n)
            .map(|k| line[k] + 10.0 * sigma * (k as f64 / n as f64).powi(2))
            .collect();
        let (_, bend) = line_end(&bent, sigma).expect("five samples");
        assert!(
            (z2 - 1.0).abs() < 0.2 && (end - line[n - 1]).abs() < 1e-9 && straight < 1e-6,
            "noise z^2 {z2:.2}, end {end}, straight {straight:.1e}"
        );
        assert!(bend > 4.0, "bend {bend:.1}");
    }

    #[test]
    fn segments_cover_the_record_and_alternate() {
        let s = segments(3001, 0.01, 2.5, &[]);
        assert_eq!(s.len(), 12);
        assert_eq!((s[0].start, s[11].end), (0, 3001));
        assert!(s
            .windows(2)
            .all(|w| w[0].end == w[1].start && w[0].fold != w[1].fold));
    }

    #[test]
    fn boundaries_skip_unsettled_samples() {
        let mut unsettled = vec![false; 1000];
        unsettled[499..530].iter_mut().for_each(|u| *u = true);
        let s = segments(1000, 0.01, 5.0, &unsettled);
        assert_eq!(s[1].start, 530);
    }

    #[test]
    fn jittered_stamps_are_placed_on_their_grid() {
        let time: Vec<f64> = (0..500)
            .map(|k| k as f64 * 0.01 + if k % 2 == 1 { 0.002 } else { -0.001 })
            .collect();
        let s = Series::from_columns(&time, |n| {
            ["x", "p", "Q1", "Q2"].contains(&n).then(|| vec![1.0; 500])
        })
        .unwrap();
        assert!((s.dt - 0.01).abs() < 1e-6 && s.len() == 500);
        assert!(matches!(s.notes[0], Note::Jitter { .. }), "{:?}", s.notes);
    }

    #[test]
    fn uneven_sampling_is_resampled() {
        let time: Vec<f64> = (0..500)
            .map(|k| {
                k as f64 * 0.01
                    + if k % 2 == 1 { 0.004 } else { 0.0 }
                    + if k > 250 { 0.5 } else { 0.0 }
            })
            .collect();
        let s = Series::from_columns(&time, |n| {
            ["x", "p", "Q1", "Q2"].contains(&n).then(|| time.clone())
        })
        .unwrap();
        assert!(
            matches!(s.notes[0], Note::Resampled { .. }),
            "{:?}",
            s.notes
        );
        assert!((s.at(s.col("x"), 1.234) - 1.234).abs() < 1e-9);
    }
}
