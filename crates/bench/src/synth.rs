//! Synthetic bench recordings with concealed effects, for proving `diagnose` on data whose
//! truth it never sees.
//!
//! A case is a bench scenario (start-up ramps, start-stop, speed steps, load steps, or a
//! mixed programme), a pump scheme, a plant whose nominal unknowns are mismatched against the
//! defaults (beta_e, C_ip, b within Table 2, pump gains within +-20 %), zero, one or two
//! contract effects at realistic magnitudes, and bench sensors (noise, coloured by a
//! first-order sensor response, and ADC quantisation). The recording CSV carries no hint of
//! the truth; the truth goes to a separate JSON.

use crate::diagnose::effect::Effect;
use crate::numerics::csv::{self, Column, Number};
use crate::numerics::rng::{seeded, Draw, Rng};
use crate::numerics::stats::quantile;
use std::collections::BTreeMap;
use std::f64::consts::PI;
use tbm_thrust::control::CONTROL_PERIOD;
use tbm_thrust::params::ParamError;
use tbm_thrust::pump::Pump;
use tbm_thrust::simulation::{run_with_substeps, Profile, Scenario, Trace, DEFAULT_SUBSTEPS};
use tbm_thrust::units::LPM;
use tbm_thrust::variables::{Controller, Params, Scheme};

/// Recording length [s] and sample period [s] of every bench scenario.
pub const DURATION: f64 = 30.0;
pub const SAMPLE_PERIOD: f64 = 0.01;

/// The bench programmes the generator can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchScenario {
    /// Three start-ups from rest, ramped to a low, a medium and a high speed.
    Startup,
    /// Five run / stop cycles at one speed.
    StartStop,
    /// Speed steps from 5 to 40 mm/s at constant load.
    SpeedSteps,
    /// Load steps from 4 to 15 kN at constant speed.
    LoadSteps,
    /// A bench programme with all of the above: start-up, speed steps, stop, low-speed
    /// restart, load steps down to 3 kN and up to 14 kN.
    Mixed,
}

impl BenchScenario {
    pub const NAMES: [&'static str; 5] = [
        "startup",
        "start_stop",
        "speed_steps",
        "load_steps",
        "mixed",
    ];
    const ALL: [BenchScenario; 5] = [
        BenchScenario::Startup,
        BenchScenario::StartStop,
        BenchScenario::SpeedSteps,
        BenchScenario::LoadSteps,
        BenchScenario::Mixed,
    ];

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    pub fn parse(name: &str) -> Option<Self> {
        Self::NAMES
            .iter()
            .position(|n| *n == name)
            .map(|i| Self::ALL[i])
    }

    /// The reference-velocity and load profiles, with speeds and loads varied by the seed.
    pub fn scenario(self, rng: &mut Rng) -> Scenario {
        let mm = 1e-3;
        let kn = 1e3;
        let (v, load) = match self {
            BenchScenario::Startup => {
                let mut speeds = [10.0, 25.0, 40.0];
                let k = (rng.unit() * 3.0) as usize;
                speeds.swap(0, k);
                let s: Vec<f64> = speeds
                    .iter()
                    .map(|s| s * mm * rng.range(0.9, 1.1))
                    .collect();
                let mut v = Steps::default();
                v.ramp(0.0, 0.5, 0.0, s[0]).hold(8.0, 0.0);
                v.ramp(10.0, 11.0, 0.0, s[1]).hold(18.0, 0.0);
                v.ramp(20.0, 22.0, 0.0, s[2]);
                (v, Steps::constant(12.0 * kn * rng.range(0.7, 1.1)))
            }
            BenchScenario::StartStop => {
                let speed = rng.range(15.0, 30.0) * mm;
                let mut v = Steps::default();
                for c in 0..5 {
                    v.hold(6.0 * c as f64, speed)
                        .hold(6.0 * c as f64 + 4.0, 0.0);
                }
                (v, Steps::constant(12.0 * kn * rng.range(0.7, 1.1)))
            }
            BenchScenario::SpeedSteps => {
                let mut v = Steps::default();
                for (i, s) in [5.0, 15.0, 30.0, 10.0, 40.0, 20.0].iter().enumerate() {
                    v.hold(5.0 * i as f64, s * mm * rng.range(0.9, 1.1));
                }
                (v, Steps::constant(12.0 * kn * rng.range(0.7, 1.1)))
            }
            BenchScenario::LoadSteps => {
                let mut load = Steps::default();
                for (i, f) in [12.0, 7.0, 15.0, 4.0, 10.0, 13.0].iter().enumerate() {
                    load.hold(5.0 * i as f64, f * kn * rng.range(0.95, 1.05));
                }
                (Steps::constant(rng.range(15.0, 25.0) * mm), load)
            }
            BenchScenario::Mixed => mixed(rng),
        };
        Scenario {
            v_ref: v.profile(),
            load: load.profile(),
            duration: DURATION,
            sample_period: SAMPLE_PERIOD,
        }
    }
}

