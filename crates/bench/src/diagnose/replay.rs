//! Open-loop replays of each subsystem from the recorded signals at its boundary, so that
//! the bench's controller (whatever it is) never enters the model, and an error in one
//! subsystem does not smear into another's fit:
//! - pump i, Eq. (8): drive command `uc_i` and measured pressure in, flow `Q_i` out; without
//!   a `uc_i` column but with the commanded flow `u_i`, the drive command is the one the
//!   bench's flow loop gave: the model's controller (PID or ADRC, `control`, its gains fitted
//!   as nominal unknowns) run over the recorded `u_i` and `Q_i` from rest at the first sample;
//!   with neither column (or a chattering `uc_i`), the pump's own flow through a running
//!   median, against which only a ripple can be tested;
//! - hydromechanics, Eq. (1)-(4): measured total pump flow and load in, `x`, `v`, `p` out.
//!
//! Each replay runs segment by segment from the recorded state at the segment's start
//! (multiple shooting; a hydromechanics segment from the recorded state
//! [`HYDRO_READ_IN_S`] before it, a pump segment read in through its flow's noise), with
//! the plant's own equations (`plant`, `pump`, `cylinder`, `chamber`) on a fixed step of
//! about 1 ms.

use super::effect::min_ripple_frequency;
use super::filter::running_median;
use super::noise::EnvelopeNoise;
use super::series::{backward_quadratic, line_end, velocity, Segment, Series};
use crate::numerics::stats::{noise_level, robust_sd};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use tbm_thrust::control::adrc::{Adrc, AdrcGains};
use tbm_thrust::control::pid::{Pid, PidGains};
use tbm_thrust::control::CONTROL_PERIOD;
use tbm_thrust::cylinder::Motion;
use tbm_thrust::ode;
use tbm_thrust::plant::{stable_substeps, Drive, PlantState};
use tbm_thrust::pump::{Pump, PumpParams};
use tbm_thrust::units::LPM;
use tbm_thrust::variables::{Controller, Params, PidForm};

/// Solver step target [s].
const STEP: f64 = 2e-3;
/// Speed below which a replay starts with the piston stuck [m/s].
const V_STUCK: f64 = 5e-4;

/// Least span of recording [s] behind a segment's start from which its initial
/// displacement, velocity and pressure are read (a causal quadratic fit): at 1 kHz the ten
/// and eight samples of slower loggers span 8-10 ms, and the fit's end value there carries
/// most of one sample's noise into the whole segment. A piston that starts the segment stuck
/// keeps that pressure error to the segment's end (frozen seed 900 052: the bench's own
/// model replayed 30-100 kPa off through its standstills, 20 kPa noise; the held-out `p`
/// error of the bench's model 31.2 -> 20.7 kPa, `x` 1.01e-4 -> 0.82e-4 m with 20 ms).
/// Longer spans smear a stick-slip cycle (frozen seed 900 064 at 30 ms: `p` 86 -> 89 kPa).
const INIT_SPAN: f64 = 0.02;

/// Span of recording [s] before a pump segment over which its initial flow is read through
/// the recorded flow's noise ([`Bench::read_in`]).
const READ_IN_S: f64 = 1.0;

/// Curvature of the recorded flow over the read-in [standard errors] at which the read-in
/// and the recorded flow's last samples weigh alike ([`Bench::read_in_weight`]).
const READ_IN_KINK: f64 = 2.0;

/// A read-in weight below which the read-in is not replayed: its share of the segment's
/// start is below this [-] (a replay saved at every segment that starts on a kink).
const READ_IN_NEGLIGIBLE: f64 = 1e-3;

/// Span [s] before a hydromechanics segment over which the model is replayed from the
/// recorded state there, so that the segment starts from the model's own state, not from
/// one read through the sensors' noise, which a stiffer oil column settles sooner (a fold
/// with no stop in it fitted `beta_e` 3.7 times too stiff; docs/diagnose.md, "The replays
/// are multiple shooting"). About seven times the oil column's decay time 2 m / b at the
/// paper's values, and at least 0.1 s after a step (no segment starts within 0.3 s of one).
/// Only where the piston slides throughout ([`Bench::hydro_read_in`]).
const HYDRO_READ_IN_S: f64 = 0.2;

/// Smoothed speed above which the piston counts as sliding [m/s].
pub const SLIDING_SPEED: f64 = 1e-3;

