//! Bench recordings: the contract's recording CSV (`docs/contract.md`, "Recording
//! CSV"), read robustly, and the closed-loop replay of the model against one.
//!
//! A recording is UTF-8, comma-separated, with `# key = value` metadata lines before one
//! header row, SI units, free column order. Required columns: `time` [s] (strictly
//! increasing), `x` [m], `p` [Pa], `Q1`, `Q2` [m^3/s]; optional: `v` [m/s], `x_ref` [m],
//! `v_ref` [m/s], `u1`, `u2` [m^3/s], `uc1`, `uc2` [V], `F_L` [N], `p_t` [Pa]. Other columns
//! (for example the rest of the model's outputs) are kept and not checked.
//!
//! Everything wrong is refused with one [`RecordingError`] line naming the file, the line and
//! the column. Irregularities that can be handled (uneven sampling, missing optional columns,
//! checks that could not run) are listed in [`Recording::notes`].
//!
//! Unit-slip heuristics (a value is refused, never rescaled):
//! - `x`: |x| above 5 m (longer than any thrust-cylinder stroke) looks like millimetres.
//! - `p`: max |p| below 10 kPa cannot be a loaded working chamber in pascals (the Coulomb
//!   friction alone needs more than 100 kPa on a bench cylinder): up to 70 it looks like MPa
//!   or bar, up to 1000 like bar, up to 10 000 like kPa.
//! - `Q1`, `Q2`: above 0.05 m^3/s (3000 L/min; the bench's flow meters end at 80 L/min)
//!   looks like L/min.
//! - `v`: above 2 m/s looks like mm/s. `F_L`: a nonzero load below 50 N looks like kN.
//! - `time`: a median step above 0.5 s looks like milliseconds.
//! - Cross-checks between columns, run when the piston travels more than 50 noise levels:
//!   the piston area implied by the delivered volume over the travel,
//!   integral (Q1 + Q2) dt / (x_end - x_start), must lie in [1e-5, 10] m^2 (a 3.6 mm to
//!   3.6 m bore): a slip by 1000 (mm) or 60 000 (L/min) lands outside; and the travel must
//!   agree with the integral of `v` within a factor of 30.

use crate::numerics::csv::{self, Column, Number};
use crate::numerics::stats::{median, noise_level, peak, trapezoid};
use std::collections::BTreeMap;
use std::fmt;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use tbm_thrust::params::ParamError;
use tbm_thrust::simulation::sample_and_hold;
use tbm_thrust::simulation::Trace;
use tbm_thrust::variables::{by_name, Inputs, Kind, Outputs, Params, Scheme};
use tbm_thrust::Simulator;

/// The columns every recording must have.
pub const REQUIRED: [&str; 5] = ["time", "x", "p", "Q1", "Q2"];
/// The optional columns the tools use.
pub const OPTIONAL: [&str; 9] = [
    "v", "x_ref", "v_ref", "u1", "u2", "uc1", "uc2", "F_L", "p_t",
];
/// Fewest samples a recording may have.
pub const MIN_SAMPLES: usize = 20;

const X_MAX_M: f64 = 5.0;
const P_MIN_PEAK_PA: f64 = 1.0e4;
const Q_MAX_M3S: f64 = 0.05;
const V_MAX_MS: f64 = 2.0;
const F_L_MIN_N: f64 = 50.0;
const DT_MAX_S: f64 = 0.5;
const AREA_RANGE_M2: (f64, f64) = (1.0e-5, 10.0);
const TRAVEL_NOISE_LEVELS: f64 = 50.0;
const V_RATIO_MAX: f64 = 30.0;
/// Magnitudes no bench signal reaches in its SI unit (column, limit, unit): beyond them a
/// value is refused, naming its line, whatever the unit-slip checks say.
const PLAUSIBLE: [(&str, f64, &str); 9] = [
    ("p", 1e9, "Pa"),
    ("p_t", 1e9, "Pa"),
    ("F_L", 1e9, "N"),
    ("u1", 1.0, "m^3/s"),
    ("u2", 1.0, "m^3/s"),
    ("uc1", 1e4, "V"),
    ("uc2", 1e4, "V"),
    ("v_ref", 100.0, "m/s"),
    ("x_ref", 1e3, "m"),
];

/// What is wrong with a recording; `Display` gives one line naming file, line and column.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RecordingError {
    /// The file cannot be read.
    #[error("{file}: cannot read the recording: {message}")]
    Io { file: String, message: String },
    /// Larger than [`MAX_FILE_BYTES`].
    #[error("{file}: {bytes} bytes or more; a recording may have at most {} bytes (docs/identify.md, \"Reading recordings\")", MAX_FILE_BYTES)]
    TooLarge { file: String, bytes: u64 },
    /// A line longer than [`MAX_LINE_BYTES`].
    #[error("{file} line {line}: longer than {} bytes: not a recording (a binary file, or line endings lost?)", MAX_LINE_BYTES)]
    LineTooLong { file: String, line: usize },
    /// A NUL byte: a binary file, or a logger that pads with zeros.
    #[error("{file} line {line}, byte {byte}: a NUL byte (\\0): a recording is text; is this a binary file or a zero-padded log?")]
    NulByte {
        file: String,
        line: usize,
        byte: usize,
    },
    /// Bytes that are not UTF-8 (a Latin-1 or Windows-1252 export).
    #[error("{file} line {line}{}: byte 0x{byte:02X} is not UTF-8 (a Latin-1 or Windows export?): save the file as UTF-8", column.as_ref().map(|c| format!(", column `{c}`")).unwrap_or_default())]
    NotUtf8 {
        file: String,
        line: usize,
        column: Option<String>,
        byte: u8,
    },
    /// No header row (the file is empty or holds only comments).
    #[error("{file}: no header row (the file is empty or holds only `#` comments)")]
    NoHeader { file: String },
    /// A metadata line the tools use (`F_L`, `scheme`, `controller`) with a bad value.
    #[error("{file} line {line}: metadata `{key} = {value}`: {message}")]
    Metadata {
        file: String,
        line: usize,
        key: String,
        value: String,
        message: String,
    },
    /// The rows are not separated by commas.
    #[error("{file} line {line}: fields are separated by {found}; a recording must be comma-separated{}", if *decimal_comma { " (the numbers use decimal commas, as a German spreadsheet exports them: export with `.` decimals and `,` between fields)" } else { "" })]
    Delimiter {
        file: String,
        line: usize,
        found: Separator,
        decimal_comma: bool,
    },
    /// A problem with the header row itself (empty or duplicate name, unit in a name).
    #[error("{file} line {line} (header): {message}")]
    Header {
        file: String,
        line: usize,
        message: String,
    },
    #[error("{file}: missing required column `{column}` (required: {}; found: {})", REQUIRED.join(", "), found.join(", "))]
    MissingColumn {
        file: String,
        column: String,
        found: Vec<String>,
    },
    #[error("{file} line {line} (data row {row}): {found} fields, but the header has {expected}{}", if *decimal_comma { " (a decimal comma, as in `3,75`, splits a number in two: numbers must use `.`)" } else { "" })]
    FieldCount {
        file: String,
        line: usize,
        row: usize,
        found: usize,
        expected: usize,
        decimal_comma: bool,
    },
    #[error("{file} line {line} (data row {row}), column `{column}`: empty cell")]
    EmptyCell {
        file: String,
        line: usize,
        row: usize,
        column: String,
    },
    #[error(
        "{file} line {line} (data row {row}), column `{column}`: `{text}` is not a finite number"
    )]
    NotFinite {
        file: String,
        line: usize,
        row: usize,
        column: String,
        text: String,
    },
    #[error("{file} line {line} (data row {row}), column `{column}`: `{text}` is not a number{}", if *decimal_comma { " (a decimal comma? numbers must use `.`, as in `3.75`)" } else { "" })]
    Malformed {
        file: String,
        line: usize,
        row: usize,
        column: String,
        text: String,
        decimal_comma: bool,
    },
    #[error("{file} line {line} (data row {row}), column `time`: {time} s does not follow {previous} s; time must be strictly increasing")]
    TimeNotIncreasing {
        file: String,
        line: usize,
        row: usize,
        previous: f64,
        time: f64,
    },
    #[error("{file}: only {found} samples; at least {min} are needed")]
    TooFewSamples {
        file: String,
        found: usize,
        min: usize,
    },
    /// Values whose magnitude says they are not in the contract's SI unit.
    #[error("{file}: units look slipped (the recording must be in SI units): {}", findings.join("; "))]
    UnitSlip { file: String, findings: Vec<String> },
    /// A value no bench signal reaches (see `PLAUSIBLE`).
    #[error("{file} line {line}, column `{column}`: {value:e} {unit} is beyond any bench signal (|{column}| <= {limit:e} {unit})")]
    Implausible {
        file: String,
        line: usize,
        column: String,
        value: f64,
        limit: f64,
        unit: &'static str,
    },
    /// More isolated spikes than glitches explain: a faulty sensor or logger.
    #[error("{file}: {found} isolated spikes in {samples} samples ({}{}): more than sensor glitches; check the sensor and the logger", lines.iter().take(5).map(|(l, c)| format!("`{c}` at line {l}")).collect::<Vec<_>>().join(", "), if lines.len() > 5 { ", ..." } else { "" })]
    TooManySpikes {
        file: String,
        found: usize,
        samples: usize,
        lines: Vec<(usize, &'static str)>,
    },
}

