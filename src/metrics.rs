//! The paper's metrics: displacement-error statistics Eq. (34)-(37), recovery time,
//! overshoot, the steady main:auxiliary flow ratio, and the fit indices of Table 3.

/// Max, min, mean and sample standard deviation of e_x, in millimetres (Eq. 34-37).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ErrorStats {
    pub max_mm: f64,
    pub min_mm: f64,
    pub mean_mm: f64,
    pub sd_mm: f64,
}

/// Eq. (34)-(37) over the samples of e_x [m] taken every 0.01 s in (0, 20] s (N = 2000).
/// `e_x[0]` (t = 0) is excluded so that N = 2000 for a 20 s trace.
pub fn error_stats(e_x: &[f64]) -> ErrorStats {
    let mut s = ErrorPasses::new();
    e_x.iter().skip(1).for_each(|&e| s.push(e));
    e_x.iter().skip(1).for_each(|&e| s.spread(e));
    s.stats()
}

/// Eq. (34)-(37) gathered sample by sample, so that a run of any length needs no memory of
/// its samples (`simulate` streams its recording): every sample of e_x [m] after t = 0 goes
/// to `push`, then, in a second pass over the same samples, to `spread` (the standard
/// deviation needs the mean first).
#[derive(Clone, Copy, Debug)]
pub struct ErrorPasses {
    n: usize,
    sum: f64,
    max: f64,
    min: f64,
    squares: f64,
}

impl ErrorPasses {
    pub fn new() -> Self {
        // Sums start at -0.0, as the standard library's `sum` does.
        ErrorPasses {
            n: 0,
            sum: -0.0,
            max: f64::NEG_INFINITY,
            min: f64::INFINITY,
            squares: -0.0,
        }
    }

    /// First pass: one sample of e_x [m].
    pub fn push(&mut self, e_x: f64) {
        let v = e_x * 1e3;
        self.n += 1;
        self.sum += v;
        self.max = self.max.max(v);
        self.min = self.min.min(v);
    }

    /// Second pass: the same sample again.
    pub fn spread(&mut self, e_x: f64) {
        self.squares += (e_x * 1e3 - self.mean()).powi(2);
    }

    fn mean(&self) -> f64 {
        self.sum / self.n as f64
    }

    pub fn stats(&self) -> ErrorStats {
        ErrorStats {
            max_mm: self.max,
            min_mm: self.min,
            mean_mm: self.mean(),
            sd_mm: (self.squares / (self.n as f64 - 1.0)).sqrt(),
        }
    }
}

impl Default for ErrorPasses {
    fn default() -> Self {
        Self::new()
    }
}

/// Smallest recovery band [m]: an LVDT's resolution-scale 20 um, so that a run without a
/// start-up peak does not get a vanishing band.
const RECOVERY_BAND_FLOOR: f64 = 20e-6;

/// Position-error recovery time [s]: the time after which e_x stays within 10 % of its
/// start-up excursion (peak minus steady value), at least 20 um, around its steady value
/// (mean of the last quarter of the run).
pub fn recovery_time(time: &[f64], e_x: &[f64]) -> f64 {
    let mut r = RecoveryPasses::new(e_x.len());
    e_x.iter().for_each(|&e| r.push(e));
    time.iter().zip(e_x).for_each(|(&t, &e)| r.check(t, e));
    r.time()
}

/// The recovery time gathered sample by sample in two passes over a run of `n` samples
/// (t = 0 included), as `ErrorPasses` does: every e_x [m] goes to `push`, then every
/// (time [s], e_x [m]) to `check` (the band needs the steady value and the peak first).
#[derive(Clone, Copy, Debug)]
pub struct RecoveryPasses {
    n: usize,
    pushed: usize,
    tail: f64,
    peak: f64,
    start: Option<f64>,
    last: f64,
    out: bool,
    recovered: Option<f64>,
}

impl RecoveryPasses {
    pub fn new(n: usize) -> Self {
        RecoveryPasses {
            n,
            pushed: 0,
            tail: -0.0,
            peak: f64::NEG_INFINITY,
            start: None,
            last: f64::NAN,
            out: false,
            recovered: None,
        }
    }