fn mixed(rng: &mut Rng) -> (Steps, Steps) {
    let mm = 1e-3 * rng.range(0.9, 1.1);
    let kn = 1e3 * rng.range(0.9, 1.1);
    let mut v = Steps::default();
    v.hold(0.0, 20.0 * mm).hold(5.0, 40.0 * mm).hold(9.0, 0.0);
    v.ramp(11.0, 11.5, 0.0, 4.0 * mm)
        .hold(15.0, 25.0 * mm)
        .hold(22.0, 0.0);
    v.ramp(24.0, 24.5, 0.0, 15.0 * mm).hold(28.0, 30.0 * mm);
    let mut load = Steps::default();
    load.hold(0.0, 10.0 * kn)
        .hold(16.0, 3.0 * kn)
        .hold(19.0, 14.0 * kn)
        .hold(26.0, 6.0 * kn);
    (v, load)
}

/// Builder of a piecewise-constant profile; ramps are staircases of one sample period.
#[derive(Clone, Debug, Default)]
struct Steps(Vec<(f64, f64)>);

impl Steps {
    fn constant(value: f64) -> Self {
        Steps(vec![(0.0, value)])
    }

    fn hold(&mut self, t: f64, value: f64) -> &mut Self {
        self.0.push((t, value));
        self
    }

    fn ramp(&mut self, t0: f64, t1: f64, from: f64, to: f64) -> &mut Self {
        let n = ((t1 - t0) / SAMPLE_PERIOD).round().max(1.0) as usize;
        for k in 0..=n {
            let s = k as f64 / n as f64;
            self.0.push((t0 + s * (t1 - t0), from + s * (to - from)));
        }
        self
    }

    fn profile(&self) -> Profile {
        let mut points = self.0.clone();
        if points.first().map_or(true, |p| p.0 > 0.0) {
            points.insert(0, (0.0, 0.0));
        }
        Profile(points)
    }
}

/// Bench sensors: Gaussian noise of standard deviation `*_noise`, coloured by a first-order
/// sensor response with sample-to-sample correlation `colour`, then ADC quantisation.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Sensors {
    /// Displacement noise [m] and ADC step [m] (LVDT 0-500 mm, 16 bit).
    pub x_noise: f64,
    pub x_lsb: f64,
    /// Pressure noise [Pa] and ADC step [Pa] (0-200 bar, 16 bit).
    pub p_noise: f64,
    pub p_lsb: f64,
    /// Flow noise as a fraction of the reading [1] and ADC step [m^3/s] (0-80 L/min, 16 bit).
    pub q_noise: f64,
    pub q_lsb: f64,
    /// Correlation of successive noise samples [1].
    pub colour: f64,
}

