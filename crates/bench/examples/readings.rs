//! Measures one reading of the paper's unclear points on every comparison the issue's
//! targets name (docs/reproduce.md, "Readings"): single, fixed_split and adaptive with PID,
//! single and adaptive with ADRC, the adaptive law with frozen gains (Gamma = 0) and without
//! micro-gating (g_min = 1) under each controller, at 10 kN and 0.05 m/s, and the auxiliary
//! pump's peak flow after a speed step 0.03 -> 0.05 m/s with and without gating.
//!
//! `cargo run --release -p tbm-bench --example readings [-- NAME=VALUE...]`

use tbm_bench::experiments::{Case, RunMetrics, COMPARISON_LOAD, COMPARISON_SPEED};
use tbm_thrust::simulation::{run, Profile, Scenario};
use tbm_thrust::{Controller, Params, Scheme};

/// The base parameters with NAME=VALUE arguments applied.
fn base(args: &[String]) -> Params {
    let mut p = Params::default();
    for a in args {
        let (name, value) = a.split_once('=').expect("arguments are NAME=VALUE");
        match value.parse::<f64>() {
            Ok(v) => p.set(name, v),
            Err(_) => p.set_item(name, value),
        }
        .unwrap_or_else(|e| panic!("{a}: {e}"));
    }
    p
}

fn metrics(p: &Params, scheme: Scheme, controller: Controller) -> RunMetrics {
    let case = Case::new(scheme, controller, COMPARISON_SPEED, COMPARISON_LOAD);
    RunMetrics::of(&run(&case.params(p), &case.scenario()))
}

/// Peak auxiliary flow [L/min] in the second after the 5 s speed step, and peak error after
/// it [mm].
fn after_speed_step(p: &Params) -> (f64, f64) {
    let scenario = Scenario {
        v_ref: Profile(vec![(0.0, 0.03), (5.0, 0.05), (10.0, 0.03)]),
        load: Profile::constant(COMPARISON_LOAD),
        duration: 7.0,
        sample_period: 0.01,
    };
    let trace = run(p, &scenario);
    let peak = |name: &str, scale: f64| {
        let s = trace.signal(name).expect("recorded");
        trace
            .time
            .iter()
            .zip(&s)
            .filter(|(t, _)| **t > 5.0 && **t <= 6.0)
            .map(|(_, v)| v * scale)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    (peak("Q2", tbm_thrust::units::LPM), peak("e_x", 1e3))
}

fn line(name: &str, m: &RunMetrics) {
    let e = &m.error;
    println!(
        "| {name} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {} |",
        e.max_mm,
        e.min_mm,
        e.mean_mm,
        e.sd_mm,
        m.recovery_time_s,
        m.flow_ratio_main_aux
            .map_or("-".to_string(), |r| format!("{r:.2}"))
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let p = base(&args);
    println!("reading: {}", args.join(" "));
    println!("| run | max [mm] | min [mm] | mean [mm] | S.D. [mm] | recovery [s] | Q1:Q2 |");
    println!("|---|---|---|---|---|---|---|");
    let frozen = Params {
        Gamma_x: 0.0,
        Gamma_v: 0.0,
        Gamma_a: 0.0,
        ..p.clone()
    };
    let ungated = Params {
        g_min: 1.0,
        ..p.clone()
    };
    let rows = [
        ("single PID", &p, Scheme::Single, Controller::Pid),
        ("fixed_split PID", &p, Scheme::FixedSplit, Controller::Pid),
        ("adaptive PID", &p, Scheme::Adaptive, Controller::Pid),
        (
            "adaptive PID, Gamma = 0",
            &frozen,
            Scheme::Adaptive,
            Controller::Pid,
        ),
        (
            "adaptive PID, g_min = 1",
            &ungated,
            Scheme::Adaptive,
            Controller::Pid,
        ),
        ("single ADRC", &p, Scheme::Single, Controller::Adrc),
        ("adaptive ADRC", &p, Scheme::Adaptive, Controller::Adrc),
        (
            "adaptive ADRC, Gamma = 0",
            &frozen,
            Scheme::Adaptive,
            Controller::Adrc,
        ),
        (
            "adaptive ADRC, g_min = 1",
            &ungated,
            Scheme::Adaptive,
            Controller::Adrc,
        ),
    ];
    for (name, params, scheme, controller) in rows {
        line(name, &metrics(params, scheme, controller));
    }
    let adaptive = |q: &Params| Params {
        scheme: Scheme::Adaptive,
        ..q.clone()
    };
    let (gated, ungated_step) = (
        after_speed_step(&adaptive(&p)),
        after_speed_step(&adaptive(&ungated)),
    );
    println!(
        "speed step 0.03 -> 0.05 m/s at 5 s: aux peak {:.3} L/min (g_min = {}) vs {:.3} (g_min = 1); \
         peak e_x after it {:.3} vs {:.3} mm",
        gated.0, p.g_min, ungated_step.0, gated.1, ungated_step.1
    );
}
