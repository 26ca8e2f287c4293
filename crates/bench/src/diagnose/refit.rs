//! Stage 2, refit the nominal model: each replayable part's nominal unknowns cross-fitted
//! on blocked halves of the recording (a plain parameter mismatch is not missing physics).

use super::model::{cross_fit, nominal_specs, Split, POLISH_ITERATIONS};
use super::prepare::Prepared;
use super::search::PartResult;
use crate::progress::Progress;
use rayon::prelude::*;

/// Each part's nominal cross-fit, the start of `propose::propose`.
pub struct Refit {
    pub parts: Vec<PartResult>,
}

/// Cross-fits the nominal unknowns of every part (in parallel, rayon), telling `progress`
/// of each part.
pub fn refit(prepared: &Prepared, progress: &dyn Progress) -> Refit {
    let (bench, base, parts) = (&prepared.bench, &prepared.base, &prepared.parts);
    progress.found(parts.len() as u64);
    let parts: Vec<PartResult> = parts
        .par_iter()
        .map(|&part| {
            let specs = nominal_specs(part, bench, base.params.controller);
            let cf = cross_fit(
                bench,
                &[vec![base.clone()], vec![base.clone()]],
                part,
                &specs,
                &[],
                prepared.layout.of(part),
                POLISH_ITERATIONS,
                Split::Blocked,
            );
            PartResult::nominal(part, specs, cf)
        })
        .collect();
    progress.done(parts.len() as u64);
    Refit { parts }
}
