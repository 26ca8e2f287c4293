//! `tbm-thrust simulate`: one run of the model, written as a recording CSV (contract format,
//! sampled every 0.01 s) with the paper's metrics printed.

use std::path::PathBuf;
use tbm_bench::recording::TraceWriter;
use tbm_thrust::metrics::{flow_ratio, overshoot, ErrorPasses, RecoveryPasses};
use tbm_thrust::simulation::{self, Profile, Scenario, DEFAULT_SUBSTEPS};
use tbm_thrust::units::LPM;
use tbm_thrust::variables::Outputs;
use tbm_thrust::Params;

#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
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
/// Bytes of one row of the recording, measured: a 3600 s run wrote 141,090,289 B in 360,001
/// rows.
const ROW_BYTES: f64 = 392.0;
/// A run whose recording would be larger than this [B] is announced on stderr before it
/// starts. Any size runs in the same small memory: the recording is written as the run goes.
const WARN_BYTES: f64 = 1e9;

pub fn run(args: Args) -> Result<(), String> {
    let params = build_params(&args)?;
    let scenario = build_scenario(&args)?;
    let inputs: Vec<(&str, &std::path::Path)> = args
        .params
        .iter()
        .map(|p| ("--params", p.as_path()))
        .collect();
    crate::output::check(&inputs, &[("--out", &args.out)], &[])?;
    warn_size(&scenario, &args);
    let source = format!("tbm-thrust {} simulate", env!("CARGO_PKG_VERSION"));
    let meta = [
        ("source", source.as_str()),
        ("scheme", params.scheme.name()),
        ("controller", params.controller.name()),
    ];
    let mut summary = Summary::new(&params, scenario.samples());
    crate::output::write_atomic_with(&args.out, |w| {
        let mut csv = TraceWriter::new(w, &meta)?;
        simulation::run_each(
            &params,
            &scenario,
            DEFAULT_SUBSTEPS,
            |t, inputs, outputs| {
                summary.push(t, outputs);
                csv.sample(t, inputs, outputs)
            },
        )?;
        csv.finish().map(drop)
    })?;
    print_metrics(&params, &scenario, &mut summary, &args);
    summary.warn_motion();
    Ok(())
}

/// One line on stderr before a run whose recording would exceed `WARN_BYTES`.
fn warn_size(scenario: &Scenario, args: &Args) {
    if let Some(w) = size_warning(scenario, args) {
        eprintln!("{w}");
    }
}

fn size_warning(scenario: &Scenario, args: &Args) -> Option<String> {
    let bytes = scenario.samples() as f64 * ROW_BYTES;
    (bytes > WARN_BYTES).then(|| {
        format!(
            "warning: --duration {} s writes {} rows, about {:.1} GB, to {}",
            args.duration,
            scenario.samples(),
            bytes / 1e9,
            args.out.display()
        )
    })
}

/// What `simulate` prints about a run, gathered sample by sample as the run is written, so
/// that no sample is kept: the sums and extremes of the metrics' first pass, the motion.
struct Summary {
    samples: usize,
    taken: usize,
    errors: ErrorPasses,
    recovery: RecoveryPasses,
    /// Lowest e_x [m] (the overshoot).
    lowest: f64,
    /// Peak flows [m^3/s], from 0.
    peaks: [f64; 2],
    /// Flows summed over the second half of the run (the flow ratio).
    late_flows: [f64; 2],
    /// Farthest the piston got [m], from 0.
    x_max: f64,
    /// The stroke and when the piston first reached it [s].
    stroke: f64,
    end_stop: Option<f64>,
}

impl Summary {
    fn new(p: &Params, samples: usize) -> Self {
        Summary {
            samples,
            taken: 0,
            errors: ErrorPasses::new(),
            recovery: RecoveryPasses::new(samples),
            lowest: f64::INFINITY,
            peaks: [0.0; 2],
            late_flows: [-0.0; 2],
            x_max: 0.0,
            stroke: p.x_max,
            end_stop: None,
        }
    }

    fn push(&mut self, t: f64, o: &Outputs) {
        if self.taken > 0 {
            self.errors.push(o.e_x);
        }
        self.recovery.push(o.e_x);
        self.lowest = self.lowest.min(o.e_x);
        for (i, q) in [o.Q1, o.Q2].into_iter().enumerate() {
            self.peaks[i] = self.peaks[i].max(q);
            if self.taken >= self.samples / 2 {
                self.late_flows[i] += q;
            }
        }
        self.x_max = self.x_max.max(o.x);
        if o.x >= self.stroke && self.end_stop.is_none() {
            self.end_stop = Some(t);
        }
        self.taken += 1;
    }

