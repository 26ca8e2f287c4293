//! Stage 3, propose, fit and select candidate effects: per part, every effect of the
//! contract is fitted on top of the current model and judged on out-of-fold free-run
//! replays; the best one that passes the selection rule is accepted, and the rest are
//! tested on top of it (`search.rs`, with the rule's statistics in `select.rs` and
//! `plausible.rs`).

use super::model::{Part, Split};
use super::note::Note;
use super::prepare::Prepared;
use super::refit::Refit;
use super::search::{search, PartResult};
use crate::progress::Progress;

/// Each part's accepted effects with every trial, taken by every later stage.
pub struct Proposed {
    pub parts: Vec<PartResult>,
    /// The pumps judged on interleaved samples with no effect named: a single event.
    pub notes: Vec<Note>,
}

/// Runs the forward selection from the nominal fits, telling `progress` of each trial.
pub fn propose(prepared: &Prepared, refit: Refit, progress: &dyn Progress) -> Proposed {
    let parts = search(
        &prepared.bench,
        &prepared.base,
        refit.parts,
        &prepared.layout,
        &prepared.floors,
        progress,
    );
    let notes = parts
        .iter()
        .filter_map(|r| match r.part {
            Part::Pump(pump) if r.effects.is_empty() && r.last.split == Split::Interleaved => {
                Some(Note::SingleEvent { pump })
            }
            _ => None,
        })
        .collect();
    Proposed { parts, notes }
}
