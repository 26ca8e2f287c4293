//! Stage 4, fit on the whole recording: the nominal model and the model with the accepted
//! effects, each part refitted on all its segments and the parts merged into one model.

use super::model::{self, Model};
use super::prepare::Prepared;
use super::propose::Proposed;
use super::search::PartResult;
use crate::numerics::lm;
use crate::progress::Progress;
use rayon::prelude::*;

/// The two models on all data, taken by `attribute::attribute` and `report::report`.
pub struct Whole {
    /// The nominal model refitted.
    pub nominal: Model,
    /// The final model, with the effects.
    pub fitted: Model,
}

/// Fits the nominal and the final model on all data, telling `progress` of each.
pub fn fit_whole(prepared: &Prepared, proposed: &Proposed, progress: &dyn Progress) -> Whole {
    let bench = &prepared.bench;
    let nominal = merge(prepared, &proposed.parts, |r| {
        (
            &r.nominal.folds[..],
            model::nominal_specs(r.part, bench, r.nominal.folds[0].params.controller),
        )
    });
    progress.done(1);
    let fitted = merge(prepared, &proposed.parts, |r| {
        (&r.last.folds[..], r.specs.clone())
    });
    progress.done(1);
    Whole { nominal, fitted }
}

/// Each part's model fitted on all segments (from the better of the two fold fits on all
/// data: where the fold fits disagree along a flat direction, all data decide), merged into
/// one model.
fn merge<'a>(
    prepared: &Prepared,
    results: &'a [PartResult],
    pick: impl Fn(&'a PartResult) -> (&'a [Model], Vec<lm::Spec>) + Sync,
) -> Model {
    let (bench, layout) = (&prepared.bench, &prepared.layout);
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
    let mut out = prepared.base.clone();
    for (specs, m) in fitted {
        out = out.with(&specs, &m.values(&specs));
    }
    out
}
