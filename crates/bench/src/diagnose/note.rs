//! What the diagnosis could not check, or handled on the way, as typed notes: code decides on
//! the variant, the report prints the sentence.

use super::effect::Effect;
use std::fmt;
use tbm_thrust::pump::Pump;

/// One note of the diagnosis (units in the fields' names).
#[derive(Clone, Debug, PartialEq)]
pub enum Note {
    /// A note of the recording reader or its data-quality screen.
    Reader(crate::recording::Note),
    /// Stamps that jitter around a uniform grid were taken on the grid.
    Jitter { deviation_s: f64, step_s: f64 },
    /// Uneven sampling, resampled linearly at the median step.
    Resampled { step_s: f64 },
    /// A pump whose flow stays below `share` of the peak flow: not tested.
    PumpIdle { pump: Pump, share: f64 },
    /// A pump without its drive command and commanded flow columns: only its ripple tested.
    NoDriveCommand { pump: Pump },
    /// A pump without its drive command column, replayed from its commanded flow through a
    /// reconstructed flow loop.
    FlowLoopDrive { pump: Pump },
    /// A drive command that jumps by more than a quarter of its range between `share` of
    /// successive samples: the pump cannot be replayed from it; only its ripple tested.
    ChatteringCommand { pump: Pump, share: f64 },
    /// A pump whose refitted time constant is shorter than the logger's sample period: its
    /// flow follows the drive command between samples, which the recording does not show;
    /// replayed from its own flow, only its ripple tested.
    FasterThanTheLogger {
        pump: Pump,
        time_constant_s: f64,
        period_s: f64,
    },
    /// No `F_L` column: a constant load is fitted.
    ConstantLoad,
    /// A pump without effects judged on interleaved samples: on blocked folds its flow's
    /// held-out error stood above the floor multiple, interleaved within it.
    SingleEvent { pump: Pump },
    /// A friction effect named on a recording whose piston slides at one pressure (the
    /// sliding pressures' 5-95 % span `span_pa`): there the two friction effects stand in
    /// for each other.
    FrictionAtOneLoad { effect: Effect, span_pa: f64 },
    /// A part's refit that stopped in a local minimum, moved to a lower one found from a
    /// candidate's fit with the candidate switched off: a pump's, or (`None`) the
    /// hydromechanics'.
    Restarted { pump: Option<Pump> },
    /// A held-out error above `ratio` times its reachable floor.
    AboveFloor {
        signal: &'static str,
        ratio: f64,
        explained: bool,
    },
}

impl fmt::Display for Note {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Note::Reader(text) => write!(f, "{text}"),
            Note::Jitter { deviation_s, step_s } => write!(
                f,
                "time stamps deviate by up to {:.2} ms from a uniform {:.2} ms grid (logger jitter): samples taken on the grid",
                deviation_s * 1e3,
                step_s * 1e3
            ),
            Note::Resampled { step_s } => write!(
                f,
                "uneven sampling resampled linearly at the median step {step_s:.4} s"
            ),
            Note::PumpIdle { pump, share } => write!(
                f,
                "pump {pump} is idle (Q{pump} stays below {:.0} % of the peak flow): its equation was not checked",
                100.0 * share
            ),
            Note::NoDriveCommand { pump } => write!(
                f,
                "no `uc{pump}` nor `u{pump}` column: pump {pump}'s equation (Eq. 8), dead time and flow limit were not checked; its ripple was tested as a tone on `Q{pump}` over the flow's running median (one period of the slowest plausible ripple wide), and `Q{pump}` is still used as the chamber's inflow, so the hydromechanics and the other pump are tested"
            ),
            Note::FlowLoopDrive { pump } => write!(
                f,
                "no `uc{pump}` column: pump {pump} is replayed from its commanded flow `u{pump}`, its drive command taken as the one a flow loop (the PID of section 3.3 or the ADRC of section 4.2, the family and gains fitted with the pump's unknowns) gives `u{pump}` and the recorded `Q{pump}`, from rest at the first sample; its effects (dead time, flow limit, ripple) are tested inside that loop"
            ),
            Note::ChatteringCommand { pump, share } => write!(
                f,
                "`uc{pump}` changes by more than a quarter of its range between {:.0} % of successive samples: the drive command varies faster than the recording resolves, so pump {pump} cannot be replayed from it; its equation (Eq. 8), dead time and flow limit were not checked, its ripple was tested as a tone on `Q{pump}` over the flow's running median, and `Q{pump}` is still used as the chamber's inflow, so the hydromechanics and the other pump are tested",
                100.0 * share
            ),
            Note::FasterThanTheLogger {
                pump,
                time_constant_s,
                period_s,
            } => write!(
                f,
                "pump {pump} answers faster than the logger samples (refitted time constant {:.1} ms against a {:.1} ms sample period): its flow at each sample follows the drive command's path between samples, which the recording does not show, so pump {pump} cannot be replayed from its command; its equation (Eq. 8), dead time and flow limit were not checked, its ripple was tested as a tone on `Q{pump}` over the flow's running median, and `Q{pump}` is still used as the chamber's inflow, so the hydromechanics and the other pump are tested",
                time_constant_s * 1e3,
                period_s * 1e3
            ),
            Note::ConstantLoad => write!(
                f,
                "no `F_L` column: the load is fitted as a constant with the nominal unknowns"
            ),
            Note::SingleEvent { pump } => write!(
                f,
                "pump {pump} is judged on interleaved samples: with whole segments held out, `Q{pump}`'s error stood above the floor multiple, with every event in both halves within it, so its nominal unknowns are seen in a single event (a start-up), which one half cannot learn from the other; its `fit_before` and `fit_after` are on interleaved samples"
            ),
            Note::FrictionAtOneLoad { effect, span_pa } => write!(
                f,
                "the piston slides at one pressure (5-95 % of the sliding pressures within {:.2} MPa): there a pressure-dependent friction `mu A p` is a constant friction offset, and a Stribeck hump with a refitted viscous term stands in for it (and the other way round); `{}` was told from the other friction effect only by the breakaways and speed ramps, not by a change of load",
                span_pa / 1e6,
                effect.id()
            ),
            Note::Restarted { pump } => write!(
                f,
                "the refit of {} had stopped in a local minimum: a candidate's fit, with the candidate switched off, reached a lower one of the same unknowns, and every candidate was tested again from there",
                match pump {
                    None => "the hydromechanics".to_string(),
                    Some(i) => format!("pump {i}"),
                }
            ),
            Note::AboveFloor {
                signal,
                ratio,
                explained: false,
            } => write!(
                f,
                "the held-out error of `{signal}` stands at {ratio:.1} times the floor a replay can reach on this recording (its sensor noise plus the recorded inputs' noise carried through the replay): physics is missing, but no contract effect passed the selection rule (every candidate tried is listed with its statistics); look for an unrecorded input or physics outside the contract's list"
            ),
            Note::AboveFloor {
                signal,
                ratio,
                explained: true,
            } => write!(
                f,
                "with the effects found, the held-out error of `{signal}` still stands at {ratio:.1} times its reachable floor: part of the mismatch remains unexplained"
            ),
        }
    }
}
