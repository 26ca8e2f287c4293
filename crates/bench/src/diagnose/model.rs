//! What is fitted: the nominal unknowns of each replayed part and the parameters of each
//! effect, as bounded free parameters; the residuals of a part over a set of segments; and
//! blocked two-fold cross-fitting, which gives every sample a prediction from a model that
//! was fitted without it.

use super::effect::Effect;
use super::filter::{envelope_gaps, hydro_error, ENVELOPE_WINDOW};
use super::noise::EnvelopeNoise;
use super::replay::{Bench, DriveSource, Load};
use super::series::Segment;
use crate::numerics::bounds::Scale::{Linear, Log};
use crate::numerics::lm::{self, Spec};
use crate::numerics::pattern::compass;
use rayon::prelude::*;
use std::f64::consts::PI;
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::{Controller, Params};

/// A replayed part of the plant: the hydromechanics (mechanics + chamber) or one pump.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Part {
    Hydro,
    Pump(Pump),
}

impl Part {
    /// The recorded signals the part's replay predicts.
    pub fn signals(self, bench: &Bench) -> Vec<&'static str> {
        match self {
            Part::Hydro if bench.s.has("v") => vec!["x", "v", "p"],
            Part::Hydro => vec!["x", "p"],
            Part::Pump(Pump::Main) => vec!["Q1"],
            Part::Pump(Pump::Aux) => vec!["Q2"],
        }
    }

    /// The part whose replay carries an effect.
    pub fn of(effect: Effect) -> Part {
        effect.pump().map_or(Part::Hydro, Part::Pump)
    }

    /// The pump the part replays; `None` for the hydromechanics.
    pub fn pump(self) -> Option<Pump> {
        match self {
            Part::Hydro => None,
            Part::Pump(i) => Some(i),
        }
    }

    /// A pump replayed from its own flow's running median ([`DriveSource::OwnFlow`]).
    pub fn own_flow(self, bench: &Bench) -> bool {
        self.pump()
            .is_some_and(|i| bench.drive_source(i) == DriveSource::OwnFlow)
    }

    /// Whether the part's replay can show `effect`: a pump replayed from its own flow shows
    /// a ripple (a tone the running median does not follow) and nothing of its dynamics (a
    /// dead time or a flow limit is in the recorded flow the median follows).
    pub fn shows(self, bench: &Bench, effect: Effect) -> bool {
        Part::of(effect) == self
            && (!self.own_flow(bench) || matches!(effect, Effect::FlowRipple(_)))
    }
}

/// Replay segment lengths [s]: the hydromechanics long enough to integrate leakage into a
/// displacement drift; the pumps short, so that a single fast transient (a flow ramp at
/// start-up) is cut into pieces that land in both folds.
pub const HYDRO_SEGMENT_S: f64 = 1.0;
pub const PUMP_SEGMENT_S: f64 = 0.25;

/// The replay segments of each part (blocked, alternating between two folds).
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub hydro: Vec<Segment>,
    pub pump: Vec<Segment>,
}

impl Layout {
    /// Segments that never start within 0.3 s after a step of the load or the reference.
    pub fn new(s: &super::series::Series) -> Layout {
        let unsettled = super::series::unsettled(s, &["F_L", "v_ref"], 0.02, 0.3);
        let cut = |length: f64| super::series::segments(s.len(), s.dt, length, &unsettled);
        Layout {
            hydro: cut(HYDRO_SEGMENT_S),
            pump: cut(PUMP_SEGMENT_S),
        }
    }

    pub fn of(&self, part: Part) -> &[Segment] {
        match part {
            Part::Hydro => &self.hydro,
            Part::Pump(_) => &self.pump,
        }
    }
}

/// The fitted quantities: plant parameters and, without an `F_L` column, a constant load.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    pub params: Params,
    pub load: Load,
}

/// Name of the constant-load unknown (not a plant parameter).
pub const LOAD: &str = "F_L";

impl Model {
    pub fn get(&self, name: &str) -> f64 {
        match (name, self.load) {
            (LOAD, Load::Constant(f)) => f,
            _ => self.params.get(name).unwrap_or(f64::NAN),
        }
    }

