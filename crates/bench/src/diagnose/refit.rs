//! Stage 2, refit the nominal model: each replayable part's nominal unknowns cross-fitted
//! on blocked halves of the recording (a plain parameter mismatch is not missing physics).

use super::model::{cross_fit, nominal_specs, pump_speeds, Part, Split, POLISH_ITERATIONS};
use super::prepare::Prepared;
use super::search::PartResult;
use crate::progress::Progress;
use rayon::prelude::*;
use tbm_thrust::pump::Pump;

/// Each part's nominal cross-fit, the start of `propose::propose`.
pub struct Refit {
    pub parts: Vec<PartResult>,
}

/// Cross-fits the nominal unknowns of every part (in parallel, rayon), telling `progress`
/// of each part. A pump refitted faster than the logger samples ([`faster_than_the_logger`])
/// is moved to its own flow on the prepared bench and refitted so.
pub fn refit(prepared: &mut Prepared, progress: &dyn Progress) -> Refit {
    let mut parts = refit_parts(prepared, &prepared.parts, progress);
    let fast = faster_than_the_logger(prepared, &parts);
    if !fast.is_empty() {
        prepared.replay_from_own_flow(&fast);
        let again: Vec<Part> = fast.iter().map(|&(pump, _)| Part::Pump(pump)).collect();
        for fit in refit_parts(prepared, &again, progress) {
            if let Some(old) = parts.iter_mut().find(|r| r.part == fit.part) {
                *old = fit;
            }
        }
    }
    Refit { parts }
}

/// The nominal cross-fits of `parts`, in parallel.
fn refit_parts(prepared: &Prepared, parts: &[Part], progress: &dyn Progress) -> Vec<PartResult> {
    let (bench, base) = (&prepared.bench, &prepared.base);
    progress.found(parts.len() as u64);
    let fits: Vec<PartResult> = parts
        .par_iter()
        .map(|&part| {
            let specs = nominal_specs(part, bench, base.params.controller);
            let bases = match part {
                Part::Pump(_) => pump_speeds(base, &specs),
                Part::Hydro => vec![base.clone()],
            };
            let cf = cross_fit(
                bench,
                &[bases.clone(), bases],
                part,
                &specs,
                [&[], &[]],
                prepared.layout.of(part),
                POLISH_ITERATIONS,
                Split::Blocked,
            );
            PartResult::nominal(part, specs, cf)
        })
        .collect();
    progress.done(fits.len() as u64);
    fits
}

