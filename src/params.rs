//! Setting and checking parameters by name: the TOML parameter files of the CLI
//! (`--params FILE`), the `params_file` written by `diagnose`, and the FMU start values all
//! go through here. The names, bounds and defaults come from the generated variable table.

use crate::variables::{by_name, Causality, Kind, Params, Variable, VARIABLES};
use std::fmt;
use std::path::Path;

/// A parameter problem, worded for a one-line error message.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamError {
    Unknown(String),
    NotANumber(String),
    OutOfRange {
        name: String,
        value: f64,
        min: f64,
        max: f64,
        unit: String,
    },
    BadItem {
        name: String,
        item: String,
        allowed: String,
    },
    /// NaN or an infinity given for a real parameter.
    NotFinite {
        name: String,
        value: f64,
    },
    /// A value of the wrong type: `found` says what was given (`the number 3`, `a table`).
    WrongType {
        name: String,
        expected: String,
        found: String,
    },
    /// A TOML table: parameter files are flat, so `[params] beta_e` would be ambiguous.
    Table(String),
    File(String),
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamError::Unknown(n) => {
                let hint = closest_name(n).map(|c| format!(" (did you mean `{c}`?)")).unwrap_or_default();
                write!(f, "unknown parameter `{n}`{hint}")
            }
            ParamError::NotANumber(n) => write!(f, "parameter `{n}` must be a finite number"),
            ParamError::OutOfRange { name, value, min, max, unit } => write!(
                f,
                "parameter `{name}` = {value} {unit} is not physical: allowed range is [{min}, {max}] {unit}"
            ),
            ParamError::BadItem { name, item, allowed } => {
                write!(f, "parameter `{name}` = \"{item}\" is not one of {allowed}")
            }
            ParamError::NotFinite { name, value } => {
                let what = if value.is_nan() { "NaN" } else { "an infinity" };
                write!(f, "parameter `{name}` = {value}: {what} is not a finite number")
            }
            ParamError::WrongType { name, expected, found } => {
                write!(f, "parameter `{name}` takes {expected}, not {found}")
            }
            ParamError::Table(t) => write!(
                f,
                "`[{t}]` is a table; a parameter file holds `name = value` lines only (modelDescription/variables.toml), so its entries would be ambiguous"
            ),
            ParamError::File(msg) => f.write_str(msg),
        }
    }
}

impl std::error::Error for ParamError {}

fn closest_name(n: &str) -> Option<&'static str> {
    let lower = n.to_ascii_lowercase();
    VARIABLES
        .iter()
        .filter(|v| v.causality == Causality::Parameter)
        .find(|v| v.name.to_ascii_lowercase() == lower)
        .map(|v| v.name)
}

fn parameter(name: &str) -> Result<&'static Variable, ParamError> {
    by_name(name)
        .filter(|v| v.causality == Causality::Parameter)
        .ok_or_else(|| ParamError::Unknown(name.to_string()))
}

/// Checks `value` against the table's bounds for a real parameter.
pub fn check_real(var: &Variable, value: f64) -> Result<(), ParamError> {
    let Kind::Real { min, max, .. } = var.kind else {
        return Err(ParamError::NotANumber(var.name.into()));
    };
    if !value.is_finite() {
        return Err(ParamError::NotFinite {
            name: var.name.into(),
            value,
        });
    }
    if value < min || value > max {
        return Err(ParamError::OutOfRange {
            name: var.name.into(),
            value,
            min,
            max,
            unit: var.unit.into(),
        });
    }
    Ok(())
}

impl Params {
    /// Sets a real parameter by name after checking it.
    pub fn set(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let var = parameter(name)?;
        check_real(var, value)?;
        *self.real_mut(var.vr).expect("real parameter in table") = value;
        Ok(())
    }

    /// Sets an enumeration parameter (`scheme`, `controller`) by item name.
    pub fn set_item(&mut self, name: &str, item: &str) -> Result<(), ParamError> {
        let var = parameter(name)?;
        let Kind::Enumeration { names, .. } = var.kind else {
            return Err(ParamError::NotANumber(name.into()));
        };
        let value = names.iter().position(|n| *n == item).map(|i| i as i32 + 1);
        match value {
            Some(v) if self.set_enumeration(var.vr, v) => Ok(()),
            _ => Err(ParamError::BadItem {
                name: name.into(),
                item: item.into(),
                allowed: names.join(" | "),
            }),
        }
    }

