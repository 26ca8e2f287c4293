//! Statistics of sampled signals: peak magnitude, extremes and span, median, quantile, robust
//! standard deviation, white-noise level, trapezoidal integral and linear interpolation. identify, diagnose and the recording
//! checks measure a recording's noise with the one [`noise_level`] here.

/// The largest magnitude in `v` (0 for an empty slice).
pub fn peak(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// The smallest and the largest value (+inf and -inf for an empty slice; NaN ignored).
pub fn extremes(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        })
}

/// The largest value minus the smallest (-inf for an empty slice).
pub fn span(v: &[f64]) -> f64 {
    let (lo, hi) = extremes(v);
    hi - lo
}

/// Median (the mean of the two middle values for an even count; 0 for an empty slice).
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// The q-quantile (0 <= q <= 1) as the nearest-rank sample of the sorted values.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// Robust standard deviation: 1.4826 times the median absolute deviation from the median
/// (equal to the SD for Gaussian samples, blind to a minority of outliers).
pub fn robust_sd(v: &[f64]) -> f64 {
    let m = median(v);
    1.4826 * median(&v.iter().map(|x| (x - m).abs()).collect::<Vec<_>>())
}

/// White-noise standard deviation of a sampled signal, from its second differences: a
/// second difference of white noise has variance 6 sigma^2, smooth motion barely
/// contributes, and the robust SD ignores the few samples at steps.
pub fn noise_level(v: &[f64]) -> f64 {
    let d2: Vec<f64> = v.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect();
    robust_sd(&d2) / 6f64.sqrt()
}

/// Least-squares tone a sin + b cos from its 2x2 normal equations: Gram entries
/// [ss, sc, cc] and right-hand side [rs, rc] -> (a, b, the Gram determinant); nothing when
/// the Gram matrix is singular.
pub fn tone_coefficients([ss, sc, cc]: [f64; 3], [rs, rc]: [f64; 2]) -> Option<(f64, f64, f64)> {
    let det = ss * cc - sc * sc;
    if det <= 0.0 {
        return None;
    }
    Some(((rs * cc - rc * sc) / det, (rc * ss - rs * sc) / det, det))
}

/// Trapezoidal integral of samples `y` over times `t`.
pub fn trapezoid(t: &[f64], y: &[f64]) -> f64 {
    t.windows(2)
        .zip(y.windows(2))
        .map(|(t, y)| 0.5 * (t[1] - t[0]) * (y[0] + y[1]))
        .sum()
}

/// Linear interpolation of samples `y` at increasing times `time`, at time `t`; held
/// constant outside the record.
pub fn interpolate(time: &[f64], y: &[f64], t: f64) -> f64 {
    let k = time.partition_point(|&s| s <= t);
    if k == 0 {
        return y[0];
    }
    if k >= time.len() {
        return y[y.len() - 1];
    }
    let w = (t - time[k - 1]) / (time[k] - time[k - 1]);
    y[k - 1] + w * (y[k] - y[k - 1])
}

/// Linear interpolation of samples `y` on the uniform grid t0 + k dt, at time `t`; held
/// constant beyond the ends.
pub fn interpolate_uniform(t0: f64, dt: f64, y: &[f64], t: f64) -> f64 {
    let s = ((t - t0) / dt).max(0.0);
    // Truncation is the floor for s >= 0 (and not a call to libm's floor: replays spend
    // much of their time here).
    let k = s as usize;
    if k + 1 >= y.len() {
        return y[y.len() - 1];
    }
    let f = s - k as f64;
    y[k] + f * (y[k + 1] - y[k])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::rng::{seeded, Draw};

    #[test]
    fn extremes_skip_a_nan_cell() {
        assert_eq!(extremes(&[2.0, f64::NAN, -1.0, 5.0]), (-1.0, 5.0));
        assert_eq!(extremes(&[]), (f64::INFINITY, f64::NEG_INFINITY));
        assert_eq!(span(&[2.0, f64::NAN, -1.0, 5.0]), 6.0);
    }

    #[test]
    fn median_and_quantile() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&[]), 0.0);
        let v: Vec<f64> = (0..=100).map(f64::from).collect();
        assert_eq!((quantile(&v, 0.1), quantile(&v, 1.0)), (10.0, 100.0));
    }

    #[test]
    fn noise_level_of_white_noise_on_a_ramp() {
        let mut rng = seeded(1);
        let y: Vec<f64> = (0..5000)
            .map(|k| 1e-3 * k as f64 + 0.2 * rng.normal())
            .collect();
        assert!((noise_level(&y) - 0.2).abs() < 0.01, "{}", noise_level(&y));
    }

    #[test]
    fn interpolation_holds_outside_the_record() {
        let t = [0.0, 1.0, 3.0];
        let y = [0.0, 2.0, 4.0];
        assert_eq!(interpolate(&t, &y, -1.0), 0.0);
        assert_eq!(interpolate(&t, &y, 2.0), 3.0);
        assert_eq!(interpolate(&t, &y, 5.0), 4.0);
    }

    #[test]
    fn trapezoid_and_interpolation() {
        let t = [0.0, 1.0, 3.0];
        let y = [0.0, 2.0, 2.0];
        assert_eq!(trapezoid(&t, &y), 5.0);
        assert_eq!(interpolate(&t, &y, 0.5), 1.0);
        assert_eq!(
            (interpolate(&t, &y, -1.0), interpolate(&t, &y, 5.0)),
            (0.0, 2.0)
        );
        assert_eq!(interpolate_uniform(1.0, 0.5, &[0.0, 1.0, 4.0], 1.75), 2.5);
        assert_eq!(interpolate_uniform(1.0, 0.5, &[0.0, 1.0, 4.0], 9.0), 4.0);
    }
}
