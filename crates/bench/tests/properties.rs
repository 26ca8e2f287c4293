//! Property tests: no input makes the reader, the data-quality checks or the parameter files
//! panic; every refusal is one line. Inputs are random bytes, random edits of a clean
//! recording (the corpus's `clean.csv`), and random TOML.

use proptest::prelude::*;
use tbm_bench::quality::{screen, spikes, Stretch};
use tbm_bench::recording::{Note, Recording};
use tbm_thrust::Params;

fn clean() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/corpus/clean.csv"
    ))
    .expect("corpus")
}

/// Reads and screens `text`; an error must be one line naming the source.
fn read_and_screen(text: &[u8]) {
    let r = Recording::from_reader(text, "prop.csv");
    match r {
        Ok(rec) => {
            assert!(rec.time.windows(2).all(|w| w[1] > w[0]));
            for name in rec.names() {
                assert!(rec.column(name).unwrap().iter().all(|v| v.is_finite()));
            }
            for stretch in [Stretch::First, Stretch::Longest] {
                if let Err(e) = screen(&rec, &Params::default(), stretch) {
                    let e = e.to_string();
                    assert!(!e.contains('\n') && e.starts_with("prop.csv"), "{e}");
                }
            }
        }
        Err(e) => {
            let e = e.to_string();
            assert!(!e.contains('\n') && e.starts_with("prop.csv"), "{e}");
        }
    }
}

/// A cell text: numbers of every size, the reader's troublemakers, or random text.
fn cell() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f64>().prop_map(|v| v.to_string()),
        (-308i32..308).prop_map(|e| format!("1e{e}")),
        Just("1.7e308".to_string()),
        Just("-1.7e308".to_string()),
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just(String::new()),
        Just("\"3,4e6\"".to_string()),
        Just("\u{0}".to_string()),
        "[ -~]{0,8}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        read_and_screen(&bytes);
    }

    #[test]
    fn random_text_lines_never_panic(lines in proptest::collection::vec("[-0-9a-z,;.#=\" \t\r]{0,40}", 0..60)) {
        read_and_screen(lines.join("\n").as_bytes());
    }

    #[test]
    fn edited_recordings_never_panic(
        edits in proptest::collection::vec((0usize..120, 0usize..9, cell()), 1..6),
        ending in prop_oneof![Just("\n"), Just("\r\n"), Just("\r")],
        truncate in proptest::option::of(0usize..15000),
    ) {
        let text = clean();
        let mut lines: Vec<Vec<String>> = text
            .lines()
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect();
        for (row, col, value) in edits {
            let row = 2 + row % (lines.len() - 2);
            let col = col % lines[row].len();
            lines[row][col] = value;
        }
        let mut out = lines.iter().map(|l| l.join(",")).collect::<Vec<_>>().join(ending);
        if let Some(n) = truncate {
            let n = n.min(out.len());
            let mut cut = n;
            while !out.is_char_boundary(cut) {
                cut -= 1;
            }
            out.truncate(cut);
        }
        read_and_screen(out.as_bytes());
    }

    #[test]
    fn spikes_never_panic(values in proptest::collection::vec(any::<f64>().prop_filter("finite", |v| v.is_finite()), 0..300)) {
        let s = spikes(&values);
        prop_assert!(s.iter().all(|&k| k < values.len()));
    }

    #[test]
    fn one_huge_cell_is_excluded_as_a_spike(row in 5usize..100, col in prop_oneof![Just(3usize), Just(5), Just(2)], exp in 12i32..308) {
        // `x`, `p` or `F_L` of data row `row` replaced by 1e`exp`: the reader excludes it.
        let text = clean();
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let mut cells: Vec<String> = lines[2 + row].split(',').map(str::to_string).collect();
        cells[col] = format!("1e{exp}");
        lines[2 + row] = cells.join(",");
        let rec = Recording::parse(&(lines.join("\n") + "\n"), "prop.csv").unwrap();
        prop_assert_eq!(rec.len(), 120);
        prop_assert!(rec.notes().iter().any(|n| matches!(n, Note::SpikesExcluded { spikes } if spikes.iter().any(|s| s.line == 3 + row))), "{:?}", rec.notes());
    }

    #[test]
    fn parameter_files_never_panic(text in "[a-zA-Z_0-9=\\[\\]\\.\" \\-+\n]{0,80}") {
        let mut p = Params::default();
        if let Err(e) = p.apply_toml(&text) {
            prop_assert!(!e.to_string().contains('\n'));
        }
        prop_assert!(p.validate().is_ok(), "a refused file leaves valid parameters");
    }

    #[test]
    fn parameter_values_never_panic(name in prop_oneof![Just("beta_e".to_string()), Just("scheme".to_string()), Just("b".to_string()), "[a-z_]{1,8}"], value in "[ -~]{0,12}") {
        let mut p = Params::default();
        if let Err(e) = p.set_text(&name, &value) {
            prop_assert!(!e.to_string().contains('\n'));
        }
        prop_assert!(p.validate().is_ok());
    }
}