/// The metadata the tools read must be usable, so that every command accepts the same
/// recordings: `F_L` a finite number, `scheme` and `controller` an item of their lists.
fn check_metadata(
    meta: &BTreeMap<String, String>,
    lines: &BTreeMap<String, usize>,
    source: &str,
) -> Result<(), RecordingError> {
    for (key, value) in meta {
        let message = match key.as_str() {
            "F_L" => match value.parse::<f64>() {
                Ok(f) if f.is_finite() => continue,
                Ok(_) => "not a finite number".to_string(),
                Err(_) => "not a number [N]".to_string(),
            },
            "scheme" | "controller" => match Params::default().set_item(key, value) {
                Ok(()) => continue,
                Err(e) => e.to_string(),
            },
            _ => continue,
        };
        return Err(RecordingError::Metadata {
            file: source.to_string(),
            line: lines[key],
            key: key.clone(),
            value: shown(value),
            message,
        });
    }
    Ok(())
}

/// One sample the reader left out as an isolated spike.
#[derive(Clone, Debug, PartialEq)]
pub struct Spike {
    pub column: &'static str,
    pub value: f64,
    pub line: usize,
}

/// Which stretch between logging gaps a tool uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stretch {
    /// The first: `identify` replays from rest at the first sample.
    First,
    /// The longest: `diagnose` replays segments from their recorded states.
    Longest,
}

/// What the reader and the data-quality screen handled or could not check: code decides on
/// the variant, reports print the sentence (units in the fields' names).
#[derive(Clone, Debug, PartialEq)]
pub enum Note {
    /// A column of text, kept out of every fit.
    UnusedColumn {
        column: String,
        line: usize,
        text: String,
    },
    /// Rows of empty cells (a spreadsheet artefact), skipped.
    EmptyRows { count: usize, first_line: usize },
    /// Isolated spikes (sensor glitches), left out of every fit and check.
    SpikesExcluded { spikes: Vec<Spike> },
    /// Too little travel for the unit cross-checks.
    CrossChecksSkipped { travel_m: f64, noise_m: f64 },
    /// No flow delivered: the area cross-check was skipped.
    NoFlowDelivered,
    /// Optional columns that are absent.
    OptionalColumnsAbsent { columns: Vec<&'static str> },
    /// No `v` column.
    NoVelocity,
    /// Sample steps that vary; the model is sampled at the recording's own times.
    UnevenSampling {
        min_step_s: f64,
        max_step_s: f64,
        median_step_s: f64,
    },
    /// `x` does not start at zero.
    XOffset { x0_m: f64 },
    /// A logging gap before `line`: the recording is split there.
    Gap {
        line: usize,
        step_s: f64,
        median_s: f64,
    },
    /// The stretch between gaps that is used: lines `first..=last`, `t0_s..t1_s`.
    StretchUsed {
        first: usize,
        last: usize,
        t0_s: f64,
        t1_s: f64,
        why: Stretch,
    },
}

impl std::fmt::Display for Note {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Note::UnusedColumn { column, line, text } => write!(
                f,
                "column `{column}` is not used (line {line} holds `{text}`, not a number)"
            ),
            Note::EmptyRows { count, first_line } => write!(
                f,
                "{count} row(s) of empty cells skipped (a spreadsheet artefact), from line {first_line}"
            ),
            Note::SpikesExcluded { spikes } => {
                let listed: Vec<String> = spikes
                    .iter()
                    .map(|s| format!("`{}` = {:.3e} at line {}", s.column, s.value, s.line))
                    .collect();
                write!(
                    f,
                    "isolated spikes excluded (sensor glitches; those samples are neither fitted nor checked): {}",
                    listed.join(", ")
                )
            }
            Note::CrossChecksSkipped { travel_m, noise_m } => write!(
                f,
                "the piston travels {travel_m:.3e} m (noise {noise_m:.1e} m): area and velocity cross-checks of the units skipped"
            ),
            Note::NoFlowDelivered => write!(
                f,
                "no pump flow delivered: the area cross-check of the units skipped"
            ),
            Note::OptionalColumnsAbsent { columns } => write!(
                f,
                "optional columns absent (not used): {}",
                columns.join(", ")
            ),
            Note::NoVelocity => write!(
                f,
                "no `v`: velocity neither fitted nor checked against `x`"
            ),
            Note::UnevenSampling {
                min_step_s,
                max_step_s,
                median_step_s,
            } => write!(
                f,
                "uneven sampling: steps from {min_step_s:.3e} s to {max_step_s:.3e} s (median {median_step_s:.3e} s); the model is sampled at the recording's own times"
            ),
            Note::XOffset { x0_m } => write!(
                f,
                "`x` starts at {x0_m} m; the model starts at rest at x = 0, so a zero offset of the sensor shows as a displacement error"
            ),
            Note::Gap {
                line,
                step_s,
                median_s,
            } => write!(
                f,
                "logging gap of {step_s:.3} s before line {line} (median step {median_s:.3e} s): the recording is split there, never interpolated across"
            ),
            Note::StretchUsed {
                first,
                last,
                t0_s,
                t1_s,
                why,
            } => write!(
                f,
                "only lines {first} to {last} ({t0_s} s to {t1_s} s) are used: {}",
                match why {
                    Stretch::First => "the first stretch without a gap (the replay starts from rest at its first sample)",
                    Stretch::Longest => "the longest stretch without a gap",
                }
            ),
        }
    }
}