/// The recording prepared for replays: smoothed initial-state sources, inputs and scales.
#[derive(Clone, Debug)]
pub struct Bench<'a> {
    pub s: &'a Series,
    /// Smoothed velocity [m/s] (centred, for regimes and equation errors).
    pub v: Vec<f64>,
    /// Replay initial states from the samples up to each k only: displacement [m],
    /// velocity [m/s], pressure [Pa], pump flows [m^3/s].
    pub init: Vec<[f64; 5]>,
    /// Measured total pump flow into the chamber [m^3/s].
    pub q_in: Vec<f64>,
    /// Residual scales of x [m], v [m/s], p [Pa] and Q1, Q2 [m^3/s].
    pub scale: Scales,
    /// Solver sub-steps per sample.
    pub substeps: usize,
    /// Noise level of the oscillation envelope of `x` [m] and `p` [Pa], from each signal's
    /// own noise estimate; made at its first use ([`Bench::envelope_noise`]: the floors'
    /// perturbed benches never judge an envelope).
    envelope_noise: OnceLock<[EnvelopeNoise; 2]>,
    /// Every sampled input read between samples the other admissible way: the drive commands
    /// and pump flows held (zero-order) instead of interpolated linearly, the load
    /// interpolated instead of held (a load step falls somewhere between two samples); used
    /// to measure what the sampling leaves unknown (`floor.rs`).
    pub other_reading: bool,
    /// Each pump's flow-loop reference u_i and measured flow Q_i [L/min] at the samples,
    /// when its drive command is not recorded but its commanded flow is (the loop's drive is
    /// then reconstructed).
    flow_loop: [Option<(Vec<f64>, Vec<f64>)>; 2],
    /// Each pump's recorded flow through a running median over one period of the slowest
    /// plausible ripple, when the pump cannot be replayed from a command
    /// ([`DriveSource::OwnFlow`]): it follows the pump's rises and falls (a median keeps a
    /// monotone ramp) but not a tone. Computed at the pump's first replay (`None`: the pump
    /// has a command), so that the benches which never replay it (the floors') skip it.
    own_flow: [Option<OnceLock<Vec<f64>>>; 2],
    /// Each pump's recorded flow noise level [m^3/s].
    flow_noise: [f64; 2],
    /// Identity of the recording, keying the reconstructed drive commands' cache.
    id: u64,
}

/// Where a pump's drive command comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveSource {
    /// The recorded `uc_i`.
    Recorded,
    /// The flow loop run over the recorded u_i and Q_i.
    FlowLoop,
    /// None that the pump can be replayed from (neither `uc_i` nor `u_i` recorded, or a
    /// chattering `uc_i`): the pump's flow is its own recorded flow's running median
    /// (`Bench::own_flow`), on which only a ripple can be tested.
    OwnFlow,
}

/// A drive command chatters when more than this share of its sample-to-sample changes
/// exceed a quarter of its range: it varies faster than the recording resolves.
const CHATTER_SHARE: f64 = 0.1;

/// The share of large sample-to-sample jumps of a drive command, if it counts as chatter.
pub fn chatter(uc: &[f64]) -> Option<f64> {
    let range = crate::numerics::stats::span(uc);
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

/// A pump's drive command [V] at the samples: the recorded column or a reconstruction.
pub enum DriveCommand<'a> {
    Recorded(&'a [f64]),
    FlowLoop(Arc<Vec<f64>>),
}

impl std::ops::Deref for DriveCommand<'_> {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        match self {
            DriveCommand::Recorded(v) => v,
            DriveCommand::FlowLoop(v) => v,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scales {
    pub x: f64,
    pub v: f64,
    pub p: f64,
    pub q: [f64; 2],
}

/// Load of a hydromechanics replay: the recorded `F_L`, or a fitted constant [N].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Load {
    Recorded,
    Constant(f64),
}

/// Hydromechanics replay outputs at the samples of one segment.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HydroOut {
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub p: Vec<f64>,
}

