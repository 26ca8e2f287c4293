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
pub mod explain;
pub mod locate;
pub mod model;
pub mod plausible;
pub mod replay;
pub mod search;
pub mod select;
pub mod series;
pub mod starts;

use crate::numerics::lm;
use effect::{Effect, Subsystem};
use locate::{equation_errors, EquationError, Regimes};
use model::{Layout, Model, Part, Prediction};
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
    /// What could not be checked or was handled, one sentence each.
    pub notes: Vec<String>,
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
}

impl Diagnosis {
    pub fn verdict(&self) -> &'static str {
        if self.findings.is_empty() {
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
pub fn diagnose(series: &Series, base: &Params) -> Result<Diagnosis, String> {
    base.validate().map_err(|e| e.to_string())?;
    let bench = Bench::new(series);
    let mut notes = series.notes.clone();
    let parts = active_parts(&bench, &mut notes);
    let layout = Layout::new(series);
    let base = Model {
        params: base.clone(),
        load: initial_load(&bench, base, &mut notes),
    };
    let results = search(&bench, &base, &parts, &layout);
    let nominal = merge(&bench, &base, &results, &layout, |r| {
        (&r.nominal.folds[0], model::nominal_specs(r.part, &bench))
    });
    let fitted = merge(&bench, &base, &results, &layout, |r| {
        (&r.last.folds[0], r.specs.clone())
    });
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
    let mismatch = mismatch(&bench, &results, &regimes, &layout);
    let before = predictions(&results, |r| &r.nominal.prediction);
    let after = predictions(&results, |r| &r.last.prediction);
    let fit_before = fits(series, &layout.hydro, &before);
    let fit_after = fits(series, &layout.hydro, &after);
    notes.extend(poor_fits(&fit_after));
    Ok(Diagnosis {
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
    })
}

/// R^2 below which a held-out fit does not even fit at a glance.
const POOR_R2: f64 = 0.9;

/// A sentence for every signal the final model still fits poorly: something outside the
/// contract's effects (or an unrecorded input) is missing, and nothing is invented for it.
fn poor_fits(fits: &[(&'static str, Fit)]) -> Vec<String> {
    fits.iter()
        .filter(|(_, f)| f.r2 < POOR_R2)
        .map(|(n, f)| {
            format!(
                "the model explains only R^2 = {:.2} of `{n}` on held-out data and no contract effect accounts for the rest: look for an unrecorded input (a varying load without `F_L`?) or physics outside the contract's list",
                f.r2
            )
        })
        .collect()
}

/// The parts that can be replayed: the hydromechanics always; a pump when it runs and its
/// drive command is recorded and resolved by the sampling.
fn active_parts(bench: &Bench, notes: &mut Vec<String>) -> Vec<Part> {
    let s = bench.s;
    let peak = |name: &str| s.col(name).iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let total = peak("Q1").max(peak("Q2"));
    let mut parts = vec![Part::Hydro];
    for i in Pump::BOTH {
        let (q, uc) = (i.flow(), i.drive());
        if peak(q) <= IDLE_SHARE * total {
            notes.push(format!("pump {i} is idle ({q} stays below {:.0} % of the peak flow): its equation was not checked", 100.0 * IDLE_SHARE));
        } else if !s.has(uc) {
            notes.push(format!("no `{uc}` column: pump {i}'s equation (Eq. 8) and its effects (dead time, flow limit, ripple) were not checked; `{q}` is still used as the chamber's inflow"));
        } else if let Some(share) = chatter(s.col(uc)) {
            notes.push(format!(
                "`{uc}` changes by more than a quarter of its range between {:.0} % of successive samples: the drive command varies faster than the recording resolves, so pump {i} cannot be replayed from it and its effects were not checked",
                100.0 * share
            ));
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
fn initial_load(bench: &Bench, p: &Params, notes: &mut Vec<String>) -> Load {
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
    notes
        .push("no `F_L` column: the load is fitted as a constant with the nominal unknowns".into());
    Load::Constant((p.A * (mean - p.p_t) - p.F_c).max(0.0))
}

/// Each part's model fitted on all segments (from the fold-0 fit), merged into one model.
fn merge<'a>(
    bench: &Bench,
    base: &Model,
    results: &'a [PartResult],
    layout: &Layout,
    pick: impl Fn(&'a PartResult) -> (&'a Model, Vec<lm::Spec>) + Sync,
) -> Model {
    let fitted: Vec<_> = results
        .par_iter()
        .map(|r| {
            let (start, specs) = pick(r);
            (
                specs.clone(),
                model::fit(
                    bench,
                    std::slice::from_ref(start),
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

/// Fit indices of each predicted signal, on the signal as the method judges it: the
/// hydromechanics signals low-passed segment by segment (measured and replayed alike), the
/// pump flows as recorded.
fn fits(
    series: &Series,
    segs: &[Segment],
    preds: &[(&'static str, Vec<f64>)],
) -> Vec<(&'static str, Fit)> {
    preds
        .iter()
        .map(|(n, p)| {
            let (y, m) = judged(series, segs, n, p);
            (*n, fit_signal(&y, &m))
        })
        .collect()
}

/// A measured signal and its replay as the method judges them (see [`fits`]).
pub fn judged(series: &Series, segs: &[Segment], name: &str, pred: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let y = series.col(name);
    if name.starts_with('Q') {
        return (y.to_vec(), pred.to_vec());
    }
    let (mut ly, mut lm) = (vec![0.0; y.len()], vec![0.0; y.len()]);
    for s in segs {
        ly[s.start..s.end].copy_from_slice(&model::low_pass(&y[s.start..s.end]));
        lm[s.start..s.end].copy_from_slice(&model::low_pass(&pred[s.start..s.end]));
    }
    (ly, lm)
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