/// A bench recording: time, named SI columns and `# key = value` metadata.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// Sample times [s], strictly increasing.
    pub time: Vec<f64>,
    /// `# key = value` lines before the header (e.g. `scheme`, `controller`, `F_L`).
    pub meta: BTreeMap<String, String>,
    /// Where the recording came from (file path or a label), used in messages.
    pub source: String,
    /// Every column except `time`, in file order.
    columns: Vec<(String, Vec<f64>)>,
    notes: Vec<Note>,
    /// The file line of each sample, for messages.
    lines: Vec<usize>,
}

/// Longest line the reader accepts [bytes]: a header of every contract column is about
/// 100 bytes and a data row of 30 columns about 700, so 64 KiB is a file that is not a
/// recording (a binary file, or one whose line endings were lost).
pub const MAX_LINE_BYTES: usize = 64 * 1024;
/// Largest recording the reader accepts [bytes]: one hour at 1 kHz with 25 columns is about
/// 1.6 GB of text; the columns take about 0.4 bytes of memory per byte of text.
pub const MAX_FILE_BYTES: u64 = 2 << 30;

/// What the guarded byte stream found; carried inside an `io::Error` through the CSV parser.
#[derive(Clone, Copy, Debug, PartialEq)]
enum StreamFault {
    Nul { line: usize, byte: usize },
    LineTooLong { line: usize },
    TooLarge { bytes: u64 },
}

impl fmt::Display for StreamFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self:?}")
    }
}

impl std::error::Error for StreamFault {}

/// A byte stream checked as it is read, so that memory and time stay bounded whatever the
/// file holds: a NUL byte, a line longer than [`MAX_LINE_BYTES`] or more than
/// [`MAX_FILE_BYTES`] stop the read at once. Line endings are normalised to `\n` (CR-only
/// files from old spreadsheets, CRLF from Windows), so line numbers count every ending.
struct Guarded<R> {
    inner: R,
    total: u64,
    line: usize,
    line_len: usize,
    /// The previous chunk ended in `\r` (already emitted as `\n`): drop a leading `\n`.
    after_cr: bool,
}

impl<R: Read> Guarded<R> {
    fn new(inner: R) -> Guarded<R> {
        Guarded {
            inner,
            total: 0,
            line: 1,
            line_len: 0,
            after_cr: false,
        }
    }
}

impl<R: Read> Read for Guarded<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        loop {
            let n = self.inner.read(buf)?;
            if n == 0 {
                return Ok(0);
            }
            self.total += n as u64;
            if self.total > MAX_FILE_BYTES {
                return Err(fault(StreamFault::TooLarge { bytes: self.total }));
            }
            let mut w = 0;
            for r in 0..n {
                let b = buf[r];
                if std::mem::take(&mut self.after_cr) && b == b'\n' {
                    continue;
                }
                let out = match b {
                    0 => {
                        return Err(fault(StreamFault::Nul {
                            line: self.line,
                            byte: self.line_len + 1,
                        }))
                    }
                    b'\r' => {
                        self.after_cr = true;
                        b'\n'
                    }
                    b => b,
                };
                if out == b'\n' {
                    self.line += 1;
                    self.line_len = 0;
                } else {
                    self.line_len += 1;
                    if self.line_len > MAX_LINE_BYTES {
                        return Err(fault(StreamFault::LineTooLong { line: self.line }));
                    }
                }
                buf[w] = out;
                w += 1;
            }
            if w > 0 {
                return Ok(w);
            }
        }
    }
}

fn fault(f: StreamFault) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidData, f)
}

/// The stream fault inside an I/O error, if it is one.
fn stream_fault(e: &std::io::Error) -> Option<StreamFault> {
    e.get_ref()
        .and_then(|inner| inner.downcast_ref::<StreamFault>())
        .copied()
}

