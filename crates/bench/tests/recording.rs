//! Reading recordings: every refusal is one line naming file, line and column; unit slips
//! are reported; uneven sampling and missing optional columns are handled; the replay
//! reproduces the model.

mod common;

use common::scenario;
use std::path::Path;
use tbm_bench::numerics::csv::{self, Column, Number};
use tbm_bench::numerics::rng::{seeded, Draw};
use tbm_bench::recording::{replay, Note, Recording, TraceWriter};
use tbm_thrust::simulation::{run_each, DEFAULT_SUBSTEPS};
use tbm_thrust::units::LPM;
use tbm_thrust::variables::{Inputs, Outputs};
use tbm_thrust::{run, Params};

fn params() -> Params {
    let mut p = Params::default();
    p.set_item("scheme", "single").unwrap();
    p
}

/// A clean 1 s recording of the model (101 samples), with `# scheme = single`.
fn base() -> Recording {
    Recording::from_trace(&run(&params(), &scenario(1.0))).with_meta("scheme", "single")
}

/// The error message for `text`, checked to be one line.
fn error(text: &str) -> String {
    let e = Recording::parse(text, "bench.csv").unwrap_err().to_string();
    assert!(!e.contains('\n'), "one line: {e}");
    assert!(e.starts_with("bench.csv"), "names the file: {e}");
    e
}

/// The CSV with the cell of data row `row` (1-based) in `column` replaced by `text`.
fn with_cell(csv: &str, row: usize, column: &str, text: &str) -> String {
    let mut lines: Vec<String> = csv.lines().map(String::from).collect();
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let col = lines[header].split(',').position(|c| c == column).unwrap();
    let mut cells: Vec<String> = lines[header + row].split(',').map(String::from).collect();
    cells[col] = text.to_string();
    lines[header + row] = cells.join(",");
    lines.join("\n") + "\n"
}

/// The recording with one column scaled (a unit slip).
fn scaled(rec: Recording, column: &str, factor: f64) -> String {
    let v: Vec<f64> = rec
        .column(column)
        .unwrap()
        .iter()
        .map(|x| x * factor)
        .collect();
    rec.with_column(column, v).to_csv()
}

#[test]
fn csv_round_trip_is_exact() {
    let rec = base();
    let back = Recording::parse(&rec.to_csv(), "simulation").unwrap();
    assert_eq!(back.names(), rec.names());
    assert_eq!(back.meta.get("scheme").map(String::as_str), Some("single"));
    for name in rec.names() {
        assert_eq!(back.column(name), rec.column(name), "{name}");
    }
    assert_eq!(back.len(), 101);
    assert!(back.has("uc1") && !back.has("p_t"));
}

/// `simulate`'s recording, written sample by sample as the run goes, is byte for byte the
/// whole-table CSV of the same run held in memory (`time` with 6 decimals, the inputs and
/// outputs with 13 significant digits), as `simulate` wrote it before it streamed.
#[test]
fn a_streamed_run_is_the_whole_table_csv() {
    let (p, sc) = (params(), scenario(2.0));
    let trace = run(&p, &sc);
    let signals: Vec<(&str, Vec<f64>)> = Inputs::NAMES
        .iter()
        .chain(Outputs::NAMES)
        .map(|&n| (n, trace.signal(n).unwrap()))
        .collect();
    let mut columns = vec![Column {
        name: "time",
        values: &trace.time,
        format: Number::Fixed(6),
    }];
    columns.extend(signals.iter().map(|(name, values)| Column {
        name,
        values,
        format: Number::Scientific(12),
    }));
    let meta = [("source", "test"), ("scheme", "single")];
    let whole = csv::write(meta, &columns);
    let mut w = TraceWriter::new(Vec::new(), &meta).unwrap();
    run_each(&p, &sc, DEFAULT_SUBSTEPS, |t, i, o| w.sample(t, i, o)).unwrap();
    assert_eq!(String::from_utf8(w.finish().unwrap()).unwrap(), whole);
}

#[test]
fn missing_required_column() {
    let e = error(&base().without_column("Q2").to_csv());
    assert!(e.starts_with("bench.csv: missing required column `Q2` (required: time, x, p, Q1, Q2; found: time, v_ref"), "{e}");
}

