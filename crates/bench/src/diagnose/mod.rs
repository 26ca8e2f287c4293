//! `diagnose`: what an expert does at the bench, in five steps (docs/diagnose.md):
//! 1. refit the nominal unknowns of each subsystem (a plain parameter mismatch is not
//!    missing physics), on blocked halves of the recording;
//! 2. locate the mismatch: weak-form equation errors of mechanics (Eq. 1), chamber (Eq. 4)
//!    and each pump (Eq. 8), their time windows and operating regime;
//! 3. test every contract effect against the current model on out-of-fold free-run
//!    replays and name those that pass the selection rule, with the evidence in words;
//! 4. fit the named effects with the nominal unknowns on the whole recording;
//! 5. report the fit before and after on data not used to fit.

pub mod effect;
pub mod error;
pub mod explain;
pub mod filter;
pub mod floor;
pub mod locate;
pub mod model;
pub mod note;
pub mod oracle;
pub mod plausible;
pub mod replay;
pub mod search;
pub mod select;
pub mod series;
pub mod starts;

use crate::numerics::lm;
use crate::progress::{Progress, Silent};
use effect::{Effect, Subsystem};
pub use error::Error;
pub use filter::judged;
pub use floor::FLOOR_MULTIPLE;
use locate::{equation_errors, EquationError, Regimes};
use model::{Layout, Model, Part, Prediction};
use note::Note;
use rayon::prelude::*;
use replay::{Bench, Load};
use search::{search, PartResult, Trial};
use series::{Segment, Series};
use std::collections::BTreeMap;
use tbm_thrust::metrics::{fit as fit_signal, Fit};
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::Params;

/// A pump is idle when its peak flow is below this share of the total peak flow.
const IDLE_SHARE: f64 = 0.02;
/// A drive command chatters when more than this share of its sample-to-sample changes
/// exceed a quarter of its range: it varies faster than the recording resolves.
const CHATTER_SHARE: f64 = 0.1;

/// Where the model misses, as in the contract's `mismatch[]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Mismatch {
    pub subsystem: Subsystem,
    pub signal: &'static str,
    pub windows: Vec<[f64; 2]>,
    pub share: f64,
    pub regime: String,
}

/// A named effect, as in the contract's `missing_physics[]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    pub effect: Effect,
    pub parameters: BTreeMap<String, f64>,
    pub evidence: String,
}