    /// The model with `values` set for `specs` (values clamped to the bounds).
    pub fn with(&self, specs: &[Spec], values: &[f64]) -> Model {
        let mut m = self.clone();
        for (s, &v) in specs.iter().zip(values) {
            let v = v.clamp(s.bounds.lo, s.bounds.hi);
            if s.name == LOAD {
                m.load = Load::Constant(v);
            } else {
                m.params
                    .set(s.name, v)
                    .expect("spec bounds lie within the variable table's");
            }
        }
        m
    }

    pub fn values(&self, specs: &[Spec]) -> Vec<f64> {
        specs.iter().map(|s| self.get(s.name)).collect()
    }

    /// The model with the values of `specs` multiplied by `factor` (a pump's speed: its
    /// pole a_i with its drive gain b_u_i, so the steady flow per command stays).
    pub fn scaled(&self, specs: &[Spec], factor: f64) -> Model {
        let values: Vec<f64> = self.values(specs).iter().map(|v| v * factor).collect();
        self.with(specs, &values)
    }
}

/// The nominal unknowns of a part over their `search` ranges of variables.toml (Table 2
/// widened for robustness, and the pump's gains; for a pump replayed through its flow loop,
/// the gains of that loop of the family `controller`).
pub fn nominal_specs(part: Part, bench: &Bench, controller: Controller) -> Vec<Spec> {
    match part {
        Part::Hydro => {
            let mut v = vec![
                Spec::searched("beta_e", Log),
                Spec::searched("C_ip", Log),
                Spec::searched("b", Log),
            ];
            if !bench.s.has("F_L") {
                v.push(Spec::linear(LOAD, -1e5, 1e6));
            }
            v
        }
        Part::Pump(_) if part.own_flow(bench) => Vec::new(),
        Part::Pump(i) => {
            let pump = match i {
                Pump::Main => ["a1", "b_u1", "b_p1"],
                Pump::Aux => ["a2", "b_u2", "b_p2"],
            };
            let mut v: Vec<Spec> = pump.map(|n| Spec::searched(n, Log)).into();
            if bench.drive_source(i) == DriveSource::FlowLoop {
                v.extend(loop_specs(i, controller));
            }
            v
        }
    }
}

/// The fitted gains of pump i's reconstructed flow loop (`replay::Bench::drive`): a PID's
/// proportional [mV per L/min] and integral [mV per (L/min s)] gains (an integral gain at
/// the floor acts as none, a P loop), or an ADRC's control bandwidth [rad/s] and estimated
/// input gain [(L/min)/s per V] (its observer as given).
pub fn loop_specs(i: Pump, controller: Controller) -> [Spec; 2] {
    let names = match (controller, i) {
        (Controller::Pid, Pump::Main) => ["Kp1", "Ki1"],
        (Controller::Pid, Pump::Aux) => ["Kp2", "Ki2"],
        (Controller::Adrc, Pump::Main) => ["wc1", "b0_1"],
        (Controller::Adrc, Pump::Aux) => ["wc2", "b0_2"],
    };
    match controller {
        Controller::Pid => [
            Spec::log(names[0], 10.0, 1e5),
            Spec::log(names[1], 1e-2, 1e5),
        ],
        Controller::Adrc => [
            Spec::log(names[0], 1.0, 1e3),
            Spec::log(names[1], 1e-2, 1e4),
        ],
    }
}

/// The free parameters an effect adds: `search` ranges of variables.toml (physically
/// possible, wider than plausible), and those that scale with the recording here. The
/// Stribeck velocity is bounded so that the fitted term is a hump: its excess has decayed to
/// half at the recording's typical sliding speed. A longer v_s makes it a raised friction
/// level, which the viscous term already fits when the piston runs at few speeds.
pub fn effect_specs(effect: Effect, params: &Params, bench: &Bench) -> Vec<Spec> {
    let n = effect.model_parameters();
    let dt = bench.s.dt;
    match effect {
        Effect::StribeckFriction => vec![
            Spec::linear("F_s", params.F_c, (5.0 * params.F_c).max(params.F_c + 1e3)),
            Spec::log(
                "v_s",
                Spec::searched("v_s", Log).bounds.lo,
                widest_hump(bench),
            ),
        ],
        Effect::PressureDependentFriction => vec![Spec::searched("mu", Linear)],
        Effect::PositionDependentLoad => vec![Spec::searched("k_load", Linear)],
        Effect::EntrainedAir => vec![Spec::searched("air_fraction", Log)],
        Effect::ReliefLeakage => vec![
            Spec::searched("p_crack", Linear),
            Spec::searched("K_relief", Log),
        ],
        Effect::PumpDeadTime(_) => vec![Spec::searched(n[0], Linear)],
        Effect::PumpFlowLimit(_) => vec![Spec::searched(n[0], Log)],
        Effect::FlowRipple(_) => vec![
            Spec::searched(n[0], Linear),
            Spec::linear(n[1], 0.01, 0.5 / dt),
            Spec::linear(n[2], -4.0 * PI, 4.0 * PI),
        ],
    }
}

