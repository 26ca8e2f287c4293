//! The floor a replay can reach on this recording, signal by signal, estimated from the
//! recording itself: the sensor noise of the compared signal (as the method judges it,
//! low-passed for the hydromechanics) plus what the noise of the recorded inputs and initial
//! states propagates into the replay, plus what the sampling of the inputs and the replay's
//! solver step leave unknown. A held-out error well above this floor is a misfit,
//! whatever the candidate effects make of it (docs/diagnose.md, "The verdict").

use super::filter::hydro_error;
use super::model::{predict, Model, Part};
use super::noise::{held_still, low_pass_gain, noise, Noise};
use super::replay::Bench;
use super::series::{Segment, Series};
use crate::numerics::rng::{seeded, Draw};

/// A held-out RMSE above this multiple of its signal's reachable floor is a misfit: the
/// verdict cannot be `adequate` (docs/diagnose.md, "The verdict").
pub const FLOOR_MULTIPLE: f64 = 2.0;

/// Sensor columns whose noise is propagated (commands such as `uc_i` and `v_ref` are written
/// by the controller and are exact).
const SENSORS: [&str; 7] = ["x", "p", "Q1", "Q2", "v", "F_L", "p_t"];
/// Noise realisations averaged for the propagated part.
const REALISATIONS: u64 = 2;

/// The reachable floor of one judged signal [signal unit].
#[derive(Clone, Debug, PartialEq)]
pub struct Floor {
    pub signal: &'static str,
    /// The compared signal's own sensor noise, as judged.
    pub sensor: f64,
    /// RMS of the replay's change when the recorded inputs and initial states carry another
    /// realisation of their estimated noise.
    pub propagated: f64,
    /// RMS of the replay's changes when the sampled inputs (drive commands, pump flows, load)
    /// are read the other way between samples (`Bench::other_reading`) and when the solver
    /// takes half its step: what the sampling and the replay's discretisation leave unknown.
    pub sampling: f64,
    /// The same three parts' variance at every sample of the record (0 outside the part's
    /// segments) [signal unit^2]: the sensor noise at the sample's reading, the squared
    /// changes of the perturbed replay, of the replay with the inputs read the other way and
    /// of the replay at half its step there. Its mean over the segments is
    /// `total()^2`; the sampling part concentrates in fast transients.
    pub variance: Vec<f64>,
}

impl Floor {
    /// sqrt(sensor^2 + propagated^2 + sampling^2).
    pub fn total(&self) -> f64 {
        self.sensor.hypot(self.propagated).hypot(self.sampling)
    }

    /// The floor's RMS over `samples` [signal unit].
    pub fn over(&self, samples: &[usize]) -> f64 {
        if samples.is_empty() {
            return self.total();
        }
        (samples.iter().map(|&k| self.variance[k]).sum::<f64>() / samples.len() as f64).sqrt()
    }
}

/// One array per signal over the record: a replay's prediction [signal unit], or squared
/// changes of replays summed per sample [signal unit^2].
type PerSignal = Vec<(&'static str, Vec<f64>)>;

/// Adds the squares of the judged change from replay `a` to replay `b` of the segment that
/// starts at `start`, signal by signal, to `acc` (entries created at the record's length
/// `n`), scaled by `scale`.
fn accumulate(
    acc: &mut PerSignal,
    (a, b): (&PerSignal, &PerSignal),
    judged: &dyn Fn(&str, Vec<f64>) -> Vec<f64>,
    (n, start): (usize, usize),
    scale: f64,
) {
    for ((name, pa), (_, pb)) in a.iter().zip(b) {
        let d = judged(name, pa.iter().zip(pb).map(|(a, b)| a - b).collect());
        let slot = match acc.iter().position(|s| s.0 == *name) {
            Some(i) => i,
            None => {
                acc.push((name, vec![0.0; n]));
                acc.len() - 1
            }
        };
        for (v, d) in acc[slot].1[start..start + d.len()].iter_mut().zip(&d) {
            *v += scale * d * d;
        }
    }
}

/// A sensor column's noise and the samples where it is held still (no noise there).
type SensorNoise<'a> = (&'a str, Noise, Vec<bool>);

