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
    for (k, v) in meta {
        let _ = writeln!(s, "# {k} = {v}");
    }
    let names: Vec<&str> = columns.iter().map(|c| c.name).collect();
    s.push_str(&names.join(","));
    s.push('\n');
    let rows = columns.first().map_or(0, |c| c.values.len());
    for k in 0..rows {
        for (j, c) in columns.iter().enumerate() {
            if j > 0 {
                s.push(',');
            }
            c.format.write(&mut s, c.values[k]);
        }
        s.push('\n');
    }
    s
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
