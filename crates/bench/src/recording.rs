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
use crate::numerics::stats::{median, noise_level, trapezoid};
use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;
use tbm_thrust::simulation::sample_and_hold;
use tbm_thrust::simulation::Trace;
use tbm_thrust::variables::{by_name, Inputs, Kind, Outputs, Params};
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

/// What is wrong with a recording; `Display` gives one line naming file, line and column.
#[derive(Clone, Debug, PartialEq)]
pub enum RecordingError {
    /// The file cannot be read.
    Io { source: String, message: String },
    /// No header row (the file is empty or holds only comments).
    NoHeader { source: String },
    /// The rows are not separated by commas.
    Delimiter {
        source: String,
        line: usize,
        found: String,
    },
    /// A problem with the header row itself (empty or duplicate name, unit in a name).
    Header {
        source: String,
        line: usize,
        message: String,
    },
    MissingColumn {
        source: String,
        column: String,
        found: Vec<String>,
    },
    FieldCount {
        source: String,
        line: usize,
        row: usize,
        found: usize,
        expected: usize,
    },
    EmptyCell {
        source: String,
        line: usize,
        row: usize,
        column: String,
    },
    NotFinite {
        source: String,
        line: usize,
        row: usize,
        column: String,
        text: String,
    },
    Malformed {
        source: String,
        line: usize,
        row: usize,
        column: String,
        text: String,
    },
    TimeNotIncreasing {
        source: String,
        line: usize,
        row: usize,
        previous: f64,
        time: f64,
    },
    TooFewSamples {
        source: String,
        found: usize,
        min: usize,
    },
    /// Values whose magnitude says they are not in the contract's SI unit.
    UnitSlip {
        source: String,
        findings: Vec<String>,
    },
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use RecordingError::*;
        match self {
            Io { source, message } => write!(f, "{source}: cannot read the recording: {message}"),
            NoHeader { source } => write!(f, "{source}: no header row (the file is empty or holds only `#` comments)"),
            Delimiter { source, line, found } => write!(
                f,
                "{source} line {line}: fields are separated by {found}; a recording must be comma-separated"
            ),
            Header { source, line, message } => write!(f, "{source} line {line} (header): {message}"),
            MissingColumn { source, column, found } => write!(
                f,
                "{source}: missing required column `{column}` (required: {}; found: {})",
                REQUIRED.join(", "),
                found.join(", ")
            ),
            FieldCount { source, line, row, found, expected } => write!(
                f,
                "{source} line {line} (data row {row}): {found} fields, but the header has {expected}"
            ),
            EmptyCell { source, line, row, column } => {
                write!(f, "{source} line {line} (data row {row}), column `{column}`: empty cell")
            }
            NotFinite { source, line, row, column, text } => write!(
                f,
                "{source} line {line} (data row {row}), column `{column}`: `{text}` is not a finite number"
            ),
            Malformed { source, line, row, column, text } => write!(
                f,
                "{source} line {line} (data row {row}), column `{column}`: `{text}` is not a number"
            ),
            TimeNotIncreasing { source, line, row, previous, time } => write!(
                f,
                "{source} line {line} (data row {row}), column `time`: {time} s does not follow {previous} s; time must be strictly increasing"
            ),
            TooFewSamples { source, found, min } => {
                write!(f, "{source}: only {found} samples; at least {min} are needed")
            }
            UnitSlip { source, findings } => write!(
                f,
                "{source}: units look slipped (the recording must be in SI units): {}",
                findings.join("; ")
            ),
        }
    }
}

impl std::error::Error for RecordingError {}

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
    notes: Vec<String>,
}

/// Strips one pair of surrounding double quotes and blanks.
fn unquote(s: &str) -> &str {
    let s = s.trim();
    s.strip_prefix('"')
        .and_then(|r| r.strip_suffix('"'))
        .map_or(s, str::trim)
}