/// The widest Stribeck velocity the fit may take [m/s]: the hump's excess has decayed to
/// under half at the recording's typical sliding speed.
pub fn widest_hump(bench: &Bench) -> f64 {
    (0.95 * bench.typical_speed() / std::f64::consts::LN_2.sqrt()).clamp(2e-4, 0.1)
}

/// Weighted residuals of a part's replay over `segs`: every feature of every signal.
pub fn residuals(bench: &Bench, model: &Model, part: Part, segs: &[Segment]) -> Vec<f64> {
    let mut r = Vec::new();
    for &seg in segs {
        for (name, pred) in predict(bench, model, part, seg) {
            for (_, f) in features(bench, part, name, seg, &pred) {
                r.extend(f.into_iter().filter(|v| *v != 0.0));
            }
        }
    }
    r
}

/// [`residuals`] on the samples of one fold of a split only.
fn fold_residuals(
    bench: &Bench,
    model: &Model,
    part: Part,
    segs: &[Segment],
    split: Split,
    fold: usize,
) -> Vec<f64> {
    let mut r = Vec::new();
    for &seg in segs.iter().filter(|s| split.covers(s, fold)) {
        for (name, pred) in predict(bench, model, part, seg) {
            for (_, f) in features(bench, part, name, seg, &pred) {
                r.extend(
                    f.into_iter()
                        .enumerate()
                        .filter(|&(j, v)| v != 0.0 && split.fold(&seg, seg.start + j) == fold)
                        .map(|(_, v)| v),
                );
            }
        }
    }
    r
}

/// The features a part's prediction of one signal is judged on over a segment, each as an
/// array over the segment's samples (envelope features sit at their window's first sample,
/// zeros elsewhere), in units of the signal's residual scale:
/// - pumps: the raw error (ripple is phase-coherent with the pump);
/// - hydromechanics: the error low-passed (two centred 5-sample moving averages, a
///   9-sample triangle with nulls at 0.2/dt and 0.4/dt; `x`'s about its segment mean,
///   `filter::hydro_error`) and, for `x` and `p`, the error of
///   the oscillation envelope: per 20-sample window, measured RMS of the high-passed signal
///   minus the model's (with the measured noise floor added). Oscillations near the
///   oil-column mode (stick-slip, ringing) have a phase no replay can predict sample by
///   sample, but their amplitude it can.
pub fn features(
    bench: &Bench,
    part: Part,
    name: &'static str,
    seg: Segment,
    pred: &[f64],
) -> Vec<(String, Vec<f64>)> {
    let y = &bench.s.col(name)[seg.start..seg.end];
    let w = 1.0 / scale(bench, name);
    let e: Vec<f64> = y.iter().zip(pred).map(|(y, m)| (y - m) * w).collect();
    match part {
        Part::Pump(_) => vec![(name.to_string(), e)],
        Part::Hydro => {
            let mut out = vec![(name.to_string(), hydro_error(name, &e))];
            if let Some(noise) = bench.envelope_noise(name) {
                out.push((format!("{name}~"), envelope_error(y, pred, noise)));
            }
            out
        }
    }
}

/// Envelope error, (measured - sqrt(model^2 + level^2)) / (level / sqrt(2 W)), `level` the
/// noise's in the window: about zero mean and unit variance when both are noise.
fn envelope_error(y: &[f64], pred: &[f64], noise: &EnvelopeNoise) -> Vec<f64> {
    let mut out = vec![0.0; y.len()];
    let per_level = (2.0 * ENVELOPE_WINDOW as f64).sqrt();
    for (k, gap, level) in envelope_gaps(y, pred, |w| noise.level(w)) {
        let v = gap * per_level / level;
        out[k] = if v == 0.0 { f64::MIN_POSITIVE } else { v };
    }
    out
}

