//! `tbm-thrust simulate`: one run of the model, written as a recording CSV (contract format,
//! sampled every 0.01 s) with the paper's metrics printed.

use std::path::PathBuf;
use tbm_thrust::metrics::{error_stats, flow_ratio, overshoot, recovery_time};
use tbm_thrust::simulation::{self, Profile, Scenario};
use tbm_thrust::units::LPM;
use tbm_thrust::{Params, Trace};

#[derive(clap::Args)]
pub struct Args {
    /// Pump scheme: single, fixed_split or adaptive (default: the parameter file's, else adaptive).
    #[arg(long)]
    scheme: Option<String>,
    /// Inner flow-loop controller: pid or adrc (default: the parameter file's, else pid).
    #[arg(long)]
    controller: Option<String>,
    /// Constant commanded advance velocity [m/s], from rest at t = 0.
    #[arg(long, default_value_t = 0.05, value_name = "M_PER_S")]
    v_ref: f64,
    /// Piecewise-constant velocity profile "t0:v0,t1:v1,..." [s:m/s] (speed steps, start-stop);
    /// overrides --v-ref. Example: "0:0.03,5:0.05,10:0,12:0.05".
    #[arg(long, value_name = "PROFILE")]
    v_profile: Option<String>,
    /// Constant external load [N].
    #[arg(long, default_value_t = 12_000.0, value_name = "N")]
    load: f64,
    /// Piecewise-constant load profile "t0:F0,t1:F1,..." [s:N] (load steps); overrides --load.
    #[arg(long, value_name = "PROFILE")]
    load_profile: Option<String>,
    /// Simulated time [s].
    #[arg(long, default_value_t = 20.0, value_name = "S")]
    duration: f64,
    /// TOML parameter file (`name = value`; see modelDescription/variables.toml).
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Set one parameter, e.g. --set beta_e=1.2e9 (repeatable; applied after --params).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Output recording CSV.
    #[arg(long, value_name = "FILE.csv")]
    out: PathBuf,
}

/// Sample period of the recording [s].
const SAMPLE_PERIOD: f64 = 0.01;
/// Longest run accepted [s] (a whole TBM stroke at the slowest speed is well below).
const MAX_DURATION: f64 = 1.0e5;

pub fn run(args: Args) -> Result<(), String> {
    let params = build_params(&args)?;
    let scenario = build_scenario(&args)?;
    let trace = simulation::run(&params, &scenario);
    let csv = recording_csv(&params, &trace);
    std::fs::write(&args.out, csv)
        .map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    print_metrics(&params, &trace, &args);
    Ok(())
}

fn build_params(args: &Args) -> Result<Params, String> {
    let mut p = match &args.params {
        Some(path) => Params::from_toml_file(path).map_err(|e| e.to_string())?,
        None => Params::default(),
    };
    if let Some(s) = &args.scheme {
        p.set_item("scheme", s)
            .map_err(|e| format!("--scheme: {e}"))?;
    }
    if let Some(c) = &args.controller {
        p.set_item("controller", c)
            .map_err(|e| format!("--controller: {e}"))?;
    }
    for kv in &args.set {
        let (name, value) = kv
            .split_once('=')
            .ok_or_else(|| format!("--set {kv}: expected NAME=VALUE"))?;
        let text = format!("{} = {}", name.trim(), toml_value(value.trim()));
        p.apply_toml(&text)
            .map_err(|e| format!("--set {kv}: {e}"))?;
    }
    p.validate().map_err(|e| e.to_string())?;
    Ok(p)
}

/// A number stays a number; anything else becomes a TOML string (an enumeration item).
fn toml_value(v: &str) -> String {
    if v.parse::<f64>().is_ok() {
        v.to_string()
    } else {
        format!("\"{v}\"")
    }
}

