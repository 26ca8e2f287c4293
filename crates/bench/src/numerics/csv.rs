//! The one CSV writer: `# key = value` metadata lines, a header, one row per sample, each
//! column with its own number format (the recording format of docs/contract.md). Reading is
//! `recording::Recording::parse`.

use std::fmt::Write;

/// How a column's numbers are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Number {
    /// Rust's shortest form that parses back to the same f64.
    Shortest,
    /// Fixed point with this many decimals.
    Fixed(usize),
    /// Scientific with this many decimals of mantissa.
    Scientific(usize),
}

impl Number {
    fn write(self, s: &mut String, v: f64) {
        let _ = match self {
            Number::Shortest => write!(s, "{v}"),
            Number::Fixed(d) => write!(s, "{v:.d$}"),
            Number::Scientific(d) => write!(s, "{v:.d$e}"),
        };
    }
}

/// One column: header name, values (one per row) and number format.
#[derive(Clone, Copy, Debug)]
pub struct Column<'a> {
    pub name: &'a str,
    pub values: &'a [f64],
    pub format: Number,
}

/// The CSV text of `columns` (equal lengths) after the metadata lines.
pub fn write<'a>(meta: impl IntoIterator<Item = (&'a str, &'a str)>, columns: &[Column]) -> String {
    let mut s = String::new();
    header(&mut s, meta, columns.iter().map(|c| c.name));
    let rows = columns.first().map_or(0, |c| c.values.len());
    for k in 0..rows {
        row(&mut s, columns.iter().map(|c| (c.format, c.values[k])));
    }
    s
}

/// Appends the metadata lines and the header line of the columns `names`.
pub fn header<'a, 'b>(
    s: &mut String,
    meta: impl IntoIterator<Item = (&'a str, &'a str)>,
    names: impl IntoIterator<Item = &'b str>,
) {
    for (k, v) in meta {
        let _ = writeln!(s, "# {k} = {v}");
    }
    s.push_str(&names.into_iter().collect::<Vec<_>>().join(","));
    s.push('\n');
}

/// Appends one row: each value in its column's format.
pub fn row(s: &mut String, cells: impl IntoIterator<Item = (Number, f64)>) {
    for (j, (format, v)) in cells.into_iter().enumerate() {
        if j > 0 {
            s.push(',');
        }
        format.write(s, v);
    }
    s.push('\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metadata_header_and_formats() {
        let t = [0.0, 0.01];
        let x = [1.5e-3, 0.1 + 0.2];
        let csv = write(
            [("scheme", "single")],
            &[
                Column {
                    name: "time",
                    values: &t,
                    format: Number::Fixed(2),
                },
                Column {
                    name: "x",
                    values: &x,
                    format: Number::Shortest,
                },
                Column {
                    name: "p",
                    values: &x,
                    format: Number::Scientific(3),
                },
            ],
        );
        assert_eq!(
            csv,
            "# scheme = single\ntime,x,p\n0.00,0.0015,1.500e-3\n0.01,0.30000000000000004,3.000e-1\n"
        );
    }
}
