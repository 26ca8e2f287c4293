//! Data quality of a bench recording, checked before any fit, the same for `identify` and
//! `diagnose` (docs/robustness.md):
//! - isolated spikes (a sensor or logger glitch: one sample far from both neighbours, which
//!   agree with each other) are excluded by the reader, named by line, never fitted; too
//!   many of them refuse the recording;
//! - sensor contradictions refuse the recording with one line: a signal whose sign is
//!   flipped, a dead sensor, `x` moving against the delivered flow, a pressure below what
//!   the load needs;
//! - a logging gap splits the recording into stretches; the tools use one stretch and never
//!   interpolate across a gap.
//!
//! Findings are typed ([`Fault`], [`Note`]); the command turns them into one line each.

use crate::numerics::stats::{extremes, median};
pub use crate::recording::Stretch;
use crate::recording::{Note, Recording};
use tbm_thrust::Params;

/// The measured signals searched for spikes (commands and references may step).
pub const SPIKE_COLUMNS: [&str; 7] = ["x", "p", "Q1", "Q2", "v", "F_L", "p_t"];
/// A spike departs from both neighbours by more than this many robust standard deviations
/// of the signal's sample-to-sample change...
const SPIKE_SIGMAS: f64 = 30.0;
/// ...and by more than this multiple of the signal's robust range (1 % to 99 % quantile,
/// at least as many samples left out at each end as spikes are tolerated): a physical transient (a piston that shoots
/// forward for one sample when the load drops) stays within about the range its signal
/// spans elsewhere.
const SPIKE_RANGE_SHARE: f64 = 2.0;
/// ...and by more than this many quantisation steps (the smallest nonzero change).
const SPIKE_STEPS: f64 = 10.0;
/// ...and by more than this share of the signal's median level: a pressure that settles
/// to a constant after a start-up oscillation has a small range, but its oscillation is no
/// glitch; a dropout to zero is.
const SPIKE_LEVEL_SHARE: f64 = 0.2;
/// A departure beyond this multiple of the signal's scale is a spike in any case.
const GROSS: f64 = 1e3;
/// The two neighbours of a spike differ by less than this share of its departure.
const NEIGHBOURS_AGREE: f64 = 0.1;
/// More spikes than this share of the samples (at least [`MIN_SPIKES_REFUSED`]) is a faulty
/// sensor, not a glitch.
const SPIKE_SHARE_MAX: f64 = 0.005;
const MIN_SPIKES_REFUSED: usize = 5;

/// Most spikes excluded from a recording of `n` samples before it is refused.
pub fn max_spikes(n: usize) -> usize {
    ((SPIKE_SHARE_MAX * n as f64) as usize).max(MIN_SPIKES_REFUSED - 1)
}

fn sorted(v: &[f64]) -> Vec<f64> {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s
}

/// Indices of isolated spikes of a signal: samples that depart from both neighbours in the
/// same direction by more than the threshold while the neighbours agree with each other
/// (an end sample: departs from its one neighbour, which agrees with the next).
pub fn spikes(y: &[f64]) -> Vec<usize> {
    let n = y.len();
    if n < 5 {
        return Vec::new();
    }
    let d: Vec<f64> = y.windows(2).map(|w| w[1] - w[0]).collect();
    let med = median(&d);
    let mad = median(&d.iter().map(|x| (x - med).abs()).collect::<Vec<_>>());
    let sy = sorted(y);
    let lo = ((0.01 * n as f64) as usize).max(MIN_SPIKES_REFUSED.min(n / 4));
    let hi = (n - 1 - lo).max(lo);
    let range = sy[hi] - sy[lo];
    let step = d
        .iter()
        .map(|x| x.abs())
        .filter(|&x| x > 0.0)
        .fold(f64::INFINITY, f64::min);
    let step = if step.is_finite() { step } else { 0.0 };
    let threshold = (SPIKE_SIGMAS * 1.4826 * mad)
        .max(SPIKE_RANGE_SHARE * range)
        .max(SPIKE_STEPS * step)
        .max(SPIKE_LEVEL_SHARE * sy[n / 2].abs());
    // A departure by more than GROSS times the signal's scale (its robust range, or its
    // median when it is constant) counts whatever the quantisation step: a constant load
    // of 12 kN with one cell of 1.7e308 N.
    let scale = range.max(sy[n / 2].abs());
    let threshold = if scale > 0.0 {
        threshold.min(GROSS * scale)
    } else {
        threshold
    };
    let far = |a: f64| a.abs() > threshold || !a.is_finite();
    let near = |a: f64, limit: f64| a.abs() <= limit;
    let mut out = Vec::new();
    for k in 0..n {
        let spike = if k == 0 {
            far(y[0] - y[1]) && near(y[1] - y[2], NEIGHBOURS_AGREE * threshold)
        } else if k == n - 1 {
            far(y[k] - y[k - 1]) && near(y[k - 1] - y[k - 2], NEIGHBOURS_AGREE * threshold)
        } else {
            let (a, b) = (y[k] - y[k - 1], y[k] - y[k + 1]);
            far(a)
                && far(b)
                && (a > 0.0) == (b > 0.0)
                && near(y[k + 1] - y[k - 1], NEIGHBOURS_AGREE * a.abs().min(b.abs()))
        };
        if spike {
            out.push(k);
        }
    }
    out
}

