//! Stage 3, propose, fit and select candidate effects: per part, every effect of the
//! contract is fitted on top of the current model and judged on out-of-fold free-run
//! replays; the best one that passes the selection rule is accepted, and the rest are
//! tested on top of it (`search.rs`, with the rule's statistics in `select.rs` and
//! `plausible.rs`).

use super::effect::Effect;
use super::model::{Part, Split};
use super::note::Note;
use super::prepare::Prepared;
use super::refit::Refit;
use super::search::{search, PartResult};
use crate::numerics::stats::quantile;
use crate::progress::Progress;

/// Each part's accepted effects with every trial, taken by every later stage.
pub struct Proposed {
    pub parts: Vec<PartResult>,
    /// The parts whose refit moved to a lower minimum, the pumps judged on interleaved
    /// samples with no effect named (a single event), and a friction effect named at one
    /// sliding pressure.
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
    let span_pa = sliding_pressure_span(&prepared.bench);
    let restarted = parts
        .iter()
        .filter(|r| r.restarted)
        .map(|r| Note::Restarted {
            pump: r.part.pump(),
        });
    let notes = restarted
        .chain(parts.iter().flat_map(|r| {
            match r.part {
                Part::Pump(pump) if r.effects.is_empty() && r.last.split == Split::Interleaved => {
                    vec![Note::SingleEvent { pump }]
                }
                Part::Hydro if span_pa < super::plausible::PRESSURE_SPAN => r
                    .effects
                    .iter()
                    .filter(|e| FRICTION.contains(e))
                    .map(|&effect| Note::FrictionAtOneLoad { effect, span_pa })
                    .collect(),
                _ => Vec::new(),
            }
        }))
        .collect();
    Proposed { parts, notes }
}

/// The two friction effects, whose only difference at one pressure is over speed.
const FRICTION: [Effect; 2] = [Effect::StribeckFriction, Effect::PressureDependentFriction];

/// The 5-95 % span of the chamber pressure while the piston slides [Pa]: over it, and only
/// over it, `mu A p` changes with the load.
fn sliding_pressure_span(bench: &super::replay::Bench) -> f64 {
    let p = bench.moving_pressures();
    quantile(&p, 0.95) - quantile(&p, 0.05)
}