/// The separator a header line uses instead of commas, if any.
fn foreign_delimiter(line: &str) -> Option<String> {
    for (c, name) in [(';', "semicolons"), ('\t', "tabs"), ('|', "vertical bars")] {
        if line.contains(c) {
            return Some(name.to_string());
        }
    }
    (line.split_whitespace().count() > 1).then(|| "blanks".to_string())
}

/// The name a header field would have without a unit suffix like `x [mm]` or `p (bar)`.
fn strip_unit(name: &str) -> Option<(&str, &str)> {
    let open = name.find(['[', '('])?;
    let base = name[..open].trim();
    let unit = name[open..].trim_matches(|c| "[]() ".contains(c));
    Some((base, unit))
}

impl Recording {
    /// Reads and checks a recording file.
    pub fn read(path: &Path) -> Result<Recording, RecordingError> {
        let source = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| RecordingError::Io {
            source: source.clone(),
            message: e.to_string(),
        })?;
        let text = String::from_utf8(bytes).map_err(|e| RecordingError::Io {
            source: source.clone(),
            message: format!(
                "not UTF-8 (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        })?;
        Recording::parse(&text, &source)
    }

    /// Parses and checks a recording held in memory; `source` names it in messages.
    pub fn parse(text: &str, source: &str) -> Result<Recording, RecordingError> {
        let src = || source.to_string();
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut meta = BTreeMap::new();
        let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
        // Comments and metadata, then the header.
        let (header_line, header) = loop {
            let Some((n, line)) = lines.next() else {
                return Err(RecordingError::NoHeader { source: src() });
            };
            let trimmed = line.trim();
            if trimmed.is_empty() {
                continue;
            }
            if let Some(comment) = trimmed.strip_prefix('#') {
                if let Some((k, v)) = comment.split_once('=') {
                    let key = k.trim();
                    if !key.is_empty() && !key.contains(char::is_whitespace) {
                        meta.insert(key.to_string(), unquote(v).to_string());
                    }
                }
                continue;
            }
            break (n, line);
        };
        let mut names: Vec<String> = header.split(',').map(|s| unquote(s).to_string()).collect();
        if names.len() == 1 {
            let found = foreign_delimiter(header)
                .unwrap_or_else(|| "nothing (one column only)".to_string());
            return Err(RecordingError::Delimiter {
                source: src(),
                line: header_line,
                found,
            });
        }
        // A trailing comma gives empty trailing names; rows may then carry empty trailing cells.
        let mut trailing = 0;
        while names.last().is_some_and(|n| n.is_empty()) {
            names.pop();
            trailing += 1;
        }
        let header_err = |message: String| RecordingError::Header {
            source: src(),
            line: header_line,
            message,
        };
        for (i, n) in names.iter().enumerate() {
            if n.is_empty() {
                return Err(header_err(format!("column {} has no name", i + 1)));
            }
            if names[..i].contains(n) {
                return Err(header_err(format!("column `{n}` appears twice")));
            }
            if let Some((base, unit)) = strip_unit(n) {
                if REQUIRED.contains(&base) || OPTIONAL.contains(&base) {
                    return Err(header_err(format!(
                        "column `{n}` carries a unit; names are exact (`{base}`) and values SI, not `{unit}`"
                    )));
                }
            }
        }
        for required in REQUIRED {
            if !names.iter().any(|n| n == required) {
                return Err(RecordingError::MissingColumn {
                    source: src(),
                    column: required.into(),
                    found: names.clone(),
                });
            }
        }

        let t_col = names
            .iter()
            .position(|n| n == "time")
            .expect("time is required");
        let mut data: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
        let mut row = 0;
        for (n, line) in lines {
            let trimmed = line.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            row += 1;
            let mut fields: Vec<&str> = line.split(',').collect();
            if fields.len() == 1 && names.len() > 1 {
                if let Some(found) = foreign_delimiter(line) {
                    return Err(RecordingError::Delimiter {
                        source: src(),
                        line: n,
                        found,
                    });
                }
            }
            if fields.len() > names.len()
                && fields.len() <= names.len() + trailing
                && fields[names.len()..].iter().all(|f| f.trim().is_empty())
            {
                fields.truncate(names.len());
            }
            if fields.len() != names.len() {
                return Err(RecordingError::FieldCount {
                    source: src(),
                    line: n,
                    row,
                    found: fields.len(),
                    expected: names.len(),
                });
            }
            for ((field, name), column) in fields.iter().zip(&names).zip(data.iter_mut()) {
                let cell = unquote(field);
                if cell.is_empty() {
                    return Err(RecordingError::EmptyCell {
                        source: src(),
                        line: n,
                        row,
                        column: name.clone(),
                    });
                }
                let value: f64 = cell.parse().map_err(|_| RecordingError::Malformed {
                    source: src(),
                    line: n,
                    row,
                    column: name.clone(),
                    text: cell.to_string(),
                })?;
                if !value.is_finite() {
                    return Err(RecordingError::NotFinite {
                        source: src(),
                        line: n,
                        row,
                        column: name.clone(),
                        text: cell.to_string(),
                    });
                }
                column.push(value);
            }
            let t = &data[t_col];
            if t.len() >= 2 && t[t.len() - 1] <= t[t.len() - 2] {
                return Err(RecordingError::TimeNotIncreasing {
                    source: src(),
                    line: n,
                    row,
                    previous: t[t.len() - 2],
                    time: t[t.len() - 1],
                });
            }
        }
        if row < MIN_SAMPLES {
            return Err(RecordingError::TooFewSamples {
                source: src(),
                found: row,
                min: MIN_SAMPLES,
            });
        }
        let mut columns: Vec<(String, Vec<f64>)> = names.into_iter().zip(data).collect();
        let (_, time) = columns.remove(t_col);
        let mut rec = Recording {
            time,
            meta,
            source: source.to_string(),
            columns,
            notes: Vec::new(),
        };
        let findings = rec.check_units();
        if !findings.is_empty() {
            return Err(RecordingError::UnitSlip {
                source: src(),
                findings,
            });
        }
        rec.note_columns();
        Ok(rec)
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
    /// columns, skipped cross-checks), one sentence each.
    pub fn notes(&self) -> &[String] {
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
        let mut findings = Vec::new();
        let peak = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut slipped = |name: &str, found: Option<String>| {
            if let Some(f) = found {
                findings.push(format!("`{name}` {f}"));
                true
            } else {
                false
            }
        };
        let dt = median(
            &self
                .time
                .windows(2)
                .map(|w| w[1] - w[0])
                .collect::<Vec<_>>(),
        );
        slipped(
            "time",
            (dt > DT_MAX_S).then(|| format!("steps by {} s (median), looks like milliseconds (a 100 Hz bench logs every 0.01 s)", sig(dt))),
        );
        let x_peak = peak(self.column("x").expect("required"));
        let x_slip = slipped(
            "x",
            (x_peak > X_MAX_M).then(|| {
                format!("reaches {} m, longer than any thrust-cylinder stroke (<= {X_MAX_M} m): looks like mm ({} m)", sig(x_peak), sig(x_peak / 1e3))
            }),
        );
        let p_peak = peak(self.column("p").expect("required"));
        slipped(
            "p",
            (p_peak < P_MIN_PEAK_PA).then(|| {
                let guess = if p_peak <= 70.0 {
                    "MPa (x 1e6 to Pa) or bar (x 1e5)"
                } else if p_peak <= 1000.0 {
                    "bar (x 1e5 to Pa)"
                } else {
                    "kPa (x 1e3 to Pa)"
                };
                format!("peaks at {} Pa, far below a loaded working chamber (>= {P_MIN_PEAK_PA} Pa): looks like {guess}", sig(p_peak))
            }),
        );
        let mut q_slip = false;
        for q in ["Q1", "Q2"] {
            let q_peak = peak(self.column(q).expect("required"));
            q_slip |= slipped(
                q,
                (q_peak > Q_MAX_M3S).then(|| {
                    format!("peaks at {} m^3/s (above {Q_MAX_M3S} m^3/s = 3000 L/min): looks like L/min ({} m^3/s)", sig(q_peak), sig(q_peak / 6e4))
                }),
            );
        }
        let mut v_slip = false;
        if let Some(v) = self.column("v") {
            let v_peak = peak(v);
            v_slip = slipped(
                "v",
                (v_peak > V_MAX_MS).then(|| {
                    format!(
                        "peaks at {} m/s (above {V_MAX_MS} m/s): looks like mm/s ({} m/s)",
                        sig(v_peak),
                        sig(v_peak / 1e3)
                    )
                }),
            );
        }
        if let Some(f) = self.column("F_L") {
            let f_peak = peak(f);
            slipped(
                "F_L",
                (f_peak > 0.0 && f_peak < F_L_MIN_N).then(|| {
                    format!(
                        "peaks at {} N (below {F_L_MIN_N} N): looks like kN",
                        sig(f_peak)
                    )
                }),
            );
        }
        if x_slip || q_slip || v_slip || !findings.is_empty() {
            return findings;
        }

        // Cross-checks need real travel: more than 50 noise levels of x.
        let x = self.column("x").expect("required");
        let travel = x[x.len() - 1] - x[0];
        let x_noise = noise_level(x);
        if travel <= TRAVEL_NOISE_LEVELS * x_noise || travel <= 0.0 {
            self.notes.push(format!(
                "the piston travels {travel:.3e} m (noise {x_noise:.1e} m): area and velocity cross-checks of the units skipped"
            ));
            return findings;
        }
        let q: Vec<f64> = {
            let (q1, q2) = (
                self.column("Q1").expect("required"),
                self.column("Q2").expect("required"),
            );
            q1.iter().zip(q2).map(|(a, b)| a + b).collect()
        };
        let volume = trapezoid(&self.time, &q);
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
            self.notes
                .push("no pump flow delivered: the area cross-check of the units skipped".into());
        }
        if let Some(v) = self.column("v") {
            let integral = trapezoid(&self.time, v);
            let ratio = travel / integral;
            if integral <= 0.0 || !(1.0 / V_RATIO_MAX..=V_RATIO_MAX).contains(&ratio) {
                findings.push(format!(
                    "`x` travels {travel:.3e} m but `v` integrates to {integral:.3e} m: one of them is not in SI units (mm vs m?)"
                ));
            }
        }
        findings
    }

    /// Notes on optional columns that are absent and on uneven sampling.
    fn note_columns(&mut self) {
        let missing: Vec<&str> = OPTIONAL.iter().copied().filter(|c| !self.has(c)).collect();
        if !missing.is_empty() {
            self.notes.push(format!(
                "optional columns absent (not used): {}",
                missing.join(", ")
            ));
        }
        if !self.has("v") {
            self.notes
                .push("no `v`: velocity neither fitted nor checked against `x`".into());
        }
        let steps: Vec<f64> = self.time.windows(2).map(|w| w[1] - w[0]).collect();
        let (lo, hi) = steps
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &d| (a.min(d), b.max(d)));
        let med = median(&steps);
        if hi - lo > 1e-3 * med {
            self.notes.push(format!(
                "uneven sampling: steps from {lo:.3e} s to {hi:.3e} s (median {med:.3e} s); the model is sampled at the recording's own times"
            ));
        }
        if let Some(x0) = self.column("x").map(|x| x[0]) {
            if x0.abs() > 1e-3 {
                self.notes.push(format!(
                    "`x` starts at {x0} m; the model starts at rest at x = 0, so a zero offset of the sensor shows as a displacement error"
                ));
            }
        }
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

/// The CSV `simulate` writes (docs/contract.md's recording): the metadata lines, then
/// `time` [s] with 6 decimals, the inputs and every output in SI units with 13 significant
/// digits.
pub fn trace_csv(meta: &[(&str, &str)], trace: &Trace) -> String {
    let signals: Vec<(&str, Vec<f64>)> = Inputs::NAMES
        .iter()
        .chain(Outputs::NAMES)
        .map(|&n| (n, trace.signal(n).expect("input or output")))
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
    csv::write(meta.iter().copied(), &columns)
}

/// Default of an input of the variable table (e.g. the paper's load `F_L` = 12 kN).
fn input_start(name: &str) -> f64 {
    match by_name(name).map(|v| v.kind) {
        Some(Kind::Real { start, .. }) => start,
        _ => 0.0,
    }
}

/// The model set up to replay a recording: parameters with the recording's scheme and
/// controller, and the inputs at every sample.
#[derive(Clone, Debug)]
pub(crate) struct Replay {
    time: Vec<f64>,
    inputs: Vec<Inputs>,
    /// How the inputs and the scheme were chosen, one sentence each.
    pub notes: Vec<String>,
    scheme: Option<String>,
    controller: Option<String>,
}

impl Replay {
    pub fn new(params: &Params, rec: &Recording) -> Result<Replay, String> {
        let n = rec.len();
        if n < 2 {
            return Err(format!(
                "{}: {n} samples; the replay needs at least 2",
                rec.source
            ));
        }
        let mut notes = Vec::new();
        let v_ref: Vec<f64> = if let Some(v) = rec.column("v_ref") {
            v.to_vec()
        } else if let Some(x_ref) = rec.column("x_ref") {
            notes.push("no `v_ref`: taken as the slope of `x_ref` between samples".into());
            // x_ref is the integral of a v_ref held between samples, so the forward
            // difference recovers it exactly on [t_k, t_k+1).
            let mut v: Vec<f64> = (0..n - 1)
                .map(|k| (x_ref[k + 1] - x_ref[k]) / (rec.time[k + 1] - rec.time[k]))
                .collect();
            v.push(v[n - 2]);
            v
        } else {
            return Err(format!(
                "{}: neither `v_ref` nor `x_ref`: the closed-loop replay needs the reference",
                rec.source
            ));
        };
        let f_l: Vec<f64> = if let Some(f) = rec.column("F_L") {
            f.to_vec()
        } else if let Some(text) = rec.meta.get("F_L") {
            let f: f64 = text
                .parse()
                .ok()
                .filter(|f: &f64| f.is_finite())
                .ok_or_else(|| {
                    format!("{}: metadata `F_L = {text}` is not a number", rec.source)
                })?;
            notes.push(format!("no `F_L` column: load {f} N from the metadata"));
            vec![f; n]
        } else {
            let f = input_start("F_L");
            notes.push(format!(
                "no `F_L` column or metadata: load {f} N (the model's default)"
            ));
            vec![f; n]
        };
        let mut scheme = rec.meta.get("scheme").cloned();
        if scheme.is_none()
            && rec
                .column("Q2")
                .is_some_and(|q| q.iter().all(|&v| v == 0.0))
            && params.scheme.name() != "single"
        {
            notes.push(
                "no `scheme` metadata and `Q2` is zero throughout: replayed as `single`".into(),
            );
            scheme = Some("single".into());
        }
        let replay = Replay {
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
        replay
            .params(params)
            .map_err(|e| format!("{}: {e}", rec.source))?;
        Ok(replay)
    }

    /// `params` with the recording's scheme and controller.
    pub fn params(&self, params: &Params) -> Result<Params, String> {
        let mut p = params.clone();
        for (name, item) in [("scheme", &self.scheme), ("controller", &self.controller)] {
            if let Some(item) = item {
                p.set_item(name, item)
                    .map_err(|e| format!("metadata: {e}"))?;
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
pub fn replay(params: &Params, rec: &Recording) -> Result<Trace, String> {
    let r = Replay::new(params, rec)?;
    Ok(r.run(&r.params(params)?))
}
