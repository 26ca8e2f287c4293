//! Numerics of the paper runs (determinism, solver step) and the `reproduce` command's output.
//! About ten seconds with `cargo test --release`.

use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;
use tbm_bench::experiments::{plan, run_case, Reproduction, Run};
use tbm_thrust::simulation::DEFAULT_SUBSTEPS;
use tbm_thrust::Params;

/// Every sampled number of a run, as bits.
fn bits(run: &Run) -> Vec<u64> {
    let t = &run.trace;
    let inputs = t.inputs.iter().flat_map(|i| i.values());
    let outputs = t.outputs.iter().flat_map(|o| o.values());
    t.time
        .iter()
        .copied()
        .chain(inputs)
        .chain(outputs)
        .map(f64::to_bits)
        .collect()
}

#[test]
fn repeated_runs_are_bit_identical_sequentially_and_in_parallel() {
    let base = Params::default();
    let sequential = Reproduction::compute(&base, DEFAULT_SUBSTEPS);
    // The same cases again, each on its own thread, as `reproduce` runs them.
    let threaded: Vec<Run> = std::thread::scope(|s| {
        let handles: Vec<_> = plan()
            .into_iter()
            .map(|case| {
                let base = &base;
                s.spawn(move || run_case(base, &case, DEFAULT_SUBSTEPS))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a run panicked"))
            .collect()
    });
    assert_eq!(sequential.runs().len(), threaded.len());
    for (a, b) in sequential.runs().iter().zip(&threaded) {
        assert_eq!(a.case, b.case);
        assert!(
            bits(a) == bits(b),
            "{}: the two runs differ",
            a.case.label()
        );
    }
}

/// Halving the solver step may change a metric by at most 1 % of its value, or by this
/// absolute floor when that is larger (for metrics near zero, such as a minimum error of a
/// few micrometres): 5 um for the error statistics (far below the displacement sensor's
/// resolution), 0.02 s (two samples of the 0.01 s grid it is measured on) for the recovery
/// time, and 0.01 for the flow ratio.
const RELATIVE: f64 = 0.01;
const FLOOR_MM: f64 = 0.005;
const FLOOR_S: f64 = 0.02;
const FLOOR_RATIO: f64 = 0.01;

fn floor(path: &str) -> f64 {
    if path.ends_with("_mm") {
        FLOOR_MM
    } else if path.contains("recovery_time_s") {
        FLOOR_S
    } else {
        FLOOR_RATIO
    }
}

/// Every number of a JSON document by its dotted path (null for a non-finite number).
fn flatten(prefix: &str, value: &Value, out: &mut Vec<(String, Option<f64>)>) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                let path = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&path, v, out);
            }
        }
        other => out.push((prefix.to_string(), other.as_f64())),
    }
}

fn paper_metrics(substeps: u32) -> Vec<(String, Option<f64>)> {
    let summary = Reproduction::compute(&Params::default(), substeps).summary();
    let mut out = Vec::new();
    flatten("", &serde_json::to_value(summary).unwrap(), &mut out);
    out
}

#[test]
fn halving_the_solver_step_changes_the_paper_metrics_by_less_than_one_percent() {
    let (coarse, fine) = (
        paper_metrics(DEFAULT_SUBSTEPS),
        paper_metrics(2 * DEFAULT_SUBSTEPS),
    );
    assert_eq!(coarse.len(), fine.len());
    let violations: Vec<String> = coarse
        .iter()
        .zip(&fine)
        .filter(|((path, a), (_, b))| match (a, b) {
            (Some(a), Some(b)) => {
                (a - b).abs() > (RELATIVE * a.abs().max(b.abs())).max(floor(path))
            }
            (a, b) => a.is_some() != b.is_some(),
        })
        .map(|((path, a), (_, b))| {
            format!(
                "{path}: {a:?} ({DEFAULT_SUBSTEPS} RK4 steps per controller period) vs {b:?} ({} steps)",
                2 * DEFAULT_SUBSTEPS
            )
        })
        .collect();
    assert!(
        violations.is_empty(),
        "{} metrics moved:\n{}",
        violations.len(),
        violations.join("\n")
    );
}

/// The figures `reproduce` must write.
const FIGURES: [&str; 7] = [
    "fig03_displacement.png",
    "fig04_error.png",
    "fig05_flows.png",
    "fig06_gains.png",
    "fig11_schemes.png",
    "fig12_loads.png",
    "fig13_controllers.png",
];

fn assert_stats(v: &Value, at: &str) {
    for key in ["max_mm", "min_mm", "mean_mm", "sd_mm"] {
        assert!(v[key].is_number(), "{at}.{key} is not a number: {}", v[key]);
    }
}

fn assert_summary_keys(j: &Value) {
    for scheme in ["single", "adaptive"] {
        for load in ["7", "8", "9", "10"] {
            assert_stats(
                &j["table7"][scheme][load],
                &format!("table7.{scheme}.{load}"),
            );
        }
        assert_stats(&j["adrc"][scheme], &format!("adrc.{scheme}"));
        for v in ["0.01", "0.03", "0.05"] {
            assert_stats(&j["startup"][v][scheme], &format!("startup.{v}.{scheme}"));
        }
        assert!(
            j["recovery_time_s"][scheme].is_number(),
            "recovery_time_s.{scheme}"
        );
    }
    assert_stats(&j["fixed_split"], "fixed_split");
    assert!(j["flow_ratio_main_aux"].is_number(), "flow_ratio_main_aux");
}

#[test]
fn reproduce_writes_every_figure_the_report_and_the_json() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("reproduce-cli");
    let _ = std::fs::remove_dir_all(&dir);
    let json = dir.join("r.json");
    let out = Command::new(env!("CARGO_BIN_EXE_tbm-thrust"))
        .arg("reproduce")
        .arg("--out")
        .arg(&dir)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "reproduce failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in FIGURES {
        let bytes = std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{f} is not a PNG");
    }
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("Table 7") && FIGURES.iter().all(|f| report.contains(f)));
    let text = std::fs::read_to_string(&json).unwrap();
    assert_summary_keys(&serde_json::from_str(&text).expect("valid JSON"));
}

#[test]
fn reproduce_reports_a_bad_parameter_file_in_one_line() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("reproduce-bad-params");
    let out = Command::new(env!("CARGO_BIN_EXE_tbm-thrust"))
        .arg("reproduce")
        .arg("--out")
        .arg(&dir)
        .arg("--params")
        .arg(dir.join("missing.toml"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.starts_with("error: ") && stderr.trim_end().lines().count() == 1,
        "{stderr}"
    );
}