/// Residual scale of a signal (its unit).
pub fn scale(bench: &Bench, name: &str) -> f64 {
    match name {
        "x" => bench.scale.x,
        "v" => bench.scale.v,
        "p" => bench.scale.p,
        "Q1" => bench.scale.q[0],
        _ => bench.scale.q[1],
    }
}

/// A part's predicted signals over one segment.
pub fn predict(
    bench: &Bench,
    model: &Model,
    part: Part,
    seg: Segment,
) -> Vec<(&'static str, Vec<f64>)> {
    match part {
        Part::Hydro => {
            let out = bench.hydro(&model.params, model.load, seg);
            let mut v = vec![("x", out.x), ("p", out.p)];
            if bench.s.has("v") {
                v.push(("v", out.v));
            }
            v
        }
        Part::Pump(i) => vec![(i.flow(), bench.pump(&model.params, i, seg))],
    }
}

/// Most Levenberg-Marquardt iterations of a stage of a candidate's fit, and of a polish
/// (the model every candidate is compared with is fitted to convergence, so that a
/// candidate's gain is its effect's and not further convergence of the nominal unknowns).
pub const ITERATIONS: usize = 15;
pub const POLISH_ITERATIONS: usize = 60;

/// The least-squares options of every diagnosis fit (see `numerics::lm`): Jacobian step
/// 1e-4 in unit coordinates, stop below 1e-4 relative gain or after `iterations`.
fn lm_options(iterations: usize) -> lm::Options {
    lm::Options {
        jacobian_step: 1e-4,
        max_iterations: iterations,
        min_gain: 1e-4,
    }
}

/// Whether `new` are the parameters of an effect whose replay cost is piecewise constant in
/// them: a stuck piston breaks away at the first time step where the drive exceeds `F_s`,
/// so a finite-difference step of `F_s` or `v_s` moves no breakaway and the cost changes
/// only where one jumps a step (measured: the Levenberg-Marquardt fit left both at their
/// starting grid point in both folds of the tune cases 133, 139 and 144).
fn rough(new: &[Spec]) -> bool {
    !new.is_empty()
        && new
            .iter()
            .map(|s| s.name)
            .eq(Effect::StribeckFriction.model_parameters().iter().copied())
}

/// `model` with the friction curve over speed searched by compass steps: the rough `new`
/// parameters together with the viscous `b` of `specs`, which shares the curve with them. A
/// missing hump drags `b` off (to the floor of its range at one sliding speed), and the hump
/// fitted to that `b` alone is the wrong one (measured on tune case 164: one fold's hump
/// 612 N with `b` at the floor, the other 788 N with `b` 3 364 N s/m, truth 793 N and
/// 3 438 N s/m; with `b` searched alongside, 775 and 625 N, `b` 3 108 and 284 N s/m).
fn friction_curve(
    model: &Model,
    specs: &[Spec],
    new: &[Spec],
    cost: &dyn Fn(&Model) -> f64,
) -> Model {
    let curve: Vec<Spec> = specs
        .iter()
        .filter(|s| s.name == "b")
        .chain(new)
        .copied()
        .collect();
    let bounds: Vec<_> = curve.iter().map(|s| s.bounds).collect();
    let f = |v: &[f64]| cost(&model.with(&curve, v));
    let (v, _) = compass(
        &bounds,
        &model.values(&curve),
        &f,
        COMPASS_STEP,
        COMPASS_MIN_STEP,
    );
    model.with(&curve, &v)
}

/// First and least compass step in unit coordinates: about the starting grid's spacing of
/// `v_s` (a factor 1.6) down to 3 % of `v_s` and 0.6 % of the range of `F_s`.
const COMPASS_STEP: f64 = 0.1;
const COMPASS_MIN_STEP: f64 = 0.1 / 16.0;

