//! `tbm-thrust generate --out DIR [--seed N] [--effect ID[,ID]] [--scenario NAME] [--scheme S]
//! [--controller C] [--substeps N] [--jitter S] [--vary] [--rate HZ]`:
//! a synthetic bench recording with zero, one or two concealed effects. Writes
//! `DIR/recording.csv` (the contract's format; nothing in it reveals the effects),
//! `DIR/truth.json` (effects and their parameters, mismatched nominal unknowns, sensors) and
//! `DIR/truth_params.toml` (the plant that produced it, loadable by `--params`).

use std::path::PathBuf;
use tbm_bench::diagnose::effect::Effect;
use tbm_bench::synth::{generate, BenchScenario, Case, Variation};
use tbm_thrust::{Controller, Scheme};

#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Output directory (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Seed of the case: speeds, loads, nominal mismatch, effect magnitudes, sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Concealed effects, comma separated contract IDs; pump effects take `:1` or `:2`
    /// (default pump 1), e.g. `stribeck_friction,pump_dead_time:2`. Omit for none.
    #[arg(long, value_delimiter = ',')]
    effect: Vec<String>,
    /// Bench programme: startup | start_stop | speed_steps | load_steps | mixed.
    #[arg(long, default_value = "mixed")]
    scenario: String,
    /// Pump scheme: single | fixed_split | adaptive.
    #[arg(long, default_value = "adaptive")]
    scheme: String,
    /// Inner flow-loop controller of the bench: pid | adrc.
    #[arg(long, default_value = "pid")]
    controller: String,
    /// Plant solver sub-steps per 1 ms controller period (the bench's numerics).
    #[arg(long, default_value_t = tbm_thrust::simulation::DEFAULT_SUBSTEPS)]
    substeps: u32,
    /// Logger time-stamp jitter, uniform within +-S seconds (below half a sample).
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    jitter: f64,
    /// Draw the bench from wide ranges, from the seed: logger rate 50-1000 Hz and clock
    /// offset, sensor noise 0.5-3x, optional columns absent, P/PI/PID flow loops, pump sizes
    /// and time constants, weak or strong effects, both relief regimes (as every case of the
    /// evaluation sets); truth.json says what was drawn.
    #[arg(long)]
    vary: bool,
    /// Logger rate [Hz], 20-2000 (default: 100 Hz, or the drawn bench's with --vary).
    #[arg(long, value_name = "HZ")]
    rate: Option<f64>,
}

/// Logger rates `--rate` accepts [Hz]: those `diagnose` is built for.
const RATES: std::ops::RangeInclusive<f64> = 20.0..=2000.0;

/// Most solver sub-steps per 1 ms controller period (0.05 ms steps): finer steps change
/// nothing the 100 Hz recording resolves and only cost time.
pub const MAX_SUBSTEPS: u32 = 20;

pub fn run(args: Args) -> Result<(), String> {
    if !(1..=MAX_SUBSTEPS).contains(&args.substeps) {
        return Err(format!(
            "--substeps {}: must be in 1..={MAX_SUBSTEPS} (sub-steps of the 1 ms controller period)",
            args.substeps
        ));
    }
    if !(args.jitter.is_finite() && args.jitter >= 0.0) {
        return Err(format!(
            "--jitter {}: must be a finite number of seconds >= 0",
            args.jitter
        ));
    }
    if let Some(hz) = args.rate.filter(|hz| !RATES.contains(hz)) {
        return Err(format!(
            "--rate {hz}: must be a logger rate in {}-{} Hz",
            RATES.start(),
            RATES.end()
        ));
    }
    let case = case(&args)?;
    crate::output::check(&[], &[], &[("--out", &args.out)])?;
    let synthesis = generate(&case).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let write = |name: &str, text: &str| crate::output::write_atomic(&args.out.join(name), text);
    write("recording.csv", &synthesis.csv)?;
    let truth = serde_json::to_string_pretty(&synthesis.truth).map_err(|e| e.to_string())?;
    write("truth.json", &truth)?;
    write("truth_params.toml", &synthesis.params_toml)?;
    let names: Vec<&str> = case.effects.iter().map(|e| e.id()).collect();
    outln!(
        "wrote {}/recording.csv ({} scenario, {} scheme, {} concealed effect(s), {:.0} Hz{}) and truth.json",
        args.out.display(),
        case.scenario.name(),
        case.scheme.name(),
        names.len(),
        1.0 / case.sample_period,
        case.variation.as_ref().map_or(String::new(), drawn)
    );
    Ok(())
}

fn case(args: &Args) -> Result<Case, String> {
    let scenario = BenchScenario::parse(&args.scenario).ok_or_else(|| {
        format!(
            "unknown scenario `{}`: use one of {}",
            args.scenario,
            BenchScenario::NAMES.join(" | ")
        )
    })?;
    let scheme = Scheme::from_name(&args.scheme).ok_or_else(|| {
        format!(
            "unknown scheme `{}`: use one of {}",
            args.scheme,
            Scheme::NAMES.join(" | ")
        )
    })?;
    let effects = args
        .effect
        .iter()
        .filter(|e| !e.is_empty() && e.as_str() != "none")
        .map(|e| {
            Effect::parse(e).ok_or_else(|| {
                format!("unknown effect `{e}` (contract IDs, pump effects with :1 or :2)")
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let controller = Controller::from_name(&args.controller).ok_or_else(|| {
        format!(
            "unknown controller `{}`: use one of {}",
            args.controller,
            Controller::NAMES.join(" | ")
        )
    })?;
    let case = Case {
        controller,
        substeps: args.substeps,
        jitter: args.jitter,
        ..Case::new(scenario, scheme, effects, args.seed)
    };
    let case = if args.vary {
        case.on_a_drawn_bench()
    } else {
        case
    };
    Ok(Case {
        sample_period: args.rate.map_or(case.sample_period, |hz| 1.0 / hz),
        ..case
    })
}

/// A drawn bench in a few words: its flow loops, sensor noise and absent columns.
fn drawn(v: &Variation) -> String {
    let absent = if v.absent.is_empty() {
        String::new()
    } else {
        format!(", without {}", v.absent.join(" "))
    };
    format!(
        ", a drawn bench: {} flow loops, sensor noise x{:.2}{absent}",
        v.family, v.noise_scale
    )
}