/// The floor of every signal the parts predict, each part replayed with `models[i]`.
pub fn floors(series: &Series, parts: &[(Part, Model, Vec<Segment>)]) -> Vec<Floor> {
    let noises: Vec<SensorNoise> = SENSORS
        .iter()
        .filter_map(|&n| series.get(n).map(|y| (n, noise(y), held_still(y))))
        .collect();
    let bench = Bench::new(series);
    // The replay with the inputs read the other way between samples, and at half its
    // solver step: a stop or a breakaway whose timing moves with the step is as unknown as
    // one the sampling hides.
    let mut other = Bench::new(series);
    other.other_reading = true;
    let mut fine = Bench::new(series);
    fine.substeps *= 2;
    parts
        .iter()
        .flat_map(|(part, model, segs)| {
            let benches = (&bench, [&other, &fine]);
            part_floors(series, benches, &noises, *part, model, segs)
        })
        .collect()
}

/// The floors of the signals one part predicts over `segs`, replayed on `bench` and on the
/// `unknowns` (what the sampling and the solver step leave unknown).
fn part_floors(
    series: &Series,
    (bench, unknowns): (&Bench, [&Bench; 2]),
    noises: &[SensorNoise],
    part: Part,
    model: &Model,
    segs: &[Segment],
) -> Vec<Floor> {
    let hydro = part == Part::Hydro;
    let judged = |name: &str, d: Vec<f64>| if hydro { hydro_error(name, &d) } else { d };
    let reference: Vec<_> = segs
        .iter()
        .map(|seg| predict(bench, model, part, *seg))
        .collect();
    let sampling = sampling_changes(unknowns, (part, model), segs, &reference, &judged);
    let propagated = propagated_changes(series, noises, part, model, segs, &reference, &judged);
    let samples: Vec<usize> = segs.iter().flat_map(|s| s.start..s.end).collect();
    propagated
        .into_iter()
        .map(|(name, prop)| {
            let (nz, still) = noises
                .iter()
                .find(|(n, _, _)| *n == name)
                .map_or((Noise::SILENT, None), |x| (x.1, Some(&x.2)));
            let gain = if hydro { low_pass_gain(nz.rho) } else { 1.0 };
            let y = series.col(name);
            let sensor: Vec<f64> = (0..series.len())
                .map(|k| {
                    if still.is_some_and(|s| s[k]) {
                        0.0
                    } else {
                        (nz.at(y[k]) * gain).powi(2)
                    }
                })
                .collect();
            let held = sampling
                .iter()
                .find(|s| s.0 == name)
                .map_or(vec![0.0; series.len()], |s| s.1.clone());
            floor_of(name, &samples, [&sensor, &prop, &held])
        })
        .collect()
}

/// The floor of `name` from its sensor, propagated and sampling variances per sample, over
/// the part's `samples`.
fn floor_of(name: &'static str, samples: &[usize], [sensor, prop, held]: [&[f64]; 3]) -> Floor {
    let mean = |v: &[f64]| {
        (samples.iter().map(|&k| v[k]).sum::<f64>() / samples.len().max(1) as f64).sqrt()
    };
    let mut variance = vec![0.0; sensor.len()];
    for &k in samples {
        variance[k] = sensor[k] + prop[k] + held[k];
    }
    Floor {
        signal: name,
        sensor: mean(sensor),
        propagated: mean(prop),
        sampling: mean(held),
        variance,
    }
}

/// Squared changes of the replays on the `unknowns` benches from `reference`.
fn sampling_changes(
    unknowns: [&Bench; 2],
    (part, model): (Part, &Model),
    segs: &[Segment],
    reference: &[PerSignal],
    judged: &dyn Fn(&str, Vec<f64>) -> Vec<f64>,
) -> PerSignal {
    let mut sampling = PerSignal::new();
    for (seg, a) in segs.iter().zip(reference) {
        for unknown in unknowns {
            let b = predict(unknown, model, part, *seg);
            let at = (unknown.s.len(), seg.start);
            accumulate(&mut sampling, (a, &b), judged, at, 1.0);
        }
    }
    sampling
}

/// Squared changes of the replay when the recorded sensors carry another realisation of
/// their estimated noise (mean over `REALISATIONS`), from `reference`.
fn propagated_changes(
    series: &Series,
    noises: &[SensorNoise],
    part: Part,
    model: &Model,
    segs: &[Segment],
    reference: &[PerSignal],
    judged: &dyn Fn(&str, Vec<f64>) -> Vec<f64>,
) -> PerSignal {
    let mut propagated = PerSignal::new();
    for r in 0..REALISATIONS {
        let perturbed = perturbed(series, noises, r);
        let noisy = Bench::new(&perturbed);
        for (seg, a) in segs.iter().zip(reference) {
            let b = predict(&noisy, model, part, *seg);
            let at = (series.len(), seg.start);
            accumulate(
                &mut propagated,
                (a, &b),
                judged,
                at,
                1.0 / REALISATIONS as f64,
            );
        }
    }
    propagated
}