    /// First pass: one sample of e_x [m].
    pub fn push(&mut self, e_x: f64) {
        if self.pushed >= 3 * self.n / 4 {
            self.tail += e_x;
        }
        self.peak = self.peak.max(e_x);
        self.pushed += 1;
    }

    /// Second pass: the same sample again, with its time [s].
    pub fn check(&mut self, t: f64, e_x: f64) {
        let steady = self.tail / (self.n - 3 * self.n / 4) as f64;
        let band = (0.1 * (self.peak - steady).abs()).max(RECOVERY_BAND_FLOOR);
        self.start.get_or_insert(t);
        if self.out {
            self.recovered = Some(t);
        }
        self.out = (e_x - steady).abs() > band;
        self.last = t;
    }

    /// The time of the first sample back in the band for good (the last one if the run
    /// ends outside it, the first one if it never left).
    pub fn time(&self) -> f64 {
        if self.out {
            self.last
        } else {
            self.recovered.or(self.start).unwrap_or(f64::NAN)
        }
    }
}

/// Overshoot [m]: how far the piston ran ahead of the reference (0 if never).
pub fn overshoot(e_x: &[f64]) -> f64 {
    (-e_x.iter().cloned().fold(f64::INFINITY, f64::min)).max(0.0)
}

/// Steady-state main:auxiliary flow ratio: mean Q1 / mean Q2 over the second half of the run.
pub fn flow_ratio(q1: &[f64], q2: &[f64]) -> f64 {
    let from = q1.len() / 2;
    let m1: f64 = q1[from..].iter().sum();
    let m2: f64 = q2[from..].iter().sum();
    m1 / m2
}

/// Fit indices of a model signal against a measured one (Table 3).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Fit {
    /// Coefficient of determination.
    pub r2: f64,
    /// Root mean square error, in the signal's SI unit.
    pub rmse: f64,
    /// Mean absolute percentage error [%], over samples with |measured| above 1 % of its peak.
    pub mape: f64,
}

pub fn fit(measured: &[f64], model: &[f64]) -> Fit {
    let n = measured.len() as f64;
    let mean = measured.iter().sum::<f64>() / n;
    let ss_res: f64 = measured
        .iter()
        .zip(model)
        .map(|(y, m)| (y - m).powi(2))
        .sum();
    let ss_tot: f64 = measured.iter().map(|y| (y - mean).powi(2)).sum();
    let floor = 0.01 * measured.iter().fold(0.0f64, |a, y| a.max(y.abs()));
    let pct: Vec<f64> = measured
        .iter()
        .zip(model)
        .filter(|(y, _)| y.abs() > floor)
        .map(|(y, m)| ((y - m) / y).abs())
        .collect();
    Fit {
        r2: if ss_tot > 0.0 {
            1.0 - ss_res / ss_tot
        } else {
            f64::NAN
        },
        rmse: (ss_res / n).sqrt(),
        mape: 100.0 * pct.iter().sum::<f64>() / pct.len().max(1) as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_follow_eq_34_to_37() {
        let e: Vec<f64> = [0.0, 1e-3, 2e-3, 3e-3, -1e-3].to_vec();
        let s = error_stats(&e);
        assert_eq!((s.max_mm, s.min_mm), (3.0, -1.0));
        assert!((s.mean_mm - 1.25).abs() < 1e-12);
        let var =
            ((1.0f64 - 1.25).powi(2) + 0.75f64.powi(2) + 1.75f64.powi(2) + 2.25f64.powi(2)) / 3.0;
        assert!((s.sd_mm - var.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn fit_of_a_perfect_model() {
        let y = [1.0, 2.0, 3.0];
        let f = fit(&y, &y);
        assert_eq!((f.r2, f.rmse, f.mape), (1.0, 0.0, 0.0));
        let g = fit(&y, &[1.1, 2.2, 3.3]);
        assert!((g.mape - 10.0).abs() < 1e-9);
    }

    #[test]
    fn recovery_after_a_peak() {
        let time: Vec<f64> = (0..1000).map(|k| k as f64 * 0.01).collect();
        let e: Vec<f64> = time
            .iter()
            .map(|t| if *t < 2.0 { 1.0 } else { 0.0 })
            .collect();
        assert!((recovery_time(&time, &e) - 2.0).abs() < 1e-9);
    }
}
