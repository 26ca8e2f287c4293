//! Stage 6, report: the fit before and after on data not used to fit, the signals whose
//! held-out error stays above the reachable floor, the notes, and where the model misses
//! when no effect explains it.

use super::attribute::{Attribution, Finding, Mismatch};
use super::effect::Subsystem;
use super::filter::{self, judged};
use super::floor::{self, FLOOR_MULTIPLE};
use super::locate::{self, EquationError, Regimes};
use super::model::{Layout, Prediction};
use super::note::Note;
use super::prepare::Prepared;
use super::propose::Proposed;
use super::replay::{Bench, Load};
use super::search::{PartResult, Trial};
use super::series::{Segment, Series};
use super::whole::Whole;
use tbm_thrust::metrics::{fit as fit_signal, Fit};
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::Params;

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

/// The diagnosis from the stages' results.
pub fn report(
    prepared: Prepared,
    proposed: Proposed,
    whole: Whole,
    attribution: Attribution,
) -> Diagnosis {
    let Prepared {
        series,
        bench,
        mut notes,
        layout,
        floors,
        ..
    } = prepared;
    let results = &proposed.parts;
    notes.extend(proposed.notes);
    let before = predictions(results, |r| &r.nominal.prediction);
    let after = predictions(results, |r| &r.last.prediction);
    let fit_before = fits(&bench, &layout.hydro, &before);
    let fit_after = fits(&bench, &layout.hydro, &after);
    let above_floor = above_floor(&fit_after, &floors);
    let Attribution {
        regimes,
        equations_before,
        equations_after,
        findings,
        mut mismatch,
    } = attribution;
    notes.extend(above_floor.iter().map(|&(signal, ratio)| Note::AboveFloor {
        signal,
        ratio,
        explained: !findings.is_empty(),
    }));
    if findings.is_empty() {
        mismatch = unexplained(&bench, &layout, &after, &floors, &above_floor, &regimes);
    }
    Diagnosis {
        above_floor,
        fit_before,
        fit_after,
        mismatch,
        findings,
        nominal: whole.nominal.params,
        params: whole.fitted.params,
        load: whole.fitted.load,
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
    }
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
/// low-passed segment by segment (measured and replayed alike; `x` about its segment mean,
/// `filter::hydro_error`) and, for `x` and `p`, their
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
            if let Some(noise) = bench.envelope_noise(n) {
                let raw = bench.s.col(n);
                let extra: f64 = segs
                    .iter()
                    .flat_map(|s| {
                        filter::envelope_gap(&raw[s.start..s.end], &p[s.start..s.end], |w| {
                            noise.level(w)
                        })
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
