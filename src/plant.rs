//! The assembled plant, Eq. (12): states x, v, p, Q1, Q2, advanced by one fixed solver step.
//!
//! Within a step the friction mode (stuck, or sliding in a frozen direction) is fixed, so the
//! right-hand side is smooth and classic RK4 applies; mode changes are decided between steps
//! (breakaway when the drive exceeds static friction, sticking when the velocity would cross
//! zero), except that a velocity crossing zero inside a step is followed to the crossing
//! and the rest of the step taken in the new mode. This is the stick model: no chattering at
//! v = 0. See ARCHITECTURE.md, "Numerics".

use crate::chamber;
use crate::cylinder::{self, Motion};
use crate::ode;
use crate::pump::PumpParams;
use crate::variables::Params;

/// The plant's continuous state plus its friction mode.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlantState {
    /// Displacement [m].
    pub x: f64,
    /// Velocity [m/s].
    pub v: f64,
    /// Working-chamber gauge pressure [Pa].
    pub p: f64,
    /// Pump flows before ripple, main and auxiliary [m^3/s].
    pub q: [f64; 2],
    pub motion: Motion,
}

/// What acts on the plant during one solver step.
#[derive(Clone, Copy, Debug)]
pub struct Drive {
    /// Drive commands reaching the two motors (after saturation and dead time) [V].
    pub uc: [f64; 2],
    /// External load [N].
    pub f_load: f64,
}

type Y = [f64; 5];

impl PlantState {
    /// Piston at rest at x = 0 holding the load F_L: the chamber is pre-pressurised to
    /// F_L / A + p_t (as on the bench, where the cylinder is in contact with the load before
    /// each run), both pumps stopped.
    pub fn at_rest(p: &Params, f_load: f64) -> Self {
        PlantState {
            x: 0.0,
            v: 0.0,
            p: (f_load / p.A + p.p_t).max(0.0),
            q: [0.0, 0.0],
            motion: Motion::Stuck,
        }
    }

    /// Flows delivered into the chamber at time t (with ripple) [m^3/s].
    pub fn delivered(&self, pumps: &[PumpParams; 2], t: f64) -> [f64; 2] {
        [
            pumps[0].delivered(self.q[0], t),
            pumps[1].delivered(self.q[1], t),
        ]
    }

    /// Friction force acting against the motion [N]. Sliding: Eq. (1)'s friction with the
    /// effect terms. At rest: the static friction that balances the drive
    /// A (p - p_t) - F_L - k_load x; at an end stop it holds at most the breakaway force and
    /// the stop takes the rest ([`PlantState::stop_reaction`]).
    pub fn friction(&self, p: &Params, f_load: f64) -> f64 {
        match self.motion {
            Motion::Sliding(d) => cylinder::friction(p, d as f64, self.v, self.p),
            Motion::Stuck => self.at_rest_forces(p, f_load).0,
        }
    }

    /// Reaction of an end stop on the piston [N], counted like the friction (positive
    /// against extension): the part of the drive A (p - p_t) - F_L - k_load x beyond the
    /// breakaway friction that a stop takes, negative at the retracted stop x = 0, positive
    /// at x = x_max, 0 away from the stops and while sliding.
    pub fn stop_reaction(&self, p: &Params, f_load: f64) -> f64 {
        match self.motion {
            Motion::Sliding(_) => 0.0,
            Motion::Stuck => self.at_rest_forces(p, f_load).1,
        }
    }

    /// (static friction, end-stop reaction) of a piston at rest; their sum is the drive.
    fn at_rest_forces(&self, p: &Params, f_load: f64) -> (f64, f64) {
        let drive = cylinder::hydraulic_force(p, self.p) - cylinder::load_force(p, f_load, self.x);
        let holding = cylinder::dry_friction(p, 0.0, self.p);
        let pressed = (self.x <= 0.0 && drive < -holding) || (self.x >= p.x_max && drive > holding);
        if pressed {
            let friction = drive.clamp(-holding, holding);
            (friction, drive - friction)
        } else {
            (drive, 0.0)
        }
    }

    /// Advances the state by one solver step h [s] starting at time t.
    pub fn step(&mut self, p: &Params, pumps: &[PumpParams; 2], drive: &Drive, t: f64, h: f64) {
        self.advance(p, pumps, drive, t, h, true);
    }