/// Fits `specs` on `segs`. From each base model (the current fit first, alternatives after)
/// the fit starts at its lowest-cost starting value of the trailing new parameters
/// (`starts`, each as long as the new parameters); the new parameters are fitted alone (the
/// others held; where the cost is piecewise constant in them, [`rough`], by compass steps
/// over the friction curve, [`friction_curve`]), then all jointly; the base whose fit ends
/// lowest wins. A base far off at the start may end lowest: a missing effect can drag the
/// nominal unknowns to where the effect no longer binds (a flow-rate limit taken for a slow
/// pump). Without starts, the joint fit only.
pub fn fit(
    bench: &Bench,
    bases: &[Model],
    part: Part,
    specs: &[Spec],
    starts: &[Vec<f64>],
    segs: &[Segment],
    iterations: usize,
) -> Model {
    fit_on(bases, specs, starts, iterations, &|m: &Model| {
        residuals(bench, m, part, segs)
    })
}

/// [`fit`] on the residual vector `residual` gives for a model.
fn fit_on(
    bases: &[Model],
    specs: &[Spec],
    starts: &[Vec<f64>],
    iterations: usize,
    residual: &(dyn Fn(&Model) -> Vec<f64> + Sync),
) -> Model {
    let cost = |m: &Model| residual(m).iter().map(|r| r * r).sum::<f64>();
    let lowest = |models: Vec<Model>| {
        models
            .into_iter()
            .map(|m| (cost(&m), m))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("at least one model")
    };
    if specs.is_empty() {
        // Nothing to fit (a pump replayed from its own flow, nominally).
        return lowest(bases.to_vec()).1;
    }
    let new = &specs[specs.len() - starts.first().map_or(0, Vec::len)..];
    // Each base is fitted on its own (in parallel, rayon).
    let fitted: Vec<(f64, Model)> = bases
        .par_iter()
        .map(|b| {
            let mut current = if starts.is_empty() {
                b.clone()
            } else {
                lowest(starts.iter().map(|s| b.with(new, s)).collect()).1
            };
            if rough(new) {
                current = friction_curve(&current, specs, new, &cost);
            } else if !new.is_empty() {
                let f = |v: &[f64]| residual(&current.with(new, v));
                current = current.with(
                    new,
                    &lm::fit(new, &current.values(new), &f, &lm_options(iterations)).0,
                );
            }
            // The solver's final cost is that of the model it returns (the same point).
            let f = |v: &[f64]| residual(&current.with(specs, v));
            let (v, solution) = lm::fit(specs, &current.values(specs), &f, &lm_options(iterations));
            (solution.cost, current.with(specs, &v))
        })
        .collect();
    fitted
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .expect("at least one base")
        .1
}

/// Out-of-fold predictions of every signal of a part, one value per sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    pub signals: Vec<(&'static str, Vec<f64>)>,
}

impl Prediction {
    pub fn get(&self, name: &str) -> &[f64] {
        &self
            .signals
            .iter()
            .find(|(n, _)| *n == name)
            .expect("predicted signal")
            .1
    }
}

/// How the samples are split between the two folds of a cross-fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Whole segments alternate: neighbouring, correlated samples stay in one fold, and an
    /// effect must show in more than one event to be validated.
    Blocked,
    /// Samples alternate within every segment: an effect that acts in a single event (a
    /// pump's dead time at the only start-up) lands in both folds; only the noise of the
    /// held-out samples is new to the fit.
    Interleaved,
}

impl Split {
    /// The fold of sample `k` of segment `seg`.
    pub fn fold(self, seg: &Segment, k: usize) -> usize {
        match self {
            Split::Blocked => seg.fold,
            Split::Interleaved => k % 2,
        }
    }

    /// Whether segment `seg` holds samples of fold `fold`.
    fn covers(self, seg: &Segment, fold: usize) -> bool {
        self == Split::Interleaved || seg.fold == fold
    }
}

/// A candidate model fitted on each fold and predicting the other.
#[derive(Clone, Debug)]
pub struct CrossFit {
    /// Model fitted on fold 0 and on fold 1.
    pub folds: [Model; 2],
    pub prediction: Prediction,
    pub split: Split,
}

/// Factors on a pump's speed (its pole a_i with its drive gain b_u_i, so the steady flow per
/// command stays) that its nominal refits start from besides the given one.
const PUMP_SPEEDS: [f64; 2] = [1.0 / 3.0, 3.0];

