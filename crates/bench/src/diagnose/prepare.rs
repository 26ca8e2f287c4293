//! Stage 1, prepare the series: the replay bench over the recording, the parts that can be
//! replayed, the replay segments, the model as given with its load (and the flow-loop gains
//! of a pump replayed through its loop, started on a grid), and the floor each
//! signal's held-out error can reach on this recording.

use super::error::Error;
use super::floor::{self, Floor};
use super::model::{Layout, Model, Part};
use super::note::Note;
use super::replay::{chatter, Bench, DriveSource, Load};
use super::series::{Segment, Series};
use super::starts::loop_start;
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::Params;

/// A pump is idle when its peak flow is below this share of the total peak flow.
const IDLE_SHARE: f64 = 0.02;

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
    // A pump replayed from its own flow has no floor: its running median is no replay, and
    // its misfit where the median clips a peak is no missing physics.
    let floor_parts: Vec<(Part, Model, Vec<Segment>)> = parts
        .iter()
        .filter(|p| !p.own_flow(&bench))
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

impl Prepared<'_> {
    /// Replays each of `pumps` (with its refitted time constant [s]) from its own flow from
    /// now on, as one without a drive command (`refit::faster_than_the_logger`): noted, and
    /// its flow's floor dropped (a running median is no replay).
    pub fn replay_from_own_flow(&mut self, pumps: &[(Pump, f64)]) {
        for &(pump, time_constant_s) in pumps {
            self.bench.replay_from_own_flow(pump);
            self.floors.retain(|f| f.signal != pump.flow());
            self.notes.push(Note::FasterThanTheLogger {
                pump,
                time_constant_s,
                period_s: self.series.dt,
            });
        }
    }
}

/// The parts that can be replayed: the hydromechanics always; a pump when it runs, from its
/// recorded drive command, or, without it, from its commanded flow through the flow loop
/// (`replay::Bench::drive`), or, with neither (or a chattering command), from its own
/// flow's running median, on which only its ripple is tested.
pub(super) fn active_parts(bench: &Bench, notes: &mut Vec<Note>) -> Vec<Part> {
    let s = bench.s;
    let peak = |name: &str| crate::numerics::stats::peak(s.col(name));
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
            DriveSource::Recorded => {}
            DriveSource::FlowLoop => notes.push(Note::FlowLoopDrive { pump: i }),
            DriveSource::OwnFlow => notes.push(match s.get(i.drive()).and_then(chatter) {
                Some(share) => Note::ChatteringCommand { pump: i, share },
                None => Note::NoDriveCommand { pump: i },
            }),
        }
        parts.push(Part::Pump(i));
    }
    parts
}

/// The load of the replays: the `F_L` column, or a constant to fit, started from the mean
/// hydraulic force while the piston moves.
pub(super) fn initial_load(bench: &Bench, p: &Params, notes: &mut Vec<Note>) -> Load {
    if bench.s.has("F_L") {
        return Load::Recorded;
    }
    let pr = bench.s.col("p");
    let moving: Vec<f64> = (0..pr.len())
        .filter(|&k| bench.v[k] > super::replay::SLIDING_SPEED)
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

#[cfg(test)]
mod tests {
    use crate::diagnose::effect::Effect;
    use crate::diagnose::{diagnose, series::Series};
    use crate::synth::{BenchScenario, Case, LoopFamily, Variation};
    use tbm_thrust::pump::Pump;
    use tbm_thrust::{Controller, Params, Scheme};

    /// A start-stop bench under the adaptive scheme that logs neither drive commands nor
    /// commanded flows (500 Hz), with `effects`.
    fn no_drive_columns(effects: Vec<Effect>) -> Case {
        let variation = Variation {
            time_offset: 0.02,
            noise_scale: 0.8,
            absent: ["uc1", "uc2", "u1", "u2"].map(String::from).into(),
            family: LoopFamily::P,
            main_tau: 0.27,
            main_size: 1.4,
            aux_tau: 0.04,
            aux_size: 1.6,
            magnitude: 0.7,
            relief_in_plateau: true,
        };
        Case {
            controller: Controller::Adrc,
            substeps: 1,
            jitter: 2.5e-4,
            sample_period: 0.002,
            variation: Some(variation),
            ..Case::new(BenchScenario::StartStop, Scheme::Adaptive, effects, 4081)
        }
    }

    /// A main pump without drive columns cannot be replayed, but a ripple on its flow is a
    /// tone its own flow's running median does not follow: named, at the generated
    /// frequency within 5 % (with the pump untested, as before, nothing is named).
    #[test]
    fn a_ripple_is_found_on_a_pump_without_drive_columns() {
        let case = no_drive_columns(vec![Effect::FlowRipple(Pump::Main)]);
        let truth = crate::synth::generate(&case).expect("generates").truth;
        let f_true = truth.effects[0].parameters["frequency"];
        let d = diagnose(&Series::generated(&case), &Params::default()).expect("runs");
        let ripple = d
            .findings
            .iter()
            .find(|f| f.effect == Effect::FlowRipple(Pump::Main))
            .unwrap_or_else(|| panic!("no ripple named: {:?}", d.trials));
        let f = ripple.parameters["frequency"];
        assert!(
            (f / f_true - 1.0).abs() < 0.05,
            "{f} Hz against {f_true} Hz"
        );
    }

    /// The same bench without the ripple: the running median's clipped start-up peaks and
    /// the flow loops' transients are no tone, and the recording is adequate.
    #[test]
    fn a_pump_without_drive_columns_and_without_ripple_is_adequate() {
        let case = no_drive_columns(Vec::new());
        let d = diagnose(&Series::generated(&case), &Params::default()).expect("runs");
        assert_eq!(d.verdict(), "adequate", "{:?}", d.trials);
    }
}
