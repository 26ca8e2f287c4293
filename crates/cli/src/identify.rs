//! `tbm-thrust identify RECORDING.csv [--params FILE] [--method paper-ga|default] [--seed N]
//! [--json FILE] [--out-params FILE.toml]`: fits the pumps (when the recording has their
//! drive commands) and the unknowns beta_e, C_ip, b (Table 2 ranges) to a recording, and
//! reports the fit per signal like Table 3.

use serde_json::{json, Map, Value};
use std::path::PathBuf;
use tbm_bench::identify::pump::PumpFit;
use tbm_bench::identify::{self, default_unknowns, FitOptions, FitResult, Method};
use tbm_bench::quality::{screen, Stretch};
use tbm_bench::recording::Recording;
use tbm_thrust::metrics::Fit;
use tbm_thrust::variables::by_name;
use tbm_thrust::Params;

#[derive(Clone, Copy, clap::ValueEnum)]
enum MethodArg {
    /// The paper's genetic algorithm, exactly as section 2.3
    PaperGa,
    /// Differential evolution in log-scaled parameters, then Levenberg-Marquardt
    Default,
}

#[derive(clap::Args)]
pub struct Args {
    /// Recording CSV (the contract's format, SI units)
    recording: PathBuf,
    /// Parameter file (TOML) to start from; the model's defaults otherwise
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Optimiser of the closed-loop stage
    #[arg(long, value_enum, default_value = "default")]
    method: MethodArg,
    /// Seed of every random draw (equal seeds give equal results)
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    /// Write the report as JSON to FILE
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Write the fitted parameters (every parameter, TOML) to FILE, loadable by --params
    #[arg(long, value_name = "FILE")]
    out_params: Option<PathBuf>,
    /// No progress bar
    #[arg(long)]
    quiet: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    let mut inputs = vec![("recording", args.recording.as_path())];
    inputs.extend(args.params.iter().map(|p| ("--params", p.as_path())));
    let outputs: Vec<(&str, &std::path::Path)> =
        [("--json", &args.json), ("--out-params", &args.out_params)]
            .into_iter()
            .filter_map(|(o, p)| p.as_deref().map(|p| (o, p)))
            .collect();
    crate::output::check(&inputs, &outputs, &[])?;
    let rec = Recording::read(&args.recording).map_err(|e| e.to_string())?;
    let base = match &args.params {
        Some(path) => Params::from_toml_file(path).map_err(|e| e.to_string())?,
        None => Params::default(),
    };
    let rec = screen(&rec, &base, Stretch::First)
        .map_err(|e| e.to_string())?
        .recording;
    let method = match args.method {
        MethodArg::PaperGa => Method::PaperGa,
        MethodArg::Default => Method::Default,
    };
    let (names, bounds) = default_unknowns();
    let opts = FitOptions {
        method,
        seed: args.seed,
        names,
        bounds,
        progress: !args.quiet,
    };
    let start: Vec<f64> = opts
        .names
        .iter()
        .map(|n| base.get(n).unwrap_or(f64::NAN))
        .collect();
    let result = identify::fit(&rec, &base, &opts).map_err(|e| e.to_string())?;
    let fits = identify::signal_fits(&rec, &result.params).map_err(|e| e.to_string())?;

    out!("{}", report(&rec, &opts, &start, &result, &fits));
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&to_json(&rec, &opts, &start, &result, &fits))
            .expect("serialisable");
        crate::output::write_atomic(path, &(text + "\n"))?;
    }
    if let Some(path) = &args.out_params {
        let header = format!(
            "# fitted by `tbm-thrust identify {}` (method {}, seed {}), J = {:.6e}\n",
            rec.source,
            method.name(),
            args.seed,
            result.cost
        );
        crate::output::write_atomic(path, &(header + &result.params.to_toml()))?;
    }
    Ok(())
}

fn unit_of(name: &str) -> &'static str {
    match by_name(name).map(|v| v.unit) {
        Some("") | None => "-",
        Some(u) => u,
    }
}

fn signal_unit(name: &str) -> &'static str {
    identify::REPORT_SIGNALS
        .iter()
        .find(|(n, _)| *n == name)
        .map_or("", |(_, u)| u)
}

/// The reader's notes, then the fit's, one sentence each.
fn all_notes(rec: &Recording, r: &FitResult) -> Vec<String> {
    rec.notes()
        .iter()
        .map(ToString::to_string)
        .chain(r.notes.iter().cloned())
        .collect()
}

/// The human-readable report: notes, pump stage, fitted parameters, Table-3-like fit.
fn report(
    rec: &Recording,
    opts: &FitOptions,
    start: &[f64],
    r: &FitResult,
    fits: &[(String, Fit)],
) -> String {
    let mut s = String::new();
    let (t0, t1) = (rec.time[0], rec.time[rec.len() - 1]);
    s += &format!(
        "identify: {} ({} samples, {t0} s to {t1} s)\n",
        rec.source,
        rec.len()
    );
    s += &format!(
        "method: {} ({}), seed {}\n",
        opts.method.name(),
        opts.method.description(),
        opts.seed
    );
    let notes = all_notes(rec, r);
    if !notes.is_empty() {
        s += "notes:\n";
        for n in notes {
            s += &format!("  - {n}\n");
        }
    }
    for pf in &r.pumps {
        s += &pump_section(pf);
    }
    s += &parameters_section(opts, start, r);
    s += &fit_section(t0, fits);
    s += &format!(
        "\ncost J = {:.6e} (weighted x, v, p errors; about 1 per signal at the noise level)\nsimulations: {} closed-loop",
        r.cost, r.simulations
    );
    let pump_sims: usize = r.pumps.iter().map(|p| p.simulations).sum();
    if pump_sims > 0 {
        s += &format!(" + {pump_sims} open-loop pump");
    }
    s += &format!("; wall time {:.2} s\n", r.wall_time_s);
    s
}