/// A step between samples longer than this many median steps is a logging gap.
pub const GAP_STEPS: f64 = 10.0;
/// Travel that counts as motion: more than this many noise levels of `x`...
const MOTION_NOISE_LEVELS: f64 = 50.0;
/// ...and more than this [m].
const MOTION_MIN_M: f64 = 1e-3;
/// A pump flow reads negative when its most negative reading outweighs its most positive
/// one, lies below this [m^3/s] (1 L/min: an idle meter's zero offset stays above)...
const NEGATIVE_FLOW_MIN: f64 = 1.0 / tbm_thrust::units::LPM;
/// ...and stands this many of the meter's own noise levels below zero (white noise over
/// thousands of samples reaches about 4: an idle pump's noisy zero is no fault).
const NEGATIVE_FLOW_NOISE_LEVELS: f64 = 10.0;
/// The chamber pressure while the load acts must reach at least this share of F_L / A.
const LOAD_PRESSURE_SHARE: f64 = 0.5;

/// A sensor contradiction: the recording is refused, since no fit can be trusted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Fault {
    #[error("`p` is negative most of the time (median {median:.3e} Pa, peak {peak:.3e} Pa): the pressure sensor's sign looks flipped")]
    PressureSignFlipped { median: f64, peak: f64 },
    #[error("`{column}` reads {min:.3e} m^3/s (peak {peak:.3e} m^3/s); a pump delivers no negative flow (check valves): the flow meter's sign looks flipped")]
    NegativeFlow {
        column: &'static str,
        min: f64,
        peak: f64,
    },
    #[error("`x` moves by {travel:.3e} m while the pumps deliver {volume:.3e} m^3 into the chamber: the piston moves against the flow; the displacement sensor's sign looks flipped")]
    AgainstFlow { travel: f64, volume: f64 },
    #[error("`v` integrates to {integral:.3e} m while `x` moves by {travel:.3e} m: the velocity sensor's sign looks flipped")]
    VelocityAgainstX { travel: f64, integral: f64 },
    #[error("`{column}` stays at {value:e} throughout while the pumps deliver enough to move the piston by {travel:.3e} m (piston area {area} m^2): a dead sensor (or the piston on its end stop: then there is nothing to fit)")]
    Dead {
        column: &'static str,
        value: f64,
        travel: f64,
        area: f64,
    },
    #[error(
        "`x` advances by {travel:.3e} m but `Q1` and `Q2` are zero throughout: dead flow meters"
    )]
    NoFlow { travel: f64 },
    #[error("`p` (median {median:.3e} Pa) is below what the load needs: F_L = {load:.3e} N on the piston area {area} m^2 needs about {needed:.3e} Pa; a pressure sensor offset, a wrong unit or sign, or a wrong `A`")]
    BelowLoad {
        median: f64,
        load: f64,
        area: f64,
        needed: f64,
    },
    #[error("nothing moves: `x` travels {travel:.3e} m (noise {noise:.1e} m) and the pumps deliver {volume:.3e} m^3: there is nothing to fit")]
    NoMotion {
        travel: f64,
        noise: f64,
        volume: f64,
    },
    #[error("the {} stretch without a logging gap has {found} samples (the gaps are before lines {gaps}); at least {min} are needed", match stretch { Stretch::First => "first", Stretch::Longest => "longest" })]
    StretchTooShort {
        stretch: Stretch,
        found: usize,
        min: usize,
        gaps: String,
    },
}