impl<'a> Bench<'a> {
    pub fn new(s: &'a Series) -> Bench<'a> {
        let span = |samples: usize| samples.max((INIT_SPAN / s.dt).round() as usize);
        let xb = backward_quadratic(s.col("x"), span(10));
        let pb = backward_quadratic(s.col("p"), span(8));
        let q1 = backward_quadratic(s.col("Q1"), 5);
        let q2 = backward_quadratic(s.col("Q2"), 5);
        let init = (0..s.len())
            .map(|k| [xb[k].0, xb[k].1 / s.dt, pb[k].0, q1[k].0, q2[k].0])
            .collect();
        let q_in: Vec<f64> = s
            .col("Q1")
            .iter()
            .zip(s.col("Q2"))
            .map(|(a, b)| a + b)
            .collect();
        let scale = Scales {
            x: noise_level(s.col("x")).max(1e-4),
            v: s.get("v").map_or(1e-3, |v| noise_level(v).max(1e-3)),
            p: noise_level(s.col("p")).max(5e3),
            q: [flow_scale(s.col("Q1")), flow_scale(s.col("Q2"))],
        };
        Bench {
            v: velocity(s, 5),
            init,
            q_in,
            scale,
            substeps: ((s.dt / STEP).round() as usize).max(1),
            envelope_noise: OnceLock::new(),
            other_reading: false,
            flow_loop: Pump::BOTH.map(|i| {
                let u = s.get(&i.name("u"))?;
                let lpm = |v: &[f64]| v.iter().map(|v| v * LPM).collect();
                (!s.has(i.drive())).then(|| (lpm(u), lpm(s.col(i.flow()))))
            }),
            own_flow: Pump::BOTH.map(|i| {
                let replayable = match s.get(i.drive()) {
                    Some(uc) => chatter(uc).is_none(),
                    None => s.has(&i.name("u")),
                };
                (!replayable).then(OnceLock::new)
            }),
            flow_noise: Pump::BOTH.map(|i| noise_level(s.col(i.flow()))),
            id: NEXT_BENCH.fetch_add(1, Ordering::Relaxed),
            s,
        }
    }

    /// The noise level of the oscillation envelope of `name`, for `x` and `p` (the signals
    /// whose envelope is judged); none for the others.
    pub fn envelope_noise(&self, name: &str) -> Option<&EnvelopeNoise> {
        const JUDGED: [&str; 2] = ["x", "p"];
        let i = JUDGED.iter().position(|n| *n == name)?;
        let levels = self
            .envelope_noise
            .get_or_init(|| JUDGED.map(|n| EnvelopeNoise::of(self.s.col(n))));
        Some(&levels[i])
    }

    /// Replays `pump` from its own flow's running median from now on
    /// ([`DriveSource::OwnFlow`]): its drive command cannot drive a replay
    /// (`refit::faster_than_the_logger`).
    pub fn replay_from_own_flow(&mut self, pump: Pump) {
        self.own_flow[pump.index()].get_or_insert_with(OnceLock::new);
    }

    /// Where pump i's drive command comes from.
    pub fn drive_source(&self, pump: Pump) -> DriveSource {
        if self.own_flow[pump.index()].is_some() {
            DriveSource::OwnFlow
        } else if self.flow_loop[pump.index()].is_some() {
            DriveSource::FlowLoop
        } else {
            DriveSource::Recorded
        }
    }

    /// Pump i's drive command [V] at the samples: the recorded `uc_i`, or the command the
    /// flow loop of the model (`run_loop`) gives the recorded reference and flow. The
    /// reconstruction depends on the loop's parameters only, so the last one of each thread
    /// is kept for the segments that follow.
    pub fn drive(&self, params: &Params, pump: Pump) -> DriveCommand<'_> {
        let Some((reference, measured)) = self.flow_loop[pump.index()].as_ref() else {
            return DriveCommand::Recorded(self.s.col(pump.drive()));
        };
        let uc_max = PumpParams::of(params, pump).uc_max;
        let gains: Vec<u64> = loop_gains(pump)
            .iter()
            .map(|n| params.get(n).unwrap_or(f64::NAN))
            .chain([params.tau_d, uc_max])
            .map(f64::to_bits)
            .collect();
        let key = (self.id, pump, gains, params.pid_form, params.controller);
        LAST_DRIVE.with(|last| {
            let mut last = last.borrow_mut();
            if let Some((k, v)) = last.as_ref() {
                if *k == key {
                    return DriveCommand::FlowLoop(v.clone());
                }
            }
            let v = Arc::new(self.run_loop(params, pump, reference, measured, uc_max));
            *last = Some((key, v.clone()));
            DriveCommand::FlowLoop(v)
        })
    }

