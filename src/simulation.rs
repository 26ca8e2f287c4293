//! The fixed-step solver and simulation driver: plant + dual-pump controller + reference.
//!
//! Time is split on an absolute grid: the controller samples every `CONTROL_PERIOD` (1 kHz)
//! from the start time, and the plant is integrated by RK4 in `substeps` equal steps per
//! controller period. A communication step of any length walks this grid (a step that ends
//! between grid points is integrated exactly to its end), so the result barely depends on
//! how an importer chooses its communication steps. See ARCHITECTURE.md, "Numerics".

use crate::control::{DualPumpController, Measurement, Settings, CONTROL_PERIOD};
use crate::cylinder;
use crate::plant::{stable_substeps, Drive, PlantState};
use crate::pump::PumpParams;
use crate::variables::{Inputs, Outputs, Params};

/// Default plant solver steps per controller period (0.5 ms).
pub const DEFAULT_SUBSTEPS: u32 = 2;
/// Longest pump dead time the drive-command history holds [s] (the table's max of delay1/2
/// plus that of t_d1).
const MAX_DELAY: f64 = 1.5;
const HISTORY: usize = (MAX_DELAY / CONTROL_PERIOD) as usize + 2;

/// A complete, serialisable simulation: replaying a restored copy gives identical numbers.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Simulator {
    pub params: Params,
    pub inputs: Inputs,
    plant: PlantState,
    controller: DualPumpController,
    start_time: f64,
    time: f64,
    /// Controller samples taken so far; the next one is at start_time + ticks * CONTROL_PERIOD.
    ticks: u64,
    x_ref: f64,
    substeps: u32,
    /// Drive commands of the last HISTORY samples (ring buffer indexed by tick), for dead time.
    uc_history: Vec<[f64; 2]>,
}

impl Simulator {
    /// A simulator at `start_time` with the piston at rest holding the load `inputs.F_L`.
    pub fn new(params: Params, inputs: Inputs, start_time: f64) -> Self {
        Self::with_substeps(params, inputs, start_time, DEFAULT_SUBSTEPS)
    }