/// The report's section on one pump's open-loop fit.
fn pump_section(pf: &PumpFit) -> String {
    let verdict = if pf.accepted {
        "used"
    } else {
        "NOT used, given values kept"
    };
    let mut s = format!(
        "\npump {} (Eq. 8 replayed open-loop with the measured uc{} and p; {} simulations; {verdict}):\n",
        pf.pump, pf.pump, pf.simulations
    );
    for ((name, v), (lo, hi)) in pf.names.iter().zip(&pf.values).zip(&pf.bounds) {
        s += &format!(
            "  {name:<8} {v:>12.5e} {:<13} range [{lo:.3e}, {hi:.3e}]\n",
            unit_of(name)
        );
    }
    s += &format!(
        "  Q{}: R^2 {:.4}, RMSE {:.3e} m^3/s, MAPE {:.2} %\n",
        pf.pump, pf.fit.r2, pf.fit.rmse, pf.fit.mape
    );
    s
}

/// The report's table of the closed-loop unknowns: value, unit, start and range.
fn parameters_section(opts: &FitOptions, start: &[f64], r: &FitResult) -> String {
    let mut s = String::from("\nfitted parameters (closed loop, Eq. 12):\n");
    s += &format!(
        "  {:<8} {:>12} {:<13} {:>12} {}\n",
        "name", "value", "unit", "start", "range"
    );
    for (i, name) in opts.names.iter().enumerate() {
        let v = r.params.get(name).unwrap_or(f64::NAN);
        let (lo, hi) = opts.bounds[i];
        s += &format!(
            "  {name:<8} {v:>12.5e} {:<13} {:>12.5e} [{lo:.3e}, {hi:.3e}]\n",
            unit_of(name),
            start[i]
        );
    }
    s
}

/// The report's Table-3-like fit of each signal from the first sample the cost uses (the
/// recording starting at `t0`).
fn fit_section(t0: f64, fits: &[(String, Fit)]) -> String {
    let mut s = format!("\nfit from {} s (Table 3):\n", t0 + identify::SKIP_START_S);
    s += &format!(
        "  {:<6} {:>9} {:>22} {:>10}\n",
        "signal", "R^2", "RMSE", "MAPE [%]"
    );
    for (name, f) in fits {
        let rmse = format!("{:.4e} {}", f.rmse, signal_unit(name));
        s += &format!("  {name:<6} {:>9.5} {rmse:>22} {:>10.3}\n", f.r2, f.mape);
    }
    s
}

fn fit_json(f: &Fit, unit: &str) -> Value {
    json!({"r2": f.r2, "rmse": f.rmse, "mape": f.mape, "rmse_unit": unit})
}

/// One pump stage's fit: its parameters with units and ranges, the flow fit and its checks.
fn pump_json(pf: &PumpFit) -> Value {
    let params: Map<String, Value> = pf
        .names
        .iter()
        .zip(&pf.values)
        .zip(&pf.bounds)
        .map(|((n, v), b)| {
            (
                n.clone(),
                json!({"value": v, "unit": unit_of(n), "range": [b.0, b.1]}),
            )
        })
        .collect();
    json!({
        "pump": pf.pump.number(),
        "parameters": params,
        "fit": fit_json(&pf.fit, "m^3/s"),
        "residual_autocorrelation": pf.autocorrelation,
        "accepted": pf.accepted,
        "excluded_samples": pf.excluded_samples,
        "simulations": pf.simulations,
    })
}

fn to_json(
    rec: &Recording,
    opts: &FitOptions,
    start: &[f64],
    r: &FitResult,
    fits: &[(String, Fit)],
) -> Value {
    let mut parameters = Map::new();
    for (i, name) in opts.names.iter().enumerate() {
        parameters.insert(
            name.clone(),
            json!({
                "value": r.params.get(name),
                "unit": unit_of(name),
                "start": start[i],
                "range": [opts.bounds[i].0, opts.bounds[i].1],
            }),
        );
    }
    let pumps: Vec<Value> = r.pumps.iter().map(pump_json).collect();
    let fit: Map<String, Value> = fits
        .iter()
        .map(|(n, f)| (n.clone(), fit_json(f, signal_unit(n))))
        .collect();
    let notes = all_notes(rec, r);
    json!({
        "recording": rec.source,
        "samples": rec.len(),
        "method": opts.method.name(),
        "seed": opts.seed,
        "parameters": parameters,
        "pumps": pumps,
        "fit_from_s": rec.time[0] + identify::SKIP_START_S,
        "fit": fit,
        "cost": r.cost,
        "simulations": r.simulations,
        "pump_simulations": r.pumps.iter().map(|p| p.simulations).sum::<usize>(),
        "wall_time_s": r.wall_time_s,
        "history": r.history,
        "notes": notes,
    })
}
