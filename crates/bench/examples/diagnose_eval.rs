//! Scores `diagnose` on generated recordings drawn from wide bench ranges
//! (`synth::Variation`): every case draws its programme, scheme, controller, solver steps,
//! logger jitter, rate and offset, sensor noise, recorded columns, flow-loop family, pump
//! sizes and time constants, and zero, one or two concealed effects (two in different
//! subsystems) at weak to strong magnitudes.
//!
//! `cargo run --release --example diagnose_eval -- SET [N [SKIP]]` with SET `tune` (seeds from 1: the
//! set thresholds may be looked at with) or `frozen` (seeds from 900 001: generated the same way,
//! never used to pick a threshold; default N = 200). Prints one Markdown row per case (with
//! each concealed effect's oracle `z`, and in brackets the true model's `z` against the
//! nominal refit: `diagnose::oracle`), then the
//! per-effect confusion matrix, the false alarms on effect-free recordings, how often the
//! verdict was `adequate` with a held-out error above the floor multiple, and how many cases
//! right by their names failed the independent scorer's two other checks (the named effect's
//! held-out fit improves; the first mismatch lies in a true subsystem).

use std::collections::BTreeMap;
use std::time::Instant;
use tbm_bench::diagnose::effect::{Effect, ALL};
use tbm_bench::diagnose::oracle::{beyond_refit, detectability};
use tbm_bench::diagnose::refit::Refit;
use tbm_bench::diagnose::report::Diagnosis;
use tbm_bench::diagnose::search::RULE;
use tbm_bench::diagnose::{diagnose, prepare, refit, series::Series, FLOOR_MULTIPLE};
use tbm_bench::numerics::rng::{seeded, Draw, Rng};
use tbm_bench::progress::Silent;
use tbm_bench::recording::Recording;
use tbm_bench::synth::{generate, BenchScenario, Case, Synthesis, Variation};
use tbm_thrust::pump::Pump;
use tbm_thrust::{Controller, Params, Scheme};

/// The key parameter of an effect and whether an estimate is close enough (the tolerances
/// of `crates/cli/tests/diagnose.rs`).
fn key(effect: Effect) -> (&'static str, fn(f64, f64) -> bool) {
    let within30 = |est: f64, truth: f64| (est / truth - 1.0).abs() <= 0.3;
    match effect {
        Effect::StribeckFriction => ("F_s", within30),
        Effect::PressureDependentFriction => ("mu", within30),
        Effect::PositionDependentLoad => ("k", within30),
        Effect::EntrainedAir => ("air_fraction", |e, t| (e / t).max(t / e) <= 1.6),
        Effect::ReliefLeakage => ("p_crack", |e, t| (e - t).abs() <= 0.3e6),
        Effect::PumpDeadTime(_) => ("delay", within30),
        Effect::PumpFlowLimit(_) => ("rate_limit", within30),
        Effect::FlowRipple(_) => ("frequency", |e, t| (e / t - 1.0).abs() <= 0.05),
    }
}

const SCENARIOS: [BenchScenario; 5] = [
    BenchScenario::Startup,
    BenchScenario::StartStop,
    BenchScenario::SpeedSteps,
    BenchScenario::LoadSteps,
    BenchScenario::Mixed,
];