    pub fn with_substeps(params: Params, inputs: Inputs, start_time: f64, substeps: u32) -> Self {
        Simulator {
            plant: PlantState::at_rest(&params, inputs.F_L),
            controller: DualPumpController::new(&params),
            params,
            inputs,
            start_time,
            time: start_time,
            ticks: 0,
            x_ref: 0.0,
            substeps: substeps.max(1),
            uc_history: vec![[0.0; 2]; HISTORY],
        }
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    /// Solver steps per controller period: as asked, or more where the parameters make the
    /// plant stiffer than RK4 at that step can follow (`plant::stable_substeps`; the
    /// default parameters need 1, so the default 2 stand).
    fn substeps(&self) -> u32 {
        let p = &self.params;
        let stable = stable_substeps(p, CONTROL_PERIOD, &[p.a1, p.a2]);
        self.substeps.max(u32::try_from(stable).unwrap_or(u32::MAX))
    }

    /// Advances the simulation by `dt` [s] with the inputs held.
    pub fn advance(&mut self, dt: f64) {
        let t_end = self.time + dt;
        let eps = 1e-12 * t_end.abs().max(1.0);
        let h = CONTROL_PERIOD / self.substeps() as f64;
        let pumps = PumpParams::both(&self.params);
        // Parameters and inputs are held over the call: the dead times in ticks and the
        // controller's settings are computed once, and the drive reaching the motors
        // changes only at controller samples.
        let lags = self.lags();
        let settings = Settings::new(&self.params, CONTROL_PERIOD);
        let mut drive = self.drive(&lags);
        while self.time < t_end - eps {
            let next_sample = self.start_time + self.ticks as f64 * CONTROL_PERIOD;
            if self.time >= next_sample - eps {
                self.time = self.time.max(next_sample);
                self.sample(&pumps, &settings);
                drive = self.drive(&lags);
                continue;
            }
            let last_sample = next_sample - CONTROL_PERIOD;
            let j = ((self.time - last_sample) / h + 1e-6).floor() + 1.0;
            let grid = (last_sample + j * h).min(next_sample);
            // A step end within eps of a grid point is snapped onto it, so that importers
            // computing the end as t + h or as n h integrate exactly the same steps.
            let to = if grid <= t_end + eps { grid } else { t_end };
            self.plant
                .step(&self.params, &pumps, &drive, self.time, to - self.time);
            self.x_ref += self.inputs.v_ref * (to - self.time);
            self.time = to;
        }
    }

    /// One controller sample at the current time.
    fn sample(&mut self, pumps: &[PumpParams; 2], settings: &Settings) {
        let m = Measurement {
            x: self.plant.x,
            v: self.plant.v,
            q: self.plant.delivered(pumps, self.time),
            x_ref: self.x_ref,
            v_ref: self.inputs.v_ref,
        };
        self.controller.sample(&self.params, settings, &m);
        self.uc_history[self.ticks as usize % HISTORY] = self.controller.uc;
        self.ticks += 1;
    }

    /// Each pump's dead time in controller ticks, at most the history's length: the main
    /// drive's own t_d1 plus the pump_dead_time effect's delay1, and delay2.
    fn lags(&self) -> [i64; 2] {
        [self.params.t_d1 + self.params.delay1, self.params.delay2]
            .map(|d| ((d / CONTROL_PERIOD).round() as i64).min(HISTORY as i64 - 1))
    }

    /// What acts on the plant until the next sample: the drive commands reaching the motors
    /// after each pump's dead time of `lags` ticks [V], and the load [N].
    fn drive(&self, lags: &[i64; 2]) -> Drive {
        Drive {
            uc: self.applied_commands(lags),
            f_load: self.inputs.F_L,
        }
    }

    /// Drive commands reaching the motors now, after each pump's dead time [V].
    fn applied_commands(&self, lags: &[i64; 2]) -> [f64; 2] {
        let latest = self.ticks as i64 - 1;
        std::array::from_fn(|i| {
            let tick = latest - lags[i];
            if tick < 0 {
                0.0
            } else {
                self.uc_history[tick as usize % HISTORY][i]
            }
        })
    }

    /// The outputs at the current time.
    pub fn outputs(&self) -> Outputs {
        let p = &self.params;
        let pumps = PumpParams::both(p);
        let s = &self.plant;
        let q = s.delivered(&pumps, self.time);
        Outputs {
            x: s.x,
            v: s.v,
            p: s.p,
            Q1: q[0],
            Q2: q[1],
            u1: self.controller.u[0],
            u2: self.controller.u[1],
            x_ref: self.x_ref,
            e_x: self.x_ref - s.x,
            F_cyl: cylinder::hydraulic_force(p, s.p),
            P_hyd1: s.p * q[0],
            P_hyd2: s.p * q[1],
            uc1: self.controller.uc[0],
            uc2: self.controller.uc[1],
            k_x: self.controller.law.k[0],
            k_v: self.controller.law.k[1],
            k_a: self.controller.law.k[2],
            g_sw: self.controller.law.g_sw,
            F_fric: s.friction(p, self.inputs.F_L),
            F_stop: s.stop_reaction(p, self.inputs.F_L),
        }
    }
}

/// A piecewise-constant signal: `(time, value)` breakpoints, value held until the next.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile(pub Vec<(f64, f64)>);

impl Profile {
    pub fn constant(value: f64) -> Self {
        Profile(vec![(0.0, value)])
    }

    pub fn at(&self, t: f64) -> f64 {
        let eps = 1e-9;
        self.0
            .iter()
            .take_while(|(t0, _)| *t0 <= t + eps)
            .last()
            .map_or(0.0, |&(_, v)| v)
    }
}

/// One run: reference velocity and load profiles, duration and output sampling.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    pub v_ref: Profile,
    pub load: Profile,
    pub duration: f64,
    pub sample_period: f64,
}

impl Scenario {
    /// The paper's start-up run: constant v_ref from rest at t = 0, constant load, 20 s at 0.01 s.
    pub fn startup(v_ref: f64, load: f64) -> Self {
        Scenario {
            v_ref: Profile::constant(v_ref),
            load: Profile::constant(load),
            duration: 20.0,
            sample_period: 0.01,
        }
    }