    /// The flow loop of `params.controller` (PID or ADRC, `control`) run at the controller's
    /// period over the recorded reference and measured flow [L/min] (linear between samples),
    /// from rest at the first sample: its command [V] at every sample.
    fn run_loop(
        &self,
        params: &Params,
        pump: Pump,
        reference: &[f64],
        measured: &[f64],
        uc_max: f64,
    ) -> Vec<f64> {
        let ticks = ((self.s.dt / CONTROL_PERIOD).round() as usize).max(1);
        let ts = self.s.dt / ticks as f64;
        let get = |stem: &str| params.get(&pump.name(stem)).unwrap_or(0.0);
        let pid_gains = PidGains::new(
            get("Kp"),
            get("Ki"),
            get("Kd"),
            params.pid_form == PidForm::PerSample,
            ts,
            params.tau_d,
        );
        let adrc_gains = AdrcGains {
            wc: get("wc"),
            beta1: get("beta1_"),
            beta2: get("beta2_"),
            b0: get("b0_"),
            ts,
        };
        let mut pid = Pid::default();
        let mut adrc = Adrc::default();
        let mut out = Vec::with_capacity(reference.len());
        let mut uc = 0.0;
        for k in 0..reference.len() {
            let k0 = k.saturating_sub(1);
            for j in 1..=ticks {
                let w = if k == 0 { 1.0 } else { j as f64 / ticks as f64 };
                let r = reference[k0] + w * (reference[k] - reference[k0]);
                let q = measured[k0] + w * (measured[k] - measured[k0]);
                uc = match params.controller {
                    Controller::Pid => pid.update(&pid_gains, r - q, uc_max),
                    Controller::Adrc => adrc.update(adrc_gains, r, q, uc_max),
                };
            }
            out.push(uc);
        }
        out
    }

    /// A sampled input at time t: linear between samples, or held (see `other_reading`).
    fn input(&self, values: &[f64], t: f64) -> f64 {
        if self.other_reading {
            self.s.held(values, t)
        } else {
            self.s.at(values, t)
        }
    }

    /// Whether the piston slides at sample `k`: its smoothed speed above [`SLIDING_SPEED`].
    pub fn sliding(&self, k: usize) -> bool {
        self.v[k].abs() > SLIDING_SPEED
    }

    /// Measured pressures while the piston moves ([`Bench::sliding`]) [Pa].
    pub fn moving_pressures(&self) -> Vec<f64> {
        let p = self.s.col("p");
        let moving: Vec<f64> = (0..p.len())
            .filter(|&k| self.sliding(k))
            .map(|k| p[k])
            .collect();
        if moving.is_empty() {
            p.to_vec()
        } else {
            moving
        }
    }

    /// Median smoothed speed while the piston slides ([`Bench::sliding`]) [m/s].
    pub fn typical_speed(&self) -> f64 {
        let mut moving: Vec<f64> = (0..self.v.len())
            .filter(|&k| self.sliding(k))
            .map(|k| self.v[k].abs())
            .collect();
        if moving.is_empty() {
            return SLIDING_SPEED;
        }
        moving.sort_by(f64::total_cmp);
        moving[moving.len() / 2]
    }

