//! Stage 1, prepare the series: the replay bench over the recording, the parts that can be
//! replayed, the replay segments, the model as given with its load (and the flow-loop gains
//! of a pump replayed through its loop, started on a grid), and the floor each
//! signal's held-out error can reach on this recording.

use super::error::Error;
use super::floor::{self, Floor};
use super::model::{Layout, Model, Part};
use super::note::Note;
use super::replay::{Bench, DriveSource, Load};
use super::series::{Segment, Series};
use super::starts::loop_start;
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::Params;

/// A pump is idle when its peak flow is below this share of the total peak flow.
const IDLE_SHARE: f64 = 0.02;
/// A drive command chatters when more than this share of its sample-to-sample changes
/// exceed a quarter of its range: it varies faster than the recording resolves.
const CHATTER_SHARE: f64 = 0.1;

/// The recording made ready for the fits, taken by every later stage.
pub struct Prepared<'a> {
    pub series: &'a Series,
    pub bench: Bench<'a>,
    /// The series' notes, and what this stage could not check.
    pub notes: Vec<Note>,
    /// The parts that can be replayed.
    pub parts: Vec<Part>,
    pub layout: Layout,
    /// The model as given, with the recorded load or a constant one to fit.
    pub base: Model,
    /// The floor each judged signal's held-out error can reach on this recording.
    pub floors: Vec<Floor>,
}

/// Prepares `series` for the diagnosis against the model `base`.
pub fn prepare<'a>(series: &'a Series, base: &Params) -> Result<Prepared<'a>, Error> {
    base.validate()?;
    let bench = Bench::new(series);
    let mut notes = series.notes.clone();
    let parts = active_parts(&bench, &mut notes);
    let layout = Layout::new(series);
    let given = Model {
        params: base.clone(),
        load: initial_load(&bench, base, &mut notes),
    };
    let base = loop_start(&bench, &given, &layout);
    // The floor each signal's replay can reach, with the model as given (the propagation of
    // noise hardly depends on the nominal unknowns).
    let floor_parts: Vec<(Part, Model, Vec<Segment>)> = parts
        .iter()
        .map(|&p| (p, base.clone(), layout.of(p).to_vec()))
        .collect();
    let floors = floor::floors(series, &floor_parts);
    Ok(Prepared {
        series,
        bench,
        notes,
        parts,
        layout,
        base,
        floors,
    })
}

/// The parts that can be replayed: the hydromechanics always; a pump when it runs and its
/// drive command is recorded and resolved by the sampling, or, without it, its commanded
/// flow is recorded (the drive is then the flow loop's, `replay::Bench::drive`).
pub(super) fn active_parts(bench: &Bench, notes: &mut Vec<Note>) -> Vec<Part> {
    let s = bench.s;
    let peak = |name: &str| s.col(name).iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let total = peak("Q1").max(peak("Q2"));
    let mut parts = vec![Part::Hydro];
    for i in Pump::BOTH {
        if peak(i.flow()) <= IDLE_SHARE * total {
            notes.push(Note::PumpIdle {
                pump: i,
                share: IDLE_SHARE,
            });
            continue;
        }
        match bench.drive_source(i) {
            None => notes.push(Note::NoDriveCommand { pump: i }),
            Some(DriveSource::Recorded) => match chatter(s.col(i.drive())) {
                Some(share) => notes.push(Note::ChatteringCommand { pump: i, share }),
                None => parts.push(Part::Pump(i)),
            },
            Some(DriveSource::FlowLoop) => {
                notes.push(Note::FlowLoopDrive { pump: i });
                parts.push(Part::Pump(i));
            }
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
pub(super) fn initial_load(bench: &Bench, p: &Params, notes: &mut Vec<Note>) -> Load {
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