impl Sensors {
    /// Noise levels drawn from bench-like ranges: 0.01-0.05 mm, 0.01-0.05 MPa, 0.5-2 %.
    pub fn draw(rng: &mut Rng) -> Self {
        Sensors {
            x_noise: rng.range(0.01e-3, 0.05e-3),
            x_lsb: 0.5 / 65_536.0,
            p_noise: rng.range(0.01e6, 0.05e6),
            p_lsb: 20e6 / 65_536.0,
            q_noise: rng.range(0.005, 0.02),
            q_lsb: 80.0 / LPM / 65_536.0,
            colour: rng.range(0.0, 0.6),
        }
    }
}

/// What to generate.
#[derive(Clone, Debug)]
pub struct Case {
    pub scenario: BenchScenario,
    pub scheme: Scheme,
    pub controller: Controller,
    pub effects: Vec<Effect>,
    pub seed: u64,
    /// Plant solver sub-steps per 1 ms controller period (numerics of the "bench").
    pub substeps: u32,
    /// Time-stamp jitter of the logger, uniform within +-jitter [s] (below half a sample).
    pub jitter: f64,
    /// Logger sample period [s]: [`SAMPLE_PERIOD`] unless a drawn bench or the caller
    /// sets another.
    pub sample_period: f64,
    /// The bench drawn from wide ranges (`Variation::draw`), or the default bench.
    pub variation: Option<Variation>,
}

/// Why a case cannot be generated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SynthError {
    #[error("time-stamp jitter must lie in [0, {limit}) s")]
    Jitter { limit: f64 },
    #[error("at least one solver sub-step")]
    NoSubstep,
    #[error("at most two concealed effects per recording")]
    TooManyEffects,
    #[error("pump-2 effects need a scheme that runs the auxiliary pump (adaptive or fixed_split)")]
    AuxIdle,
    #[error("the two concealed effects must differ")]
    SameEffectTwice,
    #[error(transparent)]
    Param(#[from] ParamError),
}

/// The bench's flow-loop family: which of the PID's terms it uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum LoopFamily {
    P,
    PI,
    PID,
}

impl LoopFamily {
    pub const ALL: [LoopFamily; 3] = [LoopFamily::P, LoopFamily::PI, LoopFamily::PID];
}

impl std::fmt::Display for LoopFamily {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(self, f)
    }
}

/// Logger rates of a drawn bench [Hz], ours (100 Hz) drawn twice as often.
pub const DRAWN_RATES: [f64; 6] = [50.0, 100.0, 100.0, 200.0, 500.0, 1000.0];

/// A bench unlike the default one: logger rate and clock offset, sensor noise, recorded
/// columns, flow-loop family, pump sizes and time constants, effect magnitudes and relief
/// regime (docs/diagnose.md, "Proof on concealed data").
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Variation {
    /// Time offset of the logger's first stamp [s].
    pub time_offset: f64,
    /// Multiplier of every sensor's noise [1] (0.5-3).
    pub noise_scale: f64,
    /// Optional columns the bench does not record.
    pub absent: Vec<String>,
    /// Flow-loop family (the integral and derivative gains zeroed or
    /// raised accordingly).
    pub family: LoopFamily,
    /// Main-pump time constant [s] (0.1-0.6) and displacement multiplier (20-100 L/min at
    /// full command); auxiliary-pump time constant [s] (0.02-0.1) and multiplier (5-30 L/min).
    pub main_tau: f64,
    pub main_size: f64,
    pub aux_tau: f64,
    pub aux_size: f64,
    /// Effect magnitude multiplier [1] (0.5 weak - 1.5 strong).
    pub magnitude: f64,
    /// Relief regime: cracking inside the upper load plateau (true) or only in pressure peaks.
    pub relief_in_plateau: bool,
}