/// Text of a cell for a message: control characters (a NUL, a tab) made visible.
fn shown(text: &str) -> String {
    text.chars()
        .flat_map(|c| {
            if c.is_control() {
                c.escape_default().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

/// What separates the fields of a line that is not comma-separated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Separator {
    Semicolons,
    Tabs,
    VerticalBars,
    Blanks,
    /// Nothing: the line is one field.
    Nothing,
}

impl fmt::Display for Separator {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(match self {
            Separator::Semicolons => "semicolons",
            Separator::Tabs => "tabs",
            Separator::VerticalBars => "vertical bars",
            Separator::Blanks => "blanks",
            Separator::Nothing => "nothing (one column only)",
        })
    }
}

/// The separator a header line uses instead of commas, if any.
fn foreign_delimiter(line: &str) -> Option<Separator> {
    for (c, found) in [
        (';', Separator::Semicolons),
        ('\t', Separator::Tabs),
        ('|', Separator::VerticalBars),
    ] {
        if line.contains(c) {
            return Some(found);
        }
    }
    (line.split_whitespace().count() > 1).then_some(Separator::Blanks)
}

/// Whether a text reads as a number written with a decimal comma (`3,75`, `-0,5e6`).
fn decimal_comma(text: &str) -> bool {
    let t = text.trim().trim_start_matches(['+', '-']);
    let Some((int, frac)) = t.split_once(',') else {
        return false;
    };
    let frac = frac.split(['e', 'E']).next().unwrap_or("");
    !int.is_empty()
        && int.bytes().all(|b| b.is_ascii_digit())
        && !frac.is_empty()
        && frac.bytes().all(|b| b.is_ascii_digit())
        && t.replacen(',', ".", 1).parse::<f64>().is_ok()
}

/// The name a header field would have without a unit suffix like `x [mm]` or `p (bar)`.
fn strip_unit(name: &str) -> Option<(&str, &str)> {
    let open = name.find(['[', '('])?;
    let base = name[..open].trim();
    let unit = name[open..].trim_matches(|c| "[]() ".contains(c));
    Some((base, unit))
}

/// A column while the rows are read: the tools' columns must hold numbers in every row;
/// any other column is kept while it does and dropped (noted) at its first other cell.
enum ReadColumn {
    Numbers(Vec<f64>),
    Unused { line: usize, text: String },
}

/// A stream fault of [`Guarded`] or an I/O error, as the recording error that names it.
fn stream_error(source: &str, e: std::io::Error) -> RecordingError {
    let file = source.to_string();
    match stream_fault(&e) {
        Some(StreamFault::Nul { line, byte }) => RecordingError::NulByte { file, line, byte },
        Some(StreamFault::LineTooLong { line }) => RecordingError::LineTooLong { file, line },
        Some(StreamFault::TooLarge { bytes }) => RecordingError::TooLarge { file, bytes },
        None => RecordingError::Io {
            file,
            message: e.to_string(),
        },
    }
}

/// What comes before the rows: the `# key = value` metadata (with the line of each key)
/// and the header row.
struct Preamble {
    meta: BTreeMap<String, String>,
    meta_lines: BTreeMap<String, usize>,
    header_line: usize,
    header: String,
}

/// Reads comments and metadata up to the first other non-blank line, the header (a UTF-8
/// byte-order mark on the first line is skipped).
fn read_preamble(input: &mut impl BufRead, source: &str) -> Result<Preamble, RecordingError> {
    let mut meta = BTreeMap::new();
    let mut meta_lines = BTreeMap::new();
    let mut n = 0;
    let mut buf = Vec::new();
    loop {
        buf.clear();
        let read = input
            .read_until(b'\n', &mut buf)
            .map_err(|e| stream_error(source, e))?;
        if read == 0 {
            return Err(RecordingError::NoHeader {
                file: source.to_string(),
            });
        }
        n += 1;
        let bytes = if n == 1 {
            buf.strip_prefix("\u{feff}".as_bytes()).unwrap_or(&buf)
        } else {
            &buf
        };
        let line = std::str::from_utf8(bytes).map_err(|e| RecordingError::NotUtf8 {
            file: source.to_string(),
            line: n,
            column: None,
            byte: bytes[e.valid_up_to()],
        })?;
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        let Some(comment) = trimmed.strip_prefix('#') else {
            return Ok(Preamble {
                meta,
                meta_lines,
                header_line: n,
                header: line.trim_end_matches('\n').to_string(),
            });
        };
        if let Some((key, value)) = metadata(comment) {
            meta.insert(key.to_string(), value.to_string());
            meta_lines.insert(key.to_string(), n);
        }
    }
}

/// A comment's `key = value` (a key without spaces; a quoted value unquoted).
fn metadata(comment: &str) -> Option<(&str, &str)> {
    let (k, v) = comment.split_once('=')?;
    let key = k.trim();
    if key.is_empty() || key.contains(char::is_whitespace) {
        return None;
    }
    let v = v.trim();
    let value = v
        .strip_prefix('"')
        .and_then(|r| r.strip_suffix('"'))
        .map_or(v, str::trim);
    Some((key, value))
}

/// The header's column names, checked: separated by commas, each named once, the tools'
/// columns without a unit suffix, every required column present. A header that does not
/// split on commas is refused with the separator it uses (and, for semicolons, whether the
/// next line's numbers carry decimal commas: a German spreadsheet export).
fn header_names(
    preamble: &Preamble,
    input: &mut impl BufRead,
    source: &str,
) -> Result<Vec<String>, RecordingError> {
    let mut names: Vec<String> = ::csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(::csv::Trim::All)
        .from_reader(preamble.header.as_bytes())
        .records()
        .next()
        .and_then(Result::ok)
        .map(|r| r.iter().map(str::to_string).collect())
        .unwrap_or_default();
    if names.len() <= 1 {
        return Err(delimiter_error(preamble, input, source));
    }
    // A trailing comma gives empty trailing names; rows may then carry empty trailing cells.
    while names.last().is_some_and(|n| n.is_empty()) {
        names.pop();
    }
    check_names(&names).map_err(|message| RecordingError::Header {
        file: source.to_string(),
        line: preamble.header_line,
        message,
    })?;
    if let Some(required) = REQUIRED.iter().find(|r| !names.iter().any(|n| n == *r)) {
        return Err(RecordingError::MissingColumn {
            file: source.to_string(),
            column: (*required).into(),
            found: names.iter().map(|n| shown(n)).collect(),
        });
    }
    Ok(names)
}

/// A header that does not split on commas: the separator it uses and, for semicolons,
/// whether the next line's numbers carry decimal commas (a German spreadsheet export).
fn delimiter_error(preamble: &Preamble, input: &mut impl BufRead, source: &str) -> RecordingError {
    let found = foreign_delimiter(&preamble.header).unwrap_or(Separator::Nothing);
    let mut hint = false;
    if found == Separator::Semicolons {
        let mut buf = Vec::new();
        if input.read_until(b'\n', &mut buf).is_ok() {
            hint = String::from_utf8_lossy(&buf).split(';').any(decimal_comma);
        }
    }
    RecordingError::Delimiter {
        file: source.to_string(),
        line: preamble.header_line,
        found,
        decimal_comma: hint,
    }
}

/// Every column named, once, and the tools' columns without a unit suffix.
fn check_names(names: &[String]) -> Result<(), String> {
    for (i, n) in names.iter().enumerate() {
        if n.is_empty() {
            return Err(format!("column {} has no name", i + 1));
        }
        if names[..i].contains(n) {
            return Err(format!("column `{}` appears twice", shown(n)));
        }
        if let Some((base, unit)) = strip_unit(n) {
            if used(base) {
                return Err(format!(
                    "column `{}` carries a unit; names are exact (`{base}`) and values SI, not `{}`",
                    shown(n),
                    shown(unit)
                ));
            }
        }
    }
    Ok(())
}

/// Whether the tools read the column (required or optional).
fn used(name: &str) -> bool {
    REQUIRED.contains(&name) || OPTIONAL.contains(&name)
}

/// The data rows as read: each column's values, each row's line, the lines of empty rows
/// (skipped) and the number of rows.
struct Rows {
    data: Vec<ReadColumn>,
    lines: Vec<usize>,
    empty_rows: Vec<usize>,
    count: usize,
}

/// Reads the rows after the header, streaming: blank lines and lines of commas only (a
/// spreadsheet's empty row) skipped, every row's cells parsed ([`push_cells`]) and the time
/// checked to increase.
fn read_rows(
    input: impl Read,
    names: &[String],
    header_line: usize,
    source: &str,
) -> Result<Rows, RecordingError> {
    let t_col = names
        .iter()
        .position(|n| n == "time")
        .expect("time is required");
    let mut rows = Rows {
        data: names
            .iter()
            .map(|_| ReadColumn::Numbers(Vec::new()))
            .collect(),
        lines: Vec::new(),
        empty_rows: Vec::new(),
        count: 0,
    };
    let mut reader = ::csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .comment(Some(b'#'))
        .trim(::csv::Trim::All)
        .from_reader(input);
    let mut record = ::csv::ByteRecord::new();
    while next_record(&mut reader, &mut record, source)? {
        let line = header_line + record.position().map_or(0, |p| p.line() as usize);
        if record.iter().all(<[u8]>::is_empty) {
            if record.len() > 1 {
                rows.empty_rows.push(line);
            }
            continue;
        }
        rows.count += 1;
        let at = (line, rows.count);
        let fields = row_fields(&record, names, at, source)?;
        push_cells(&fields, names, &mut rows.data, at, source)?;
        rows.lines.push(line);
        if let ReadColumn::Numbers(t) = &rows.data[t_col] {
            check_time_step(t, at, source)?;
        }
    }
    Ok(rows)
}

/// Reads the next record; false at the end of the stream.
fn next_record<R: Read>(
    reader: &mut ::csv::Reader<R>,
    record: &mut ::csv::ByteRecord,
    source: &str,
) -> Result<bool, RecordingError> {
    reader
        .read_byte_record(record)
        .map_err(|e| match e.into_kind() {
            ::csv::ErrorKind::Io(e) => stream_error(source, e),
            other => RecordingError::Io {
                file: source.to_string(),
                message: format!("{other:?}"),
            },
        })
}

/// A row's cells as text, as many as the header names (trailing empty cells of a trailing
/// comma dropped). `(line, row)` place it in messages.
fn row_fields<'a>(
    record: &'a ::csv::ByteRecord,
    names: &[String],
    (line, row): (usize, usize),
    source: &str,
) -> Result<Vec<&'a str>, RecordingError> {
    let mut fields: Vec<&str> = Vec::with_capacity(record.len());
    for (i, field) in record.iter().enumerate() {
        fields.push(
            std::str::from_utf8(field).map_err(|e| RecordingError::NotUtf8 {
                file: source.to_string(),
                line,
                column: names.get(i).cloned(),
                byte: field[e.valid_up_to()],
            })?,
        );
    }
    if fields.len() == 1 {
        if let Some(found) = foreign_delimiter(fields[0]) {
            return Err(RecordingError::Delimiter {
                file: source.to_string(),
                line,
                found,
                decimal_comma: false,
            });
        }
    }
    while fields.len() > names.len() && fields.last().is_some_and(|f| f.is_empty()) {
        fields.pop();
    }
    if fields.len() != names.len() {
        return Err(RecordingError::FieldCount {
            file: source.to_string(),
            line,
            row,
            found: fields.len(),
            expected: names.len(),
            decimal_comma: fields.len() > names.len() && split_number(&fields),
        });
    }
    Ok(fields)
}

