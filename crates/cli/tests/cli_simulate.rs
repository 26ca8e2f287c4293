//! `tbm-thrust simulate`: the contract's recording and one-line errors for bad input.

use std::process::Command;

fn simulate(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tbm-thrust"))
        .arg("simulate")
        .args(args)
        .output()
        .expect("run tbm-thrust")
}

#[test]
fn writes_the_contract_recording() {
    let scratch = tempfile::Builder::new()
        .prefix("tbm-sim-")
        .tempdir()
        .unwrap();
    let dir = scratch.path();
    let out = dir.join("run.csv");
    let o = simulate(&[
        "--scheme",
        "single",
        "--v-ref",
        "0.03",
        "--load",
        "9000",
        "--duration",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("max"));
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines().skip_while(|l| l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for col in [
        "time", "x", "p", "Q1", "Q2", "v", "x_ref", "v_ref", "u1", "u2", "uc1", "uc2", "F_L",
    ] {
        assert!(header.contains(&col), "missing column {col}");
    }
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 201, "0..2 s every 0.01 s");
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    assert!((rows[100][col("time")] - 1.0).abs() < 1e-9);
    assert_eq!(rows[100][col("v_ref")], 0.03);
    assert_eq!(rows[100][col("F_L")], 9000.0);
    assert!(
        rows.iter().all(|r| r[col("Q2")] == 0.0),
        "single pump: no auxiliary flow"
    );
    assert!(text.contains("# scheme = single"));
}

#[test]
fn bad_input_gets_one_line_and_a_non_zero_exit() {
    let scratch = tempfile::Builder::new()
        .prefix("tbm-sim-bad-")
        .tempdir()
        .unwrap();
    let bad = scratch.path().join("bad.toml");
    std::fs::write(&bad, "m = [\n").unwrap();
    let cases: [(&[&str], &str); 7] = [
        (&["--scheme", "dual"], "single | fixed_split | adaptive"),
        (&["--set", "m=-1"], "not physical"),
        (&["--set", "A=0"], "not physical"),
        (&["--set", "mass=1"], "unknown parameter `mass`"),
        (&["--v-ref", "NaN"], "finite"),
        (&["--duration", "0"], "--duration"),
        (
            &["--params", bad.to_str().unwrap()],
            "malformed TOML at line 1",
        ),
    ];
    for (args, expected) in cases {
        let mut all = args.to_vec();
        all.extend(["--out", "/tmp/never-written.csv"]);
        let o = simulate(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{args:?}: one line, got {err}"
        );
        assert!(err.contains(expected), "{args:?}: {err}");
    }
}

/// A stiff but legal damping gives finite numbers (the solver step adapts), and a run too
/// short for the metrics says so instead of printing infinities.
#[test]
fn stiff_damping_and_a_too_short_run() {
    let scratch = tempfile::Builder::new()
        .prefix("tbm-sim-stiff-")
        .tempdir()
        .unwrap();
    let dir = scratch.path();
    let out = dir.join("run.csv");
    for b in ["5e5", "1e7"] {
        let set = format!("b={b}");
        let o = simulate(&[
            "--set",
            &set,
            "--duration",
            "2",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let csv = std::fs::read_to_string(&out).unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout);
        for text in [csv.as_str(), &stdout] {
            assert!(
                !text.contains("NaN") && !text.contains("inf"),
                "b = {b}: {stdout}"
            );
        }
    }
    let o = simulate(&["--duration", "0.001", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("no metrics: Eq. 34-37 need at least 2 output samples"),
        "{stdout}"
    );
    assert!(
        !stdout.contains("NaN") && !stdout.contains("inf"),
        "{stdout}"
    );
}
