//! The regression corpus (`tests/corpus/`): every malformed or unusual recording the bench
//! tool was tried on, read as both `identify` and `diagnose` read it (the reader, then the
//! data-quality checks). Each is either accepted, with the note that says what was handled,
//! or refused in one line naming the file and, where there is one, the line.

use std::path::{Path, PathBuf};
use tbm_bench::quality::{screen, Stretch};
use tbm_bench::recording::Recording;
use tbm_thrust::Params;

fn path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/corpus")
        .join(name)
}

/// Reads and screens a corpus file as both tools do: Ok(notes) or Err(one line).
fn outcome(name: &str) -> Result<String, String> {
    let mut results = Vec::new();
    for stretch in [Stretch::First, Stretch::Longest] {
        let r = Recording::read(&path(name))
            .map_err(|e| e.to_string())
            .and_then(|rec| screen(&rec, &Params::default(), stretch).map_err(|e| e.to_string()))
            .map(|s| joined(s.recording.notes()));
        if let Err(e) = &r {
            assert!(!e.contains('\n'), "one line: {e}");
            assert!(e.contains(name), "names the file: {e}");
        }
        results.push(r);
    }
    // Both tools accept or refuse the same recordings.
    assert_eq!(
        results[0].is_ok(),
        results[1].is_ok(),
        "{name}: {results:?}"
    );
    results.remove(0)
}

/// The notes as one line, as a report prints them.
fn joined(notes: &[tbm_bench::recording::Note]) -> String {
    notes
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(" | ")
}

fn accepted(name: &str, note: &str) {
    match outcome(name) {
        Ok(notes) => assert!(notes.contains(note), "{name}: `{note}` not in {notes}"),
        Err(e) => panic!("{name} refused: {e}"),
    }
}

fn refused(name: &str, message: &str) {
    match outcome(name) {
        Ok(notes) => panic!("{name} accepted: {notes}"),
        Err(e) => assert!(e.contains(message), "{name}: `{message}` not in {e}"),
    }
}

#[test]
fn clean_recording_is_accepted_without_quality_notes() {
    let notes = outcome("clean.csv").unwrap();
    assert!(
        !notes.contains("spike") && !notes.contains("gap"),
        "{notes}"
    );
}

#[test]
fn huge_finite_cells_are_spikes_excluded_by_line() {
    accepted("huge_p.csv", "isolated spikes excluded");
    accepted("huge_p.csv", "`p` = 1.000e160 at line 63");
    accepted("huge_f_l.csv", "`F_L` = 1.700e308 at line 43");
}

#[test]
fn a_single_glitch_is_a_spike_not_a_unit_slip() {
    accepted("p_spike_1e10.csv", "`p` = 1.000e10 at line 73");
    accepted("x_glitch_1e10.csv", "`x` = 1.000e10 at line 53");
}

#[test]
fn unit_slips_name_the_right_unit() {
    refused("x_in_cm.csv", "`x` reaches");
    refused("x_in_cm.csv", "looks like cm");
    refused("v_in_mm_per_s.csv", "looks like mm/s");
}

#[test]
fn spreadsheet_artefacts_are_accepted() {
    accepted("quoted_cells.csv", "");
    accepted("trailing_comma_rows.csv", "");
    accepted(
        "trailing_line_of_commas.csv",
        "row(s) of empty cells skipped",
    );
    accepted(
        "extra_text_column.csv",
        "column `operator` is not used (line 3 holds `bob`, not a number)",
    );
    accepted("cr_only.csv", "");
    accepted("crlf_bom.csv", "");
    for name in ["cr_only.csv", "crlf_bom.csv", "quoted_cells.csv"] {
        let rec = Recording::read(&path(name)).unwrap();
        let clean = Recording::read(&path("clean.csv")).unwrap();
        assert_eq!(rec.len(), clean.len(), "{name}");
        assert_eq!(rec.column("p"), clean.column("p"), "{name}");
        assert_eq!(rec.line(5), clean.line(5), "{name}: line numbers");
    }
}

#[test]
fn decimal_commas_get_a_hint() {
    refused("german_excel.csv", "separated by semicolons");
    refused("german_excel.csv", "decimal commas");
    refused(
        "quoted_decimal_comma.csv",
        "line 13 (data row 11), column `p`: `3,4e6` is not a number (a decimal comma?",
    );
}

#[test]
fn bytes_that_are_not_text_are_named_with_their_line() {
    refused("nul_byte.csv", "line 6, byte 11: a NUL byte (\\0)");
    refused("latin1_comment.csv", "line 2: byte 0xFC is not UTF-8");
}

#[test]
fn metadata_the_tools_use_must_be_usable() {
    refused(
        "f_l_metadata_not_a_number.csv",
        "line 2: metadata `F_L = notanumber`: not a number",
    );
}

/// An idle auxiliary pump (single-pump run) reads its meter's noise around zero, half of it
/// negative: that is no sign fault.
#[test]
fn an_idle_pumps_noisy_zero_is_accepted() {
    assert!(outcome("idle_aux_pump_noise.csv").is_ok());
}