impl Variation {
    /// A bench drawn from the ranges above, with its logger's sample period [s] (one of
    /// [`DRAWN_RATES`]; the period is the case's, [`Case::sample_period`]).
    pub fn draw(rng: &mut Rng) -> (f64, Variation) {
        let rate = DRAWN_RATES[(rng.unit() * DRAWN_RATES.len() as f64) as usize];
        let mut absent = Vec::new();
        for (cols, p) in [
            (&["uc1", "uc2"][..], 0.15),
            (&["u1", "u2"][..], 0.3),
            (&["x_ref"][..], 0.3),
        ] {
            if rng.unit() < p {
                absent.extend(cols.iter().map(|c| c.to_string()));
            }
        }
        let family = LoopFamily::ALL[(rng.unit() * 3.0) as usize];
        let variation = Variation {
            time_offset: rng.range(0.0, 2.0),
            noise_scale: rng.log_range(0.5, 3.0),
            absent,
            family,
            main_tau: rng.log_range(0.1, 0.6),
            main_size: rng.log_range(0.5, 2.0),
            aux_tau: rng.log_range(0.02, 0.1),
            aux_size: rng.log_range(0.5, 2.0),
            magnitude: rng.range(0.5, 1.5),
            relief_in_plateau: rng.unit() < 0.5,
        };
        (1.0 / rate, variation)
    }

    /// Applies the pump sizes, time constants and loop family to the plant and controller.
    fn apply(&self, p: &mut Params) -> Result<(), ParamError> {
        let set = |p: &mut Params, n: &str, v: f64| p.set(n, v);
        // The pole a = 1/tau; the displacement D scales the flow at full command (k_u / a)
        // with the size; b_u scales with a so the size alone sets k_u / a; the loop's
        // proportional gain is divided by the size so that its loop gain Kp k_u / a stays.
        let (a1, a2) = (1.0 / self.main_tau, 1.0 / self.aux_tau);
        let (r1, r2) = (a1 / p.a1, a2 / p.a2);
        set(p, "a1", a1)?;
        set(p, "a2", a2)?;
        set(p, "D1", p.D1 * self.main_size)?;
        set(p, "D2", p.D2 * self.aux_size)?;
        set(p, "b_u1", p.b_u1 * r1)?;
        set(p, "b_u2", p.b_u2 * r2)?;
        set(p, "Kp1", p.Kp1 / self.main_size)?;
        set(p, "Kp2", p.Kp2 / self.aux_size)?;
        match self.family {
            LoopFamily::P => {
                for n in ["Ki1", "Kd1", "Ki2", "Kd2"] {
                    set(p, n, 0.0)?;
                }
            }
            LoopFamily::PI => {
                set(p, "Kd1", 0.0)?;
                set(p, "Kd2", 0.0)?;
                set(p, "Ki1", p.Kp1 * 2.0)?;
                set(p, "Ki2", p.Kp2 * 5.0)?;
            }
            LoopFamily::PID => {
                set(p, "Ki1", p.Kp1 * 2.0)?;
                set(p, "Ki2", p.Kp2 * 5.0)?;
                set(p, "Kd1", p.Kp1 * 1e-3)?;
                set(p, "Kd2", p.Kp2 * 1e-3)?;
            }
        }
        Ok(())
    }
}

impl Case {
    /// A case with the simulator's default numerics, the PID controller and exact stamps.
    pub fn new(scenario: BenchScenario, scheme: Scheme, effects: Vec<Effect>, seed: u64) -> Case {
        Case {
            scenario,
            scheme,
            controller: Controller::Pid,
            effects,
            seed,
            substeps: DEFAULT_SUBSTEPS,
            jitter: 0.0,
            sample_period: SAMPLE_PERIOD,
            variation: None,
        }
    }

    /// The same case on a bench drawn from wide ranges ([`Variation::draw`]), logged at the
    /// drawn rate; the draw comes from the seed, on a stream apart from the case's own.
    pub fn on_a_drawn_bench(self) -> Case {
        let (sample_period, variation) = Variation::draw(&mut seeded(self.seed ^ DRAWN_BENCH));
        Case {
            sample_period,
            variation: Some(variation),
            ..self
        }
    }
}

/// Mixed into a case's seed for the stream its drawn bench comes from.
const DRAWN_BENCH: u64 = 0xBE4C;