/// Whether two neighbouring cells read as the integer and fraction of one number split at a
/// decimal comma (`3,4` read as `3` and `4`).
fn split_number(fields: &[&str]) -> bool {
    fields.windows(2).any(|w| {
        !w[0].is_empty()
            && w[0]
                .trim_start_matches(['+', '-'])
                .bytes()
                .all(|b| b.is_ascii_digit())
            && !w[1].is_empty()
            && w[1].bytes().all(|b| b.is_ascii_digit())
    })
}

/// Parses a row's cells into their columns: a tools' column must hold a finite number; any
/// other column is dropped (noted) at its first cell that does not.
fn push_cells(
    fields: &[&str],
    names: &[String],
    data: &mut [ReadColumn],
    (line, row): (usize, usize),
    source: &str,
) -> Result<(), RecordingError> {
    for ((cell, name), column) in fields.iter().zip(names).zip(data.iter_mut()) {
        let ReadColumn::Numbers(values) = column else {
            continue;
        };
        let file = || source.to_string();
        let value = match cell.parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            _ if !used(name) => {
                *column = ReadColumn::Unused {
                    line,
                    text: shown(cell),
                };
                continue;
            }
            _ if cell.is_empty() => {
                return Err(RecordingError::EmptyCell {
                    file: file(),
                    line,
                    row,
                    column: name.clone(),
                })
            }
            Ok(_) => {
                return Err(RecordingError::NotFinite {
                    file: file(),
                    line,
                    row,
                    column: name.clone(),
                    text: shown(cell),
                })
            }
            Err(_) => {
                return Err(RecordingError::Malformed {
                    file: file(),
                    line,
                    row,
                    column: name.clone(),
                    text: shown(cell),
                    decimal_comma: decimal_comma(cell),
                })
            }
        };
        values.push(value);
    }
    Ok(())
}

/// Refuses a time that does not increase over its predecessor (the last two values of `t`).
fn check_time_step(
    t: &[f64],
    (line, row): (usize, usize),
    source: &str,
) -> Result<(), RecordingError> {
    match t {
        [.., previous, time] if time <= previous => Err(RecordingError::TimeNotIncreasing {
            file: source.to_string(),
            line,
            row,
            previous: *previous,
            time: *time,
        }),
        _ => Ok(()),
    }
}

impl Recording {
    /// Reads and checks a recording file (the contract's CSV), streaming: memory stays
    /// bounded by the columns read, and a file that is not text stops the read at once.
    pub fn read(path: &Path) -> Result<Recording, RecordingError> {
        let source = path.display().to_string();
        let io = |e: std::io::Error| RecordingError::Io {
            file: source.clone(),
            message: e.to_string(),
        };
        let file = std::fs::File::open(path).map_err(io)?;
        let meta = file.metadata().map_err(io)?;
        if meta.is_dir() {
            return Err(RecordingError::Io {
                file: source,
                message: "it is a directory".into(),
            });
        }
        if meta.is_file() && meta.len() > MAX_FILE_BYTES {
            return Err(RecordingError::TooLarge {
                file: source,
                bytes: meta.len(),
            });
        }
        Recording::from_reader(file, &source)
    }

    /// Parses and checks a recording held in memory; `source` names it in messages.
    pub fn parse(text: &str, source: &str) -> Result<Recording, RecordingError> {
        Recording::from_reader(text.as_bytes(), source)
    }

    /// Parses and checks a recording from any byte stream (see [`Recording::read`]).
    pub fn from_reader(input: impl Read, source: &str) -> Result<Recording, RecordingError> {
        let mut input = BufReader::new(Guarded::new(input));
        let preamble = read_preamble(&mut input, source)?;
        check_metadata(&preamble.meta, &preamble.meta_lines, source)?;
        let names = header_names(&preamble, &mut input, source)?;
        let rows = read_rows(input, &names, preamble.header_line, source)?;
        if rows.count < MIN_SAMPLES {
            return Err(RecordingError::TooFewSamples {
                file: source.to_string(),
                found: rows.count,
                min: MIN_SAMPLES,
            });
        }
        let mut notes = Vec::new();
        let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
        let mut time = Vec::new();
        for (name, column) in names.into_iter().zip(rows.data) {
            match column {
                ReadColumn::Numbers(v) if name == "time" => time = v,
                ReadColumn::Numbers(v) => columns.push((name, v)),
                ReadColumn::Unused { line, text } => notes.push(Note::UnusedColumn {
                    column: shown(&name).to_string(),
                    line,
                    text,
                }),
            }
        }
        if let Some(&first_line) = rows.empty_rows.first() {
            notes.push(Note::EmptyRows {
                count: rows.empty_rows.len(),
                first_line,
            });
        }
        let rec = Recording {
            time,
            meta: preamble.meta,
            source: source.to_string(),
            columns,
            notes,
            lines: rows.lines,
        };
        rec.checked()
    }

    /// The checks after parsing: isolated spikes excluded (or refused when there are too
    /// many), then unit slips and implausible magnitudes on what is left, then the notes.
    fn checked(self) -> Result<Recording, RecordingError> {
        let mut rec = self.without_spikes()?;
        let findings = rec.check_units();
        if !findings.is_empty() {
            return Err(RecordingError::UnitSlip {
                file: rec.source,
                findings,
            });
        }
        rec.check_magnitudes()?;
        rec.note_columns();
        Ok(rec)
    }

    /// The samples within three of a step of an input (the load, the reference): the piston
    /// moves for real within a sample or two of one, and what departs there is physics, not
    /// a glitch.
    fn near_input_steps(&self) -> Vec<bool> {
        let mut stepped = vec![false; self.len()];
        for name in ["F_L", "v_ref"] {
            if let Some(u) = self.column(name) {
                let (lo, hi) = crate::numerics::stats::extremes(u);
                let step = (0.02 * (hi - lo)).max(10.0 * noise_level(u));
                for k in 1..u.len() {
                    if (u[k] - u[k - 1]).abs() > step {
                        let (a, b) = (k.saturating_sub(3), (k + 3).min(u.len()));
                        stepped[a..b].iter_mut().for_each(|s| *s = true);
                    }
                }
            }
        }
        stepped
    }

