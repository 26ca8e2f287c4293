//! `tbm-thrust diagnose RECORDING.csv [--params FILE] [--json OUT.json] [--report DIR]
//! [--params-out FILE]`: refits the nominal model, locates the mismatch, names and fits the
//! missing physics (docs/contract.md, "diagnose"). Writes the fitted parameters as TOML; without
//! `--json` the contract's JSON goes to standard output, with it a summary does.

use std::path::{Path, PathBuf};
use tbm_bench::diagnose::replay::Load;
use tbm_bench::diagnose::series::Series;
use tbm_bench::diagnose::{diagnose_reporting, Diagnosis};
use tbm_bench::progress::{Progress, Silent};
use tbm_bench::quality::{screen, Stretch};
use tbm_bench::recording::Recording;
use tbm_thrust::Params;

mod report;

#[derive(clap::Args)]
pub struct Args {
    /// Recording CSV (the contract's format, SI units)
    recording: PathBuf,
    /// Parameter file (TOML) with the known parameters; the model's defaults otherwise
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Write the contract's JSON to FILE (a summary goes to standard output instead)
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Write a Markdown report with PNG figures into DIR
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Where to write the fitted parameters (default: next to the JSON, or the recording)
    #[arg(long, value_name = "FILE")]
    params_out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<(), String> {
    let params_path = args
        .params_out
        .clone()
        .unwrap_or_else(|| default_params_path(&args));
    let mut inputs = vec![("recording", args.recording.as_path())];
    inputs.extend(args.params.iter().map(|p| ("--params", p.as_path())));
    let mut outputs = vec![("--params-out", params_path.as_path())];
    outputs.extend(args.json.iter().map(|p| ("--json", p.as_path())));
    let report_dir: Vec<(&str, &Path)> = args
        .report
        .iter()
        .map(|p| ("--report", p.as_path()))
        .collect();
    crate::output::check(&inputs, &outputs, &report_dir)?;
    let rec = Recording::read(&args.recording).map_err(|e| e.to_string())?;
    let base = base_params(&args, &rec)?;
    let rec = screen(&rec, &base, Stretch::Longest)
        .map_err(|e| e.to_string())?
        .recording;
    let series = Series::from_recording(&rec).map_err(|e| e.to_string())?;
    let started = std::time::Instant::now();
    let diagnosis = match bar(&series) {
        Some(bar) => {
            let d = diagnose_reporting(&series, &base, &bar);
            bar.0.finish_and_clear();
            d
        }
        None => diagnose_reporting(&series, &base, &Silent),
    }
    .map_err(|e| e.to_string())?;
    let elapsed = started.elapsed().as_secs_f64();
    write(&params_path, &params_toml(&diagnosis, &args.recording))?;
    let json = serde_json::to_string_pretty(&diagnosis.to_json(&params_path.display().to_string()))
        .expect("serialisable");
    match &args.json {
        Some(path) => {
            write(path, &(json + "\n"))?;
            out!("{}", summary(&diagnosis, elapsed));
        }
        None => outln!("{json}"),
    }
    if let Some(dir) = &args.report {
        report::write(dir, &diagnosis, &args.recording, &params_path, elapsed)?;
    }
    Ok(())
}

/// Recordings longer than this [s] show a progress bar while they are diagnosed (on a
/// terminal).
const BAR_AFTER_S: f64 = 60.0;

/// The diagnosis's progress drawn as a bar on stderr: units of work done against those
/// found so far (the search finds its trials as it goes, so the length grows).
struct Bar(indicatif::ProgressBar);

impl Progress for Bar {
    fn found(&self, units: u64) {
        self.0.inc_length(units);
    }

    fn done(&self, units: u64) {
        self.0.inc(units);
    }
}

/// A bar for a long recording when stderr is a terminal; None otherwise (quiet in pipes,
/// logs and tests).
fn bar(series: &Series) -> Option<Bar> {
    use std::io::IsTerminal;
    let seconds = series.len() as f64 * series.dt;
    if seconds <= BAR_AFTER_S || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new(0).with_message(format!(
        "diagnosing {} samples ({seconds:.0} s of recording)",
        series.len()
    ));
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} fits, {elapsed}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    Some(Bar(bar))
}

/// The known parameters: `--params`, with the recording's `scheme` / `controller` metadata.
fn base_params(args: &Args, rec: &Recording) -> Result<Params, String> {
    let mut p = match &args.params {
        Some(path) => Params::from_toml_file(path).map_err(|e| e.to_string())?,
        None => Params::default(),
    };
    for key in ["scheme", "controller"] {
        if let Some(item) = rec.meta.get(key) {
            p.set_item(key, item)
                .map_err(|e| format!("{}: metadata: {e}", rec.source))?;
        }
    }
    Ok(p)
}

fn default_params_path(args: &Args) -> PathBuf {
    match &args.json {
        Some(json) => json.with_extension("params.toml"),
        None => args.recording.with_extension("diagnosed.toml"),
    }
}

/// The fitted parameters that differ from the defaults, loadable by `--params` and as FMU
/// start values.
fn params_toml(d: &Diagnosis, recording: &Path) -> String {
    let mut out = format!(
        "# tbm-thrust diagnose {}: verdict {}\n# Fitted parameters that differ from the defaults (SI units; modelDescription/variables.toml).\n",
        recording.display(),
        d.verdict()
    );
    for f in &d.findings {
        out.push_str(&format!(
            "# effect found: {} ({})\n",
            f.effect.id(),
            f.effect.equation()
        ));
    }
    if let Load::Constant(f) = d.load {
        out.push_str(&format!("# the recording has no F_L: fitted constant load {f:.1} N (an input, not a parameter)\n"));
    }
    out.push_str(&d.params.diff_toml());
    out
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    crate::output::write_atomic(path, text)
}

/// A few lines for the terminal.
fn summary(d: &Diagnosis, elapsed: f64) -> String {
    let mut s = format!("verdict: {} ({elapsed:.1} s)\n", d.verdict());
    for f in &d.findings {
        let params: Vec<String> = f
            .parameters
            .iter()
            .map(|(k, v)| format!("{k} = {v:.4e}"))
            .collect();
        s.push_str(&format!("  {}: {}\n", f.effect.id(), params.join(", ")));
    }
    for m in &d.mismatch {
        s.push_str(&format!(
            "  mismatch: {} / {} (share {:.2}): {}\n",
            m.subsystem.name(),
            m.signal,
            m.share,
            m.regime
        ));
    }
    for ((name, b), (_, a)) in d.fit_before.iter().zip(&d.fit_after) {
        s.push_str(&format!(
            "  {name}: R2 {:.4} -> {:.4}, RMSE {:.4e} -> {:.4e}\n",
            b.r2, a.r2, b.rmse, a.rmse
        ));
    }
    for f in &d.floors {
        let rmse = d
            .fit_after
            .iter()
            .find(|(n, _)| *n == f.signal)
            .map_or(f64::NAN, |(_, x)| x.rmse);
        s.push_str(&format!(
            "  floor {}: sensor {:.3e} propagated {:.3e} total {:.3e} ratio {:.2}\n",
            f.signal,
            f.sensor,
            f.propagated,
            f.total(),
            rmse / f.total()
        ));
    }
    for n in &d.notes {
        s.push_str(&format!("  note: {n}\n"));
    }
    s
}
