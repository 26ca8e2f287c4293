//! Starting values of each effect's parameters, read off the current model's out-of-fold
//! residuals so that the simulation-error fit starts in the right basin: a delay scan,
//! the flow slope the pump model reaches, a tone search, and a few physically spread
//! guesses where the cost is multimodal.

use super::effect::Effect;
use super::model::{
    fit, loop_specs, nominal_specs, out_of_fold, residuals, Layout, Model, Part, Prediction, Split,
    ITERATIONS,
};
use super::replay::{Bench, DriveSource};
use super::series::peak_rate;
use super::series::Segment;
use crate::numerics::lm::Spec;
use crate::numerics::stats::{quantile, tone_coefficients};
use std::f64::consts::PI;
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::Controller;

/// The Stribeck velocities [m/s] the Stribeck fit starts from (with breakaway excesses of
/// 10-100 % of `F_c`).
pub const STRIBECK_V_S: [f64; 5] = [1e-3, 2e-3, 4e-3, 8e-3, 1.6e-2];

/// Starting values of the effect's own parameters (several when the cost is multimodal).
pub fn effect_starts(
    effect: Effect,
    bench: &Bench,
    model: &Model,
    pred: &Prediction,
    segs: &[Segment],
) -> Vec<Vec<f64>> {
    let f_c = model.params.F_c;
    match effect {
        Effect::StribeckFriction => {
            grid(&[0.1, 0.2, 0.35, 0.5, 0.75, 1.0], &STRIBECK_V_S, |e, v| {
                vec![f_c * (1.0 + e), v]
            })
        }
        Effect::PressureDependentFriction => vec![vec![0.003], vec![0.01], vec![0.03]],
        Effect::PositionDependentLoad => vec![vec![-5e3], vec![5e3]],
        Effect::EntrainedAir => [1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2]
            .iter()
            .map(|a| vec![*a])
            .collect(),
        Effect::ReliefLeakage => {
            let p = bench.moving_pressures();
            // Between two load plateaus every cracking pressure explains the plateaus alike
            // (with its own K); only the transients tell them apart, so the grid is dense.
            grid(
                &[
                    0.3, 0.4, 0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.9, 0.93, 0.96, 0.98,
                ],
                &[1e-11, 3e-11, 1e-10, 3e-10],
                |q, k| vec![quantile(&p, q), k],
            )
        }
        Effect::PumpDeadTime(_) => {
            vec![vec![scan(bench, model, effect, &delay_grid(), segs)]]
        }
        Effect::PumpFlowLimit(i) => {
            let peak = peak_rate(pred.get(i.flow()), bench.s.dt);
            let grid: Vec<f64> = (0..16).map(|i| peak * 0.8f64.powi(2 * i)).collect();
            vec![vec![scan(bench, model, effect, &grid, segs)]]
        }
        // Read off each fold's own samples (`ripple_start`).
        Effect::FlowRipple(_) => Vec::new(),
    }
}

/// The starting values of pump `pump`'s ripple for the fit on fold `fold` of `split`: the
/// strongest tone ([`tone`]) in the residual of that fold's current fit `model` over the
/// fold's own samples. The search takes the largest of thousands of frequencies; read off all
/// samples, it would carry the held-out samples' highest noise peak into the fold's fit, and
/// the out-of-fold test would find that peak again there (a look-elsewhere effect the
/// test's `z` does not count). Read off the training samples, a noise peak of one fold is
/// noise on the other, while a pump ripple shows in both.
pub fn ripple_start(
    bench: &Bench,
    model: &Model,
    part: Part,
    segs: &[Segment],
    (split, fold): (Split, usize),
    pump: Pump,
) -> Option<Vec<f64>> {
    let pred = out_of_fold(bench, &[model.clone(), model.clone()], part, segs, split);
    let mut training = vec![false; bench.s.len()];
    for seg in segs {
        for (k, t) in training
            .iter_mut()
            .enumerate()
            .take(seg.end)
            .skip(seg.start)
        {
            *t = split.fold(seg, k) == fold;
        }
    }
    tone(bench, pred.get(pump.flow()), pump.flow(), &training)
}