    /// [`PlantState::step`]; with `locate`, a velocity that crosses zero within the step is
    /// followed to the crossing (linear in v between the step's ends), where the piston
    /// sticks and the rest of the step is taken in the mode the forces there decide
    /// (breakaway in either direction, or stuck). Without it the mode would change only at
    /// the step's end, and the reversal of a bouncing piston would lose up to a step's worth
    /// of velocity (the net force over the mass times h): a loss that depends on the step.
    fn advance(
        &mut self,
        p: &Params,
        pumps: &[PumpParams; 2],
        drive: &Drive,
        t: f64,
        h: f64,
        locate: bool,
    ) {
        if self.motion == Motion::Stuck {
            if let Some(dir) = cylinder::breakaway(p, self.x, self.p, drive.f_load) {
                self.motion = Motion::Sliding(dir);
            }
        }
        let dir = match self.motion {
            Motion::Stuck => None,
            Motion::Sliding(d) => Some(d as f64),
        };
        let y0 = [self.x, self.v, self.p, self.q[0], self.q[1]];
        let y = integrate(p, pumps, drive, dir, t, &y0, h);
        let reversal = dir.is_some_and(|d| locate && y[1] * d < 0.0 && y0[1] * d > 0.0);
        if reversal {
            let theta = y0[1] / (y0[1] - y[1]);
            let crossing = integrate(p, pumps, drive, dir, t, &y0, theta * h);
            self.take(&crossing);
            self.v = 0.0;
            self.x = self.x.clamp(0.0, p.x_max);
            self.motion = Motion::Stuck;
            self.advance(p, pumps, drive, t + theta * h, (1.0 - theta) * h, false);
            return;
        }
        self.take(&y);
        self.settle(p, dir);
    }

    /// The state at the end of an integration: the pressure at or above its vapour floor,
    /// the pump flows at or above zero.
    fn take(&mut self, y: &Y) {
        self.x = y[0];
        self.v = y[1];
        // `max(P_MIN)` as a branch: the same values (NaN too gives P_MIN), and the pressure
        // reaches the next step without the latency of `maxsd`.
        self.p = if y[2] >= chamber::P_MIN {
            y[2]
        } else {
            chamber::P_MIN
        };
        self.q = [y[3].max(0.0), y[4].max(0.0)];
    }

    /// Sticks the piston when its velocity crosses zero or it reaches an end stop.
    fn settle(&mut self, p: &Params, dir: Option<f64>) {
        let Some(d) = dir else { return };
        let at_stop = (self.x <= 0.0 && d < 0.0) || (self.x >= p.x_max && d > 0.0);
        if self.v * d <= 0.0 || at_stop {
            self.v = 0.0;
            self.x = self.x.clamp(0.0, p.x_max);
            self.motion = Motion::Stuck;
        }
    }
}

/// One RK4 step of h [s] from y0 at time t in the friction mode `dir` (stuck: `None`): one
/// RK4 instance per friction mode and terms, each with its right-hand side inlined and
/// specialised.
fn integrate(
    p: &Params,
    pumps: &[PumpParams; 2],
    drive: &Drive,
    dir: Option<f64>,
    t: f64,
    y0: &Y,
    h: f64,
) -> Y {
    let frozen = |dir, terms| Frozen {
        p,
        pumps,
        drive,
        dir,
        terms,
    };
    match (dir, Terms::of(p, pumps)) {
        (None, Terms::Plain) => ode::rk4(&frozen(None, Terms::Plain), t, y0, h),
        (None, Terms::Effects) => ode::rk4(&frozen(None, Terms::Effects), t, y0, h),
        (Some(d), Terms::Plain) => ode::rk4(&frozen(Some(d), Terms::Plain), t, y0, h),
        (Some(d), Terms::Effects) => ode::rk4(&frozen(Some(d), Terms::Effects), t, y0, h),
    }
}

/// Solver steps over an interval `dt` [s] that keep classic RK4 inside its stability region
/// (|lambda h| <= 2) for the stiffest mode of Eq. (1)-(4): viscous damping b/m, the
/// oil-column frequency sqrt(beta_e A^2 / (V0 m)), and pressure relaxation through leakage
/// and relief beta_e/V0 (C_ip + K_relief). `pump_rates` [1/s] adds the pumps' a_i when the
/// pumps are integrated too.
pub fn stable_substeps(p: &Params, dt: f64, pump_rates: &[f64]) -> usize {
    let damping = p.b / p.m;
    let column = (p.beta_e * p.A * p.A / (p.V0 * p.m)).sqrt();
    let relaxation = p.beta_e / p.V0 * (p.C_ip + p.K_relief);
    let fastest = pump_rates
        .iter()
        .fold(damping.max(column).max(relaxation), |a, &r| a.max(r));
    ((dt * fastest / 2.0).ceil() as usize).max(1)
}

/// Which terms a right-hand side evaluates. The effect terms that call transcendental
/// functions (Stribeck hump, entrained air, flow ripple) cost the solver's hot path its
/// registers even when off, and the pressure-dependent friction puts the pressure on the
/// path to the acceleration; a step whose parameters switch all four off evaluates the
/// `Plain` instance, which gives the same numbers to the bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Terms {
    /// Every term the parameters switch on.
    Effects,
    /// The caller knows that the Stribeck, pressure-friction, air and ripple terms are off.
    Plain,
}