/// One case of a set, drawn from its seed.
fn draw(seed: u64) -> Case {
    let mut rng = seeded(seed ^ 0xE7A1);
    let pick = |rng: &mut Rng, n: usize| ((rng.unit() * n as f64) as usize).min(n - 1);
    let scenario = SCENARIOS[pick(&mut rng, 5)];
    let mut effects: Vec<Effect> = Vec::new();
    let count = [0, 0, 1, 1, 1, 1, 1, 2][pick(&mut rng, 8)];
    while effects.len() < count {
        let e = ALL[pick(&mut rng, ALL.len())];
        let clash = effects
            .iter()
            .any(|f| f.id() == e.id() || f.subsystem() == e.subsystem());
        if !clash {
            effects.push(e);
        }
    }
    let scheme = if effects.iter().any(|e| e.pump() == Some(Pump::Aux)) {
        [Scheme::FixedSplit, Scheme::Adaptive][pick(&mut rng, 2)]
    } else {
        [Scheme::Single, Scheme::FixedSplit, Scheme::Adaptive][pick(&mut rng, 3)]
    };
    let (sample_period, variation) = Variation::draw(&mut rng);
    let jitter = 0.2 * sample_period * rng.unit();
    Case {
        sample_period,
        controller: [Controller::Pid, Controller::Pid, Controller::Adrc][pick(&mut rng, 3)],
        substeps: 1 + pick(&mut rng, 4) as u32,
        jitter,
        variation: Some(variation),
        ..Case::new(scenario, scheme, effects, seed)
    }
}

/// Tally of one truth effect: named with its key parameter in tolerance, named with it out
/// of tolerance, missed; and named although absent.
#[derive(Default)]
struct Tally {
    right: usize,
    off: usize,
    missed: usize,
    untestable: usize,
    undetectable: usize,
    false_named: usize,
}

fn label(e: Effect) -> String {
    match e.pump() {
        Some(p) => format!("{}:{p}", e.id()),
        None => e.id().to_string(),
    }
}

/// The counts over a set: cases, effect-free cases and their false alarms, and the
/// independent scorer's two other checks on cases otherwise right.
#[derive(Default)]
struct Totals {
    right: usize,
    nulls: usize,
    false_alarms: usize,
    /// `adequate` with a held-out error above the floor multiple.
    adequate_above: usize,
    /// Otherwise right, but a named effect did not improve its held-out fit.
    not_improved: usize,
    /// Otherwise right, but the first mismatch lies outside the true subsystems.
    misplaced_first: usize,
    /// Cases whose every concealed effect the truth shows above the detection limit.
    detectable: usize,
    right_detectable: usize,
}

/// The cases of a set to run: `EVAL_EFFECT=ID` keeps only the cases that conceal that
/// effect (`none`: the effect-free cases; `!ID`: those that conceal effects, none of them
/// ID), `EVAL_ABSENT=COLUMN` only those whose recording lacks that column.
struct Filter {
    only: Option<String>,
    absent: Option<String>,
}

impl Filter {
    fn from_env() -> Filter {
        Filter {
            only: std::env::var("EVAL_EFFECT").ok(),
            absent: std::env::var("EVAL_ABSENT").ok(),
        }
    }

    fn keeps(&self, case: &Case) -> bool {
        let conceals = |id: &str| match id {
            "none" => case.effects.is_empty(),
            _ => match id.strip_prefix('!') {
                Some(not) => !case.effects.is_empty() && case.effects.iter().all(|e| e.id() != not),
                None => case.effects.iter().any(|e| e.id() == id),
            },
        };
        let lacks = |col: &str| {
            case.variation
                .as_ref()
                .is_some_and(|v| v.absent.iter().any(|a| a == col))
        };
        self.only.as_deref().map_or(true, conceals) && self.absent.as_deref().map_or(true, lacks)
    }
}

/// `EVAL_DUMP=DIR`: each case's recording, truth and drawn case to `DIR/SEED.csv`,
/// `.json`, `.case.txt` (to look at one with `tbm-thrust diagnose`).
fn dump(dir: &str, seed: u64, case: &Case, synthesis: &Synthesis) {
    std::fs::write(format!("{dir}/{seed}.csv"), &synthesis.csv).expect("dump writes");
    let truth = serde_json::to_string_pretty(&synthesis.truth).expect("truth serialises");
    std::fs::write(format!("{dir}/{seed}.json"), truth).expect("dump writes");
    std::fs::write(format!("{dir}/{seed}.case.txt"), format!("{case:#?}\n")).expect("dump writes");
}