#[test]
fn time_must_increase() {
    let csv = base().to_csv();
    // Data row 10 (line 12 after the metadata line and the header) repeats row 9's time.
    let e = error(&with_cell(&csv, 10, "time", "0.08"));
    assert_eq!(e, "bench.csv line 12 (data row 10), column `time`: 0.08 s does not follow 0.08 s; time must be strictly increasing");
    let e = error(&with_cell(&csv, 3, "time", "0.5"));
    assert!(
        e.starts_with("bench.csv line 6 (data row 4), column `time`: 0.03 s does not follow 0.5 s"),
        "{e}"
    );
}

#[test]
fn empty_nan_and_malformed_cells() {
    let csv = base().to_csv();
    assert_eq!(
        error(&with_cell(&csv, 5, "p", "")),
        "bench.csv line 7 (data row 5), column `p`: empty cell"
    );
    assert_eq!(
        error(&with_cell(&csv, 7, "x", " ")),
        "bench.csv line 9 (data row 7), column `x`: empty cell"
    );
    assert_eq!(
        error(&with_cell(&csv, 6, "Q1", "NaN")),
        "bench.csv line 8 (data row 6), column `Q1`: `NaN` is not a finite number"
    );
    assert!(error(&with_cell(&csv, 6, "v", "inf"))
        .ends_with("column `v`: `inf` is not a finite number"));
    assert_eq!(
        error(&with_cell(&csv, 8, "uc1", "1.2.3")),
        "bench.csv line 10 (data row 8), column `uc1`: `1.2.3` is not a number"
    );
    let columns = base().names().len();
    let e = error(&with_cell(&csv, 8, "p", "3,75"));
    assert!(
        e.contains(&format!(
            "(data row 8): {} fields, but the header has {columns}",
            columns + 1
        )),
        "{e}"
    );
}

#[test]
fn too_few_samples() {
    let csv: String = base()
        .to_csv()
        .lines()
        .take(12)
        .map(|l| format!("{l}\n"))
        .collect();
    assert_eq!(
        error(&csv),
        "bench.csv: only 10 samples; at least 20 are needed"
    );
}

#[test]
fn wrong_delimiter_and_bad_headers() {
    let csv = base().to_csv();
    let e = error(&csv.replace(',', ";"));
    assert_eq!(
        e,
        "bench.csv line 2: fields are separated by semicolons; a recording must be comma-separated"
    );
    assert!(error(&csv.replace(',', "\t")).contains("separated by tabs"));
    assert!(error(&csv.replace(',', " ")).contains("separated by blanks"));
    assert_eq!(
        error("# only = metadata\n\n"),
        "bench.csv: no header row (the file is empty or holds only `#` comments)"
    );
    assert!(error(&csv.replacen("v_ref", "p", 1))
        .ends_with("line 2 (header): column `p` appears twice"));
    let e = error(&csv.replacen(",p,", ",p [bar],", 1));
    assert!(
        e.contains(
            "column `p [bar]` carries a unit; names are exact (`p`) and values SI, not `bar`"
        ),
        "{e}"
    );
    // European CSV: the second data row switches to semicolons.
    let lines: Vec<&str> = csv.lines().collect();
    let mixed = format!(
        "{}\n{}\n{}\n",
        lines[0],
        lines[1],
        lines[2].replace(',', ";")
    );
    assert!(error(&mixed).starts_with("bench.csv line 3: fields are separated by semicolons"));
}

#[test]
fn unit_slips_are_reported_never_used() {
    let slip = |csv: String| {
        let e = Recording::parse(&csv, "bench.csv")
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("bench.csv: units look slipped") && !e.contains('\n'),
            "{e}"
        );
        e
    };
    let e = slip(scaled(base(), "x", 1e3));
    assert!(
        e.contains("units look slipped")
            && e.contains("`x` reaches")
            && e.contains("looks like mm"),
        "{e}"
    );
    // Less than 5 mm of travel (0.2 s of a start-up at 0.02 m/s): the area cross-check
    // catches millimetres.
    let slow = run(&params(), &tbm_thrust::Scenario::startup(0.02, 12_000.0));
    let short = Recording::from_trace(&slow)
        .with_meta("scheme", "single")
        .window(0.0, 0.2);
    let e = slip(scaled(short, "x", 1e3));
    assert!(
        e.contains("implies a piston area") && e.contains("`x` looks like mm"),
        "{e}"
    );
    assert!(
        slip(scaled(base(), "p", 1e-5)).contains("`p` peaks at")
            && slip(scaled(base(), "p", 1e-5)).contains("bar")
    );
    assert!(slip(scaled(base(), "p", 1e-6)).contains("looks like MPa"));
    assert!(slip(scaled(base(), "p", 1e-3)).contains("looks like kPa"));
    let e = slip(scaled(base(), "Q1", LPM));
    assert!(
        e.contains("`Q1` peaks at") && e.contains("looks like L/min"),
        "{e}"
    );
    assert!(
        slip(scaled(base(), "v", 1e3)).contains("`v` peaks at")
            && slip(scaled(base(), "v", 1e3)).contains("mm/s")
    );
    assert!(slip(scaled(base(), "F_L", 1e-3)).contains("looks like kN"));
    assert!(slip(scaled(base(), "time", 1e3)).contains("looks like milliseconds"));
    // x and v disagree by 1000: one of them is not SI.
    let e = slip(scaled(base(), "v", 1e-3));
    assert!(
        e.contains("`x` travels") && e.contains("`v` integrates to"),
        "{e}"
    );
}