    /// The recording without its isolated spikes (away from input steps but in the load),
    /// with a note on each; refused when there are too many or too few samples are left.
    fn without_spikes(mut self) -> Result<Recording, RecordingError> {
        let stepped = self.near_input_steps();
        let mut spiky: Vec<(usize, &'static str)> = Vec::new();
        for name in crate::quality::SPIKE_COLUMNS {
            if let Some(v) = self.column(name) {
                spiky.extend(
                    crate::quality::spikes(v)
                        .into_iter()
                        .filter(|&k| name == "F_L" || !stepped[k])
                        .map(|k| (k, name)),
                );
            }
        }
        spiky.sort();
        if spiky.is_empty() {
            return Ok(self);
        }
        if spiky.len() > crate::quality::max_spikes(self.len()) {
            return Err(RecordingError::TooManySpikes {
                file: self.source,
                found: spiky.len(),
                samples: self.time.len(),
                lines: spiky.iter().map(|&(k, n)| (self.lines[k], n)).collect(),
            });
        }
        let spikes: Vec<Spike> = spiky
            .iter()
            .map(|&(k, column)| Spike {
                column,
                value: self.column(column).expect("spike column")[k],
                line: self.lines[k],
            })
            .collect();
        let drop: Vec<usize> = spiky.iter().map(|&(k, _)| k).collect();
        self = self.without_samples(&drop);
        self.notes.push(Note::SpikesExcluded { spikes });
        if self.len() < MIN_SAMPLES {
            return Err(RecordingError::TooFewSamples {
                found: self.len(),
                file: self.source,
                min: MIN_SAMPLES,
            });
        }
        Ok(self)
    }

    /// The first value beyond its column's plausible magnitude ([`PLAUSIBLE`]), refused.
    fn check_magnitudes(&self) -> Result<(), RecordingError> {
        for (name, limit, unit) in PLAUSIBLE {
            if let Some(v) = self.column(name) {
                if let Some(k) = v.iter().position(|x| x.abs() > limit) {
                    return Err(RecordingError::Implausible {
                        file: self.source.clone(),
                        line: self.lines[k],
                        column: name.to_string(),
                        value: v[k],
                        limit,
                        unit,
                    });
                }
            }
        }
        Ok(())
    }

    /// The recording without the samples at the given indices (sorted or not).
    fn without_samples(mut self, drop: &[usize]) -> Recording {
        let mut keep = vec![true; self.len()];
        for &k in drop {
            keep[k] = false;
        }
        let pick = |v: &mut Vec<f64>| {
            let mut i = 0;
            v.retain(|_| {
                i += 1;
                keep[i - 1]
            });
        };
        pick(&mut self.time);
        for (_, v) in &mut self.columns {
            pick(v);
        }
        let mut i = 0;
        self.lines.retain(|_| {
            i += 1;
            keep[i - 1]
        });
        self
    }

    /// Adds a note on something handled (shown with the reader's notes).
    pub fn push_note(&mut self, note: Note) {
        self.notes.push(note);
    }

    /// The line of the file that sample `k` came from (for a recording built in memory,
    /// the line it would have in [`Recording::to_csv`]'s output).
    pub fn line(&self, k: usize) -> usize {
        self.lines[k]
    }

    /// The values of a column (`time` included), or None if the recording lacks it.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        if name == "time" {
            return Some(&self.time);
        }
        self.columns
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    pub fn has(&self, name: &str) -> bool {
        self.column(name).is_some()
    }

    /// Names of all columns, `time` first, then in file order.
    pub fn names(&self) -> Vec<&str> {
        std::iter::once("time")
            .chain(self.columns.iter().map(|(n, _)| n.as_str()))
            .collect()
    }

    /// What the reader handled or could not check (uneven sampling, missing optional
    /// columns, skipped cross-checks), typed; each prints as one sentence.
    pub fn notes(&self) -> &[Note] {
        &self.notes
    }

    /// A recording of a simulated run: `time`, the inputs `v_ref`, `F_L` and every output.
    pub fn from_trace(trace: &Trace) -> Recording {
        let mut columns = Vec::new();
        for (i, name) in Inputs::NAMES.iter().enumerate() {
            columns.push((
                name.to_string(),
                trace.inputs.iter().map(|x| x.values()[i]).collect(),
            ));
        }
        for (i, name) in Outputs::NAMES.iter().enumerate() {
            columns.push((
                name.to_string(),
                trace.outputs.iter().map(|x| x.values()[i]).collect(),
            ));
        }
        Recording {
            time: trace.time.clone(),
            meta: BTreeMap::new(),
            source: "simulation".into(),
            columns,
            notes: Vec::new(),
            lines: (0..trace.time.len()).map(|k| k + 2).collect(),
        }
    }

    /// The recording with column `name` replaced (or added); `time` replaces the time stamps.
    /// Panics if the length differs from the recording's.
    pub fn with_column(mut self, name: &str, values: Vec<f64>) -> Recording {
        assert_eq!(values.len(), self.time.len(), "column `{name}` length");
        if name == "time" {
            self.time = values;
        } else if let Some((_, v)) = self.columns.iter_mut().find(|(n, _)| n == name) {
            *v = values;
        } else {
            self.columns.push((name.to_string(), values));
        }
        self
    }

    /// The recording with column `name` removed (no-op if absent; `time` cannot be removed).
    pub fn without_column(mut self, name: &str) -> Recording {
        self.columns.retain(|(n, _)| n != name);
        self
    }

    /// The recording with a metadata entry set.
    pub fn with_meta(mut self, key: &str, value: &str) -> Recording {
        self.meta.insert(key.to_string(), value.to_string());
        self
    }

    /// The samples with t0 <= time <= t1 [s]; metadata and notes are kept.
    pub fn window(&self, t0: f64, t1: f64) -> Recording {
        let keep: Vec<usize> = (0..self.len())
            .filter(|&k| self.time[k] >= t0 && self.time[k] <= t1)
            .collect();
        let pick = |v: &[f64]| keep.iter().map(|&k| v[k]).collect::<Vec<f64>>();
        Recording {
            time: pick(&self.time),
            meta: self.meta.clone(),
            source: format!("{} [{t0} s, {t1} s]", self.source),
            columns: self
                .columns
                .iter()
                .map(|(n, v)| (n.clone(), pick(v)))
                .collect(),
            notes: self.notes.clone(),
            lines: keep.iter().map(|&k| self.lines[k]).collect(),
        }
    }