/// The largest held-out error over its floor, and its signal.
fn worst_over_floor(d: &Diagnosis) -> (f64, &'static str) {
    d.fit_after
        .iter()
        .filter_map(|(s, f)| {
            let floor = d.floors.iter().find(|x| x.signal == *s)?.total();
            (floor > 0.0).then_some((f.rmse / floor, *s))
        })
        .fold((0.0, "-"), |a, b| if b.0 > a.0 { b } else { a })
}

/// Each concealed effect's outcome counted in its tally; returns whether all were named in
/// tolerance, each effect's oracle `z` (against the refit) as printed, and whether one lies
/// below the detection limit.
fn judge_effects(
    case: &Case,
    synthesis: &Synthesis,
    series: &Series,
    d: &Diagnosis,
    refitted: Option<&Refit>,
    tallies: &mut BTreeMap<String, Tally>,
) -> (bool, Vec<String>, bool) {
    let mut ok = true;
    let mut oracle = Vec::new();
    let mut oracle_below = false;
    for (e, t) in case.effects.iter().zip(&synthesis.truth.effects) {
        let tally = tallies.entry(label(*e)).or_default();
        let seen = detectability(series, &synthesis.params, *e);
        let left = refitted.and_then(|r| beyond_refit(series, &synthesis.params, *e, r));
        oracle.push(match (seen, left) {
            (Some(c), Some(l)) => format!("{:.1} ({:.1})", c.z, l.z),
            _ => "-".to_string(),
        });
        let undetectable = seen.is_some_and(|c| c.z < RULE.z_floor);
        oracle_below |= undetectable;
        // A pump effect whose pump is not replayed (no drive command nor commanded flow,
        // idle, or a chattering command).
        let untestable = seen.is_none();
        let (name, close) = key(*e);
        match d.findings.iter().find(|f| f.effect == *e) {
            Some(f) if close(f.parameters[name], t.parameters[name]) => tally.right += 1,
            Some(_) => {
                tally.off += 1;
                ok = false;
            }
            None if untestable => {
                tally.untestable += 1;
                ok = false;
            }
            None if undetectable => {
                tally.undetectable += 1;
                ok = false;
            }
            None => {
                tally.missed += 1;
                ok = false;
            }
        }
    }
    (ok, oracle, oracle_below)
}

/// As the independent scorer asks: whether a named true effect's signal (or `x`) failed to
/// improve its held-out fit, and whether the first mismatch lies outside the true subsystems.
fn scorer_checks(case: &Case, d: &Diagnosis, named: &[Effect]) -> (bool, bool) {
    let improved = |signal: &str| {
        let rmse = |fits: &[(&str, tbm_thrust::metrics::Fit)]| {
            fits.iter().find(|(n, _)| *n == signal).map(|(_, f)| f.rmse)
        };
        matches!((rmse(&d.fit_before), rmse(&d.fit_after)), (Some(b), Some(a)) if a < b)
    };
    let worse = named
        .iter()
        .filter(|e| case.effects.contains(e))
        .any(|e| !improved(e.subsystem().signal()) && !improved("x"));
    let misplaced = !case.effects.is_empty()
        && d.mismatch.first().map_or(true, |m| {
            !case.effects.iter().any(|e| e.subsystem() == m.subsystem)
        });
    (worse, misplaced)
}

fn names(v: &[Effect]) -> String {
    if v.is_empty() {
        "none".to_string()
    } else {
        v.iter().map(|e| label(*e)).collect::<Vec<_>>().join(" + ")
    }
}