/// A generated recording and the truth behind it.
#[derive(Clone, Debug)]
pub struct Synthesis {
    /// Recording CSV of the contract, with `# key = value` metadata that does not reveal
    /// the concealed effects.
    pub csv: String,
    pub truth: Truth,
    /// The plant parameters that produced it (TOML, loadable by `--params`).
    pub params_toml: String,
    /// The same parameters.
    pub params: Params,
}

/// Ground truth of a generated recording.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Truth {
    pub seed: u64,
    pub scenario: String,
    pub scheme: String,
    /// The concealed effects with the contract's reported parameters.
    pub effects: Vec<TruthEffect>,
    /// The logger's sample period [s] and, for a drawn bench, how it was drawn.
    pub sample_period: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bench: Option<Variation>,
    /// The mismatched nominal unknowns of the plant.
    pub nominal: BTreeMap<String, f64>,
    pub sensors: Sensors,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct TruthEffect {
    pub effect: String,
    pub parameters: BTreeMap<String, f64>,
}

/// Nominal unknowns the generator mismatches, with the multiplier range around the default.
const NOMINAL_SPREAD: [(&str, f64, f64); 9] = [
    ("beta_e", 0.8, 1.45),
    ("b", 0.7, 1.9),
    ("a1", 0.8, 1.2),
    ("b_u1", 0.85, 1.15),
    ("b_p1", 0.8, 1.2),
    ("a2", 0.8, 1.2),
    ("b_u2", 0.85, 1.15),
    ("b_p2", 0.8, 1.2),
    ("C_ip", 0.4, 6.0),
];

/// Runs the bench as a real one runs: its set-point and load programme moves at about the
/// controller's rate ([`CONTROL_PERIOD`], the nearest whole fraction of the logger's period)
/// and the logger keeps every n-th sample. Holding the programme over a whole logging
/// interval instead would hide the loop's answer to each step of the set-point from the
/// logger at low rates (read on 20 Hz benches, docs/diagnose-log.md, thirty-third session).
fn bench_run(params: &Params, logged: &Scenario, substeps: u32) -> Trace {
    let keep = (logged.sample_period / CONTROL_PERIOD).round().max(1.0) as usize;
    let bench = Scenario {
        sample_period: logged.sample_period / keep as f64,
        ..logged.clone()
    };
    let fine = run_with_substeps(params, &bench, substeps);
    Trace {
        time: fine.time.into_iter().step_by(keep).collect(),
        inputs: fine.inputs.into_iter().step_by(keep).collect(),
        outputs: fine.outputs.into_iter().step_by(keep).collect(),
    }
}

/// Generates one case.
pub fn generate(case: &Case) -> Result<Synthesis, SynthError> {
    check_case(case)?;
    let mut rng = seeded(case.seed);
    let mut scenario = case.scenario.scenario(&mut rng);
    scenario.sample_period = case.sample_period;
    let mut params = Params {
        scheme: case.scheme,
        controller: case.controller,
        ..Params::default()
    };
    if let Some(v) = &case.variation {
        v.apply(&mut params)?;
    }
    let magnitude = case.variation.as_ref().map_or(1.0, |v| v.magnitude);
    let in_plateau = case
        .variation
        .as_ref()
        .map_or(true, |v| v.relief_in_plateau);
    let mut nominal = BTreeMap::new();
    for (name, lo, hi) in NOMINAL_SPREAD {
        let value = params.get(name).expect("nominal unknown") * rng.log_range(lo, hi);
        params.set(name, value)?;
        nominal.insert(name.to_string(), value);
    }
    let reference = bench_run(&params, &scenario, case.substeps);
    let mut effects = Vec::new();
    for &e in &case.effects {
        conceal(
            &mut params,
            e,
            &reference,
            &mut rng,
            (magnitude, in_plateau, case.sample_period),
        );
        effects.push(TruthEffect {
            effect: e.id().to_string(),
            parameters: e.reported(&params),
        });
    }
    let trace = bench_run(&params, &scenario, case.substeps);
    let mut sensors = Sensors::draw(&mut rng);
    if let Some(v) = &case.variation {
        sensors.x_noise *= v.noise_scale;
        sensors.p_noise *= v.noise_scale;
        sensors.q_noise *= v.noise_scale;
    }
    let csv = recording_csv(&trace, &sensors, case, &mut rng);
    let truth = Truth {
        seed: case.seed,
        scenario: case.scenario.name().into(),
        scheme: case.scheme.name().into(),
        effects,
        sample_period: case.sample_period,
        bench: case.variation.clone(),
        nominal,
        sensors,
    };
    Ok(Synthesis {
        csv,
        truth,
        params_toml: params.diff_toml(),
        params,
    })
}