#[test]
fn sensor_faults_are_refused() {
    refused("p_sign_flipped.csv", "sign looks flipped");
    refused("x_sign_flipped.csv", "moves against the flow");
    refused("q1_negative.csv", "`Q1` reads");
    refused("x_stuck_at_zero.csv", "`x` stays at 0e0 throughout");
    refused("p_below_load.csv", "below what the load needs");
    refused("all_constant.csv", "nothing moves");
}

#[test]
fn a_gap_splits_the_recording() {
    accepted("gap_5s.csv", "logging gap of 5.010 s before line 73");
    accepted("gap_5s.csv", "only lines 3 to 72");
    let first = screen(
        &Recording::read(&path("gap_5s.csv")).unwrap(),
        &Params::default(),
        Stretch::First,
    )
    .unwrap();
    assert_eq!(first.recording.len(), 70);
    assert!(first.recording.time.windows(2).all(|w| w[1] - w[0] < 0.02));
}

/// `clean.csv` with the `p` cell of each listed data row (0-based) replaced.
fn clean_with_p(rows: &[usize], value: &str) -> String {
    let text = std::fs::read_to_string(path("clean.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for &r in rows {
        let mut cells: Vec<String> = lines[2 + r].split(',').map(str::to_string).collect();
        cells[5] = value.to_string();
        lines[2 + r] = cells.join(",");
    }
    lines.join("\n") + "\n"
}

#[test]
fn many_spikes_are_a_faulty_sensor() {
    let rows: Vec<usize> = (10..60).step_by(10).collect();
    let e = Recording::parse(&clean_with_p(&rows, "1e10"), "bench.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(
            "bench.csv: 5 isolated spikes in 121 samples (`p` at line 13, `p` at line 23"
        ),
        "{e}"
    );
    // Four are glitches, excluded.
    let rec = Recording::parse(&clean_with_p(&rows[..4], "1e10"), "bench.csv").unwrap();
    assert_eq!(rec.len(), 117);
}

#[test]
fn values_beyond_any_bench_signal_are_refused() {
    let text = std::fs::read_to_string(path("clean.csv")).unwrap();
    let rec = Recording::parse(&text, "bench.csv").unwrap();
    let p: Vec<f64> = rec.column("p").unwrap().iter().map(|v| v * 1e3).collect();
    let e = Recording::parse(&rec.with_column("p", p).to_csv(), "bench.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("bench.csv line 3, column `p`: 3.75e9 Pa is beyond any bench signal"),
        "{e}"
    );
}

#[test]
fn a_line_too_long_and_a_zero_padded_log_stop_the_read() {
    let long = format!("time,x,p,Q1,Q2\n{}\n", "1".repeat(70_000));
    let e = Recording::parse(&long, "bench.csv")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "bench.csv line 2: longer than 65536 bytes: not a recording (a binary file, or line endings lost?)"
    );
    // An endless stream of zeros is refused at its first byte, without reading on.
    let e = Recording::from_reader(std::io::repeat(0), "zeros")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("zeros line 1, byte 1: a NUL byte"), "{e}");
    let e = Recording::from_reader(std::io::repeat(b'1'), "ones")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 1: longer than 65536 bytes"), "{e}");
}

#[test]
fn a_gap_after_a_short_first_stretch() {
    // identify needs its first stretch (it replays from rest); diagnose takes the longest.
    let rec = Recording::read(&path("clean.csv")).unwrap();
    let time: Vec<f64> = rec
        .time
        .iter()
        .enumerate()
        .map(|(k, t)| if k >= 10 { t + 5.0 } else { *t })
        .collect();
    let rec = Recording::parse(&rec.with_column("time", time).to_csv(), "bench.csv").unwrap();
    let e = screen(&rec, &Params::default(), Stretch::First).unwrap_err();
    assert_eq!(
        e.to_string(),
        "bench.csv: the first stretch without a logging gap has 10 samples (the gaps are before lines 13); at least 20 are needed"
    );
    let longest = screen(&rec, &Params::default(), Stretch::Longest).unwrap();
    assert_eq!(longest.recording.len(), 111);
}

#[test]
fn a_transient_at_a_load_step_is_not_a_spike() {
    // The piston shoots forward for one sample when the load drops: physics, kept.
    let text = std::fs::read_to_string(path("clean.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for (r, line) in lines.iter_mut().enumerate().skip(2 + 60) {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        cells[2] = "9000.0".into();
        if r == 2 + 60 {
            cells[4] = "0.3".into();
        }
        *line = cells.join(",");
    }
    let rec = Recording::parse(&(lines.join("\n") + "\n"), "bench.csv").unwrap();
    assert_eq!(rec.len(), 121, "{:?}", rec.notes());
    // The same excursion away from any input step is a glitch.
    let text = std::fs::read_to_string(path("clean.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut cells: Vec<String> = lines[2 + 60].split(',').map(str::to_string).collect();
    cells[4] = "0.3".into();
    lines[2 + 60] = cells.join(",");
    let rec = Recording::parse(&(lines.join("\n") + "\n"), "bench.csv").unwrap();
    assert_eq!(rec.len(), 120, "{:?}", rec.notes());
}
