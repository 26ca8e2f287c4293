//! Scores `diagnose` on generated recordings with concealed effects: for every case, the
//! effects named against the truth and the key parameter's error, plus the run time.
//! `cargo run --release --example diagnose_eval [-- SEEDS [SCENARIO [variants]]]` prints a
//! Markdown table
//! (the measured results in docs/diagnose.md).

use std::time::Instant;
use tbm_bench::diagnose::effect::{Effect, ALL};
use tbm_bench::diagnose::{diagnose, series::Series};
use tbm_bench::recording::Recording;
use tbm_bench::synth::{generate, BenchScenario, Case};
use tbm_thrust::pump::Pump;
use tbm_thrust::{Controller, Params, Scheme};

/// The key parameter of an effect and whether an estimate is close enough (the tolerances of `crates/cli/tests/diagnose.rs`).
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
        Effect::FlowRipple(_) => ("amplitude", within30),
    }
}

fn scheme_for(effects: &[Effect], seed: u64) -> Scheme {
    if effects.iter().any(|e| e.pump() == Some(Pump::Aux)) {
        Scheme::FixedSplit
    } else if seed % 2 == 0 {
        Scheme::Single
    } else {
        Scheme::Adaptive
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(2);
    let scenario = args
        .get(2)
        .and_then(|s| BenchScenario::parse(s))
        .unwrap_or(BenchScenario::Mixed);
    // "variants": other controllers, solver steps and logger jitter, as a stand-in for the
    // hidden cases' own numerics, controller and noise.
    let variants = args.get(3).is_some_and(|v| v == "variants");
    let mut cases: Vec<Vec<Effect>> = vec![Vec::new(), Vec::new()];
    cases.extend(ALL.iter().map(|e| vec![*e]));
    cases.push(vec![
        Effect::StribeckFriction,
        Effect::PumpDeadTime(Pump::Main),
    ]);
    cases.push(vec![Effect::EntrainedAir, Effect::PositionDependentLoad]);
    println!("| case | scenario | scheme | controller | sub-steps | jitter [ms] | seed | truth | named | key parameter: true / estimated | ok | time [s] | z / local share (accepted, strongest rejected) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let (mut ok, mut total) = (0, 0);
    for seed in 1..=seeds {
        for (i, effects) in cases.iter().enumerate() {
            let k = seed + i as u64;
            let case = Case {
                controller: if variants && k % 3 == 0 {
                    Controller::Adrc
                } else {
                    Controller::Pid
                },
                substeps: if variants {
                    [1, 4, 8][(k % 3) as usize]
                } else {
                    4
                },
                jitter: if variants && k % 2 == 0 { 0.002 } else { 0.0 },
                ..Case::new(
                    scenario,
                    scheme_for(effects, k),
                    effects.clone(),
                    100 * seed + i as u64,
                )
            };
            let good = run(&case, i);
            total += 1;
            ok += good as usize;
        }
    }
    println!("\n{ok} of {total} cases right");
}

fn run(case: &Case, index: usize) -> bool {
    let synthesis = generate(case).expect("case generates");
    let rec = Recording::parse(&synthesis.csv, "generated").expect("generated recording parses");
    let series = Series::from_recording(&rec).expect("grid");
    let started = Instant::now();
    let d = diagnose(&series, &Params::default()).expect("diagnosis runs");
    let elapsed = started.elapsed().as_secs_f64();
    let named: Vec<Effect> = d.findings.iter().map(|f| f.effect).collect();
    let mut right = named.len() == case.effects.len();
    let mut keys = Vec::new();
    for (e, t) in case.effects.iter().zip(&synthesis.truth.effects) {
        let (name, close) = key(*e);
        let truth = t.parameters[name];
        match d.findings.iter().find(|f| f.effect == *e) {
            Some(f) => {
                let est = f.parameters[name];
                right &= close(est, truth);
                keys.push(format!("{name} {truth:.3e} / {est:.3e}"));
            }
            None => {
                right = false;
                keys.push(format!("{name} {truth:.3e} / -"));
            }
        }
    }
    let mut runners: Vec<&tbm_bench::diagnose::search::Trial> =
        d.trials.iter().filter(|t| !t.chosen).collect();
    runners.sort_by(|a, b| b.comparison.z.total_cmp(&a.comparison.z));
    let strongest: Vec<String> = d
        .trials
        .iter()
        .filter(|t| t.chosen)
        .chain(runners.into_iter().take(1))
        .map(|t| {
            format!(
                "{}{} {:.1}/{:.2}",
                if t.chosen { "" } else { "rejected " },
                id(t.effect),
                t.comparison.z,
                t.comparison.local
            )
        })
        .collect();
    let label = |v: &[Effect]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.iter().map(|e| id(*e)).collect::<Vec<_>>().join(" + ")
        }
    };
    println!(
        "| {index} | {} | {} | {} | {} | {:.0} | {} | {} | {} | {} | {} | {elapsed:.1} | {} |",
        case.scenario.name(),
        case.scheme.name(),
        case.controller.name(),
        case.substeps,
        case.jitter * 1e3,
        case.seed,
        label(&case.effects),
        label(&named),
        keys.join("; "),
        if right { "yes" } else { "**no**" },
        strongest.join(", ")
    );
    right
}

fn id(e: Effect) -> String {
    match e.pump() {
        Some(p) => format!("{}:{p}", e.id()),
        None => e.id().to_string(),
    }
}