    /// The value of a real parameter by name.
    pub fn get(&self, name: &str) -> Option<f64> {
        by_name(name).and_then(|v| self.real(v.vr))
    }

    /// Checks every real parameter against its bounds.
    pub fn validate(&self) -> Result<(), ParamError> {
        for v in VARIABLES
            .iter()
            .filter(|v| v.causality == Causality::Parameter)
        {
            if let Some(x) = self.real(v.vr) {
                check_real(v, x)?;
            }
        }
        Ok(())
    }

    /// Applies a TOML document of `name = value` lines (a number, or an item name for
    /// `scheme` / `controller`). Tables are refused: a file is flat, one value per name.
    pub fn apply_toml(&mut self, text: &str) -> Result<(), ParamError> {
        let doc: toml::Table = text.parse().map_err(|e: toml::de::Error| {
            let line = e
                .span()
                .map_or(0, |s| text[..s.start].lines().count().max(1));
            let msg = e.message().trim().replace('\n', "; ");
            ParamError::File(format!("malformed TOML at line {line}: {msg}"))
        })?;
        for (key, value) in &doc {
            match value {
                toml::Value::Float(_) | toml::Value::Integer(_) => {
                    let x = value
                        .as_float()
                        .unwrap_or_else(|| value.as_integer().map_or(f64::NAN, |i| i as f64));
                    if matches!(parameter(key)?.kind, Kind::Enumeration { .. }) {
                        return Err(self.wrong_type(key, format!("the number {value}")));
                    }
                    self.set(key, x)?
                }
                toml::Value::String(s) => self.set_text(key, s)?,
                toml::Value::Table(_) => return Err(ParamError::Table(key.clone())),
                other => {
                    let found = match other {
                        toml::Value::Boolean(b) => format!("the boolean {b}"),
                        toml::Value::Datetime(d) => format!("the date {d}"),
                        _ => "a list".to_string(),
                    };
                    return Err(self.wrong_type(key, found));
                }
            }
        }
        Ok(())
    }

    /// Sets a parameter from text, as `--set NAME=VALUE` gives it: a number for a real
    /// parameter (NaN and infinities named as such), an item name for an enumeration.
    pub fn set_text(&mut self, name: &str, text: &str) -> Result<(), ParamError> {
        let var = parameter(name)?;
        let number = text.trim().parse::<f64>();
        match (var.kind, number) {
            (Kind::Real { .. }, Ok(x)) => self.set(name, x),
            (Kind::Real { .. }, Err(_)) => {
                Err(self.wrong_type(name, format!("the text \"{text}\"")))
            }
            (Kind::Enumeration { .. }, Ok(_)) => {
                Err(self.wrong_type(name, format!("the number {}", text.trim())))
            }
            (Kind::Enumeration { .. }, Err(_)) => self.set_item(name, text.trim()),
        }
    }

    /// The wrong-type error for parameter `name` (or unknown-name error).
    fn wrong_type(&self, name: &str, found: String) -> ParamError {
        let var = match parameter(name) {
            Ok(v) => v,
            Err(e) => return e,
        };
        let expected = match var.kind {
            Kind::Real { .. } if var.unit.is_empty() => "a number".to_string(),
            Kind::Real { .. } => format!("a number [{}]", var.unit),
            Kind::Enumeration { names, .. } => format!("one of {}", names.join(" | ")),
        };
        let found = match (var.kind, found.strip_prefix("the number ")) {
            (Kind::Enumeration { .. }, Some(n)) => {
                format!("the number {n} (write the item's name in quotes)")
            }
            _ => found,
        };
        ParamError::WrongType {
            name: name.into(),
            expected,
            found,
        }
    }