/// The recording with realisation `r` of every sensor's estimated noise added (none where
/// the sensor is held still).
fn perturbed(series: &Series, noises: &[SensorNoise], r: u64) -> Series {
    let mut rng = seeded(0x5EED_F100 + r);
    let mut perturbed = series.clone();
    for (name, nz, still) in noises {
        let y = series.col(name);
        let e = rng.coloured(y.len(), nz.rho);
        perturbed.set_column(
            name,
            (0..y.len())
                .map(|k| y[k] + if still[k] { 0.0 } else { nz.at(y[k]) * e[k] })
                .collect(),
        );
    }
    perturbed
}

#[cfg(test)]
mod tests {
    use crate::diagnose::{diagnose, prepare::prepare, report::Diagnosis, series::Series};
    use crate::synth::{BenchScenario, Case, LoopFamily, Variation};
    use tbm_thrust::{Controller, Params, Scheme};

    /// An effect-free generated recording's diagnosis and its floor of `p`, whose sampling
    /// part is asserted to stand above the pressure sensor's noise.
    fn diagnosed_with_p_sampling_above_sensor(case: &Case) -> Diagnosis {
        let series = Series::generated(case);
        let prepared = prepare(&series, &Params::default()).expect("prepares");
        let p = prepared.floors.iter().find(|f| f.signal == "p").expect("p");
        assert!(
            p.sampling > p.sensor,
            "sampling {} Pa, sensor {} Pa",
            p.sampling,
            p.sensor
        );
        diagnose(&series, &Params::default()).expect("runs")
    }

    /// An effect-free start-stop programme at 200 Hz (frozen case 900 182, whose false alarm
    /// showed it): at every stop the piston passes from sliding to stuck. While the plant
    /// stuck the piston only at the end of a solver step, the sample at which the replay's
    /// pressure settled moved with the step, and the floor's replay at half the step carried
    /// those stops (its sampling part 6.1 kPa, 0.9 kPa without it). Now that the crossing is
    /// located inside the step (`tbm_thrust::plant`) the stops hardly move with it (sampling
    /// part 0.74 kPa, below the sensor's 3.3 kPa), and the recording stays adequate.
    #[test]
    fn a_piston_that_stops_and_starts_is_adequate() {
        let variation = Variation {
            time_offset: 0.778,
            noise_scale: 0.6926,
            absent: vec!["u1".into(), "u2".into(), "x_ref".into()],
            family: LoopFamily::P,
            main_tau: 0.1666,
            main_size: 1.3339,
            aux_tau: 0.046,
            aux_size: 0.8536,
            magnitude: 0.8802,
            relief_in_plateau: false,
        };
        let case = Case {
            controller: Controller::Pid,
            substeps: 3,
            jitter: 1.534e-4,
            sample_period: 0.005,
            variation: Some(variation),
            ..Case::new(BenchScenario::StartStop, Scheme::Single, vec![], 900_182)
        };
        let series = Series::generated(&case);
        let d = diagnose(&series, &Params::default()).expect("runs");
        assert_eq!(d.verdict(), "adequate", "{:?}", d.notes);
    }

    /// An effect-free load-step programme at 500 Hz (tune seed 122): every load step falls
    /// between two samples, and the replay, which holds the recorded load, steps at the next
    /// one. The floor's sampling part reads the load the other way (interpolated), so the
    /// pressure's excess at the steps is within the floor. At each load drop the piston
    /// lurches 8 mm and bounces back: while the plant reversed it only at a step's end, the
    /// nominal fit bent `beta_e` by 14 % to make up for the 2 ms step, and `x` stood at 2.2
    /// times its floor (docs/diagnose-log.md, ninth and tenth sessions); with the reversal
    /// located inside the step the recording is adequate.
    #[test]
    fn a_load_step_between_samples_is_part_of_the_floor() {
        let variation = Variation {
            time_offset: 1.71,
            noise_scale: 0.62,
            absent: vec![],
            family: LoopFamily::PI,
            main_tau: 0.31,
            main_size: 0.53,
            aux_tau: 0.069,
            aux_size: 1.86,
            magnitude: 0.86,
            relief_in_plateau: true,
        };
        let case = Case {
            controller: Controller::Adrc,
            substeps: 3,
            jitter: 8.8e-5,
            sample_period: 0.002,
            variation: Some(variation),
            ..Case::new(BenchScenario::LoadSteps, Scheme::FixedSplit, vec![], 122)
        };
        let d = diagnosed_with_p_sampling_above_sensor(&case);
        assert_eq!(d.verdict(), "adequate", "{:?}", d.notes);
    }
}
