//! The fixed-step solver and simulation driver: plant + dual-pump controller + reference.
//!
//! Time is split on an absolute grid: the controller samples every `CONTROL_PERIOD` (1 kHz)
//! from the start time, and the plant is integrated by RK4 in `substeps` equal steps per
//! controller period. A communication step of any length walks this grid (a step that ends
//! between grid points is integrated exactly to its end), so the result barely depends on
//! how an importer chooses its communication steps. See ARCHITECTURE.md, "Numerics".

use crate::control::{DualPumpController, Measurement, CONTROL_PERIOD};
use crate::cylinder;
use crate::plant::{Drive, PlantState};
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

    /// Advances the simulation by `dt` [s] with the inputs held.
    pub fn advance(&mut self, dt: f64) {
        let t_end = self.time + dt;
        let eps = 1e-12 * t_end.abs().max(1.0);
        let h = CONTROL_PERIOD / self.substeps as f64;
        let pumps = [
            PumpParams::of(&self.params, 1),
            PumpParams::of(&self.params, 2),
        ];
        while self.time < t_end - eps {
            let next_sample = self.start_time + self.ticks as f64 * CONTROL_PERIOD;
            if self.time >= next_sample - eps {
                self.time = self.time.max(next_sample);
                self.sample(&pumps);
                continue;
            }
            let last_sample = next_sample - CONTROL_PERIOD;
            let j = ((self.time - last_sample) / h + 1e-6).floor() + 1.0;
            let grid = (last_sample + j * h).min(next_sample);
            // A step end within eps of a grid point is snapped onto it, so that importers
            // computing the end as t + h or as n h integrate exactly the same steps.
            let to = if grid <= t_end + eps { grid } else { t_end };
            let drive = Drive {
                uc: self.applied_commands(),
                f_load: self.inputs.F_L,
            };
            self.plant
                .step(&self.params, &pumps, &drive, self.time, to - self.time);
            self.x_ref += self.inputs.v_ref * (to - self.time);
            self.time = to;
        }
    }

    /// One controller sample at the current time.
    fn sample(&mut self, pumps: &[PumpParams; 2]) {
        let m = Measurement {
            x: self.plant.x,
            v: self.plant.v,
            q: self.plant.delivered(pumps, self.time),
            x_ref: self.x_ref,
            v_ref: self.inputs.v_ref,
        };
        self.controller.sample(&self.params, &m, CONTROL_PERIOD);
        self.uc_history[self.ticks as usize % HISTORY] = self.controller.uc;
        self.ticks += 1;
    }

    /// Drive commands reaching the motors now, after each pump's dead time [V]: the main
    /// drive's own t_d1 plus the pump_dead_time effect.
    fn applied_commands(&self) -> [f64; 2] {
        let latest = self.ticks as i64 - 1;
        let delays = [self.params.t_d1 + self.params.delay1, self.params.delay2];
        std::array::from_fn(|i| {
            let lag = (delays[i] / CONTROL_PERIOD).round() as i64;
            let tick = latest - lag.min(HISTORY as i64 - 1);
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
        let pumps = [PumpParams::of(p, 1), PumpParams::of(p, 2)];
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
}

/// A sampled run: time, inputs and outputs at every sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    pub time: Vec<f64>,
    pub inputs: Vec<Inputs>,
    pub outputs: Vec<Outputs>,
}

impl Trace {
    /// One output signal by name (e.g. "e_x"), or an input ("v_ref", "F_L").
    pub fn signal(&self, name: &str) -> Option<Vec<f64>> {
        if let Some(i) = Outputs::NAMES.iter().position(|n| *n == name) {
            return Some(self.outputs.iter().map(|o| o.values()[i]).collect());
        }
        let i = Inputs::NAMES.iter().position(|n| *n == name)?;
        Some(self.inputs.iter().map(|o| o.values()[i]).collect())
    }

    /// The recording CSV of the contract: `time`, the inputs, then every output (SI units).
    pub fn to_csv(&self) -> String {
        let mut s = String::from("time");
        for n in Inputs::NAMES.iter().chain(Outputs::NAMES) {
            s.push(',');
            s.push_str(n);
        }
        s.push('\n');
        for ((t, i), o) in self.time.iter().zip(&self.inputs).zip(&self.outputs) {
            s.push_str(&format!("{t:.6}"));
            for v in i.values().iter().chain(o.values().iter()) {
                s.push_str(&format!(",{v:.12e}"));
            }
            s.push('\n');
        }
        s
    }
}

/// Runs a scenario: inputs are read at each sample time and held over the next interval,
/// exactly as an FMI master does with communication step `sample_period`.
pub fn run(params: &Params, scenario: &Scenario) -> Trace {
    run_with_substeps(params, scenario, DEFAULT_SUBSTEPS)
}

pub fn run_with_substeps(params: &Params, scenario: &Scenario, substeps: u32) -> Trace {
    let inputs_at = |t: f64| Inputs {
        v_ref: scenario.v_ref.at(t),
        F_L: scenario.load.at(t),
    };
    let mut sim = Simulator::with_substeps(params.clone(), inputs_at(0.0), 0.0, substeps);
    let n = (scenario.duration / scenario.sample_period).round() as usize;
    let mut trace = Trace::default();
    for k in 0..=n {
        let t = k as f64 * scenario.sample_period;
        if k > 0 {
            sim.advance(t - sim.time());
        }
        sim.inputs = inputs_at(t);
        trace.time.push(t);
        trace.inputs.push(sim.inputs);
        trace.outputs.push(sim.outputs());
    }
    trace
}