    /// Load [N] as a function of time (the column looked up once, not at every step).
    fn load(&self, load: Load) -> impl Fn(f64) -> f64 + '_ {
        let recorded = self.s.get("F_L");
        move |t| match (load, recorded) {
            (Load::Constant(f), _) => f,
            (Load::Recorded, Some(f)) if self.other_reading => self.s.at(f, t),
            (Load::Recorded, Some(f)) => self.s.held(f, t),
            (Load::Recorded, None) => 0.0,
        }
    }

    /// Pump i's flow [m^3/s] at the samples of `seg`, replayed from its drive command; for a
    /// pump that has none ([`DriveSource::OwnFlow`]), its own flow's running median (with the
    /// ripple of `params` on top).
    pub fn pump(&self, params: &Params, pump: Pump, seg: Segment) -> Vec<f64> {
        let pp = PumpParams::of(params, pump);
        if let Some(lazy) = &self.own_flow[pump.index()] {
            let own = lazy.get_or_init(|| own_flow(self.s.col(pump.flow()), own_flow_half(self.s)));
            return (seg.start..seg.end)
                .map(|k| pp.delivered(own[k], self.s.time(k)))
                .collect();
        }
        let uc = self.drive(params, pump);
        let p = self.s.col("p");
        let h = self.s.dt / self.substeps as f64;
        let t_start = self.s.time(seg.start);
        let mut q = (self.init[seg.start][3 + pump.index()] / pp.delivered(1.0, t_start)).max(0.0);
        // Before the first sample the drive command is unknown; the pump is taken to have
        // been in equilibrium with its first recorded flow and pressure (a recording that
        // starts with a command step starts from a pump at rest, not from that step).
        let before = pp.saturate(
            (pp.a * self.init[0][3 + pump.index()].max(0.0) + pp.k_p * p[0])
                / pp.k_u.max(f64::MIN_POSITIVE),
        );
        let command = |t: f64| {
            if t < self.s.t0 {
                before
            } else {
                self.input(&uc, t)
            }
        };
        // The second and third stages of a Runge-Kutta step share their time, hence inputs.
        let inputs = last_call(|t: f64| (pp.saturate(command(t - pp.delay)), self.s.at(p, t)));
        let rate = |t: f64, q: f64| {
            let (uc, pressure) = inputs(t);
            pp.flow_rate(q, uc, pressure)
        };
        let step = |q: f64, t: f64| {
            (0..self.substeps).fold(q, |q, j| {
                ode::rk4(&|t, q: &f64| rate(t, *q), t + j as f64 * h, &q, h).max(0.0)
            })
        };
        let weight = (self.drive_source(pump) == DriveSource::Recorded)
            .then(|| self.read_in_weight(pump, seg.start))
            .flatten()
            .filter(|w| *w >= READ_IN_NEGLIGIBLE);
        if let Some(weight) = weight {
            if let Some(level) = self.read_in(pump, seg.start, &pp, &step) {
                q = weight * level + (1.0 - weight) * q;
            }
        }
        let mut out = Vec::with_capacity(seg.end - seg.start);
        for k in seg.start..seg.end {
            let t = self.s.time(k);
            out.push(pp.delivered(q, t));
            q = step(q, t);
        }
        out
    }

    /// Pump `pump`'s flow at sample `start` read through the recorded flow's noise: the
    /// model replayed freely over the [`READ_IN_S`] before it, plus the end of a straight
    /// line through the recorded flow's departure from that replay (`series::line_end`).
    /// The segment's start weighs it against the recorded flow's last samples
    /// ([`Bench::read_in_weight`]); below [`READ_IN_NEGLIGIBLE`] it is not replayed. None
    /// within the recording's first [`READ_IN_S`].
    fn read_in(
        &self,
        pump: Pump,
        start: usize,
        pp: &PumpParams,
        step: &dyn Fn(f64, f64) -> f64,
    ) -> Option<f64> {
        let first = self.read_in_first(start)?;
        let recorded = self.s.col(pump.flow());
        let at = |k: usize| pp.delivered(1.0, self.s.time(k));
        let mut q = (self.init[first][3 + pump.index()] / at(first)).max(0.0);
        let mut departure = Vec::with_capacity(start - first + 1);
        for (k, flow) in recorded.iter().enumerate().take(start).skip(first) {
            departure.push(flow / at(k) - q);
            q = step(q, self.s.time(k));
        }
        departure.push(recorded[start] / at(start) - q);
        let (line, _) = line_end(&departure, self.flow_noise[pump.index()])?;
        line.is_finite().then(|| (q + line).max(0.0))
    }

    /// The weight of pump `pump`'s read-in at sample `start`: `1 / (1 + (z /
    /// READ_IN_KINK)^4)`, z the curvature of the recorded flow over the [`READ_IN_S`]
    /// before it, in standard errors of the flow's noise. A kink (a command step, a
    /// start-up) leaves the start to the recorded flow's last samples; the weight falls
    /// smoothly, so the start stays continuous in the parameters (a switch made a delay's
    /// cost jump and its fit stop short: frozen 900 099, diagnose-log.md, thirtieth
    /// session). It is the recording's alone: read off the model's departure instead, it
    /// credited a candidate whose read-in kept straighter with the noise its read-in
    /// removed (tune 55 and 156, diagnose-log.md, thirty-first session). None for a flow
    /// without noise (an idle pump's zeros), which has no curvature to weigh.
    fn read_in_weight(&self, pump: Pump, start: usize) -> Option<f64> {
        let first = self.read_in_first(start)?;
        let flow = &self.s.col(pump.flow())[first..=start];
        let (_, z) = line_end(flow, self.flow_noise[pump.index()])?;
        // Squared twice, not `powi(4)`: LLVM leaves powi's order of products open, so its
        // last bit (and a fit's ninth digit) moved with the code around it.
        let r2 = (z / READ_IN_KINK) * (z / READ_IN_KINK);
        let weight = 1.0 / (1.0 + r2 * r2);
        weight.is_finite().then_some(weight)
    }

    /// The first sample of the read-in of a segment starting at `start`.
    fn read_in_first(&self, start: usize) -> Option<usize> {
        start.checked_sub((READ_IN_S / self.s.dt).round() as usize)
    }

    /// The first sample of the replay of a hydromechanics segment starting at `start`:
    /// [`HYDRO_READ_IN_S`] before it where the piston slides throughout ([`Bench::sliding`]),
    /// else `start` (a breakaway or a stop inside the read-in would carry its timing error
    /// into the segment).
    fn hydro_read_in(&self, start: usize) -> usize {
        start
            .checked_sub((HYDRO_READ_IN_S / self.s.dt).round() as usize)
            .filter(|&first| (first..=start).all(|k| self.sliding(k)))
            .unwrap_or(start)
    }

    /// Hydromechanics x, v, p at the samples of `seg`, replayed from the measured flows (from
    /// the read-in's first sample, [`Bench::hydro_read_in`]).
    pub fn hydro(&self, params: &Params, load: Load, seg: Segment) -> HydroOut {
        let idle = PumpParams {
            a: 0.0,
            k_u: 0.0,
            k_p: 0.0,
            uc_max: 0.0,
            delay: 0.0,
            rate_limit: 0.0,
            ripple: (0.0, 0.0, 0.0),
        };
        let pumps = [idle, idle];
        let first = self.hydro_read_in(seg.start);
        let [x0, v0, p0, ..] = self.init[first];
        let mut state = PlantState {
            x: x0.clamp(0.0, params.x_max),
            v: if v0.abs() < V_STUCK { 0.0 } else { v0 },
            p: p0,
            q: [0.0, 0.0],
            motion: if v0.abs() < V_STUCK {
                Motion::Stuck
            } else {
                Motion::Sliding(v0.signum() as i8)
            },
        };
        let substeps = self.substeps.max(stable_substeps(params, self.s.dt, &[]));
        let h = self.s.dt / substeps as f64;
        let load_at = self.load(load);
        let mut out = HydroOut::default();
        for k in first..seg.end {
            let t = self.s.time(k);
            if !(state.x.is_finite() && state.v.is_finite() && state.p.is_finite()) {
                // A replay that diverged predicts nothing: hold a far-off value so that its
                // error is large but finite.
                state = PlantState {
                    x: 1e3,
                    v: 0.0,
                    p: 1e10,
                    q: [0.0; 2],
                    motion: Motion::Stuck,
                };
            }
            if k >= seg.start {
                out.x.push(state.x);
                out.v.push(state.v);
                out.p.push(state.p);
            }
            for j in 0..substeps {
                let tj = t + j as f64 * h;
                state.q = [self.input(&self.q_in, tj + 0.5 * h), 0.0];
                let drive = Drive {
                    uc: [0.0, 0.0],
                    f_load: load_at(tj + 0.5 * h),
                };
                state.step(params, &pumps, &drive, tj, h);
            }
        }
        out
    }
}