fn build_scenario(args: &Args) -> Result<Scenario, String> {
    if !(args.duration.is_finite() && args.duration > 0.0 && args.duration <= MAX_DURATION) {
        return Err(format!(
            "--duration {} s: must be in (0, {MAX_DURATION}] s",
            args.duration
        ));
    }
    let v_ref = match &args.v_profile {
        Some(text) => parse_profile(text, "--v-profile", 10.0)?,
        None => Profile::constant(finite(args.v_ref, "--v-ref", 10.0)?),
    };
    let load = match &args.load_profile {
        Some(text) => parse_profile(text, "--load-profile", 1e8)?,
        None => Profile::constant(finite(args.load, "--load", 1e8)?),
    };
    Ok(Scenario {
        v_ref,
        load,
        duration: args.duration,
        sample_period: SAMPLE_PERIOD,
    })
}

fn finite(x: f64, what: &str, limit: f64) -> Result<f64, String> {
    if x.is_finite() && x.abs() <= limit {
        Ok(x)
    } else {
        Err(format!(
            "{what} {x}: must be a finite number of magnitude at most {limit:e}"
        ))
    }
}

/// Parses "t0:v0,t1:v1,..." with strictly increasing times starting at 0.
fn parse_profile(text: &str, what: &str, limit: f64) -> Result<Profile, String> {
    let mut points = Vec::new();
    for item in text.split(',') {
        let (t, v) = item
            .split_once(':')
            .ok_or_else(|| format!("{what}: `{item}` is not TIME:VALUE"))?;
        let parse = |s: &str| {
            s.trim()
                .parse::<f64>()
                .map_err(|_| format!("{what}: `{s}` is not a number"))
        };
        let (t, v) = (parse(t)?, finite(parse(v)?, what, limit)?);
        if let Some(&(t_prev, _)) = points.last() {
            if t <= t_prev {
                return Err(format!(
                    "{what}: times must increase ({t} s after {t_prev} s)"
                ));
            }
        } else if t != 0.0 {
            return Err(format!(
                "{what}: the first breakpoint must be at 0 s, not {t} s"
            ));
        }
        points.push((finite(t, what, MAX_DURATION)?, v));
    }
    Ok(Profile(points))
}

/// The contract's recording CSV with `# key = value` metadata first.
pub fn recording_csv(p: &Params, trace: &Trace) -> String {
    let source = format!("tbm-thrust {} simulate", env!("CARGO_PKG_VERSION"));
    let meta = [
        ("source", source.as_str()),
        ("scheme", p.scheme.name()),
        ("controller", p.controller.name()),
    ];
    tbm_bench::recording::trace_csv(&meta, trace)
}

/// Output samples after t = 0 the metrics need (a mean and a standard deviation).
const METRIC_SAMPLES: usize = 2;

fn print_metrics(p: &Params, trace: &Trace, args: &Args) {
    let e_x = trace.signal("e_x").unwrap_or_default();
    let q1 = trace.signal("Q1").unwrap_or_default();
    let q2 = trace.signal("Q2").unwrap_or_default();
    println!(
        "scheme {}, controller {}, {:.1} s -> {}",
        p.scheme.name(),
        p.controller.name(),
        args.duration,
        args.out.display()
    );
    let after_start = e_x.len().saturating_sub(1);
    if after_start < METRIC_SAMPLES {
        println!(
            "no metrics: Eq. 34-37 need at least {METRIC_SAMPLES} output samples after t = 0 (a run of at least {:.2} s); this run has {after_start}",
            METRIC_SAMPLES as f64 * SAMPLE_PERIOD
        );
        return;
    }
    let s = error_stats(&e_x);
    println!(
        "e_x (Eq. 34-37): max {:.3} mm, min {:.3} mm, mean {:.3} mm, S.D. {:.3} mm",
        s.max_mm, s.min_mm, s.mean_mm, s.sd_mm
    );
    println!(
        "recovery time {:.2} s, overshoot {:.3} mm",
        recovery_time(&trace.time, &e_x),
        1e3 * overshoot(&e_x)
    );
    let peak = |q: &[f64]| LPM * q.iter().cloned().fold(0.0, f64::max);
    println!(
        "peak flows: main {:.2} L/min, auxiliary {:.2} L/min",
        peak(&q1),
        peak(&q2)
    );
    if q2.iter().any(|q| *q > 0.0) {
        println!(
            "steady main:auxiliary flow ratio {:.2}",
            flow_ratio(&q1, &q2)
        );
    }
}