    /// The metrics' second pass: the same run again (the standard deviation and the recovery
    /// band need the first pass's mean and steady value).
    fn second_pass(&mut self, p: &Params, scenario: &Scenario) {
        let mut k = 0;
        let _ = simulation::run_each(p, scenario, DEFAULT_SUBSTEPS, |t, _, o| {
            if k > 0 {
                self.errors.spread(o.e_x);
            }
            self.recovery.check(t, o.e_x);
            k += 1;
            Ok::<(), std::convert::Infallible>(())
        });
    }

    /// Warnings on stderr for runs that are legal but rarely meant: no motion at all, or the
    /// piston on its end stop (the stroke `x_max`).
    fn warn_motion(&self) {
        if self.x_max <= 0.0 {
            eprintln!("warning: the piston never moves (x stays 0): is v_ref zero, or the load beyond the pumps' pressure?");
        } else if let Some(t) = self.end_stop {
            eprintln!(
                "warning: the piston reaches its end stop x_max = {} m at {t:.2} s and stays there; the rest of the run is the pumps against the stop",
                self.stroke
            );
        }
    }
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
        let name = name.trim();
        // `--scheme single --set scheme=adaptive` says two things; neither wins silently.
        for (option, given) in [("scheme", &args.scheme), ("controller", &args.controller)] {
            if let Some(given) = given
                .as_ref()
                .filter(|g| name == option && *g != value.trim())
            {
                return Err(format!(
                    "--{option} {given} and --set {kv} disagree; give one of them"
                ));
            }
        }
        p.set_text(name, value)
            .map_err(|e| format!("--set {kv}: {e}"))?;
    }
    p.validate().map_err(|e| e.to_string())?;
    Ok(p)
}

fn build_scenario(args: &Args) -> Result<Scenario, String> {
    if !(args.duration.is_finite() && args.duration > 0.0) {
        return Err(format!(
            "--duration {} s: must be a finite number of seconds above 0",
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
        points.push((finite(t, what, f64::MAX)?, v));
    }
    Ok(Profile(points))
}

/// Output samples after t = 0 the metrics need (a mean and a standard deviation).
const METRIC_SAMPLES: usize = 2;

fn print_metrics(p: &Params, scenario: &Scenario, run: &mut Summary, args: &Args) {
    outln!(
        "scheme {}, controller {}, {:.1} s -> {}",
        p.scheme.name(),
        p.controller.name(),
        args.duration,
        args.out.display()
    );
    let after_start = run.samples.saturating_sub(1);
    if after_start < METRIC_SAMPLES {
        outln!(
            "no metrics: Eq. 34-37 need at least {METRIC_SAMPLES} output samples after t = 0 (a run of at least {:.2} s); this run has {after_start}",
            METRIC_SAMPLES as f64 * SAMPLE_PERIOD
        );
        return;
    }
    run.second_pass(p, scenario);
    let s = run.errors.stats();
    outln!(
        "e_x (Eq. 34-37): max {:.3} mm, min {:.3} mm, mean {:.3} mm, S.D. {:.3} mm",
        s.max_mm,
        s.min_mm,
        s.mean_mm,
        s.sd_mm
    );
    outln!(
        "recovery time {:.2} s, overshoot {:.3} mm",
        run.recovery.time(),
        1e3 * overshoot(&[run.lowest])
    );
    outln!(
        "peak flows: main {:.2} L/min, auxiliary {:.2} L/min",
        LPM * run.peaks[0],
        LPM * run.peaks[1]
    );
    if run.peaks[1] > 0.0 {
        let [q1, q2] = run.late_flows;
        outln!(
            "steady main:auxiliary flow ratio {:.2}",
            flow_ratio(&[q1], &[q2])
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(clap::Parser)]
    struct Command {
        #[command(flatten)]
        args: Args,
    }

    fn warning(duration: &str) -> Option<String> {
        let c = Command::parse_from(["simulate", "--duration", duration, "--out", "r.csv"]);
        size_warning(&build_scenario(&c.args).unwrap(), &c.args)
    }

    #[test]
    fn a_recording_over_a_gigabyte_is_announced_with_its_size() {
        assert_eq!(warning("20"), None);
        assert_eq!(warning("25000"), None);
        assert_eq!(
            warning("100000").as_deref(),
            Some("warning: --duration 100000 s writes 10000001 rows, about 3.9 GB, to r.csv")
        );
    }
}