/// The one-line refusal: the recording and its fault.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}: {fault}")]
pub struct QualityError {
    pub file: String,
    pub fault: Fault,
}

/// A recording that passed the checks: the stretch to use and what was handled.
#[derive(Clone, Debug)]
pub struct Screened {
    pub recording: Recording,
    pub notes: Vec<Note>,
}

/// The data-quality checks of both `identify` and `diagnose` (module docs): gaps split the
/// recording and `stretch` picks the part used, then sensor contradictions refuse it.
/// `params` gives the piston area for the flow and load checks. The notes are also added
/// to the recording's own notes, so reports list them with the reader's.
pub fn screen(
    rec: &Recording,
    params: &Params,
    stretch: Stretch,
) -> Result<Screened, QualityError> {
    let err = |fault| QualityError {
        file: rec.source.clone(),
        fault,
    };
    let (mut rec, notes) = split_at_gaps(rec, stretch).map_err(err)?;
    contradictions(&rec, params).map_err(err)?;
    for n in &notes {
        rec.push_note(n.clone());
    }
    Ok(Screened {
        recording: rec,
        notes,
    })
}

/// The stretch of `rec` between logging gaps that `stretch` picks (all of it without gaps),
/// with a note on each gap and on the stretch used.
fn split_at_gaps(rec: &Recording, stretch: Stretch) -> Result<(Recording, Vec<Note>), Fault> {
    let steps: Vec<f64> = rec.time.windows(2).map(|w| w[1] - w[0]).collect();
    let median = median(&steps);
    let gaps: Vec<usize> = (0..steps.len())
        .filter(|&k| steps[k] > GAP_STEPS * median)
        .map(|k| k + 1)
        .collect();
    if gaps.is_empty() {
        return Ok((rec.clone(), Vec::new()));
    }
    let mut notes: Vec<Note> = gaps
        .iter()
        .map(|&k| Note::Gap {
            line: rec.line(k),
            step_s: steps[k - 1],
            median_s: median,
        })
        .collect();
    let bounds: Vec<(usize, usize)> = std::iter::once(0)
        .chain(gaps.iter().copied())
        .zip(gaps.iter().copied().chain(std::iter::once(rec.len())))
        .collect();
    let (a, b) = match stretch {
        Stretch::First => bounds[0],
        Stretch::Longest => *bounds
            .iter()
            .max_by_key(|(a, b)| (b - a, usize::MAX - a))
            .expect("one stretch at least"),
    };
    if b - a < crate::recording::MIN_SAMPLES {
        return Err(Fault::StretchTooShort {
            stretch,
            found: b - a,
            min: crate::recording::MIN_SAMPLES,
            gaps: gaps
                .iter()
                .map(|&k| rec.line(k).to_string())
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    notes.push(Note::StretchUsed {
        first: rec.line(a),
        last: rec.line(b - 1),
        t0_s: rec.time[a],
        t1_s: rec.time[b - 1],
        why: stretch,
    });
    let mut used = rec.window(rec.time[a], rec.time[b - 1]);
    used.source = rec.source.clone();
    Ok((used, notes))
}

/// The sensor contradictions of the module docs, first found first.
fn contradictions(rec: &Recording, params: &Params) -> Result<(), Fault> {
    let motion = Motion::of(rec, params.A);
    if !motion.moves(motion.x_max - motion.x_min) && !motion.moves(motion.pushed) {
        return Err(Fault::NoMotion {
            travel: motion.travel,
            noise: motion.noise,
            volume: motion.volume,
        });
    }
    negative_flows(rec)?;
    motion.displacement_against_flow(rec)?;
    pressure_against_load(rec, &motion)
}

/// What the displacement and the delivered flow say of the piston's motion.
struct Motion {
    /// Displacement from the first sample to the last, its extremes and its noise level [m].
    travel: f64,
    x_min: f64,
    x_max: f64,
    noise: f64,
    /// Volume the pumps delivered [m^3] and the stroke it pushes the piston area [m^2].
    volume: f64,
    area: f64,
    pushed: f64,
}

impl Motion {
    fn of(rec: &Recording, area: f64) -> Motion {
        let col = |n: &str| rec.column(n).expect("required column");
        let (x, q1, q2) = (col("x"), col("Q1"), col("Q2"));
        let flow: Vec<f64> = q1.iter().zip(q2).map(|(a, b)| a + b).collect();
        let volume = crate::numerics::stats::trapezoid(&rec.time, &flow);
        let (x_min, x_max) = extremes(x);
        Motion {
            travel: x[x.len() - 1] - x[0],
            x_min,
            x_max,
            noise: crate::numerics::stats::noise_level(x),
            volume,
            area,
            pushed: volume / area,
        }
    }

    /// Whether a displacement `d` [m] stands above the displacement's noise.
    fn moves(&self, d: f64) -> bool {
        d.abs() > (MOTION_NOISE_LEVELS * self.noise).max(MOTION_MIN_M)
    }

    /// A dead displacement sensor, a travel without delivered flow or against it, a velocity
    /// whose integral runs against the displacement.
    fn displacement_against_flow(&self, rec: &Recording) -> Result<(), Fault> {
        let (travel, volume, pushed) = (self.travel, self.volume, self.pushed);
        if self.x_max == self.x_min && self.moves(pushed) {
            return Err(Fault::Dead {
                column: "x",
                value: self.x_min,
                travel: pushed,
                area: self.area,
            });
        }
        if self.moves(travel) && volume <= 0.0 {
            return Err(Fault::NoFlow { travel });
        }
        if self.moves(travel) && travel < 0.0 && self.moves(pushed) {
            return Err(Fault::AgainstFlow { travel, volume });
        }
        if let Some(v) = rec.column("v") {
            let integral = crate::numerics::stats::trapezoid(&rec.time, v);
            if self.moves(travel) && self.moves(integral) && (integral > 0.0) != (travel > 0.0) {
                return Err(Fault::VelocityAgainstX { travel, integral });
            }
        }
        Ok(())
    }
}

/// A flow meter whose readings go mostly negative, beyond its noise.
fn negative_flows(rec: &Recording) -> Result<(), Fault> {
    for name in ["Q1", "Q2"] {
        let q = rec.column(name).expect("required column");
        let (min, max) = extremes(q);
        let meter_noise = crate::numerics::stats::noise_level(q);
        if -min > max && min < -NEGATIVE_FLOW_MIN && min < -NEGATIVE_FLOW_NOISE_LEVELS * meter_noise
        {
            return Err(Fault::NegativeFlow {
                column: name,
                min,
                peak: crate::numerics::stats::peak(q),
            });
        }
    }
    Ok(())
}

/// A pressure with a flipped sign, a dead pressure sensor while the piston moves, a pressure
/// below what the recorded load needs.
fn pressure_against_load(rec: &Recording, motion: &Motion) -> Result<(), Fault> {
    let p = rec.column("p").expect("required column");
    let (p_min, p_max) = extremes(p);
    let p_median = median(p);
    if p_median < 0.0 && -p_min > p_max {
        return Err(Fault::PressureSignFlipped {
            median: p_median,
            peak: p_min,
        });
    }
    if p_min == p_max && (motion.moves(motion.travel) || motion.moves(motion.pushed)) {
        return Err(Fault::Dead {
            column: "p",
            value: p_min,
            travel: motion.pushed,
            area: motion.area,
        });
    }
    let load = match rec.column("F_L") {
        Some(f) => Some(median(f)),
        None => rec.meta.get("F_L").and_then(|t| t.parse::<f64>().ok()),
    };
    if let Some(load) = load.filter(|&f| f > 0.0) {
        let needed = load / motion.area;
        if p_median < LOAD_PRESSURE_SHARE * needed {
            return Err(Fault::BelowLoad {
                median: p_median,
                load,
                area: motion.area,
                needed,
            });
        }
    }
    Ok(())
}