#[test]
fn uneven_sampling_is_handled() {
    let rec = base();
    let mut rng = seeded(4);
    let jittered: Vec<f64> = rec
        .time
        .iter()
        .map(|t| t + 0.003 * (rng.unit() - 0.5))
        .collect();
    let rec = Recording::parse(
        &rec.with_column("time", jittered.clone()).to_csv(),
        "bench.csv",
    )
    .unwrap();
    assert!(
        rec.notes()
            .iter()
            .any(|n| matches!(n, Note::UnevenSampling { .. })),
        "{:?}",
        rec.notes()
    );
    let trace = replay(&params(), &rec).unwrap();
    assert_eq!(trace.time, jittered);
    assert!(trace
        .outputs
        .iter()
        .all(|o| o.x.is_finite() && o.p.is_finite()));
}

#[test]
fn missing_optional_columns_are_handled() {
    let full = base();
    let mut rec = full.clone().with_meta("F_L", "12000");
    for c in ["v", "u1", "u2", "uc1", "uc2", "F_L", "x_ref", "e_x"] {
        rec = rec.without_column(c);
    }
    let rec = Recording::parse(&rec.to_csv(), "bench.csv").unwrap();
    let notes = rec
        .notes()
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(" | ");
    assert!(
        notes.contains("optional columns absent (not used): v, x_ref, u1, u2, uc1, uc2, F_L, p_t"),
        "{notes}"
    );
    assert!(notes.contains("no `v`"), "{notes}");
    // The load steps down in the scenario, so the constant metadata load differs later on.
    let trace = replay(&params(), &rec).unwrap();
    let x = full.column("x").unwrap();
    assert!(trace.outputs[..50]
        .iter()
        .zip(x)
        .all(|(o, x)| (o.x - x).abs() < 1e-12));
}

#[test]
fn replay_reproduces_the_model() {
    let rec = base();
    let trace = replay(&params(), &rec).unwrap();
    for name in ["x", "v", "p", "Q1", "Q2", "uc1"] {
        let model = trace.signal(name).unwrap();
        let diff = model
            .iter()
            .zip(rec.column(name).unwrap())
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            diff <= 1e-12 * model.iter().fold(1e-30f64, |m, v| m.max(v.abs())),
            "{name}: {diff}"
        );
    }
    // Only x_ref: v_ref is its slope between samples.
    let only_x_ref = Recording::parse(&rec.clone().without_column("v_ref").to_csv(), "r").unwrap();
    let t2 = replay(&params(), &only_x_ref).unwrap();
    let x = rec.column("x").unwrap();
    assert!(t2
        .outputs
        .iter()
        .zip(x)
        .all(|(o, x)| (o.x - x).abs() < 1e-9));
    // Scheme from the metadata; a wrong one is a one-line error.
    let mut adaptive = params();
    adaptive.set_item("scheme", "adaptive").unwrap();
    let t3 = replay(&adaptive, &rec).unwrap();
    assert_eq!(t3.signal("x"), trace.signal("x"));
    let bad = rec.clone().with_meta("scheme", "dual");
    assert!(replay(&params(), &bad).unwrap_err().to_string().contains(
        "metadata: parameter `scheme` = \"dual\" is not one of single | fixed_split | adaptive"
    ));
    let no_reference = rec.without_column("v_ref").without_column("x_ref");
    assert!(replay(&params(), &no_reference)
        .unwrap_err()
        .to_string()
        .ends_with("neither `v_ref` nor `x_ref`: the closed-loop replay needs the reference"));
}

#[test]
fn unreadable_file() {
    let e = Recording::read(Path::new("/nonexistent/bench.csv"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("/nonexistent/bench.csv: cannot read the recording:"),
        "{e}"
    );
    assert!(!e.contains('\n'));
}
