//! The Markdown report of `reproduce`: the paper's claims, Table 7 beside the paper's
//! numbers, the metrics of every run, and the figures.

use super::figures::Figure;
use std::fmt::{Display, Write};
use tbm_bench::experiments::{
    load_key, Claim, Provenance, Reproduction, Run, Summary, PAPER_TABLE7,
};
use tbm_thrust::metrics::ErrorStats;
use tbm_thrust::Scheme;

/// The whole report; `params` names the parameter file used, if any.
pub fn markdown(
    r: &Reproduction,
    summary: &Summary,
    claims: &[Claim],
    figures: &[Figure],
    params: Option<impl Display>,
) -> String {
    let source = params.map_or(
        "the defaults of modelDescription/variables.toml".to_string(),
        |p| format!("the defaults with `{p}` applied"),
    );
    [
        format!(
            "# Reproduction of Yang et al. (2026), sections 3.3 and 4\n\n\
             Written by `tbm-thrust reproduce` with {source}. Every run is a 20 s start-up from \
             rest at a constant target velocity and load, sampled every 0.01 s; the error \
             statistics are Eq. (34)-(37) over N = 2000 samples, in millimetres.\n"
        ),
        claim_table(claims),
        scorecard(summary),
        table7(summary),
        runs(r),
        figure_list(figures),
    ]
    .join("\n")
}

/// Every number the paper prints beside ours, with the relative error and whether it was a
/// calibration target or is predicted.
fn scorecard(summary: &Summary) -> String {
    let mut s = String::from(
        "## Scorecard: every number the paper prints\n\n\
         Table 7 and section 4.1 are bench measurements; the model is noise-free \
         (docs/reproduce.md). The flow-ratio row compares with the nearer bound of 2-3.\n\n\
         | Quantity | Paper | Model | Relative error | |\n|---|---|---|---|---|\n",
    );
    for c in &summary.scorecard {
        let kind = match c.provenance {
            Provenance::Calibrated => "calibrated",
            Provenance::Predicted => "predicted",
        };
        writeln!(
            s,
            "| {} | {:.3} | {:.3} | {:+.0} % | {kind} |",
            c.quantity,
            c.paper,
            c.model,
            100.0 * c.relative_error
        )
        .unwrap();
    }
    s
}

fn claim_table(claims: &[Claim]) -> String {
    let mut s = String::from(
        "## The paper's qualitative claims\n\n| Claim | Measured | Holds |\n|---|---|---|\n",
    );
    for c in claims {
        let holds = if c.holds { "yes" } else { "**no**" };
        writeln!(s, "| {} | {} | {holds} |", c.statement, c.measured).unwrap();
    }
    s
}

/// Table 7's layout (scheme, load; max, min, mean, S.D.), each with the paper's value and
/// the deviation model - paper.
fn table7(summary: &Summary) -> String {
    let mut s = String::from(
        "## Table 7: displacement error at 0.05 m/s (PID), model vs paper\n\n\
         Each cell: model / paper / deviation (model - paper), all in mm.\n\n\
         | Scheme | Load | Max [mm] | Min [mm] | Mean [mm] | S.D. [mm] |\n\
         |---|---|---|---|---|---|\n",
    );
    for (scheme, load, paper) in PAPER_TABLE7 {
        let rows = match scheme {
            Scheme::Single => &summary.table7.single,
            _ => &summary.table7.adaptive,
        };
        let model = rows[&load_key(load)];
        let name = if scheme == Scheme::Single {
            "single pump"
        } else {
            "adaptive dual pump"
        };
        writeln!(
            s,
            "| {name} | {} kN | {} |",
            load / 1e3,
            cells(&model, &paper)
        )
        .unwrap();
    }
    s
}

fn cells(model: &ErrorStats, paper: &ErrorStats) -> String {
    let cell = |m: f64, p: f64| format!("{m:.3} / {p:.3} / {:+.3}", m - p);
    [
        cell(model.max_mm, paper.max_mm),
        cell(model.min_mm, paper.min_mm),
        cell(model.mean_mm, paper.mean_mm),
        cell(model.sd_mm, paper.sd_mm),
    ]
    .join(" | ")
}

/// Every run with all its metrics.
fn runs(r: &Reproduction) -> String {
    let mut s = String::from(
        "## Every run\n\n\
         Recovery time: when e_x stays within 10 % of its start-up excursion around its steady \
         value. Overshoot: how far x ran ahead of x_ref. Flow ratio: mean Q1 / mean Q2 over \
         10-20 s.\n\n\
         | Run | Max [mm] | Min [mm] | Mean [mm] | S.D. [mm] | Recovery [s] | Overshoot [mm] | Q1:Q2 [-] |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for run in r.runs() {
        writeln!(s, "{}", run_row(run)).unwrap();
    }
    s
}

fn run_row(run: &Run) -> String {
    let m = &run.metrics;
    let e = &m.error;
    let ratio = m.flow_ratio_main_aux.map_or("-".to_string(), ratio_text);
    format!(
        "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {:.3} | {ratio} |",
        run.case.label(),
        e.max_mm,
        e.min_mm,
        e.mean_mm,
        e.sd_mm,
        m.recovery_time_s,
        m.overshoot_mm
    )
}

/// A flow ratio; scientific notation when the auxiliary pump delivers almost nothing.
fn ratio_text(q: f64) -> String {
    if q.abs() < 1e3 {
        format!("{q:.2}")
    } else {
        format!("{q:.1e}")
    }
}

fn figure_list(figures: &[Figure]) -> String {
    let mut s = String::from("## Figures\n\n");
    for f in figures {
        writeln!(s, "{}.\n\n![{}]({})\n", f.caption, f.file, f.file).unwrap();
    }
    s
}