fn check_case(case: &Case) -> Result<(), SynthError> {
    if !(0.0..0.5 * case.sample_period).contains(&case.jitter) {
        return Err(SynthError::Jitter {
            limit: 0.5 * case.sample_period,
        });
    }
    if case.substeps == 0 {
        return Err(SynthError::NoSubstep);
    }
    if case.effects.len() > 2 {
        return Err(SynthError::TooManyEffects);
    }
    let pumps: Vec<Pump> = case.effects.iter().filter_map(|e| e.pump()).collect();
    if case.scheme == Scheme::Single && pumps.contains(&Pump::Aux) {
        return Err(SynthError::AuxIdle);
    }
    let mut ids: Vec<&str> = case.effects.iter().map(|e| e.id()).collect();
    ids.sort();
    ids.dedup();
    if ids.len() != case.effects.len() {
        return Err(SynthError::SameEffectTwice);
    }
    Ok(())
}

/// Sets the effect's parameters at a realistic magnitude, scaled where needed to what the
/// nominal run exercises; `magnitude` scales it (weak 0.5 - strong 1.5), `in_plateau` puts a
/// relief valve's cracking inside the upper load plateau instead of in the pressure peaks
/// only, `dt` is the logger's sample period [s].
fn conceal(
    p: &mut Params,
    effect: Effect,
    reference: &Trace,
    rng: &mut Rng,
    (magnitude, in_plateau, dt): (f64, bool, f64),
) {
    let set = |p: &mut Params, n: &str, v: f64| {
        p.set(n, v).expect("effect value within the table's bounds")
    };
    let names = effect.model_parameters();
    match effect {
        Effect::StribeckFriction => {
            set(p, "F_s", p.F_c * (1.0 + rng.range(0.3, 0.7) * magnitude));
            set(p, "v_s", rng.range(3e-3, 8e-3));
        }
        Effect::PressureDependentFriction => set(p, "mu", rng.range(0.01, 0.03) * magnitude),
        Effect::PositionDependentLoad => set(p, "k_load", rng.range(5e3, 1.5e4) * magnitude),
        Effect::EntrainedAir => set(p, "air_fraction", rng.log_range(0.003, 0.02) * magnitude),
        Effect::ReliefLeakage => {
            let pressures = moving_pressures(reference);
            let q = if in_plateau {
                rng.range(0.6, 0.8)
            } else {
                rng.range(0.97, 0.995)
            };
            set(p, "p_crack", quantile(&pressures, q));
            set(p, "K_relief", rng.log_range(2e-11, 8e-11));
        }
        Effect::PumpDeadTime(_) => set(p, names[0], rng.range(0.015, 0.04) * magnitude),
        Effect::PumpFlowLimit(i) => {
            let q = reference.signal(i.flow()).expect("flow output");
            // A third to a half of the slopes the pump reaches in its fastest 1 % of the run:
            // the limit binds in every start-up and large speed step of the programme.
            let slopes: Vec<f64> = q.windows(2).map(|w| (w[1] - w[0]).abs() / dt).collect();
            set(
                p,
                names[0],
                quantile(&slopes, 0.99) * rng.range(0.3, 0.5) / magnitude.max(0.5),
            );
        }
        Effect::FlowRipple(_) => {
            set(p, names[0], rng.range(0.01, 0.04) * magnitude);
            set(p, names[1], rng.range(5.0, 45.0).min(0.4 / dt));
            set(p, names[2], rng.range(-PI, PI));
        }
    }
}