/// `base` and `base` with the pump's speed (a_i and b_u_i, the first two of the pump's
/// [`nominal_specs`] `specs`) scaled by each of [`PUMP_SPEEDS`]. A bench's pump may be
/// several times faster or slower than the given one (the generator's benches: main 0.1-0.6
/// s, auxiliary 0.02-0.1 s), and a refit from the given pole can stop in a local minimum
/// where the pole trades against the pressure loss b_p_i and, through a reconstructed flow
/// loop, against the loop's gains. Used by the blocked refit (`refit.rs`) and the
/// interleaved one (`search.rs`).
pub fn pump_speeds(base: &Model, specs: &[Spec]) -> Vec<Model> {
    let Some(speed) = specs.get(..2) else {
        // A pump replayed from its own flow: no pole to move.
        return vec![base.clone()];
    };
    std::iter::once(base.clone())
        .chain(PUMP_SPEEDS.iter().map(|&f| base.scaled(speed, f)))
        .collect()
}

/// Fits on each fold of `split` (from `bases[fold]`, new parameters from `starts`, see
/// [`fit`]), moves a fold to the other fold's fit where that is a lower minimum of its own
/// training cost ([`refine`]), and predicts the other.
#[allow(clippy::too_many_arguments)]
pub fn cross_fit(
    bench: &Bench,
    bases: &[Vec<Model>; 2],
    part: Part,
    specs: &[Spec],
    starts: [&[Vec<f64>]; 2],
    segs: &[Segment],
    iterations: usize,
    split: Split,
) -> CrossFit {
    let folds: [Model; 2] = std::array::from_fn(|f| {
        fit_on(&bases[f], specs, starts[f], iterations, &|m: &Model| {
            fold_residuals(bench, m, part, segs, split, f)
        })
    });
    let prediction = out_of_fold(bench, &folds, part, segs, split);
    let cf = CrossFit {
        folds,
        prediction,
        split,
    };
    // A fold whose fit costs more on its own samples than the other fold's fit stopped in
    // a local minimum the other left: it moves there (test
    // `a_fold_stopped_in_a_local_minimum_moves_to_the_other_folds_fit`).
    let other = cf.folds.clone();
    refine(bench, &cf, part, specs, segs, &other).unwrap_or(cf)
}

/// A cross-fit whose folds moved to lower minima of their own training cost, when one of
/// `alternatives` (models of the same `specs`) starts lower than a fold's fit: on each fold
/// the alternative of lowest training cost is polished and kept if it ends below the fold's
/// fit. `None` when no fold moved. The nominal refit starts from the defaults and can stop
/// in a local minimum (a pump fitted far too slow) that a candidate's multi-start fit left
/// (the candidate itself then switched off); a lower minimum of the same cost is a better
/// refit of the same unknowns, not a finding.
pub fn refine(
    bench: &Bench,
    cf: &CrossFit,
    part: Part,
    specs: &[Spec],
    segs: &[Segment],
    alternatives: &[Model],
) -> Option<CrossFit> {
    let mut moved = false;
    let folds: [Model; 2] = std::array::from_fn(|f| {
        let residual = |m: &Model| fold_residuals(bench, m, part, segs, cf.split, f);
        let cost = |m: &Model| residual(m).iter().map(|r| r * r).sum::<f64>();
        let current = cost(&cf.folds[f]);
        let lowest = alternatives
            .iter()
            .map(|m| (cost(m), m))
            .filter(|(c, _)| *c < current)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let Some((_, start)) = lowest else {
            return cf.folds[f].clone();
        };
        let polished = fit_on(
            std::slice::from_ref(start),
            specs,
            &[],
            POLISH_ITERATIONS,
            &residual,
        );
        if cost(&polished) < current {
            moved = true;
            polished
        } else {
            cf.folds[f].clone()
        }
    });
    moved.then(|| {
        let prediction = out_of_fold(bench, &folds, part, segs, cf.split);
        CrossFit {
            folds,
            prediction,
            split: cf.split,
        }
    })
}