    /// Output samples of the run, t = 0 and the end included.
    pub fn samples(&self) -> usize {
        ((self.duration / self.sample_period).round() as usize).saturating_add(1)
    }
}

/// A sampled run: time, inputs and outputs at every sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    pub time: Vec<f64>,
    pub inputs: Vec<Inputs>,
    pub outputs: Vec<Outputs>,
}

impl Trace {
    /// An empty trace with room for `samples` samples.
    fn with_capacity(samples: usize) -> Self {
        Trace {
            time: Vec::with_capacity(samples),
            inputs: Vec::with_capacity(samples),
            outputs: Vec::with_capacity(samples),
        }
    }

    fn push(&mut self, t: f64, inputs: &Inputs, outputs: &Outputs) {
        self.time.push(t);
        self.inputs.push(*inputs);
        self.outputs.push(*outputs);
    }

    /// One output signal by name (e.g. "e_x"), or an input ("v_ref", "F_L").
    pub fn signal(&self, name: &str) -> Option<Vec<f64>> {
        if let Some(i) = Outputs::NAMES.iter().position(|n| *n == name) {
            return Some(self.outputs.iter().map(|o| o.values()[i]).collect());
        }
        let i = Inputs::NAMES.iter().position(|n| *n == name)?;
        Some(self.inputs.iter().map(|o| o.values()[i]).collect())
    }
}

/// Runs a scenario: inputs are read at each sample time and held over the next interval,
/// exactly as an FMI master does with communication step `sample_period`.
pub fn run(params: &Params, scenario: &Scenario) -> Trace {
    run_with_substeps(params, scenario, DEFAULT_SUBSTEPS)
}

pub fn run_with_substeps(params: &Params, scenario: &Scenario, substeps: u32) -> Trace {
    let mut trace = Trace::with_capacity(scenario.samples());
    let _ = run_each(params, scenario, substeps, |t, inputs, outputs| {
        trace.push(t, inputs, outputs);
        Ok::<(), std::convert::Infallible>(())
    });
    trace
}

/// Runs a scenario as `run` does, handing each sample to `each` instead of keeping it, so a
/// run of any length takes no memory for its samples; stops at the first error of `each`.
pub fn run_each<E>(
    params: &Params,
    scenario: &Scenario,
    substeps: u32,
    each: impl FnMut(f64, &Inputs, &Outputs) -> Result<(), E>,
) -> Result<(), E> {
    let inputs_at = |t: f64| Inputs {
        v_ref: scenario.v_ref.at(t),
        F_L: scenario.load.at(t),
    };
    let sim = Simulator::with_substeps(params.clone(), inputs_at(0.0), 0.0, substeps);
    let samples = (0..scenario.samples()).map(|k| {
        let t = k as f64 * scenario.sample_period;
        (t, inputs_at(t))
    });
    sample_and_hold_each(sim, samples, each)
}

/// The one sample-and-hold run loop (simulations and recording replays): at each sample
/// `(time [s], inputs)` the simulator advances to the time, records its outputs with the
/// sample's inputs and holds those inputs until the next sample, as an FMI master does.
pub fn sample_and_hold(sim: Simulator, samples: impl IntoIterator<Item = (f64, Inputs)>) -> Trace {
    let mut trace = Trace::default();
    let _ = sample_and_hold_each(sim, samples, |t, inputs, outputs| {
        trace.push(t, inputs, outputs);
        Ok::<(), std::convert::Infallible>(())
    });
    trace
}

/// `sample_and_hold`, handing each sample's time, inputs and outputs to `each`.
fn sample_and_hold_each<E>(
    mut sim: Simulator,
    samples: impl IntoIterator<Item = (f64, Inputs)>,
    mut each: impl FnMut(f64, &Inputs, &Outputs) -> Result<(), E>,
) -> Result<(), E> {
    for (k, (t, inputs)) in samples.into_iter().enumerate() {
        if k > 0 {
            sim.advance(t - sim.time());
        }
        sim.inputs = inputs;
        each(t, &sim.inputs, &sim.outputs())?;
    }
    Ok(())
}