/// Proportional gains [mV per L/min] and integral-to-proportional ratios [1/s] of the PID
/// grid a reconstructed flow loop starts from: P loops (the ratio at nothing) to PI loops
/// with an integral time of a tenth of a second; and factors on the given ADRC's control
/// bandwidth and input gain.
const LOOP_KP: [f64; 6] = [30.0, 100.0, 300.0, 1e3, 3e3, 1e4];
const LOOP_RATIO: [f64; 5] = [0.0, 0.5, 2.0, 5.0, 10.0];
const ADRC_FACTOR: [f64; 3] = [0.5, 1.0, 2.0];

/// `model` with the flow loops of the pumps replayed through them (`replay::Bench::drive`)
/// at the points that fit their flows best: of a PID grid, of a grid around the given ADRC,
/// or as given; one family for both pumps (one bench controller), the one whose best points
/// fit both flows best. The bench's controller is unknown, and the integral of the loop error
/// makes the cost multimodal in the gains: a local fit from a P loop does not find a PI loop.
pub fn loop_start(bench: &Bench, model: &Model, layout: &Layout) -> Model {
    let pumps: Vec<Pump> = Pump::BOTH
        .into_iter()
        .filter(|&i| bench.drive_source(i) == DriveSource::FlowLoop)
        .collect();
    if pumps.is_empty() {
        return model.clone();
    }
    [Controller::Pid, Controller::Adrc]
        .into_iter()
        .map(|controller| {
            let mut m = model.clone();
            m.params.controller = controller;
            let mut total = 0.0;
            for &i in &pumps {
                let (part, segs) = (Part::Pump(i), layout.of(Part::Pump(i)));
                m = best_loop(bench, &m, model, i, segs).1;
                // The family is judged after a short fit of the pump with it: at the given
                // pump parameters a wrong family can fit better than the right one.
                let specs = nominal_specs(part, bench, controller);
                let fitted = fit(bench, &[m.clone()], part, &specs, &[], segs, ITERATIONS);
                total += cost(bench, &fitted, part, segs);
            }
            (total, m)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or_else(|| model.clone(), |b| b.1)
}

/// The lowest cost of pump i's flow and the model `m` with its loop gains at that point:
/// of the family's grid and, when `given` runs the same family, its gains.
fn best_loop(bench: &Bench, m: &Model, given: &Model, i: Pump, segs: &[Segment]) -> (f64, Model) {
    let part = Part::Pump(i);
    let controller = m.params.controller;
    let gains = loop_specs(i, controller);
    let points = match controller {
        Controller::Pid => grid(&LOOP_KP, &LOOP_RATIO, |kp, r| vec![kp, kp * r]),
        Controller::Adrc => {
            let g = given.values(&gains);
            grid(&ADRC_FACTOR, &ADRC_FACTOR, |a, b| vec![a * g[0], b * g[1]])
        }
    };
    points
        .into_iter()
        .chain((given.params.controller == controller).then(|| given.values(&gains)))
        .map(|v| m.with(&gains, &v))
        .map(|m| (cost(bench, &m, part, segs), m))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .expect("a grid point")
}

/// Sum of squared residuals of `part` over `segs`.
fn cost(bench: &Bench, m: &Model, part: Part, segs: &[Segment]) -> f64 {
    residuals(bench, m, part, segs).iter().map(|r| r * r).sum()
}

/// Every combination of two parameter lists.
fn grid(a: &[f64], b: &[f64], f: impl Fn(f64, f64) -> Vec<f64>) -> Vec<Vec<f64>> {
    a.iter()
        .flat_map(|&x| b.iter().map(move |&y| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect()
}

/// The value of a pump effect's single parameter on `grid` that best explains the pump's
/// flow with the other parameters held.
fn scan(bench: &Bench, model: &Model, effect: Effect, grid: &[f64], segs: &[Segment]) -> f64 {
    let name = effect.model_parameters()[0];
    let part = super::model::Part::of(effect);
    let cost = |v: f64| {
        let mut m = model.clone();
        m.params.set(name, v).expect("scan value within bounds");
        super::model::residuals(bench, &m, part, segs)
            .iter()
            .map(|r| r * r)
            .sum::<f64>()
    };
    grid.iter()
        .map(|&v| (v, cost(v)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(grid[0], |b| b.0)
}

/// The delays a pump's dead time is scanned over [s]: 5 ms to 150 ms by 5 ms.
fn delay_grid() -> Vec<f64> {
    (1..=30).map(|i| i as f64 * 0.005).collect()
}

/// For a pump's flow-rate limit or dead time, the model on a grid of the effect's parameter
/// and pump speeds that fits best. A slow first-order pump fits a rate-limited ramp almost
/// as well, and from that fit the limit no longer binds; it fits a delayed answer in part
/// too (its lag stands in for the delay), and a delay scan with that slow pump held finds a
/// fraction of the delay only, a local minimum the fit does not leave. So neither a scan
/// with the pump held nor a local fit finds the effect: it and the pump's speed have to move
/// together. The speed (a_i) is scaled with the drive gain (b_u_i), so the steady flow per
/// command, which the plateaus fix, stays. Nothing for other effects.
pub fn profiled(
    effect: Effect,
    bench: &Bench,
    model: &Model,
    pred: &Prediction,
    segs: &[Segment],
) -> Option<Model> {
    let (i, values) = match effect {
        Effect::PumpFlowLimit(i) => {
            let peak = peak_rate(pred.get(i.flow()), bench.s.dt);
            let limits = (0..PROFILE_LIMITS).map(|j| peak * PROFILE_LIMIT_STEP.powi(j));
            (i, limits.collect::<Vec<_>>())
        }
        Effect::PumpDeadTime(i) => (i, delay_grid()),
        _ => return None,
    };
    let part = super::model::Part::Pump(i);
    let name = effect.model_parameters()[0];
    let speed = &super::model::nominal_specs(part, bench, model.params.controller)[..2];
    let cost = |m: &Model| {
        super::model::residuals(bench, m, part, segs)
            .iter()
            .map(|r| r * r)
            .sum::<f64>()
    };
    grid(
        &values,
        &(0..PROFILE_SPEEDS)
            .map(|j| PROFILE_SPEED_STEP.powi(j))
            .collect::<Vec<_>>(),
        |l, f| vec![l, f],
    )
    .into_iter()
    .map(|lf| {
        let mut m = model.scaled(speed, lf[1]);
        m.params
            .set(name, lf[0])
            .expect("profile value within bounds");
        (cost(&m), m)
    })
    .min_by(|a, b| a.0.total_cmp(&b.0))
    .map(|(_, m)| m)
}

/// The flow-rate limit profile: limits from the model's peak slope down by a factor
/// PROFILE_LIMIT_STEP per step (to 1/500 of it), pump speeds from the current fit up by
/// PROFILE_SPEED_STEP per step (to 7.6 times).
const PROFILE_LIMITS: i32 = 14;
const PROFILE_LIMIT_STEP: f64 = 0.62;
const PROFILE_SPEEDS: i32 = 6;
const PROFILE_SPEED_STEP: f64 = 1.5;

/// The effect's parameters switched off (within the fit's bounds): every fit can fall back
/// to the model without the effect.
pub fn off_start(effect: Effect, specs: &[Spec]) -> Vec<f64> {
    let base = tbm_thrust::variables::Params::default();
    specs
        .iter()
        .map(|s| match effect {
            Effect::PumpFlowLimit(_) => s.bounds.hi,
            _ => base
                .get(s.name)
                .unwrap_or(0.0)
                .clamp(s.bounds.lo, s.bounds.hi),
        })
        .collect()
}

/// The strongest tone (the highest interior peak of a Hann-tapered fit) in the relative flow
/// residual over the `training` samples where the pump delivers: [amplitude, frequency,
/// phase]. Frequencies from the lowest plausible ripple up to Nyquist in steps of a quarter
/// of the peak's width, 0.25 / (the time from the first sample the pump delivers to the
/// last); every step is a weighted least-squares fit of Q_pred (a sin + b cos) to the
/// residual (see [`TonePeriodogram`]), computed for all steps at once by FFT so that the
/// cost grows with the recording's length times its logarithm, not its square.
fn tone(bench: &Bench, pred: &[f64], name: &str, training: &[bool]) -> Option<Vec<f64>> {
    let y = bench.s.col(name);
    let floor = 0.1 * crate::numerics::stats::peak(pred);
    let delivering: Vec<usize> = (0..y.len()).filter(|&k| pred[k] > floor).collect();
    let idx: Vec<usize> = delivering
        .iter()
        .copied()
        .filter(|&k| training[k])
        .collect();
    if delivering.len() < 100 || idx.is_empty() {
        return None;
    }
    let nyquist = 0.5 / bench.s.dt;
    // At least 20 cycles while the pump delivers over the whole recording
    // (`effect::min_ripple_frequency`), not over the fold only.
    let f_min = super::effect::min_ripple_frequency(delivering.len() as f64 * bench.s.dt);
    let gram = TonePeriodogram::new(bench, y, pred, &idx, f_min);
    let fits: Vec<(f64, f64, f64, f64)> = (0..)
        .map(|j| f_min + j as f64 * gram.df)
        .take_while(|f| *f < nyquist - 0.1)
        .enumerate()
        .map(|(j, f)| {
            let (gain, a, b) = gram.fit(j, f);
            (gain, f, a, b)
        })
        .collect();
    // A tone is a peak: the search's edges, where a slow misfit's slope or the Nyquist
    // fold stands highest, are not; the taper ([`hann`]) keeps that misfit's sidelobes
    // from standing as peaks just above the lowest frequency (tune seed 116: untapered, a
    // fold's strongest peak was 2.03 Hz, its pump's 35.9 Hz ripple just below it).
    let (_, f, a, b) = fits
        .windows(3)
        .filter(|w| w[1].0 > w[0].0 && w[1].0 >= w[2].0)
        .map(|w| w[1])
        .fold(
            (0.0, 0.0, 0.0, 0.0),
            |best, x| if x.0 > best.0 { x } else { best },
        );
    // Q_pred (a sin wt + b cos wt) = Q_pred r sin(wt + phi).
    Some(vec![a.hypot(b), f, b.atan2(a)])
}

/// The sums of a least-squares fit, weighted by [`hann`], of Q_pred (a sin wt + b cos wt) to
/// the residual r = y - Q_pred over the samples `idx`, at every frequency f_j = f_min + j df
/// of the grid with df = 1 / (M dt), M = 4 (span of idx). With p = Q_pred and w = 2 pi f t:
/// sum r p sin w and sum r p cos w are one DFT of r p at f_j, and sum p^2 sin^2 w,
/// sum p^2 cos^2 w, sum p^2 sin w cos w follow from one DFT of p^2 at 2 f_j. Each DFT
/// over the whole grid is one FFT of length M (samples folded modulo M). M counts the
/// samples from the first of `idx` to the last, gaps included: a pump that delivers in
/// short bursts spread over the recording has a tone peak as narrow as their whole span.
struct TonePeriodogram {
    t0: f64,
    m: usize,
    /// The grid step 1 / (M dt) [Hz].
    df: f64,
    /// sum over k of r_k p_k e^{i 2 pi (f_min + j df) k dt}, at j.
    rp: Vec<rustfft::num_complex::Complex<f64>>,
    /// sum over k of p_k^2 e^{i 2 pi (2 f_min + j df) k dt}, at j (2 f_j is index 2 j).
    pp: Vec<rustfft::num_complex::Complex<f64>>,
    /// sum of p_k^2.
    p2: f64,
}

impl TonePeriodogram {
    fn new(bench: &Bench, y: &[f64], pred: &[f64], idx: &[usize], f_min: f64) -> Self {
        use rustfft::num_complex::Complex;
        let dt = bench.s.dt;
        let m = 4 * (idx[idx.len() - 1] + 1 - idx[0]);
        let mut rp = vec![Complex::new(0.0, 0.0); m];
        let mut pp = vec![Complex::new(0.0, 0.0); m];
        let mut p2 = 0.0;
        for &k in idx {
            let (p, r) = (pred[k], y[k] - pred[k]);
            let (w, h) = (2.0 * PI * f_min * k as f64 * dt, hann(idx, k));
            rp[k % m] += Complex::from_polar(h * r * p, w);
            pp[k % m] += Complex::from_polar(h * p * p, 2.0 * w);
            p2 += h * p * p;
        }
        // rustfft's inverse transform is the unnormalised sum with e^{+i 2 pi j m / M}.
        let fft = rustfft::FftPlanner::new().plan_fft_inverse(m);
        fft.process(&mut rp);
        fft.process(&mut pp);
        TonePeriodogram {
            t0: bench.s.t0,
            m,
            df: 1.0 / (m as f64 * dt),
            rp,
            pp,
            p2,
        }
    }

    /// (squared-error reduction, a, b) at grid frequency j (f = f_j).
    fn fit(&self, j: usize, f: f64) -> (f64, f64, f64) {
        use rustfft::num_complex::Complex;
        let s1 = Complex::from_polar(1.0, 2.0 * PI * f * self.t0) * self.rp[j % self.m];
        let s2 = Complex::from_polar(1.0, 4.0 * PI * f * self.t0) * self.pp[(2 * j) % self.m];
        let (rc, rs) = (s1.re, s1.im);
        let ss = 0.5 * (self.p2 - s2.re);
        let cc = 0.5 * (self.p2 + s2.re);
        let sc = 0.5 * s2.im;
        solve_tone([ss, sc, cc], [rs, rc])
    }
}

/// The weight of sample `k` in the tone fit over the samples `idx`: a Hann taper over their
/// span, so that a slow misfit's leakage falls off within a few peak widths of its
/// frequency (the untapered sidelobes fall as slowly as 1 / distance and, below the lowest
/// frequency searched, stand as peaks above a weak ripple; tune seed 116).
fn hann(idx: &[usize], k: usize) -> f64 {
    let span = (idx[idx.len() - 1] + 1 - idx[0]) as f64;
    (PI * ((k - idx[0]) as f64 + 0.5) / span).sin().powi(2)
}

/// The 2x2 normal equations of a sine/cosine fit: Gram entries [ss, sc, cc] and right-hand
/// side [rs, rc] -> (squared-error reduction, a, b); nothing when the Gram matrix is singular.
fn solve_tone(gram: [f64; 3], [rs, rc]: [f64; 2]) -> (f64, f64, f64) {
    tone_coefficients(gram, [rs, rc]).map_or((0.0, 0.0, 0.0), |(a, b, _)| (a * rs + b * rc, a, b))
}

/// Least-squares fit of Q_pred (a sin + b cos) to the residual at frequency f, summed
/// directly: (squared-error reduction, a, b). The reference for [`TonePeriodogram`].
#[cfg(test)]
fn tone_fit(bench: &Bench, y: &[f64], pred: &[f64], idx: &[usize], f: f64) -> (f64, f64, f64) {
    let (mut ss, mut sc, mut cc, mut rs, mut rc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &k in idx {
        let w = 2.0 * PI * f * bench.s.time(k);
        let (s, c) = (pred[k] * w.sin(), pred[k] * w.cos());
        let (r, h) = (y[k] - pred[k], hann(idx, k));
        ss += h * s * s;
        sc += h * s * c;
        cc += h * c * c;
        rs += h * r * s;
        rc += h * r * c;
    }
    solve_tone([ss, sc, cc], [rs, rc])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::replay::Load;
    use crate::diagnose::series::Series;
    use crate::synth::{generate, BenchScenario, Case};
    use tbm_thrust::Scheme;

    /// A recorded pump dead time with the pump fitted too slow, as a fit without the delay
    /// leaves it (its lag standing in for the delay): the delay scan with that pump held
    /// falls short of the true delay, the profile over delay and pump speed finds it.
    #[test]
    fn the_dead_time_profile_moves_the_pump_speed_with_the_delay() {
        let pump = Pump::Aux;
        let effect = Effect::PumpDeadTime(pump);
        let case = Case::new(
            BenchScenario::SpeedSteps,
            Scheme::FixedSplit,
            vec![effect],
            5,
        );
        let synthesis = generate(&case).expect("case generates");
        let rec = crate::recording::Recording::parse(&synthesis.csv, "bench").expect("parses");
        let series = Series::from_recording(&rec).expect("grid");
        let (bench, layout) = (Bench::new(&series), Layout::new(&series));
        let segs = layout.of(Part::Pump(pump));
        let delay = effect.model_parameters()[0];
        let truth = synthesis.params.get(delay).expect("delay");
        let mut slow = Model {
            params: synthesis.params.clone(),
            load: Load::Recorded,
        };
        slow.params.set(delay, 0.0).expect("delay off");
        let speed = &nominal_specs(Part::Pump(pump), &bench, slow.params.controller)[..2];
        slow = slow.scaled(speed, 1.0 / 3.0);
        let pred = out_of_fold(
            &bench,
            &[slow.clone(), slow.clone()],
            Part::Pump(pump),
            segs,
            Split::Blocked,
        );
        let held = effect_starts(effect, &bench, &slow, &pred, segs)[0][0];
        let profile = profiled(effect, &bench, &slow, &pred, segs).expect("a dead-time profile");
        let found = profile.get(delay);
        assert!(
            (found - truth).abs() < 0.2 * truth,
            "profile {found} s, truth {truth} s, scan with the pump held {held} s"
        );
        assert!(
            (held - truth).abs() > (found - truth).abs(),
            "profile {found} s, truth {truth} s, scan with the pump held {held} s"
        );
    }

    #[test]
    fn fft_periodogram_equals_the_direct_sums() {
        // A flow with a 7.3 Hz ripple and noise, starting at t0 = 1.5 s, partly idle.
        let n = 1500;
        let time: Vec<f64> = (0..n).map(|k| 1.5 + k as f64 * 0.01).collect();
        use crate::numerics::rng::Draw;
        let mut rng = crate::numerics::rng::seeded(3);
        let pred: Vec<f64> = (0..n)
            .map(|k| {
                if (300..400).contains(&k) {
                    0.0
                } else {
                    1e-4 * (1.0 + 0.3 * (k as f64 * 0.002).sin())
                }
            })
            .collect();
        let q: Vec<f64> = (0..n)
            .map(|k| {
                pred[k] * (1.0 + 0.02 * (2.0 * PI * 7.3 * time[k] + 0.4).sin())
                    + 1e-7 * rng.normal()
            })
            .collect();
        let s = flow_series(&time, "Q1", &q);
        let bench = Bench::new(&s);
        let idx: Vec<usize> = (0..n).filter(|&k| pred[k] > 1e-5).collect();
        let f_min = 2.0;
        let gram = TonePeriodogram::new(&bench, &q, &pred, &idx, f_min);
        for j in [0usize, 1, 17, 999, 2000, 2 * n - 50] {
            let f = f_min + j as f64 * gram.df;
            let (g1, a1, b1) = gram.fit(j, f);
            let (g2, a2, b2) = tone_fit(&bench, &q, &pred, &idx, f);
            let close = |x: f64, y: f64, scale: f64| (x - y).abs() <= 1e-7 * scale;
            assert!(close(g1, g2, g2.abs().max(1e-30)), "{j}: {g1} {g2}");
            assert!(
                close(a1, a2, 1e-2) && close(b1, b2, 1e-2),
                "{j}: {a1} {a2} {b1} {b2}"
            );
        }
        let found = tone(&bench, &pred, "Q1", &vec![true; pred.len()]).unwrap();
        assert!(
            (found[1] - 7.3).abs() < 0.01 && (found[0] - 0.02).abs() < 2e-3,
            "{found:?}"
        );
    }

    /// An auxiliary pump that delivers in short bursts (an adaptive scheme's transients: 4 %
    /// of a 60 s recording, at irregular times): its ripple's peak is as narrow as the whole recording makes it,
    /// so the frequency grid steps by the time the bursts span, not by their summed length.
    #[test]
    fn a_ripple_seen_in_short_bursts_is_found_at_its_frequency() {
        let (n, dt, f) = (12_000, 0.005, 22.71);
        let time: Vec<f64> = (0..n).map(|k| 0.7 + k as f64 * dt).collect();
        let starts = [100, 1560, 3220, 4780, 7440, 9700, 11_300];
        let burst = |k: usize| starts.iter().any(|s| (*s..s + 70).contains(&k));
        let pred: Vec<f64> = (0..n).map(|k| if burst(k) { 2e-4 } else { 0.0 }).collect();
        use crate::numerics::rng::Draw;
        let mut rng = crate::numerics::rng::seeded(5);
        let q: Vec<f64> = (0..n)
            .map(|k| {
                pred[k] * (1.0 + 0.04 * (2.0 * PI * f * time[k] + 1.1).sin()) + 2e-6 * rng.normal()
            })
            .collect();
        let s = flow_series(&time, "Q2", &q);
        let found = tone(&Bench::new(&s), &pred, "Q2", &vec![true; pred.len()]).unwrap();
        assert!(
            (found[1] - f).abs() < 0.003 && (found[0] - 0.04).abs() < 4e-3,
            "{found:?}"
        );
    }

    /// A weak ripple beside a slow misfit below the lowest frequency searched (a flow error
    /// at 1.97 Hz, ten times the ripple's amplitude): the tone found is the ripple, not the
    /// misfit's leakage at the bottom of the search (untapered, its sidelobes stand above
    /// the ripple there; tune seed 116).
    #[test]
    fn a_weak_ripple_is_found_beside_a_slow_misfit_below_the_search() {
        let (n, dt, f) = (3_000, 0.01, 35.9);
        let time: Vec<f64> = (0..n).map(|k| 0.3 + k as f64 * dt).collect();
        let pred = vec![2e-4; n];
        let q: Vec<f64> = time
            .iter()
            .map(|t| {
                2e-4 * (1.0
                    + 0.1 * (2.0 * PI * 1.97 * t).sin()
                    + 0.01 * (2.0 * PI * f * t + 0.7).sin())
            })
            .collect();
        let s = flow_series(&time, "Q1", &q);
        let found = tone(&Bench::new(&s), &pred, "Q1", &vec![true; n]).unwrap();
        assert!(
            (found[1] - f).abs() < 0.01 && (found[0] - 0.01).abs() < 1e-3,
            "{found:?}"
        );
    }

    /// A recording of flow `q` in column `flow` and nothing in `x`, `p` and the other flow.
    fn flow_series(time: &[f64], flow: &str, q: &[f64]) -> Series {
        let zeros = vec![0.0; time.len()];
        Series::from_columns(time, |name| match name {
            n if n == flow => Some(q.to_vec()),
            "x" | "p" | "Q1" | "Q2" => Some(zeros.clone()),
            _ => None,
        })
        .unwrap()
    }

    /// The tone search on one fold's own samples (blocked folds of a quarter second): a 1 %
    /// pump ripple under 2 % flow noise is found at its frequency on both folds; in the noise
    /// alone each fold's strongest tone is its own noise peak, which the other fold does not
    /// share (read off all samples, both folds' fits would start at the one peak of the
    /// whole record and find it again on their held-out samples).
    #[test]
    fn a_ripple_shows_on_each_folds_own_samples_and_a_noise_peak_does_not() {
        let (n, dt, f) = (8_000, 0.005, 17.3);
        let time: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let fold0: Vec<bool> = (0..n).map(|k| (k / 50) % 2 == 0).collect();
        let fold1: Vec<bool> = fold0.iter().map(|b| !b).collect();
        let pred = vec![2e-4; n];
        use crate::numerics::rng::Draw;
        let mut rng = crate::numerics::rng::seeded(11);
        let noise: Vec<f64> = (0..n).map(|_| 4e-6 * rng.normal()).collect();
        let found = |ripple: f64| {
            let q: Vec<f64> = (0..n)
                .map(|k| 2e-4 * (1.0 + ripple * (2.0 * PI * f * time[k]).sin()) + noise[k])
                .collect();
            let s = flow_series(&time, "Q1", &q);
            let bench = Bench::new(&s);
            [&fold0, &fold1].map(|t| tone(&bench, &pred, "Q1", t).unwrap()[1])
        };
        let [a, b] = found(0.01);
        assert!((a - f).abs() < 0.05 && (b - f).abs() < 0.05, "{a} {b} Hz");
        let [a, b] = found(0.0);
        assert!((a - b).abs() > 0.5, "noise peaks at {a} and {b} Hz");
    }
}