    /// Defaults overridden by a TOML parameter file.
    pub fn from_toml_file(path: &Path) -> Result<Params, ParamError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ParamError::File(format!("cannot read {}: {e}", path.display())))?;
        let mut p = Params::default();
        p.apply_toml(&text)
            .map_err(|e| ParamError::File(format!("{}: {e}", path.display())))?;
        Ok(p)
    }

    /// Every parameter as a TOML document, grouped and commented with units.
    pub fn to_toml(&self) -> String {
        let mut out = String::from(
            "# tbm-thrust parameters (SI units; see modelDescription/variables.toml)\n",
        );
        let mut group = "";
        for v in VARIABLES
            .iter()
            .filter(|v| v.causality == Causality::Parameter)
        {
            if v.group != group {
                group = v.group;
                out.push_str(&format!("\n# --- {group}\n"));
            }
            let value = match v.kind {
                Kind::Real { .. } => format!("{:e}", self.real(v.vr).unwrap_or_default()),
                Kind::Enumeration { names, .. } => {
                    let i = self.enumeration(v.vr).unwrap_or(1) as usize - 1;
                    format!("\"{}\"", names[i])
                }
            };
            let unit = if v.unit.is_empty() {
                String::new()
            } else {
                format!(" [{}]", v.unit)
            };
            out.push_str(&format!(
                "{} = {value}  # {}{unit}\n",
                v.name, v.description
            ));
        }
        out
    }

    /// Only the parameters that differ from the defaults, as TOML.
    pub fn diff_toml(&self) -> String {
        let base = Params::default();
        let mut out = String::new();
        for v in VARIABLES
            .iter()
            .filter(|v| v.causality == Causality::Parameter)
        {
            match v.kind {
                Kind::Real { .. } if self.real(v.vr) != base.real(v.vr) => {
                    out.push_str(&format!("{} = {:e}\n", v.name, self.real(v.vr).unwrap()));
                }
                Kind::Enumeration { names, .. }
                    if self.enumeration(v.vr) != base.enumeration(v.vr) =>
                {
                    let i = self.enumeration(v.vr).unwrap() as usize - 1;
                    out.push_str(&format!("{} = \"{}\"\n", v.name, names[i]));
                }
                _ => {}
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::variables::Scheme;

    #[test]
    fn toml_round_trip_keeps_every_value() {
        let mut p = Params::default();
        p.set("beta_e", 1.2e9).unwrap();
        p.set_item("scheme", "single").unwrap();
        let mut q = Params::default();
        q.apply_toml(&p.to_toml()).unwrap();
        assert_eq!(p, q);
        assert_eq!(q.scheme, Scheme::Single);
    }

    #[test]
    fn bad_input_gets_a_clear_error() {
        let mut p = Params::default();
        assert_eq!(
            p.set("mass", 1.0).unwrap_err().to_string(),
            "unknown parameter `mass`"
        );
        assert!(p
            .set("M", 1.0)
            .unwrap_err()
            .to_string()
            .contains("did you mean `m`"));
        assert!(p
            .set("m", -5.0)
            .unwrap_err()
            .to_string()
            .contains("not physical"));
        assert!(p
            .set("A", 0.0)
            .unwrap_err()
            .to_string()
            .contains("not physical"));
        assert!(p
            .set("b", f64::NAN)
            .unwrap_err()
            .to_string()
            .contains("NaN is not a finite number"));
        assert!(p
            .apply_toml("b = inf")
            .unwrap_err()
            .to_string()
            .contains("an infinity is not a finite number"));
        assert_eq!(
            p.apply_toml("scheme = 3").unwrap_err().to_string(),
            "parameter `scheme` takes one of single | fixed_split | adaptive, not the number 3 (write the item's name in quotes)"
        );
        assert_eq!(
            p.set_text("beta_e", "abc").unwrap_err().to_string(),
            "parameter `beta_e` takes a number [Pa], not the text \"abc\""
        );
        assert!(p
            .set_text("beta_e", "NaN")
            .unwrap_err()
            .to_string()
            .contains("NaN is not a finite number"));
        assert!(p
            .apply_toml("m = true")
            .unwrap_err()
            .to_string()
            .contains("not the boolean true"));
        assert!(p
            .apply_toml("m = [")
            .unwrap_err()
            .to_string()
            .starts_with("malformed TOML"));
        assert!(p
            .apply_toml("scheme = \"dual\"")
            .unwrap_err()
            .to_string()
            .contains("single | fixed_split | adaptive"));
        assert!(
            p.apply_toml("x = 1.0").is_err(),
            "outputs are not parameters"
        );
    }

    #[test]
    fn tables_are_not_flattened() {
        let mut p = Params::default();
        let e = p
            .apply_toml("beta_e = 1.1e9\n[params]\nbeta_e = 1.5e9\n")
            .unwrap_err();
        assert_eq!(e, ParamError::Table("params".into()));
        assert!(e.to_string().starts_with("`[params]` is a table"));
    }

    #[test]
    fn defaults_are_the_papers() {
        let p = Params::default();
        assert_eq!((p.m, p.A, p.V0, p.F_c), (50.0, 0.0032, 0.005, 500.0));
        assert_eq!((p.beta_e, p.C_ip, p.b), (1.056e9, 3.822e-13, 3360.0));
        assert_eq!(p.scheme, Scheme::Adaptive);
        p.validate().unwrap();
    }
}
