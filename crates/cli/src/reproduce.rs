//! `tbm-thrust reproduce --out DIR [--json FILE] [--params FILE]`: every comparison of the
//! paper's sections 3.3 and 4. The runs (listed by `tbm_bench::experiments`) go in
//! parallel; this module renders the figures (`figures`) and the Markdown report (`report`).

mod figures;
mod report;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use tbm_bench::experiments::{plan, run_case, Claim, Reproduction};
use tbm_thrust::simulation::DEFAULT_SUBSTEPS;
use tbm_thrust::Params;

#[derive(clap::Args)]
pub struct Args {
    /// Directory for the figures (PNG) and report.md; created if missing.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Also write the summary numbers as JSON to this file.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// TOML parameter file applied over the defaults before every run.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<(), String> {
    let base = match &args.params {
        Some(path) => Params::from_toml_file(path).map_err(|e| e.to_string())?,
        None => Params::default(),
    };
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let reproduction = run_all(&base)?;
    let summary = reproduction.summary();
    let claims = reproduction.claims();
    let written = figures::render_all(&reproduction, &args.out)?;
    let report_path = args.out.join("report.md");
    let source = args.params.as_deref().map(Path::display);
    let text = report::markdown(&reproduction, &summary, &claims, written, source);
    write(&report_path, &text)?;
    if let Some(path) = &args.json {
        let json = serde_json::to_string_pretty(&summary).map_err(|e| e.to_string())?;
        write(path, &(json + "\n"))?;
    }
    print_outcome(&args, &report_path, &claims, written.len());
    Ok(())
}

/// Every planned run, in parallel, with a progress bar on the terminal.
fn run_all(base: &Params) -> Result<Reproduction, String> {
    let cases = plan();
    let bar = ProgressBar::new(cases.len() as u64).with_style(
        ProgressStyle::with_template("simulating {bar:30} {pos}/{len} runs ({elapsed})")
            .map_err(|e| e.to_string())?,
    );
    let runs = cases
        .par_iter()
        .map(|case| {
            let run = run_case(base, case, DEFAULT_SUBSTEPS);
            bar.inc(1);
            run
        })
        .collect();
    bar.finish_and_clear();
    Reproduction::new(runs).map_err(|e| e.to_string())
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

fn print_outcome(args: &Args, report: &Path, claims: &[Claim], figures: usize) {
    outln!(
        "wrote {figures} figures to {} and {}",
        args.out.display(),
        report.display()
    );
    if let Some(json) = &args.json {
        outln!("wrote {}", json.display());
    }
    for claim in claims {
        let mark = if claim.holds { "holds " } else { "FAILS " };
        outln!("{mark} {}: {}", claim.statement, claim.measured);
    }
}