/// Predictions of every sample by the model of the other fold.
pub fn out_of_fold(
    bench: &Bench,
    folds: &[Model; 2],
    part: Part,
    segs: &[Segment],
    split: Split,
) -> Prediction {
    let n = bench.s.len();
    let mut signals: Vec<(&'static str, Vec<f64>)> = part
        .signals(bench)
        .into_iter()
        .map(|s| (s, vec![0.0; n]))
        .collect();
    for &seg in segs {
        for (fold, model) in folds.iter().enumerate() {
            if !split.covers(&seg, 1 - fold) {
                continue;
            }
            for (name, pred) in predict(bench, model, part, seg) {
                let slot = &mut signals
                    .iter_mut()
                    .find(|(n, _)| *n == name)
                    .expect("part signal")
                    .1;
                for (j, v) in pred.into_iter().enumerate() {
                    if split.fold(&seg, seg.start + j) != fold {
                        slot[seg.start + j] = v;
                    }
                }
            }
        }
    }
    Prediction { signals }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::series::Series;
    use crate::synth::{generate, BenchScenario, Case};
    use tbm_thrust::Scheme;

    /// Frozen case 900 054: Stribeck friction (`F_s` 625 N, `v_s` 6.1 mm/s) on a start-up
    /// programme of an ADRC bench, 500 Hz. One fold's Stribeck fit stopped at `v_s` 1.1 mm/s
    /// while the other fold's fit (612 N, 9.0 mm/s) cost less on the first fold's own
    /// samples; the candidate's `z` was 2.9 and nothing was named (`x` at 4.1 times its
    /// floor). Moved to the other fold's fit, both folds agree (612 / 611 N) and the friction
    /// is named.
    #[test]
    fn a_fold_stopped_in_a_local_minimum_moves_to_the_other_folds_fit() {
        use crate::diagnose::{diagnose, effect::Effect};
        use crate::synth::{LoopFamily, Variation};
        use tbm_thrust::{Controller, Params};
        let variation = Variation {
            time_offset: 1.6467340613151193,
            noise_scale: 0.8108348495259188,
            absent: vec![],
            family: LoopFamily::PI,
            main_tau: 0.3686841979021911,
            main_size: 1.028330394180764,
            aux_tau: 0.04595940571555313,
            aux_size: 1.812354471687057,
            magnitude: 0.6697441985115483,
            relief_in_plateau: true,
        };
        let case = Case {
            controller: Controller::Adrc,
            substeps: 3,
            jitter: 6.975872518511293e-5,
            sample_period: 0.002,
            variation: Some(variation),
            ..Case::new(
                BenchScenario::Startup,
                Scheme::FixedSplit,
                vec![Effect::StribeckFriction],
                900054,
            )
        };
        let d = diagnose(&Series::generated(&case), &Params::default()).expect("runs");
        let named: Vec<Effect> = d.findings.iter().map(|f| f.effect).collect();
        assert_eq!(named, [Effect::StribeckFriction]);
    }

    /// A pump refit stopped at a pump three times too slow (a local minimum of the
    /// defaults' start) moves to the lower minimum an alternative starts from, and no
    /// higher alternative moves it back.
    #[test]
    fn a_refit_moves_to_a_lower_minimum_and_not_back() {
        let case = Case::new(BenchScenario::SpeedSteps, Scheme::FixedSplit, vec![], 5);
        let synthesis = generate(&case).expect("case generates");
        let rec = crate::recording::Recording::parse(&synthesis.csv, "bench").expect("parses");
        let series = Series::from_recording(&rec).expect("grid");
        let (bench, layout) = (Bench::new(&series), Layout::new(&series));
        let part = Part::Pump(Pump::Main);
        let segs = layout.of(part);
        let truth = Model {
            params: synthesis.params.clone(),
            load: Load::Recorded,
        };
        let specs = nominal_specs(part, &bench, truth.params.controller);
        let speed = &specs[..2];
        let slow = truth.scaled(speed, 1.0 / 3.0);
        let folds = [slow.clone(), slow.clone()];
        let stuck = CrossFit {
            prediction: out_of_fold(&bench, &folds, part, segs, Split::Blocked),
            folds,
            split: Split::Blocked,
        };
        let moved = refine(&bench, &stuck, part, &specs, segs, &[slow.clone(), truth])
            .expect("the lower minimum is taken");
        for fold in &moved.folds {
            let a = fold.get(specs[0].name) / synthesis.params.get(specs[0].name).expect("a1");
            assert!((a - 1.0).abs() < 0.2, "a1 at {a} times the truth");
        }
        assert!(refine(&bench, &moved, part, &specs, segs, &[slow]).is_none());
    }
}