    /// The contract's CSV: `# key = value` metadata lines, the header, one row per sample.
    /// Numbers are written in Rust's shortest round-trip form, so `parse` restores them exactly.
    pub fn to_csv(&self) -> String {
        let mut columns = vec![Column {
            name: "time",
            values: &self.time,
            format: Number::Shortest,
        }];
        columns.extend(self.columns.iter().map(|(name, values)| Column {
            name,
            values,
            format: Number::Shortest,
        }));
        csv::write(
            self.meta.iter().map(|(k, v)| (k.as_str(), v.as_str())),
            &columns,
        )
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Unit-slip findings (empty when plausible); skipped cross-checks go to the notes.
    fn check_units(&mut self) -> Vec<String> {
        let findings = self.magnitude_slips();
        if !findings.is_empty() {
            return findings;
        }
        self.cross_checks()
    }

    /// Columns whose magnitude no bench logging in SI units produces (the module's
    /// "Unit-slip heuristics"), each as "`name` what it looks like".
    fn magnitude_slips(&self) -> Vec<String> {
        let dt = median(
            &self
                .time
                .windows(2)
                .map(|w| w[1] - w[0])
                .collect::<Vec<_>>(),
        );
        let time = (dt > DT_MAX_S).then(|| format!("steps by {} s (median), looks like milliseconds (a 100 Hz bench logs every 0.01 s)", sig(dt)));
        [
            ("time", time),
            ("x", self.x_slip()),
            ("p", self.p_slip()),
            ("Q1", self.flow_slip("Q1")),
            ("Q2", self.flow_slip("Q2")),
            ("v", self.v_slip()),
            ("F_L", self.load_slip()),
        ]
        .into_iter()
        .filter_map(|(name, found)| found.map(|f| format!("`{name}` {f}")))
        .collect()
    }

    /// The pumps' summed flow Q1 + Q2 [m^3/s].
    fn delivered(&self) -> Vec<f64> {
        let (q1, q2) = (
            self.column("Q1").expect("required"),
            self.column("Q2").expect("required"),
        );
        q1.iter().zip(q2).map(|(a, b)| a + b).collect()
    }

    /// |x_end - x_start| [m] as recorded.
    fn x_travel(&self) -> f64 {
        let x = self.column("x").expect("required");
        (x[x.len() - 1] - x[0]).abs()
    }

    /// The travel the delivered volume makes over the default piston area [m], a measure
    /// of the stroke independent of `x` and `v`.
    fn volume_travel(&self) -> f64 {
        let area = match by_name("A").map(|v| v.kind) {
            Some(Kind::Real { start, .. }) => start,
            _ => 1.0,
        };
        (trapezoid(&self.time, &self.delivered()) / area).abs()
    }

    /// `x` beyond any stroke; the unit named by how many times its travel exceeds an
    /// independent measure of it (the integral of `v` when that is in m/s, else the
    /// delivered volume's travel): 100 reads as cm, 1000 as mm.
    fn x_slip(&self) -> Option<String> {
        let x_peak = peak(self.column("x").expect("required"));
        (x_peak > X_MAX_M).then(|| {
            let v_travel = self
                .column("v")
                .filter(|v| peak(v) <= V_MAX_MS)
                .map(|v| trapezoid(&self.time, v).abs());
            let reference = v_travel
                .filter(|t| *t > 0.0)
                .unwrap_or_else(|| self.volume_travel());
            let (unit, factor) = length_unit(self.x_travel() / reference);
            format!("reaches {} m, longer than any thrust-cylinder stroke (<= {X_MAX_M} m): looks like {unit} ({} m)", sig(x_peak), sig(x_peak * factor))
        })
    }

    fn p_slip(&self) -> Option<String> {
        let p_peak = peak(self.column("p").expect("required"));
        (p_peak < P_MIN_PEAK_PA).then(|| {
            let guess = if p_peak <= 70.0 {
                "MPa (x 1e6 to Pa) or bar (x 1e5)"
            } else if p_peak <= 1000.0 {
                "bar (x 1e5 to Pa)"
            } else {
                "kPa (x 1e3 to Pa)"
            };
            format!("peaks at {} Pa, far below a loaded working chamber (>= {P_MIN_PEAK_PA} Pa): looks like {guess}", sig(p_peak))
        })
    }

    fn flow_slip(&self, q: &str) -> Option<String> {
        let q_peak = peak(self.column(q).expect("required"));
        (q_peak > Q_MAX_M3S).then(|| {
            format!("peaks at {} m^3/s (above {Q_MAX_M3S} m^3/s = 3000 L/min): looks like L/min ({} m^3/s)", sig(q_peak), sig(q_peak / tbm_thrust::units::LPM))
        })
    }

    /// `v` beyond any piston speed; the unit named by how many times its integral exceeds
    /// the travel (of `x`, or of the delivered volume when `x` slipped too).
    fn v_slip(&self) -> Option<String> {
        let v = self.column("v")?;
        let v_peak = peak(v);
        (v_peak > V_MAX_MS).then(|| {
            let x_peak = peak(self.column("x").expect("required"));
            let travel = if x_peak > X_MAX_M {
                self.volume_travel()
            } else {
                self.x_travel()
            };
            let (unit, factor) = length_unit(trapezoid(&self.time, v).abs() / travel);
            format!(
                "peaks at {} m/s (above {V_MAX_MS} m/s): looks like {unit}/s ({} m/s)",
                sig(v_peak),
                sig(v_peak * factor)
            )
        })
    }

    fn load_slip(&self) -> Option<String> {
        let f_peak = peak(self.column("F_L")?);
        (f_peak > 0.0 && f_peak < F_L_MIN_N).then(|| {
            format!(
                "peaks at {} N (below {F_L_MIN_N} N): looks like kN",
                sig(f_peak)
            )
        })
    }

    /// Cross-checks between columns when the piston travels more than 50 noise levels of
    /// `x` (noted as skipped otherwise): the piston area the delivered volume implies, and
    /// the travel against the integral of `v`.
    fn cross_checks(&mut self) -> Vec<String> {
        let mut findings = Vec::new();
        let x = self.column("x").expect("required");
        let travel = x[x.len() - 1] - x[0];
        let x_noise = noise_level(x);
        if travel <= TRAVEL_NOISE_LEVELS * x_noise || travel <= 0.0 {
            self.notes.push(Note::CrossChecksSkipped {
                travel_m: travel,
                noise_m: x_noise,
            });
            return findings;
        }
        let volume = trapezoid(&self.time, &self.delivered());
        let area = volume / travel;
        if volume > 0.0 && !(AREA_RANGE_M2.0..=AREA_RANGE_M2.1).contains(&area) {
            let guess = if area < AREA_RANGE_M2.0 {
                "`x` looks like mm (or the flows are too small by the same factor)"
            } else {
                "`Q1`/`Q2` look like L/min (or `x` is too small by the same factor)"
            };
            findings.push(format!(
                "the delivered volume {volume:.3e} m^3 over the travel {travel:.3e} m implies a piston area of {area:.3e} m^2, outside [{:e}, {:e}] m^2: {guess}",
                AREA_RANGE_M2.0, AREA_RANGE_M2.1
            ));
        } else if volume <= 0.0 {
            self.notes.push(Note::NoFlowDelivered);
        }
        if let Some(v) = self.column("v") {
            // A sign flip (opposite directions, like magnitudes) is the data-quality
            // checks' finding (crate::quality), not a unit slip.
            let integral = trapezoid(&self.time, v);
            let ratio = (travel / integral).abs();
            if !(1.0 / V_RATIO_MAX..=V_RATIO_MAX).contains(&ratio) {
                let which = if ratio > 1.0 {
                    let (unit, _) = length_unit(ratio);
                    format!("`x` looks like {unit}, or `v` is too small by the same factor")
                } else {
                    let (unit, _) = length_unit(1.0 / ratio);
                    format!("`v` looks like {unit}/s, or `x` is too small by the same factor")
                };
                findings.push(format!(
                    "`x` travels {travel:.3e} m but `v` integrates to {integral:.3e} m ({} times apart): {which}",
                    sig(ratio.max(1.0 / ratio))
                ));
            }
        }
        findings
    }

    /// Notes on optional columns that are absent and on uneven sampling.
    fn note_columns(&mut self) {
        let missing: Vec<&str> = OPTIONAL.iter().copied().filter(|c| !self.has(c)).collect();
        if !missing.is_empty() {
            self.notes
                .push(Note::OptionalColumnsAbsent { columns: missing });
        }
        if !self.has("v") {
            self.notes.push(Note::NoVelocity);
        }
        let steps: Vec<f64> = self.time.windows(2).map(|w| w[1] - w[0]).collect();
        let (lo, hi) = steps
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &d| (a.min(d), b.max(d)));
        let med = median(&steps);
        if hi - lo > 1e-3 * med {
            self.notes.push(Note::UnevenSampling {
                min_step_s: lo,
                max_step_s: hi,
                median_step_s: med,
            });
        }
        if let Some(x0) = self.column("x").map(|x| x[0]) {
            if x0.abs() > 1e-3 {
                self.notes.push(Note::XOffset { x0_m: x0 });
            }
        }
    }
}

/// The length unit a ratio to metres reads as, with its factor to metres.
fn length_unit(ratio: f64) -> (&'static str, f64) {
    if (30.0..300.0).contains(&ratio) {
        ("cm", 1e-2)
    } else if (300.0..3000.0).contains(&ratio) {
        ("mm", 1e-3)
    } else {
        ("mm or cm", 1e-3)
    }
}

/// A number with 4 significant digits, plain when it reads well, else in e-notation.
fn sig(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || !(1e-3..1e5).contains(&a) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
    format!("{v:.decimals$}")
}