/// Chamber pressures while the piston moves [Pa].
fn moving_pressures(trace: &Trace) -> Vec<f64> {
    trace
        .outputs
        .iter()
        .filter(|o| o.v.abs() > 1e-3)
        .map(|o| o.p)
        .collect()
}

fn quantise(value: f64, lsb: f64) -> f64 {
    (value / lsb).round() * lsb
}

/// The bench's view of a run: sensor channels with noise, commands as the controller wrote them.
fn recording_csv(trace: &Trace, s: &Sensors, case: &Case, rng: &mut Rng) -> String {
    let n = trace.time.len();
    let col = |name: &str| trace.signal(name).expect("trace signal");
    let mut sensed = |name: &str, sd: &dyn Fn(f64) -> f64, lsb: f64| -> Vec<f64> {
        let noise = rng.coloured(n, s.colour);
        col(name)
            .iter()
            .zip(noise)
            .map(|(v, e)| quantise(v + sd(*v) * e, lsb))
            .collect()
    };
    let x = sensed("x", &|_| s.x_noise, s.x_lsb);
    let p = sensed("p", &|_| s.p_noise, s.p_lsb);
    let q1 = sensed("Q1", &|q| s.q_noise * q.abs(), s.q_lsb);
    let q2 = sensed("Q2", &|q| s.q_noise * q.abs(), s.q_lsb);
    let absent: Vec<String> = case
        .variation
        .as_ref()
        .map_or(Vec::new(), |v| v.absent.clone());
    let offset = case.variation.as_ref().map_or(0.0, |v| v.time_offset);
    let names: Vec<&str> = ["v_ref", "x_ref", "F_L", "u1", "u2", "uc1", "uc2"]
        .into_iter()
        .filter(|n| !absent.iter().any(|a| a == n))
        .collect();
    let exact: Vec<_> = names.iter().map(|n| col(n)).collect();
    let stamps: Vec<f64> = trace
        .time
        .iter()
        .map(|t| offset + t + case.jitter * (2.0 * rng.unit() - 1.0))
        .collect();
    let seed = case.seed.to_string();
    let meta = [
        ("source", "tbm-thrust generate"),
        ("scenario", case.scenario.name()),
        ("scheme", case.scheme.name()),
        ("controller", case.controller.name()),
        ("seed", seed.as_str()),
        ("units", "SI"),
    ];
    let column = |name, values, format| Column {
        name,
        values,
        format,
    };
    let mut columns = vec![
        column("time", &stamps, Number::Fixed(6)),
        column("x", &x, Number::Scientific(7)),
        column("p", &p, Number::Scientific(7)),
        column("Q1", &q1, Number::Scientific(7)),
        column("Q2", &q2, Number::Scientific(7)),
    ];
    for (name, values) in names.iter().zip(&exact) {
        columns.push(column(name, values, Number::Scientific(9)));
    }
    csv::write(meta, &columns)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_start_at_zero_and_ramp() {
        let mut s = Steps::default();
        s.ramp(1.0, 2.0, 0.0, 1.0);
        let p = s.profile();
        assert_eq!(p.at(0.5), 0.0);
        assert!((p.at(1.5) - 0.5).abs() < 0.011);
        assert_eq!(p.at(5.0), 1.0);
    }

    #[test]
    fn pump_two_effects_need_the_auxiliary_pump() {
        let case = Case::new(
            BenchScenario::StartStop,
            Scheme::Single,
            vec![Effect::FlowRipple(Pump::Aux)],
            1,
        );
        assert!(generate(&case).is_err());
    }
}