/// Identity of the next bench made.
static NEXT_BENCH: AtomicU64 = AtomicU64::new(0);

/// Key of a reconstructed drive command: bench, pump, the loop's gains with the derivative
/// filter and the saturation (bits), PID form, controller.
type DriveKey = (u64, Pump, Vec<u64>, PidForm, Controller);

/// The model parameters of pump i's flow loop: PID and ADRC gains.
fn loop_gains(pump: Pump) -> [String; 7] {
    ["Kp", "Ki", "Kd", "wc", "beta1_", "beta2_", "b0_"].map(|stem| pump.name(stem))
}

thread_local! {
    /// The last drive command reconstructed on this thread.
    static LAST_DRIVE: std::cell::RefCell<Option<(DriveKey, Arc<Vec<f64>>)>> =
        const { std::cell::RefCell::new(None) };
}

/// `f` remembering its last argument and value: called again with the same time (bit for
/// bit), it returns that value without computing it anew.
fn last_call(f: impl Fn(f64) -> (f64, f64)) -> impl Fn(f64) -> (f64, f64) {
    let last = std::cell::Cell::new(None);
    move |t| match last.get() {
        Some((s, v)) if f64::to_bits(s) == t.to_bits() => v,
        _ => {
            let v = f(t);
            last.set(Some((t, v)));
            v
        }
    }
}

/// Flow residual scale: the larger of the noise level and 1 % of the peak flow [m^3/s].
/// Departure from the running median, in robust standard deviations of the departures
/// while the pump delivers, beyond which the flow is a peak the median clips (a command
/// spike's), not a tone.
const CLIPPED_PEAK: f64 = 4.0;