/// One case: generated, diagnosed, judged, counted and printed as a table row.
fn run_case(seed: u64, case: &Case, tallies: &mut BTreeMap<String, Tally>, totals: &mut Totals) {
    let synthesis = generate(case).expect("case generates");
    if let Ok(dir) = std::env::var("EVAL_DUMP") {
        dump(&dir, seed, case, &synthesis);
    }
    let rec = Recording::parse(&synthesis.csv, "generated").expect("parses");
    let series = Series::from_recording(&rec).expect("grid");
    let started = Instant::now();
    let d = diagnose(&series, &Params::default()).expect("diagnosis runs");
    let elapsed = started.elapsed().as_secs_f64();
    let named: Vec<Effect> = d.findings.iter().map(|f| f.effect).collect();
    let (worst, worst_signal) = worst_over_floor(&d);
    if d.verdict() == "adequate" && worst > FLOOR_MULTIPLE {
        totals.adequate_above += 1;
    }
    let mut ok = named.len() == case.effects.len();
    if case.effects.is_empty() {
        totals.nulls += 1;
        if d.verdict() != "adequate" {
            totals.false_alarms += 1;
            ok = false;
        }
    }
    // The nominal refit the diagnosis starts its search from (stage 2).
    let refitted = (!case.effects.is_empty()).then(|| {
        let mut prepared = prepare::prepare(&series, &Params::default()).expect("prepares");
        refit::refit(&mut prepared, &Silent)
    });
    let (all_named, oracle, oracle_below) =
        judge_effects(case, &synthesis, &series, &d, refitted.as_ref(), tallies);
    ok &= all_named;
    for e in named.iter().filter(|e| !case.effects.contains(e)) {
        tallies.entry(label(*e)).or_default().false_named += 1;
    }
    let (worse, misplaced) = scorer_checks(case, &d, &named);
    if ok && (worse || misplaced) {
        totals.not_improved += worse as usize;
        totals.misplaced_first += misplaced as usize;
        ok = false;
    }
    totals.right += ok as usize;
    if !oracle_below {
        totals.detectable += 1;
        totals.right_detectable += ok as usize;
    }
    let variation = case.variation.as_ref().expect("drawn");
    println!(
        "| {seed} | {} | {} | {:.0} | {} | {} | {} | {} | {} | {} | {worst:.2} ({worst_signal}) | {} | {elapsed:.1} |",
        case.scenario.name(),
        case.scheme.name(),
        1.0 / case.sample_period,
        variation.family,
        variation.absent.join(" "),
        names(&case.effects),
        oracle.join(" / "),
        names(&named),
        d.verdict(),
        if ok { "yes" } else { "**no**" },
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let set = args.get(1).map_or("tune", String::as_str);
    let n: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(200);
    // An optional third argument skips that many cases of the set (to run a set in parts).
    let skip: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0);
    let first = skip
        + match set {
            "frozen" => 900_001,
            _ => 1,
        };
    let mut tallies: BTreeMap<String, Tally> = BTreeMap::new();
    let mut totals = Totals::default();
    println!("| seed | programme | scheme | rate [Hz] | family | absent | truth | oracle z (against the refit) | named | verdict | max error/floor | ok | time [s] |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let filter = Filter::from_env();
    for seed in first..first + n {
        let case = draw(seed);
        if filter.keeps(&case) {
            run_case(seed, &case, &mut tallies, &mut totals);
        }
    }
    print_summary(set, n, &tallies, &totals);
}

/// The per-effect confusion matrix and the set's totals.
fn print_summary(set: &str, n: u64, tallies: &BTreeMap<String, Tally>, t: &Totals) {
    println!("\n| effect | named, parameter in tolerance | named, parameter off | missed | missed, not testable (pump not replayed) | missed, below the detection limit (oracle z < {}) | named when absent |", RULE.z_floor);
    println!("|---|---|---|---|---|---|---|");
    for (e, t) in tallies {
        println!(
            "| {e} | {} | {} | {} | {} | {} | {} |",
            t.right, t.off, t.missed, t.untestable, t.undetectable, t.false_named
        );
    }
    println!(
        "\n{set} set, {n} cases: {} right; of the {} cases whose effects are all above the detection limit, {} right; false alarms on effect-free recordings: {} of {}; `adequate` with a held-out error above {FLOOR_MULTIPLE} x its floor: {}; otherwise right but a named effect's held-out fit not improved: {}, first mismatch outside the true subsystems: {}",
        t.right, t.detectable, t.right_detectable, t.false_alarms, t.nulls, t.adequate_above, t.not_improved, t.misplaced_first
    );
}