impl Terms {
    /// `Plain` when the parameters switch the Stribeck, pressure-friction (mu = 0), air and
    /// ripple terms off (the conditions under which `cylinder`, `chamber` and `pump` skip
    /// them), else `Effects`.
    pub fn of(p: &Params, pumps: &[PumpParams; 2]) -> Terms {
        let stribeck = p.F_s - p.F_c > 0.0;
        let no_air = p.air_fraction <= 0.0;
        let ripple = pumps.iter().any(|pp| pp.ripple.0 != 0.0);
        if no_air && !stribeck && !ripple && p.mu == 0.0 {
            Terms::Plain
        } else {
            Terms::Effects
        }
    }
}

/// Eq. (12) over one solver step: parameters, drive, friction mode and terms held.
struct Frozen<'a> {
    p: &'a Params,
    pumps: &'a [PumpParams; 2],
    drive: &'a Drive,
    dir: Option<f64>,
    terms: Terms,
}

impl ode::Rates<Y> for Frozen<'_> {
    #[inline(always)]
    fn rates(&self, t: f64, y: &Y) -> Y {
        rhs(self, t, y)
    }
}

/// Right-hand side of Eq. (12) for a frozen friction mode.
#[inline(always)]
fn rhs(f: &Frozen, t: f64, y: &Y) -> Y {
    let (p, pumps, drive, dir, terms) = (f.p, f.pumps, f.drive, f.dir, f.terms);
    let [x, v, pressure, q1, q2] = *y;
    let (dx, dv) = match dir {
        None => (0.0, 0.0),
        Some(d) => (
            v,
            cylinder::acceleration_with(p, d, x, v, pressure, drive.f_load, terms),
        ),
    };
    let inflow = pumps[0].delivered_with(q1, t, terms) + pumps[1].delivered_with(q2, t, terms);
    let moving = if dir.is_some() { v } else { 0.0 };
    let dp = chamber::pressure_rate_with(p, pressure, x, moving, inflow, terms);
    let dq1 = pumps[0].flow_rate(q1, drive.uc[0], pressure);
    let dq2 = pumps[1].flow_rate(q2, drive.uc[1], pressure);
    [dx, dv, dp, dq1, dq2]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pumps(p: &Params) -> [PumpParams; 2] {
        PumpParams::both(p)
    }

    /// Chamber pressure [Pa] every 2 ms over 0.3 s after a load drop of `drop` [N] under a
    /// piston sliding at 50 mm/s with 14.4 kN (pumps delivering a constant flow), the piston
    /// overshooting and bouncing back, in steps of h; `locate` as in
    /// [`PlantState::advance`].
    fn after_load_drop(drop: f64, h: f64, locate: bool) -> Vec<f64> {
        let p = Params::default();
        let idle = PumpParams {
            a: 0.0,
            k_u: 0.0,
            k_p: 0.0,
            ..pumps(&p)[0]
        };
        let before = 14_400.0;
        let mut s = PlantState {
            x: 0.2,
            v: 0.05,
            p: (before + p.F_c + p.b * 0.05) / p.A,
            q: [p.A * 0.05, 0.0],
            motion: Motion::Sliding(1),
        };
        let drive = Drive {
            uc: [0.0; 2],
            f_load: before - drop,
        };
        let per_sample = (2e-3 / h).round() as usize;
        let mut out = Vec::new();
        for k in 0..150 * per_sample {
            s.advance(&p, &[idle, idle], &drive, k as f64 * h, h, locate);
            if (k + 1) % per_sample == 0 {
                out.push(s.p);
            }
        }
        out
    }

    /// Largest difference of two pressure traces [Pa].
    fn largest_gap(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_bouncing_piston_follows_its_fine_step_trace() {
        // A 4.4 kN load drop: the piston overshoots and reverses 16 ms later, the chamber
        // staying above its vapour floor. At 2 ms steps (a 500 Hz recording's replay) the
        // pressure stays within 3.1 kPa of the trace at 1/16 of the step when the reversal
        // is located, and strays by 41 kPa when the mode changes at the step's end only.
        let fine = after_load_drop(4_400.0, 1.25e-4, true);
        let located = largest_gap(&after_load_drop(4_400.0, 2e-3, true), &fine);
        let at_step_ends = largest_gap(&after_load_drop(4_400.0, 2e-3, false), &fine);
        assert!(located < 5e3, "crossing located: {located:.0} Pa off");
        assert!(
            at_step_ends > 20e3,
            "mode changed at the step's end: {at_step_ends:.0} Pa off"
        );
    }

    #[test]
    fn end_stop_takes_the_drive_beyond_breakaway_friction() {
        let p = Params::default();
        let f_load = 12_000.0;
        // At the retracted stop with the chamber leaked down: drive -9.6 kN.
        let mut s = PlantState::at_rest(&p, f_load);
        s.p = (f_load - 9_600.0) / p.A + p.p_t;
        let (friction, stop) = (s.friction(&p, f_load), s.stop_reaction(&p, f_load));
        assert!((friction + p.F_c).abs() < 1e-9, "friction {friction} N");
        assert!((stop + 9_100.0).abs() < 1e-6, "stop {stop} N");
        // Off the stops a piston at rest is held by friction alone.
        s.x = 0.3;
        s.p = (f_load - 300.0) / p.A + p.p_t;
        assert!((s.friction(&p, f_load) + 300.0).abs() < 1e-6);
        assert_eq!(s.stop_reaction(&p, f_load), 0.0);
        // At the extended stop, pushing outwards.
        s.x = p.x_max;
        s.p = (f_load + 2_000.0) / p.A + p.p_t;
        assert!((s.friction(&p, f_load) - p.F_c).abs() < 1e-9);
        assert!((s.stop_reaction(&p, f_load) - (2_000.0 - p.F_c)).abs() < 1e-6);
        // Sliding: no stop reaction.
        s.motion = Motion::Sliding(1);
        assert_eq!(s.stop_reaction(&p, f_load), 0.0);
    }

    #[test]
    fn plain_terms_only_when_every_called_effect_is_off() {
        let p = Params::default();
        assert_eq!(Terms::of(&p, &pumps(&p)), Terms::Plain);
        for q in [
            Params {
                F_s: 600.0,
                ..p.clone()
            },
            Params {
                mu: 0.02,
                ..p.clone()
            },
            Params {
                air_fraction: 0.01,
                ..p.clone()
            },
            Params {
                ripple_amp2: 0.01,
                ..p.clone()
            },
        ] {
            assert_eq!(Terms::of(&q, &pumps(&q)), Terms::Effects);
        }
    }

    #[test]
    fn stuck_piston_stays_exactly_at_rest() {
        let p = Params::default();
        let mut s = PlantState::at_rest(&p, 12_000.0);
        let drive = Drive {
            uc: [0.0, 0.0],
            f_load: 12_000.0,
        };
        for k in 0..10_000 {
            s.step(&p, &pumps(&p), &drive, k as f64 * 1e-4, 1e-4);
            assert_eq!((s.x, s.v, s.motion), (0.0, 0.0, Motion::Stuck));
        }
    }

    #[test]
    fn constant_flow_reaches_the_steady_velocity_without_chatter() {
        // A steady pump flow Q drives the piston at v = (Q - C_ip p)/A (Eq. 4 at dp/dt = 0),
        // and the pressure settles where Eq. (1) balances.
        let p = Params {
            a1: 50.0,
            ..Params::default()
        };
        let pp = pumps(&p);
        let f_load = 12_000.0;
        let p_ss = (f_load + p.F_c + p.b * 0.05) / p.A;
        let uc = (pp[0].a * (p.A * 0.05 + p.C_ip * p_ss) + pp[0].k_p * p_ss) / pp[0].k_u;
        let drive = Drive {
            uc: [uc, 0.0],
            f_load,
        };
        let mut s = PlantState::at_rest(&p, f_load);
        let h = 2.5e-4;
        for k in 0..(20.0 / h) as usize {
            s.step(&p, &pp, &drive, k as f64 * h, h);
        }
        assert!((s.v - 0.05).abs() < 1e-6, "v = {}", s.v);
        assert!((s.p - p_ss).abs() < 1.0, "p = {}", s.p);
        assert_eq!(s.motion, Motion::Sliding(1));
    }

    #[test]
    fn piston_sticks_when_flow_stops() {
        let p = Params::default();
        let pp = pumps(&p);
        let mut s = PlantState {
            v: 0.02,
            p: 12_000.0 / p.A,
            motion: Motion::Sliding(1),
            ..PlantState::at_rest(&p, 12_000.0)
        };
        s.x = 0.1;
        let drive = Drive {
            uc: [0.0, 0.0],
            f_load: 12_000.0,
        };
        let mut stuck_at = None;
        // 0.2 s: later, leakage lets the load push the piston back (physical creep).
        for k in 0..2_000 {
            s.step(&p, &pp, &drive, k as f64 * 1e-4, 1e-4);
            if s.motion == Motion::Stuck && stuck_at.is_none() {
                stuck_at = Some(k);
            }
            if let Some(k0) = stuck_at {
                assert_eq!(s.v, 0.0, "no chatter after sticking at step {k0}");
            }
        }
        assert!(stuck_at.is_some());
    }
}