/// A pump's own flow [m^3/s] as its replay ([`DriveSource::OwnFlow`]): the running median
/// over +-`half` samples, which keeps the pump's monotone rises and falls and removes a
/// tone; where the flow departs from it by more than [`CLIPPED_PEAK`] robust standard
/// deviations (and a quarter of the window around), a peak shorter than half the window
/// that the median clipped, the recorded flow as it is.
fn own_flow(q: &[f64], half: usize) -> Vec<f64> {
    let mut out = running_median(q, half);
    let peak = out.iter().fold(0.0f64, |a, v| a.max(*v));
    let departures: Vec<f64> = q
        .iter()
        .zip(&out)
        .filter(|(_, m)| **m > 0.1 * peak)
        .map(|(y, m)| y - m)
        .collect();
    if departures.is_empty() {
        return out;
    }
    let limit = CLIPPED_PEAK * robust_sd(&departures);
    let reach = half / 4;
    let clipped: Vec<usize> = (0..q.len())
        .filter(|&k| (q[k] - out[k]).abs() > limit)
        .collect();
    for k in clipped {
        let around = k.saturating_sub(reach)..(k + reach + 1).min(q.len());
        out[around.clone()].copy_from_slice(&q[around]);
    }
    out
}

/// Half-width [samples] of the running median of a pump's own flow: the window spans one
/// period of the slowest plausible ripple on this recording.
fn own_flow_half(s: &Series) -> usize {
    let f_min = min_ripple_frequency(s.len() as f64 * s.dt);
    (0.5 / (f_min * s.dt)).ceil() as usize
}

