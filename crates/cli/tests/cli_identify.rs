//! `tbm-thrust identify`: the Table-3-like report, JSON and parameter file; one-line errors.

#[path = "../../bench/tests/common/mod.rs"]
mod common;

use common::{noisy_recording, scenario, truth};
use std::process::Command;
use tbm_thrust::Params;

fn identify(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tbm-thrust"))
        .arg("identify")
        .args(args)
        .output()
        .expect("run tbm-thrust")
}

/// A scratch directory, removed with everything in it when the test ends (pass or fail).
fn temp_dir(label: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("tbm-identify-{label}-"))
        .tempdir()
        .unwrap()
}

#[test]
fn reports_fits_and_writes_json_and_params() {
    let scratch = temp_dir("ok");
    let dir = scratch.path();
    let csv = dir.join("bench.csv");
    std::fs::write(
        &csv,
        noisy_recording(&truth("single"), &scenario(1.5), 7).to_csv(),
    )
    .unwrap();
    let (json, toml) = (dir.join("fit.json"), dir.join("fitted.toml"));
    let o = identify(&[
        csv.to_str().unwrap(),
        "--seed",
        "3",
        "--json",
        json.to_str().unwrap(),
        "--out-params",
        toml.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for needle in [
        "fitted parameters",
        "beta_e",
        "C_ip",
        "N.s/m",
        "R^2",
        "RMSE",
        "MAPE",
        " m/s ",
        " Pa ",
        "cost J",
        "simulations",
        "wall time",
        "pump 1",
    ] {
        assert!(stdout.contains(needle), "missing `{needle}` in\n{stdout}");
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["method"], "default");
    assert_eq!(report["seed"], 3);
    for signal in ["x", "v", "p", "Q1"] {
        assert!(
            report["fit"][signal]["r2"].as_f64().unwrap() > 0.9,
            "{signal}"
        );
    }
    assert_eq!(report["parameters"]["b"]["unit"], "N.s/m");
    assert!(
        report["simulations"].as_u64().unwrap() > 0
            && report["wall_time_s"].as_f64().unwrap() > 0.0
    );
    let fitted = Params::from_toml_file(&toml).unwrap();
    assert_eq!(fitted.get("b"), report["parameters"]["b"]["value"].as_f64());
}

#[test]
fn bad_input_is_one_line_and_nonzero() {
    let scratch = temp_dir("bad");
    let dir = scratch.path();
    let csv = dir.join("bench.csv");
    std::fs::write(&csv, "time;x;p;Q1;Q2\n0;0;0;0;0\n").unwrap();
    for args in [
        vec![csv.to_str().unwrap()],
        vec!["/nonexistent.csv"],
        vec![csv.to_str().unwrap(), "--params", "/nonexistent.toml"],
    ] {
        let o = identify(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.starts_with("error: ") && stderr.trim_end().lines().count() == 1,
            "{stderr}"
        );
    }
}