/// A run's recording CSV (docs/contract.md), written sample by sample as the run goes
/// (`simulate`): the metadata lines, then `time` [s] with 6 decimals, the inputs and every
/// output in SI units with 13 significant digits.
pub struct TraceWriter<W: std::io::Write> {
    out: W,
    line: String,
}

/// Number formats of the run's recording: `time`, and every input and output.
const TIME_FORMAT: Number = Number::Fixed(6);
const SIGNAL_FORMAT: Number = Number::Scientific(12);

impl<W: std::io::Write> TraceWriter<W> {
    /// Writes the metadata and the header.
    pub fn new(mut out: W, meta: &[(&str, &str)]) -> std::io::Result<Self> {
        let mut line = String::new();
        let names =
            std::iter::once("time").chain(Inputs::NAMES.iter().chain(Outputs::NAMES).copied());
        csv::header(&mut line, meta.iter().copied(), names);
        out.write_all(line.as_bytes())?;
        Ok(TraceWriter { out, line })
    }

    /// Writes one sample's row.
    pub fn sample(&mut self, t: f64, inputs: &Inputs, outputs: &Outputs) -> std::io::Result<()> {
        self.line.clear();
        let signals = inputs.values().into_iter().chain(outputs.values());
        let cells = std::iter::once((TIME_FORMAT, t)).chain(signals.map(|v| (SIGNAL_FORMAT, v)));
        csv::row(&mut self.line, cells);
        self.out.write_all(self.line.as_bytes())
    }

    /// The writer, flushed.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Default of an input of the variable table (e.g. the paper's load `F_L` = 12 kN).
fn input_start(name: &str) -> f64 {
    match by_name(name).map(|v| v.kind) {
        Some(Kind::Real { start, .. }) => start,
        _ => 0.0,
    }
}

/// The speed reference of a replay at every sample: `v_ref`, or the slope of `x_ref`.
fn speed_reference(rec: &Recording, notes: &mut Vec<String>) -> Result<Vec<f64>, ReplayError> {
    let n = rec.len();
    if let Some(v) = rec.column("v_ref") {
        return Ok(v.to_vec());
    }
    let Some(x_ref) = rec.column("x_ref") else {
        return Err(ReplayError::NoReference {
            file: rec.source.clone(),
        });
    };
    notes.push("no `v_ref`: taken as the slope of `x_ref` between samples".into());
    // x_ref is the integral of a v_ref held between samples, so the forward difference
    // recovers it exactly on [t_k, t_k+1).
    let mut v: Vec<f64> = (0..n - 1)
        .map(|k| (x_ref[k + 1] - x_ref[k]) / (rec.time[k + 1] - rec.time[k]))
        .collect();
    v.push(v[n - 2]);
    Ok(v)
}

/// The load of a replay at every sample: `F_L`, or the metadata's constant, or the model's
/// default.
fn load(rec: &Recording, notes: &mut Vec<String>) -> Result<Vec<f64>, ReplayError> {
    let n = rec.len();
    if let Some(f) = rec.column("F_L") {
        return Ok(f.to_vec());
    }
    let Some(text) = rec.meta.get("F_L") else {
        let f = input_start("F_L");
        notes.push(format!(
            "no `F_L` column or metadata: load {f} N (the model's default)"
        ));
        return Ok(vec![f; n]);
    };
    let f: f64 = text
        .parse()
        .ok()
        .filter(|f: &f64| f.is_finite())
        .ok_or_else(|| ReplayError::LoadNotANumber {
            file: rec.source.clone(),
            text: text.clone(),
        })?;
    notes.push(format!("no `F_L` column: load {f} N from the metadata"));
    Ok(vec![f; n])
}

/// The scheme of a replay: the metadata's, or `single` when there is none and `Q2` is zero
/// throughout (for a two-pump `params`).
fn scheme(rec: &Recording, params: &Params, notes: &mut Vec<String>) -> Option<String> {
    let scheme = rec.meta.get("scheme").cloned();
    if scheme.is_none()
        && rec
            .column("Q2")
            .is_some_and(|q| q.iter().all(|&v| v == 0.0))
        && params.scheme != Scheme::Single
    {
        notes.push("no `scheme` metadata and `Q2` is zero throughout: replayed as `single`".into());
        return Some("single".into());
    }
    scheme
}

/// Why a recording cannot be replayed; `Display` gives one line naming the file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ReplayError {
    #[error("{file}: {samples} samples; the replay needs at least 2")]
    TooShort { file: String, samples: usize },
    #[error("{file}: neither `v_ref` nor `x_ref`: the closed-loop replay needs the reference")]
    NoReference { file: String },
    #[error("{file}: metadata `F_L = {text}` is not a number")]
    LoadNotANumber { file: String, text: String },
    /// The metadata's `scheme` or `controller` is not one the model has.
    #[error("{file}: metadata: {error}")]
    Metadata { file: String, error: ParamError },
}

/// The model set up to replay a recording: parameters with the recording's scheme and
/// controller, and the inputs at every sample.
#[derive(Clone, Debug)]
pub(crate) struct Replay {
    /// The recording's file, for messages.
    file: String,
    time: Vec<f64>,
    inputs: Vec<Inputs>,
    /// How the inputs and the scheme were chosen, one sentence each.
    pub notes: Vec<String>,
    scheme: Option<String>,
    controller: Option<String>,
}

impl Replay {
    pub fn new(params: &Params, rec: &Recording) -> Result<Replay, ReplayError> {
        let n = rec.len();
        if n < 2 {
            return Err(ReplayError::TooShort {
                file: rec.source.clone(),
                samples: n,
            });
        }
        let mut notes = Vec::new();
        let v_ref = speed_reference(rec, &mut notes)?;
        let f_l = load(rec, &mut notes)?;
        let scheme = scheme(rec, params, &mut notes);
        let replay = Replay {
            file: rec.source.clone(),
            time: rec.time.clone(),
            inputs: v_ref
                .iter()
                .zip(&f_l)
                .map(|(&v_ref, &f_l)| Inputs { v_ref, F_L: f_l })
                .collect(),
            notes,
            scheme,
            controller: rec.meta.get("controller").cloned(),
        };
        replay.params(params)?;
        Ok(replay)
    }

    /// `params` with the recording's scheme and controller.
    pub fn params(&self, params: &Params) -> Result<Params, ReplayError> {
        let mut p = params.clone();
        for (name, item) in [("scheme", &self.scheme), ("controller", &self.controller)] {
            if let Some(item) = item {
                p.set_item(name, item)
                    .map_err(|error| ReplayError::Metadata {
                        file: self.file.clone(),
                        error,
                    })?;
            }
        }
        Ok(p)
    }

    /// Closed-loop run sampled at the recording's times, inputs held between samples, from
    /// rest at the first sample. `params` must already carry the scheme (see `params`).
    pub fn run(&self, params: &Params) -> Trace {
        let sim = Simulator::new(params.clone(), self.inputs[0], self.time[0]);
        sample_and_hold(
            sim,
            self.time.iter().copied().zip(self.inputs.iter().copied()),
        )
    }
}

/// Simulates the closed-loop model with the recording's inputs, sampled at its time stamps:
/// `v_ref` (or the slope of `x_ref`), `F_L` (or metadata `F_L`, or the model's default),
/// scheme and controller from metadata (`# scheme = adaptive`) when present; a recording
/// whose `Q2` is zero throughout and has no `scheme` is replayed with the single pump. The
/// inputs are held between samples and the model starts at rest at the first sample.
pub fn replay(params: &Params, rec: &Recording) -> Result<Trace, ReplayError> {
    let r = Replay::new(params, rec)?;
    Ok(r.run(&r.params(params)?))
}
