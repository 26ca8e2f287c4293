//! The evidence for a named effect in plain words: its signature in engineering units,
//! and the held-out test it passed.

use super::effect::Effect;
use super::model::Split;
use super::replay::Bench;
use super::search::Trial;
use crate::numerics::stats::quantile;
use tbm_thrust::chamber;
use tbm_thrust::units::LPM;
use tbm_thrust::variables::Params;

/// One sentence on what the effect does in this recording, one on how it was validated.
pub fn evidence(
    effect: Effect,
    p: &Params,
    bench: &Bench,
    trial: &Trial,
    signal: &str,
    drop: f64,
    regime: &str,
) -> String {
    let validation = validation(effect, bench, trial, signal, drop);
    format!(
        "{} Seen in: {regime}. {validation}",
        signature(effect, p, bench)
    )
}

fn signature(effect: Effect, p: &Params, bench: &Bench) -> String {
    let pr = bench.s.col("p");
    let (p_lo, p_hi) = {
        let moving = bench.moving_pressures();
        (quantile(&moving, 0.05), quantile(&moving, 0.95))
    };
    let lpm = LPM;
    match effect {
        Effect::StribeckFriction => format!(
            "Friction at breakaway is {:.0} N above the Coulomb level and fades above {:.1} mm/s: the pressure peaks before the piston moves and the piston sticks and slips at low speed.",
            p.F_s - p.F_c,
            p.v_s * 1e3
        ),
        Effect::PressureDependentFriction => {
            let mean = pr.iter().sum::<f64>() / pr.len() as f64;
            format!(
                "Friction grows with chamber pressure: {:.0} N more at the mean {:.2} MPa, {:.0} N at {:.2} MPa; the force residual follows A p, not the load alone.",
                p.mu * p.A * mean,
                mean / 1e6,
                p.mu * p.A * p_hi,
                p_hi / 1e6
            )
        }
        Effect::PositionDependentLoad => {
            let x = bench.s.col("x");
            let travel = crate::numerics::stats::span(x);
            format!(
                "The load grows with stroke by {:.0} N/m ({:.0} N over the {:.3} m travelled): the pressure ramps with displacement at constant speed.",
                p.k_load,
                p.k_load * travel,
                travel
            )
        }
        Effect::EntrainedAir => format!(
            "The oil is softer at low pressure: effective bulk modulus {:.2} GPa at {:.2} MPa but {:.2} GPa at {:.2} MPa (one constant beta_e cannot fit both), so pressure builds slowly after unloading.",
            chamber::bulk_modulus(p, p_lo) / 1e9,
            p_lo / 1e6,
            chamber::bulk_modulus(p, p_hi) / 1e9,
            p_hi / 1e6
        ),
        Effect::ReliefLeakage => format!(
            "Flow goes missing above {:.2} MPa: {:.2} L/min leaves the chamber at {:.2} MPa, none below the cracking pressure, so the piston lags its pump flow at high load.",
            p.p_crack / 1e6,
            chamber::relief_flow(p, p_hi) * lpm,
            p_hi / 1e6
        ),
        Effect::PumpDeadTime(i) => {
            let delay = p.get(effect.model_parameters()[0]).unwrap_or(0.0);
            format!(
                "Q{i} answers its drive command uc{i} {:.1} ms late ({:.1} samples at the logger's {:.0} Hz): the flow stays put after each command change before it starts to move.",
                delay * 1e3,
                delay / bench.s.dt,
                1.0 / bench.s.dt
            )
        }
        Effect::PumpFlowLimit(i) => format!(
            "Pump {i}'s flow changes no faster than {:.0} L/min per second: it ramps where the first-order pump model would jump.",
            p.get(effect.model_parameters()[0]).unwrap_or(0.0) * lpm
        ),
        Effect::FlowRipple(i) => {
            let n = effect.model_parameters();
            format!(
                "Pump {i}'s flow carries a {:.2} Hz tone of {:.1} % of the flow (as sampled at {:.0} Hz; a tone above {:.0} Hz appears folded).",
                p.get(n[1]).unwrap_or(0.0),
                100.0 * p.get(n[0]).unwrap_or(0.0),
                1.0 / bench.s.dt,
                0.5 / bench.s.dt
            )
        }
    }
}

fn validation(effect: Effect, bench: &Bench, t: &Trial, signal: &str, drop: f64) -> String {
    let key = effect.model_parameters()[0];
    let halves = [t.fit.folds[0].get(key), t.fit.folds[1].get(key)];
    let what = if matches!(signal, "x" | "p") {
        "level and oscillation amplitude"
    } else {
        "samples"
    };
    let held_out = match t.fit.split {
        Split::Blocked => "On the half of the recording not used to fit".to_string(),
        Split::Interleaved => format!(
            "Its evidence lies in one half of the recording (a single event, or a regime the other half lacks), so it was tested on every other sample (the samples not used to fit, interleaved within each replay segment), where the error stood at {:.1} times its floor (at least {} required)",
            t.excess.multiple,
            super::floor::FLOOR_MULTIPLE
        ),
    };
    format!(
        "{held_out}, adding it cuts the squared free-run error of {signal} ({what}) by {:.1} %; that drop is {:.1} standard deviations of chance (autocorrelation counted), it removes {:.1} % of the error where it acts, and the fits on the two halves agree ({key} = {} / {}).{}",
        100.0 * drop,
        t.comparison.z,
        100.0 * super::search::explained(&t.comparison, t.excess),
        fmt_si(halves[0]),
        fmt_si(halves[1]),
        tone_sentence(effect, bench, t)
    )
}

/// For a ripple whose halves found the same tone (`plausible::replicated_tone`), the
/// sentence that says so; nothing otherwise.
fn tone_sentence(effect: Effect, bench: &Bench, t: &Trial) -> String {
    use super::plausible::{replicated_tone, ripple_frequencies};
    let Some(f) =
        ripple_frequencies(effect, &t.fit).filter(|_| replicated_tone(effect, bench, &t.fit))
    else {
        return String::new();
    };
    format!(
        " Each half's own tone search found it, at {:.4} and {:.4} Hz, within the recording's resolution of {:.4} Hz, which two noise peaks seldom do.",
        f[0],
        f[1],
        super::plausible::tone_resolution(bench)
    )
}

/// A number in compact scientific form.
pub fn fmt_si(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-2 || v.abs() >= 1e5) {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}