/// The pumps whose refitted time constant 1/a_i is shorter than the logger's sample period
/// in both halves, with the longer of the two [s]. Such a pump answers within one sample, so
/// its flow at each sample follows the drive command's path between samples, which the
/// recording does not show (a 1 kHz flow loop's kick after a set-point step, logged at 20
/// Hz); a replay from the logged command cannot follow it, and the refit, trying to,
/// drives the pole towards the top of its range (docs/diagnose.md, "A pump faster than the
/// logger"). Such a pump is replayed from its own flow instead, as one without a command.
fn faster_than_the_logger(prepared: &Prepared, parts: &[PartResult]) -> Vec<(Pump, f64)> {
    let dt = prepared.series.dt;
    parts
        .iter()
        .filter_map(|r| {
            let pump = r
                .part
                .pump()
                .filter(|_| !r.part.own_flow(&prepared.bench))?;
            let pole = pump.name("a");
            let slowest = r
                .nominal
                .folds
                .iter()
                .map(|m| m.get(&pole))
                .reduce(f64::min)?;
            let time_constant = 1.0 / slowest;
            (time_constant < dt).then_some((pump, time_constant))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::refit;
    use crate::diagnose::{diagnose, model::Part, note::Note, prepare::prepare, series::Series};
    use crate::progress::Silent;
    use crate::synth::{generate, BenchScenario, Case, LoopFamily, Variation};
    use tbm_thrust::{pump::Pump, Controller, Params, Scheme};

    /// An effect-free drawn bench of the adaptive scheme running `scenario`, logged at
    /// `rate` [Hz].
    fn drawn_case(scenario: BenchScenario, seed: u64, rate: f64) -> Case {
        let case = Case::new(scenario, Scheme::Adaptive, vec![], seed).on_a_drawn_bench();
        Case {
            sample_period: 1.0 / rate,
            ..case
        }
    }

    /// The drawn bench of seed 5014 (a mixed programme, PID flow loops, the auxiliary pump's
    /// pole 31.5 1/s) logged at `rate` [Hz].
    fn drawn_bench(rate: f64) -> Series {
        Series::generated(&drawn_case(BenchScenario::Mixed, 5014, rate))
    }

    fn faster_than_the_logger(notes: &[Note]) -> Vec<Pump> {
        notes
            .iter()
            .filter_map(|n| match n {
                Note::FasterThanTheLogger { pump, .. } => Some(*pump),
                _ => None,
            })
            .collect()
    }

    /// Logged at 20 Hz, the bench's 1 kHz flow loop kicks the auxiliary pump's command
    /// between samples after each set-point step; replayed from the logged command, the
    /// refit drove its pole to 75.7 1/s and `Q2` stood at 2.7 times its floor (`missing_physics`
    /// with nothing named). Refitted faster than the logger, pump 2 is replayed from its own
    /// flow and the bench is `adequate`; at 100 Hz the same bench keeps its command replay.
    #[test]
    fn a_pump_faster_than_the_logger_is_replayed_from_its_flow() {
        let slow = diagnose(&drawn_bench(20.0), &Params::default()).expect("runs");
        assert!(slow.findings.is_empty(), "{:?}", slow.findings);
        assert!(slow.above_floor.is_empty(), "{:?}", slow.above_floor);
        assert_eq!(faster_than_the_logger(&slow.notes), vec![Pump::Aux]);
        let fast = diagnose(&drawn_bench(100.0), &Params::default()).expect("runs");
        assert!(
            faster_than_the_logger(&fast.notes).is_empty(),
            "{:?}",
            fast.notes
        );
    }

    /// An effect-free drawn bench (seed 5020: a start-up programme, the adaptive scheme,
    /// 100 Hz) whose two stops and restarts all fall in one half: the other half sees steady
    /// motion only, where `beta_e` shows in nothing but how long a segment's start (read
    /// through the sensors' noise) takes to settle. Started at the recorded state, that half
    /// fitted `beta_e` 3.7 times too stiff (3.54e9 Pa, the bench's 9.62e8: a stiff oil column
    /// forgets a noisy start sooner), mispredicted the other half's stops (`x` at 3.1 times its
    /// floor, `missing_physics` with nothing named). A segment whose piston slides through
    /// the 0.2 s before it is now read in from there (`replay::HYDRO_READ_IN_S`): both halves
    /// fit `beta_e` within a factor 2 of the bench's (1.61e9 and 9.58e8 Pa; the creeping
    /// segments after each stop, not read in, still pull the second up) and the bench is
    /// `adequate`.
    #[test]
    fn a_half_without_a_stop_does_not_fit_a_stiff_oil_column() {
        let case = drawn_case(BenchScenario::Startup, 5020, 100.0);
        let truth = generate(&case).expect("generates").params.beta_e;
        let series = Series::generated(&case);
        let mut prepared = prepare(&series, &Params::default()).expect("prepares");
        let fit = refit(&mut prepared, &Silent);
        let hydro = fit
            .parts
            .iter()
            .find(|r| r.part == Part::Hydro)
            .expect("hydro");
        for fold in &hydro.nominal.folds {
            let beta = fold.params.beta_e;
            assert!(
                (beta / truth).ln().abs() < 2f64.ln(),
                "beta_e {beta:.3e} Pa, the bench's {truth:.3e} Pa"
            );
        }
        let d = diagnose(&series, &Params::default()).expect("runs");
        assert!(d.findings.is_empty(), "{:?}", d.findings);
        assert!(d.above_floor.is_empty(), "{:?}", d.above_floor);
    }

    /// Tune case 137: an effect-free bench whose auxiliary pump (a2 = 10.2 1/s, 98 ms) is
    /// more than twice as slow as the given one (25 1/s, 40 ms), replayed through a
    /// reconstructed PID flow loop. The refit from the given pole stopped where the pole
    /// traded against the pressure loss and the loop's gains (`Q2` at 4.1 times its floor);
    /// started from a third of the given speed too, it reaches the bench's pump (a2 8.5 1/s)
    /// and names nothing. (Since the plant locates the piston's reversals inside a step, the
    /// recording's `Q2` stood at 3.1 times its floor on blocked folds for 0.1 s after an
    /// 11.4 kN load rise, where the reconstructed loop saturates; judged on interleaved
    /// samples, each fold refitted from both blocked fits, it stands at 1.0 and the verdict
    /// is `adequate`: `search.rs`, `interleaved`.)
    #[test]
    fn a_pump_several_times_slower_than_given_is_refitted() {
        let variation = Variation {
            time_offset: 1.1614815165960395,
            noise_scale: 0.8793624486406919,
            absent: vec!["uc1".into(), "uc2".into()],
            family: LoopFamily::PID,
            main_tau: 0.3006025585341884,
            main_size: 0.850992618039795,
            aux_tau: 0.08872746740597728,
            aux_size: 1.1802392986098686,
            magnitude: 0.902010383649176,
            relief_in_plateau: false,
        };
        let case = Case {
            controller: Controller::Pid,
            substeps: 3,
            jitter: 0.00011817342345139504,
            sample_period: 0.005,
            variation: Some(variation),
            ..Case::new(BenchScenario::Mixed, Scheme::FixedSplit, vec![], 137)
        };
        let series = Series::generated(&case);
        let truth = generate(&case).expect("generates").params.a2;
        let d = diagnose(&series, &Params::default()).expect("runs");
        assert!(d.findings.is_empty(), "{:?}", d.findings);
        assert!(d.above_floor.is_empty(), "{:?}", d.above_floor);
        let (fitted, given) = (d.params.a2, Params::default().a2);
        assert!(given / truth > 2.0, "given a2 {given}, bench's {truth}");
        assert!(
            (fitted / truth - 1.0).abs() < 0.3,
            "a2 refitted to {fitted} 1/s, the bench's {truth} 1/s"
        );
    }
}
