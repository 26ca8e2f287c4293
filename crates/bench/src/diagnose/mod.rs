//! `diagnose`: what an expert does at the bench, as a pipeline of six stages that each take
//! the results of the stages before them and nothing later (docs/diagnose.md):
//! 1. [`prepare`]: the series on the replay bench, the parts that can be replayed, the model
//!    as given and the floor each signal's held-out error can reach;
//! 2. [`refit`]: the nominal unknowns of each part refitted on blocked halves (a plain
//!    parameter mismatch is not missing physics); a pump refitted faster than the logger
//!    samples is replayed from its own flow from then on (`refit::faster_than_the_logger`);
//! 3. [`propose`]: every contract effect fitted on top of the current model, tested on
//!    out-of-fold free-run replays and accepted when it passes the selection rule;
//! 4. [`whole`]: the nominal and the final model fitted on the whole recording;
//! 5. [`attribute`]: the mismatch located (weak-form equation errors of mechanics (Eq. 1),
//!    chamber (Eq. 4) and each pump (Eq. 8), time windows, operating regime) and the
//!    accepted effects named with the evidence in words;
//! 6. [`report`]: the fit before and after on data not used to fit.
//!
//! The other modules support the stages: series, filter, noise, replay, model, floor, starts,
//! plausible, select, search, locate, explain, effect, note, error (and oracle, for the
//! evaluation).

// The stages (in the order of the list above and of `diagnose_reporting`).
pub mod attribute;
pub mod prepare;
pub mod propose;
pub mod refit;
pub mod report;
pub mod whole;

// What the stages are built from.
pub mod effect;
pub mod error;
pub mod explain;
pub mod filter;
pub mod floor;
pub mod locate;
pub mod model;
pub mod noise;
pub mod note;
pub mod oracle;
pub mod plausible;
pub mod replay;
pub mod search;
pub mod select;
pub mod series;
pub mod starts;

use crate::progress::{Progress, Silent};
pub use attribute::{Finding, Mismatch};
pub use error::Error;
pub use filter::judged;
pub use floor::FLOOR_MULTIPLE;
pub use report::Diagnosis;
use series::Series;
use tbm_thrust::variables::Params;

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
    let mut prepared = prepare::prepare(series, base)?;
    progress.found(3);
    progress.done(1);
    let refit = refit::refit(&mut prepared, progress);
    let proposed = propose::propose(&prepared, refit, progress);
    let whole = whole::fit_whole(&prepared, &proposed, progress);
    let attribution = attribute::attribute(&prepared, &proposed, &whole);
    Ok(report::report(prepared, proposed, whole, attribution))
}
