//! Stage 5, locate and name: the operating regimes, the weak-form equation errors of the
//! nominal and the final model (Eq. 1, 4, 8), the named effects with their evidence in words,
//! and where each subsystem that carries a named effect misses.

use super::effect::{Effect, Subsystem};
use super::explain;
use super::locate::{equation_errors, windows, EquationError, Regimes};
use super::model::{Layout, Part, Prediction};
use super::prepare::Prepared;
use super::propose::Proposed;
use super::replay::Bench;
use super::search::{PartResult, Trial};
use super::select;
use super::series::Segment;
use super::whole::Whole;
use std::collections::BTreeMap;
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::Params;

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

/// What was found where, taken by `report::report`.
pub struct Attribution {
    pub regimes: Regimes,
    /// Weak-form equation errors with the nominal and the final parameters.
    pub equations_before: Vec<EquationError>,
    pub equations_after: Vec<EquationError>,
    /// The named effects, most significant first.
    pub findings: Vec<Finding>,
    /// The subsystems that carry named effects, largest share first.
    pub mismatch: Vec<Mismatch>,
}

/// Locates the mismatch and names the accepted effects with their evidence.
pub fn attribute(prepared: &Prepared, proposed: &Proposed, whole: &Whole) -> Attribution {
    let (bench, layout, results) = (&prepared.bench, &prepared.layout, &proposed.parts[..]);
    // The pumps replayed from a drive: a pump's own flow has no equation to check.
    let pumps: Vec<Pump> = prepared
        .parts
        .iter()
        .filter(|p| !p.own_flow(bench))
        .filter_map(|p| p.pump())
        .collect();
    let (nominal, fitted) = (&whole.nominal, &whole.fitted);
    let equations_before = equation_errors(bench, &nominal.params, nominal.load, &pumps);
    let equations_after = equation_errors(bench, &fitted.params, fitted.load, &pumps);
    let regimes = Regimes::of(bench);
    let findings = findings(bench, results, &fitted.params, &regimes, layout);
    let mismatch = mismatch(bench, results, &regimes, layout);
    Attribution {
        regimes,
        equations_before,
        equations_after,
        findings,
        mismatch,
    }
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
                    windows: windows(bench, &weight, 6),
                    share,
                    regime: regimes.describe(&weight),
                }),
            }
        }
    }
    out.sort_by(|a, b| b.share.total_cmp(&a.share));
    out
}