/// Everything the diagnosis found, with the series the report plots.
#[derive(Clone, Debug)]
pub struct Diagnosis {
    pub mismatch: Vec<Mismatch>,
    pub findings: Vec<Finding>,
    /// Fit indices per signal on out-of-fold replays: nominal refitted, and with the effects.
    pub fit_before: Vec<(&'static str, Fit)>,
    pub fit_after: Vec<(&'static str, Fit)>,
    /// The nominal model refitted, and the final model with the effects, on all data.
    pub nominal: Params,
    pub params: Params,
    /// Fitted constant load when the recording has no `F_L` [N].
    pub load: Load,
    /// What could not be checked or was handled.
    pub notes: Vec<Note>,
    /// Every candidate tested, in order, per part.
    pub trials: Vec<Trial>,
    /// Out-of-fold replays per signal: nominal and final.
    pub before: Vec<(&'static str, Vec<f64>)>,
    pub after: Vec<(&'static str, Vec<f64>)>,
    /// Weak-form equation errors with the nominal and the final parameters.
    pub equations_before: Vec<EquationError>,
    pub equations_after: Vec<EquationError>,
    /// The recording's grid, its smoothed velocity [m/s], and the replay segments.
    pub series: Series,
    pub velocity: Vec<f64>,
    pub layout: Layout,
    /// The floor each judged signal's held-out error can reach on this recording.
    pub floors: Vec<floor::Floor>,
    /// The signals whose held-out error (with the effects found) stands above
    /// [`FLOOR_MULTIPLE`] times their floor, with that ratio, worst first.
    pub above_floor: Vec<(&'static str, f64)>,
}

impl Diagnosis {
    /// `adequate` only when nothing was named *and* every held-out error lies within
    /// [`FLOOR_MULTIPLE`] times the floor the replay can reach on this recording.
    pub fn verdict(&self) -> &'static str {
        if self.findings.is_empty() && self.above_floor.is_empty() {
            "adequate"
        } else {
            "missing_physics"
        }
    }

    /// The contract's JSON.
    pub fn to_json(&self, params_file: &str) -> serde_json::Value {
        let fits = |f: &[(&str, Fit)]| -> serde_json::Map<String, serde_json::Value> {
            f.iter()
                .map(|(n, f)| {
                    (
                        n.to_string(),
                        serde_json::json!({"r2": f.r2, "rmse": f.rmse, "mape": f.mape}),
                    )
                })
                .collect()
        };
        serde_json::json!({
            "verdict": self.verdict(),
            "mismatch": self.mismatch.iter().map(|m| serde_json::json!({
                "subsystem": m.subsystem.name(), "signal": m.signal, "windows": m.windows,
                "share": m.share, "regime": m.regime,
            })).collect::<Vec<_>>(),
            "missing_physics": self.findings.iter().map(|f| serde_json::json!({
                "effect": f.effect.id(), "parameters": f.parameters, "evidence": f.evidence,
            })).collect::<Vec<_>>(),
            "fit_before": fits(&self.fit_before),
            "fit_after": fits(&self.fit_after),
            "params_file": params_file,
        })
    }
}

/// Runs the diagnosis of a recording against the model `base` (its nominal unknowns are
/// refitted; every other parameter is taken as known).
pub fn diagnose(series: &Series, base: &Params) -> Result<Diagnosis, Error> {
    diagnose_reporting(series, base, &Silent)
}

/// `diagnose`, telling `progress` how far it has got: the floors, each part's nominal fit,
/// each effect trial and the two final fits are a unit each.
pub fn diagnose_reporting(
    series: &Series,
    base: &Params,
    progress: &dyn Progress,
) -> Result<Diagnosis, Error> {
    base.validate()?;
    progress.found(3);
    let bench = Bench::new(series);
    let mut notes = series.notes.clone();
    let parts = active_parts(&bench, &mut notes);
    let layout = Layout::new(series);
    let base = Model {
        params: base.clone(),
        load: initial_load(&bench, base, &mut notes),
    };
    // The floor each signal's replay can reach, with the model as given (the propagation of
    // noise hardly depends on the nominal unknowns).
    let floor_parts: Vec<(Part, Model, Vec<Segment>)> = parts
        .iter()
        .map(|&p| (p, base.clone(), layout.of(p).to_vec()))
        .collect();
    let floors = floor::floors(series, &floor_parts);
    progress.done(1);
    let results = search(&bench, &base, &parts, &layout, &floors, progress);
    notes.extend(results.iter().filter_map(|r| match r.part {
        Part::Pump(pump) if r.effects.is_empty() && r.last.split == model::Split::Interleaved => {
            Some(Note::SingleEvent { pump })
        }
        _ => None,
    }));
    let nominal = merge(&bench, &base, &results, &layout, |r| {
        (&r.nominal.folds[..], model::nominal_specs(r.part, &bench))
    });
    progress.done(1);
    let fitted = merge(&bench, &base, &results, &layout, |r| {
        (&r.last.folds[..], r.specs.clone())
    });
    progress.done(1);
    let pumps: Vec<Pump> = parts
        .iter()
        .filter_map(|p| {
            if let Part::Pump(i) = p {
                Some(*i)
            } else {
                None
            }
        })
        .collect();
    let equations_before = equation_errors(&bench, &nominal.params, nominal.load, &pumps);
    let equations_after = equation_errors(&bench, &fitted.params, fitted.load, &pumps);
    let regimes = Regimes::of(&bench);
    let findings = findings(&bench, &results, &fitted.params, &regimes, &layout);
    let mut mismatch = mismatch(&bench, &results, &regimes, &layout);
    let before = predictions(&results, |r| &r.nominal.prediction);
    let after = predictions(&results, |r| &r.last.prediction);
    let fit_before = fits(&bench, &layout.hydro, &before);
    let fit_after = fits(&bench, &layout.hydro, &after);
    let above_floor = above_floor(&fit_after, &floors);
    notes.extend(above_floor.iter().map(|&(signal, ratio)| Note::AboveFloor {
        signal,
        ratio,
        explained: !findings.is_empty(),
    }));
    if findings.is_empty() {
        mismatch = unexplained(&bench, &layout, &after, &floors, &above_floor, &regimes);
    }
    Ok(Diagnosis {
        above_floor,
        fit_before,
        fit_after,
        mismatch,
        findings,
        nominal: nominal.params,
        params: fitted.params,
        load: fitted.load,
        notes,
        trials: results.iter().flat_map(|r| r.trials.clone()).collect(),
        before,
        after,
        equations_before,
        equations_after,
        velocity: bench.v.clone(),
        layout,
        series: series.clone(),
        floors,
    })
}

/// The signals whose held-out RMSE exceeds FLOOR_MULTIPLE times their floor, worst first.
fn above_floor(fits: &[(&'static str, Fit)], floors: &[floor::Floor]) -> Vec<(&'static str, f64)> {
    let mut out: Vec<(&'static str, f64)> = fits
        .iter()
        .filter_map(|(name, fit)| {
            let f = floors.iter().find(|f| f.signal == *name)?.total();
            (f > 0.0).then_some((*name, fit.rmse / f))
        })
        .filter(|(_, ratio)| *ratio > FLOOR_MULTIPLE)
        .collect();
    out.sort_by(|a, b| b.1.total_cmp(&a.1));
    out
}

/// The subsystem whose replay carries a signal's misfit when no effect explains it: the
/// pumps' flows their pumps, the displacement and velocity the mechanics, the pressure the
/// chamber.
fn subsystem_of(signal: &str) -> Subsystem {
    match signal {
        "Q1" => Subsystem::Pump(Pump::Main),
        "Q2" => Subsystem::Pump(Pump::Aux),
        "p" => Subsystem::Chamber,
        _ => Subsystem::Mechanics,
    }
}

/// The mismatch of a recording above its floor that no effect explains: per signal, where
/// its judged squared error exceeds the floor's, in which regime, and the share of its error
/// above the floor.
fn unexplained(
    bench: &Bench,
    layout: &Layout,
    after: &[(&'static str, Vec<f64>)],
    floors: &[floor::Floor],
    above: &[(&'static str, f64)],
    regimes: &Regimes,
) -> Vec<Mismatch> {
    let mut out: Vec<Mismatch> = Vec::new();
    for &(signal, ratio) in above {
        let subsystem = subsystem_of(signal);
        if out.iter().any(|m| m.subsystem == subsystem) {
            continue;
        }
        let (Some((_, pred)), Some(fl)) = (
            after.iter().find(|(n, _)| *n == signal),
            floors.iter().find(|f| f.signal == signal),
        ) else {
            continue;
        };
        let (y, m) = judged(bench.s, &layout.hydro, signal, pred);
        let f2 = fl.total().powi(2);
        let weight: Vec<f64> = y
            .iter()
            .zip(&m)
            .map(|(y, m)| ((y - m).powi(2) - f2).max(0.0))
            .collect();
        out.push(Mismatch {
            subsystem,
            signal,
            windows: locate::windows(bench, &weight, 6),
            share: 1.0 - 1.0 / (ratio * ratio),
            regime: regimes.describe(&weight),
        });
    }
    out
}

/// The parts that can be replayed: the hydromechanics always; a pump when it runs and its
/// drive command is recorded and resolved by the sampling.
pub(crate) fn active_parts(bench: &Bench, notes: &mut Vec<Note>) -> Vec<Part> {
    let s = bench.s;
    let peak = |name: &str| s.col(name).iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let total = peak("Q1").max(peak("Q2"));
    let mut parts = vec![Part::Hydro];
    for i in Pump::BOTH {
        let (q, uc) = (i.flow(), i.drive());
        if peak(q) <= IDLE_SHARE * total {
            notes.push(Note::PumpIdle {
                pump: i,
                share: IDLE_SHARE,
            });
        } else if !s.has(uc) {
            notes.push(Note::NoDriveCommand { pump: i });
        } else if let Some(share) = chatter(s.col(uc)) {
            notes.push(Note::ChatteringCommand { pump: i, share });
        } else {
            parts.push(Part::Pump(i));
        }
    }
    parts
}

/// The share of large sample-to-sample jumps of a command, if it counts as chatter.
fn chatter(uc: &[f64]) -> Option<f64> {
    let range =
        uc.iter().fold(f64::MIN, |a, &b| a.max(b)) - uc.iter().fold(f64::MAX, |a, &b| a.min(b));
    if range <= 0.0 {
        return None;
    }
    let jumps = uc
        .windows(2)
        .filter(|w| (w[1] - w[0]).abs() > 0.25 * range)
        .count();
    let share = jumps as f64 / (uc.len() - 1) as f64;
    (share > CHATTER_SHARE).then_some(share)
}

/// The load of the replays: the `F_L` column, or a constant to fit, started from the mean
/// hydraulic force while the piston moves.
pub(crate) fn initial_load(bench: &Bench, p: &Params, notes: &mut Vec<Note>) -> Load {
    if bench.s.has("F_L") {
        return Load::Recorded;
    }
    let pr = bench.s.col("p");
    let moving: Vec<f64> = (0..pr.len())
        .filter(|&k| bench.v[k] > 1e-3)
        .map(|k| pr[k])
        .collect();
    let mean = if moving.is_empty() {
        pr.iter().sum::<f64>() / pr.len() as f64
    } else {
        moving.iter().sum::<f64>() / moving.len() as f64
    };
    notes.push(Note::ConstantLoad);
    Load::Constant((p.A * (mean - p.p_t) - p.F_c).max(0.0))
}

/// Each part's model fitted on all segments (from the better of the two fold fits on all
/// data: where the fold fits disagree along a flat direction, all data decide), merged into
/// one model.
fn merge<'a>(
    bench: &Bench,
    base: &Model,
    results: &'a [PartResult],
    layout: &Layout,
    pick: impl Fn(&'a PartResult) -> (&'a [Model], Vec<lm::Spec>) + Sync,
) -> Model {
    let fitted: Vec<_> = results
        .par_iter()
        .map(|r| {
            let (start, specs) = pick(r);
            (
                specs.clone(),
                model::fit(
                    bench,
                    start,
                    r.part,
                    &specs,
                    &[],
                    layout.of(r.part),
                    model::POLISH_ITERATIONS,
                ),
            )
        })
        .collect();
    let mut out = base.clone();
    for (specs, m) in fitted {
        out = out.with(&specs, &m.values(&specs));
    }
    out
}

fn predictions<'a>(
    results: &'a [PartResult],
    pick: impl Fn(&'a PartResult) -> &'a Prediction,
) -> Vec<(&'static str, Vec<f64>)> {
    results
        .iter()
        .flat_map(|r| pick(r).signals.clone())
        .collect()
}

/// Fit indices of each predicted signal, on the signal as the method judges it: the pump
/// flows as recorded; the hydromechanics signals on what a replay can predict, their level
/// low-passed segment by segment (measured and replayed alike) and, for `x` and `p`, their
/// oscillation envelope: the squared envelope error (per 20-sample window, held over the
/// window's samples, in the signal's unit) is added to the squared level error of every
/// sample, so that RMSE and R^2 count both; MAPE is the level's.
fn fits(
    bench: &Bench,
    segs: &[Segment],
    preds: &[(&'static str, Vec<f64>)],
) -> Vec<(&'static str, Fit)> {
    preds
        .iter()
        .map(|(n, p)| {
            let (y, m) = judged(bench.s, segs, n, p);
            let mut fit = fit_signal(&y, &m);
            if let Some(&floor) = bench.envelope_floor.get(n) {
                let raw = bench.s.col(n);
                let extra: f64 = segs
                    .iter()
                    .flat_map(|s| {
                        filter::envelope_gap(&raw[s.start..s.end], &p[s.start..s.end], floor)
                    })
                    .map(|g| g * g)
                    .sum::<f64>();
                let count = segs.iter().map(|s| s.end - s.start).sum::<usize>().max(1) as f64;
                let mean = y.iter().sum::<f64>() / y.len() as f64;
                let ss_tot: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
                let sse = fit.rmse.powi(2) * y.len() as f64 + extra;
                fit.rmse = (fit.rmse.powi(2) + extra / count).sqrt();
                if ss_tot > 0.0 {
                    fit.r2 = 1.0 - sse / ss_tot;
                }
            }
            (*n, fit)
        })
        .collect()
}

/// The accepted trials of a part in order, each with the prediction it improved on.
fn accepted(r: &PartResult) -> Vec<(&Trial, &Prediction)> {
    let mut prev = &r.nominal.prediction;
    let mut out = Vec::new();
    for e in &r.effects {
        let t = r
            .trials
            .iter()
            .find(|t| t.chosen && t.effect == *e)
            .expect("accepted trial");
        out.push((t, prev));
        prev = &t.fit.prediction;
    }
    out
}

/// The signal whose judged free-run error (level and, for `x` and `p`, oscillation
/// envelope: the selection rule's features) an effect cut the most, and by how much [1].
fn best_signal(
    bench: &Bench,
    part: Part,
    segs: &[Segment],
    before: &Prediction,
    after: &Prediction,
) -> (&'static str, f64) {
    let fb = select::feature_arrays(bench, part, segs, before);
    let fa = select::feature_arrays(bench, part, segs, after);
    let sum = |f: &[(String, Vec<f64>)], n: &str| -> f64 {
        f.iter()
            .filter(|(k, _)| k.trim_end_matches('~') == n)
            .flat_map(|(_, v)| v.iter().map(|x| x * x))
            .sum()
    };
    before
        .signals
        .iter()
        .map(|(n, _)| {
            let (b, a) = (sum(&fb, n), sum(&fa, n));
            (*n, if b > 0.0 { 1.0 - a / b } else { 0.0 })
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .expect("a part predicts at least one signal")
}

/// Per-sample squared-error drop of a part's features from `before` to `after`.
fn improvement(
    bench: &Bench,
    part: Part,
    segs: &[Segment],
    before: &Prediction,
    after: &Prediction,
) -> Vec<f64> {
    let fb = select::feature_arrays(bench, part, segs, before);
    let fa = select::feature_arrays(bench, part, segs, after);
    let mut w = vec![0.0; bench.s.len()];
    for ((_, b), (_, a)) in fb.iter().zip(&fa) {
        for k in 0..w.len() {
            w[k] += (b[k] * b[k] - a[k] * a[k]).max(0.0);
        }
    }
    w
}

fn findings(
    bench: &Bench,
    results: &[PartResult],
    p: &Params,
    regimes: &Regimes,
    layout: &Layout,
) -> Vec<Finding> {
    let mut out: Vec<(f64, Finding)> = Vec::new();
    for r in results {
        for (t, before) in accepted(r) {
            let (signal, drop) =
                best_signal(bench, r.part, layout.of(r.part), before, &t.fit.prediction);
            let regime = regimes.describe(&improvement(
                bench,
                r.part,
                layout.of(r.part),
                before,
                &t.fit.prediction,
            ));
            let evidence = explain::evidence(t.effect, p, bench, t, signal, drop, &regime);
            out.push((
                t.comparison.z,
                Finding {
                    effect: t.effect,
                    parameters: t.effect.reported(p),
                    evidence,
                },
            ));
        }
    }
    out.sort_by(|a, b| b.0.total_cmp(&a.0));
    out.into_iter().map(|(_, f)| f).collect()
}

/// The subsystems that carry named effects, best first: the signal that shows it, where,
/// in which regime, and the share of the nominal model's held-out error it removes.
fn mismatch(
    bench: &Bench,
    results: &[PartResult],
    regimes: &Regimes,
    layout: &Layout,
) -> Vec<Mismatch> {
    let total: f64 = results
        .iter()
        .flat_map(|r| {
            select::feature_arrays(bench, r.part, layout.of(r.part), &r.nominal.prediction)
        })
        .flat_map(|(_, v)| v.into_iter().map(|x| x * x))
        .sum();
    let mut out: Vec<Mismatch> = Vec::new();
    for r in results {
        for (t, before) in accepted(r) {
            let weight = improvement(bench, r.part, layout.of(r.part), before, &t.fit.prediction);
            let share = weight.iter().sum::<f64>() / total.max(f64::MIN_POSITIVE);
            let subsystem = t.effect.subsystem();
            match out.iter_mut().find(|m| m.subsystem == subsystem) {
                Some(m) => m.share += share,
                None => out.push(Mismatch {
                    subsystem,
                    signal: best_signal(
                        bench,
                        r.part,
                        layout.of(r.part),
                        before,
                        &t.fit.prediction,
                    )
                    .0,
                    windows: locate::windows(bench, &weight, 6),
                    share,
                    regime: regimes.describe(&weight),
                }),
            }
        }
    }
    out.sort_by(|a, b| b.share.total_cmp(&a.share));
    out
}