fn flow_scale(q: &[f64]) -> f64 {
    noise_level(q)
        .max(0.01 * crate::numerics::stats::peak(q))
        .max(1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::rng::{seeded, Draw};

    /// A piston at rest logged at 1 kHz under white pressure noise: each segment start's
    /// pressure is read over `INIT_SPAN` (20 samples), its error about 0.61 of the noise's
    /// standard deviation; over the 8 samples of a 100 Hz logger it would be 0.84.
    #[test]
    fn a_segment_start_reads_its_pressure_over_a_span_not_a_few_samples() {
        let n = 20_000;
        let (p0, sd) = (4e6, 2e4);
        let mut rng = seeded(31);
        let noise = rng.coloured(n, 0.0);
        let time: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
        let series = Series::from_columns(&time, |c| match c {
            "p" => Some(noise.iter().map(|e| p0 + sd * e).collect()),
            "x" => Some(vec![0.1; n]),
            "Q1" | "Q2" => Some(vec![0.0; n]),
            _ => None,
        })
        .expect("series");
        let bench = Bench::new(&series);
        let rms = (bench.init[100..]
            .iter()
            .map(|s| (s[2] - p0).powi(2))
            .sum::<f64>()
            / (n - 100) as f64)
            .sqrt();
        assert!(rms < 0.7 * sd, "initial pressure error {rms:.0} Pa");
    }

    /// An auxiliary pump's command step answered 10 ms late, logged at 1 kHz under flow
    /// noise, and a segment 0.55 s after the step, its read-in reaching back across it (the
    /// step near the read-in's middle, where it bends the recorded flow's quadratic term
    /// least, so the read-in weighs fully): as the delay tried sweeps 0-20 ms in 0.25 ms
    /// steps the segment's start moves by about one noise level in all but by at most 0.02
    /// of it per step (asserted: a fifth), so that a delay's cost has no step for its fit to
    /// stop at (a read-in switched off at a curvature of two standard errors of the model's
    /// departure jumped by 1.2 of the noise 0.3 s after the step).
    #[test]
    fn a_pump_segment_start_moves_continuously_with_the_delay() {
        let (n, dt, p0, sd) = (3_000, 1e-3, 4e6, 2e-6);
        let (t_step, delay, uc_before, uc_after) = (2.0, 0.01, 2.0, 6.0);
        let params = Params::default();
        let pp = PumpParams::of(&params, Pump::Aux);
        let settled = |uc: f64| (pp.k_u * uc - pp.k_p * p0) / pp.a;
        let flow = |t: f64| {
            let (before, after) = (settled(uc_before), settled(uc_after));
            let late = (t - t_step - delay).max(0.0);
            after + (before - after) * (-pp.a * late).exp()
        };
        let noise = seeded(11).coloured(n, 0.0);
        let time: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let series = Series::from_columns(&time, |c| match c {
            "p" => Some(vec![p0; n]),
            "x" => Some(vec![0.1; n]),
            "Q1" => Some(vec![0.0; n]),
            "Q2" => Some(
                time.iter()
                    .zip(&noise)
                    .map(|(t, e)| flow(*t) + sd * e)
                    .collect(),
            ),
            "uc2" => Some(
                time.iter()
                    .map(|t| if *t < t_step { uc_before } else { uc_after })
                    .collect(),
            ),
            _ => None,
        })
        .expect("series");
        let bench = Bench::new(&series);
        let seg = Segment {
            start: 2_550,
            end: 2_800,
            fold: 0,
        };
        let starts: Vec<f64> = (0..=80)
            .map(|i| {
                let tried = Params {
                    delay2: 2.5e-4 * i as f64,
                    ..params.clone()
                };
                bench.pump(&tried, Pump::Aux, seg)[0]
            })
            .collect();
        let jump = starts
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        let spread = starts.iter().fold(f64::MIN, |a, &b| a.max(b))
            - starts.iter().fold(f64::MAX, |a, &b| a.min(b));
        let weight = bench.read_in_weight(Pump::Aux, seg.start);
        assert!(
            jump < 0.2 * sd && spread > 0.5 * sd && weight > Some(0.9),
            "largest jump {jump:.2e}, spread {spread:.2e} m^3/s, weight {weight:?}"
        );
    }

    /// The read-in's weight is the recording's: over a steady flow under white noise it
    /// stays near one (the curvature's square averages one standard error), and half a
    /// second into a start-up ramp (the flow rising by ten times the noise over that half
    /// second) it falls near zero; no parameter enters it (`Bench::read_in_weight` takes
    /// none), so no candidate moves it.
    #[test]
    fn a_read_in_weighs_by_the_recorded_flow_alone() {
        let (n, dt, sd) = (3_000, 0.01, 1e-6);
        let noise = seeded(5).coloured(n, 0.0);
        let time: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let ramp_at = 2_000;
        let series = Series::from_columns(&time, |c| match c {
            "p" => Some(vec![4e6; n]),
            "x" => Some(vec![0.1; n]),
            "Q1" => Some(
                (0..n)
                    .map(|k| 5e-6 + k.saturating_sub(ramp_at) as f64 * 0.2 * sd + sd * noise[k])
                    .collect(),
            ),
            "Q2" => Some(vec![0.0; n]),
            _ => None,
        })
        .expect("series");
        let bench = Bench::new(&series);
        let weight = |start: usize| bench.read_in_weight(Pump::Main, start).expect("noisy");
        let steady: Vec<f64> = (100..ramp_at).step_by(25).map(weight).collect();
        let mean = steady.iter().sum::<f64>() / steady.len() as f64;
        let ramp = weight(ramp_at + 50);
        assert!(
            mean > 0.8 && ramp < 0.05 && bench.read_in_weight(Pump::Main, 99).is_none(),
            "steady mean weight {mean:.2}, 0.5 s into the ramp {ramp:.3}"
        );
        assert!(
            bench.read_in_weight(Pump::Aux, 500).is_none(),
            "an idle pump's zeros"
        );
    }

    /// A slow main pump (the model's 2.25 1/s) delivering a steady 0.3 L/min, logged at
    /// 100 Hz under 0.06 L/min of white flow noise, each 0.25 s segment replayed from its
    /// start: read in over the last second, the start is about 0.32 of the noise's standard
    /// deviation off the true flow (the read-in's own noisy start decays through it, and
    /// where the noise bends the recorded flow the last samples' value weighs in); from the
    /// last five samples (the quadratic a kink asks for) it would be about 0.94.
    #[test]
    fn a_steady_pump_segment_starts_from_its_read_in_not_from_its_last_samples() {
        let (n, dt) = (6_000, 0.01);
        let params = Params::default();
        let pp = PumpParams::of(&params, Pump::Main);
        let (q0, sd, p0) = (5e-6, 1e-6, 4e6);
        let uc = (pp.a * q0 + pp.k_p * p0) / pp.k_u;
        let noise = seeded(7).coloured(n, 0.0);
        let time: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let series = Series::from_columns(&time, |c| match c {
            "p" => Some(vec![p0; n]),
            "x" => Some(vec![0.1; n]),
            "Q1" => Some(noise.iter().map(|e| q0 + sd * e).collect()),
            "Q2" => Some(vec![0.0; n]),
            "uc1" => Some(vec![uc; n]),
            _ => None,
        })
        .expect("series");
        let bench = Bench::new(&series);
        let rms = |errors: Vec<f64>| {
            (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt()
        };
        let starts: Vec<f64> = (4..n / 25)
            .map(|i| {
                let seg = Segment {
                    start: 25 * i,
                    end: 25 * i + 25,
                    fold: i % 2,
                };
                bench.pump(&params, Pump::Main, seg)[0] - q0
            })
            .collect();
        let last_samples: Vec<f64> = (4..n / 25).map(|i| bench.init[25 * i][3] - q0).collect();
        let (read_in, last) = (rms(starts), rms(last_samples));
        assert!(
            read_in < 0.5 * sd && last > 0.8 * sd,
            "read in {read_in:.2e}, last samples {last:.2e} m^3/s"
        );
    }
}
