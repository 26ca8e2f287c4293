//! The thrust-cylinder model behind the FMI 2.0 layer: [`ThrustModel`] implements
//! [`CoSimModel`] with the library's [`Simulator`] and the generated variable table, and
//! this module exports the `fmi2*` C symbols of the cdylib.
//!
//! Rules, from the variable table:
//! - inputs (`v_ref`, `F_L`) may be set at any time values may be set; finite values only;
//! - outputs cannot be set;
//! - `fixed` parameters (geometry, fluid, pumps, `scheme`, `controller`) only before
//!   fmi2ExitInitializationMode; `tunable` ones also between communication steps;
//! - every parameter value is checked against the table's bounds ([`check_real`]);
//! - `scheme` and `controller` are enumerations: fmi2Get/SetInteger, values 1..n.

use crate::fmi::model::{CoSimModel, Phase};
use crate::params::{check_real, ParamError};
use crate::simulation::Simulator;
use crate::variables::{
    self, by_vr, Causality, Inputs, Kind, Params, Variability, Variable, VARIABLES,
};
use serde::{Deserialize, Serialize};

/// Longest communication step accepted [s]. The controller samples at 1 kHz, so one hour
/// of machine time is 3.6 million samples (seconds of computing in one call); a TBM stroke
/// lasts minutes, so a longer single step is taken to be an importer's mistake.
pub const MAX_STEP: f64 = 3600.0;

/// The FMU's model: the simulator (whose `params` and `inputs` hold the values set) and
/// whether initialisation is over.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThrustModel {
    sim: Simulator,
    initialized: bool,
}

crate::fmi2_cosimulation_exports!(ThrustModel);

fn start_inputs() -> Inputs {
    let mut inputs = Inputs::default();
    for v in VARIABLES.iter().filter(|v| v.causality == Causality::Input) {
        if let (Some(slot), Kind::Real { start, .. }) = (inputs.get_mut(v.vr), v.kind) {
            *slot = start;
        }
    }
    inputs
}

/// Why the binding refuses a call; the FMI layer logs its text as one line.
#[derive(Debug)]
pub enum BindingError {
    UnknownVr(u32),
    /// The variable is of another type; `function` is the one to use.
    WrongType {
        v: &'static Variable,
        function: &'static str,
    },
    NoValue(&'static Variable),
    Output(&'static Variable),
    FixedAfterInitialization(&'static Variable),
    Rejected {
        v: &'static Variable,
        value: f64,
        why: ParamError,
    },
    NotAnItem {
        v: &'static Variable,
        value: i32,
        names: &'static [&'static str],
    },
    Invalid(ParamError),
    Diverged {
        output: &'static str,
        t: f64,
    },
}

impl std::fmt::Display for BindingError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BindingError::UnknownVr(vr) => write!(f, "unknown value reference {vr}."),
            BindingError::WrongType { v, function } => write!(
                f,
                "{} is not accessed with this function; use {function}.",
                describe(v)
            ),
            BindingError::NoValue(v) => write!(f, "{} has no value.", describe(v)),
            BindingError::Output(v) => {
                write!(f, "{} is an output and cannot be set.", describe(v))
            }
            BindingError::FixedAfterInitialization(v) => write!(
                f,
                "{} can be set only before fmi2ExitInitializationMode.",
                describe(v)
            ),
            BindingError::Rejected { v, value, why } => {
                write!(f, "{} = {value}: {why}.", describe(v))
            }
            BindingError::NotAnItem { v, value, names } => {
                let items: Vec<String> = names
                    .iter()
                    .enumerate()
                    .map(|(i, n)| format!("{} = {n}", i + 1))
                    .collect();
                write!(
                    f,
                    "{} = {value} is not one of {}.",
                    describe(v),
                    items.join(", ")
                )
            }
            BindingError::Invalid(e) => write!(f, "{e}."),
            BindingError::Diverged { output, t } => write!(
                f,
                "the model diverged: `{output}` is not finite at t = {t} s."
            ),
        }
    }
}

impl std::error::Error for BindingError {}

fn variable(vr: u32) -> Result<&'static Variable, BindingError> {
    by_vr(vr).ok_or(BindingError::UnknownVr(vr))
}

fn type_name(v: &Variable) -> &'static str {
    match v.kind {
        Kind::Real { .. } => "Real",
        Kind::Enumeration { .. } => "Integer (enumeration)",
    }
}

fn describe(v: &Variable) -> String {
    let role = match (v.causality, v.variability) {
        (Causality::Input, _) => "input",
        (Causality::Output, _) => "output",
        (Causality::Parameter, Variability::Fixed) => "fixed parameter",
        (Causality::Parameter, _) => "tunable parameter",
    };
    format!("`{}` (vr {}, {} {role})", v.name, v.vr, type_name(v))
}

/// May `v` be written in `phase` (whatever its type)?
fn check_writable(v: &'static Variable, phase: Phase) -> Result<(), BindingError> {
    match (v.causality, v.variability) {
        (Causality::Output, _) => Err(BindingError::Output(v)),
        (Causality::Parameter, Variability::Fixed) if !phase.before_exit_initialization() => {
            Err(BindingError::FixedAfterInitialization(v))
        }
        _ => Ok(()),
    }
}

impl ThrustModel {
    /// The simulator whose outputs the getters report: before initialisation, one freshly
    /// built from the values set so far (the piston at rest under the load).
    fn current(&self) -> std::borrow::Cow<'_, Simulator> {
        if self.initialized {
            std::borrow::Cow::Borrowed(&self.sim)
        } else {
            let s = &self.sim;
            std::borrow::Cow::Owned(Simulator::new(s.params.clone(), s.inputs, s.time()))
        }
    }

    fn real(&self, vr: u32, outputs: &mut Option<variables::Outputs>) -> Result<f64, BindingError> {
        let v = variable(vr)?;
        let value = match (v.causality, v.kind) {
            (_, Kind::Enumeration { .. }) => {
                return Err(BindingError::WrongType {
                    v,
                    function: "fmi2GetInteger",
                })
            }
            (Causality::Input, _) => self.sim.inputs.get(vr),
            (Causality::Parameter, _) => self.sim.params.real(vr),
            (Causality::Output, _) => outputs
                .get_or_insert_with(|| self.current().outputs())
                .get(vr),
        };
        value.ok_or(BindingError::NoValue(v))
    }
}

impl CoSimModel for ThrustModel {
    const GUID: &'static str = variables::GUID;
    const LOG_CATEGORIES: &'static [&'static str] = variables::LOG_CATEGORIES;
    const MAX_STEP: f64 = MAX_STEP;
    type Error = BindingError;

    fn instantiate() -> Self {
        ThrustModel {
            sim: Simulator::new(Params::default(), start_inputs(), 0.0),
            initialized: false,
        }
    }

    fn describe(vr: u32) -> Option<String> {
        by_vr(vr).map(describe)
    }

    fn get_reals(&self, vrs: &[u32], values: &mut [f64]) -> Result<(), BindingError> {
        let mut outputs = None;
        for (&vr, value) in vrs.iter().zip(values) {
            *value = self.real(vr, &mut outputs)?;
        }
        Ok(())
    }

    fn get_integer(&self, vr: u32) -> Result<i32, BindingError> {
        let v = variable(vr)?;
        self.sim
            .params
            .enumeration(vr)
            .ok_or(BindingError::WrongType {
                v,
                function: "fmi2GetReal",
            })
    }

    fn check_real(&self, vr: u32, value: f64, phase: Phase) -> Result<(), BindingError> {
        let v = variable(vr)?;
        if let Kind::Enumeration { .. } = v.kind {
            return Err(BindingError::WrongType {
                v,
                function: "fmi2SetInteger",
            });
        }
        check_writable(v, phase)?;
        check_real(v, value).map_err(|why| BindingError::Rejected { v, value, why })
    }

    fn set_real(&mut self, vr: u32, value: f64) {
        let slot = match self.sim.inputs.get_mut(vr) {
            Some(input) => Some(input),
            None => self.sim.params.real_mut(vr),
        };
        if let Some(slot) = slot {
            *slot = value;
        }
    }

    fn check_integer(&self, vr: u32, value: i32, phase: Phase) -> Result<(), BindingError> {
        let v = variable(vr)?;
        let Kind::Enumeration { names, .. } = v.kind else {
            return Err(BindingError::WrongType {
                v,
                function: "fmi2SetReal",
            });
        };
        check_writable(v, phase)?;
        if value < 1 || value as usize > names.len() {
            return Err(BindingError::NotAnItem { v, value, names });
        }
        Ok(())
    }

    fn set_integer(&mut self, vr: u32, value: i32) {
        self.sim.params.set_enumeration(vr, value);
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), BindingError> {
        self.sim.params.validate().map_err(BindingError::Invalid)?;
        self.sim = Simulator::new(self.sim.params.clone(), self.sim.inputs, start_time);
        self.initialized = true;
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<(), BindingError> {
        self.sim.advance((t + h) - self.sim.time());
        let outputs = self.sim.outputs();
        match first_non_finite(&outputs) {
            None => Ok(()),
            Some(output) => Err(BindingError::Diverged {
                output,
                t: self.sim.time(),
            }),
        }
    }
}

/// The first output that is NaN or infinite.
fn first_non_finite(outputs: &variables::Outputs) -> Option<&'static str> {
    let values = outputs.values();
    variables::Outputs::NAMES
        .iter()
        .zip(values)
        .find(|(_, v)| !v.is_finite())
        .map(|(n, _)| *n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::variables::vr;

    fn var(name: &str) -> &'static Variable {
        variables::by_name(name).unwrap()
    }

    #[test]
    fn the_table_declares_every_category_the_layer_logs_to() {
        for category in crate::fmi::log::LAYER_CATEGORIES {
            assert!(
                ThrustModel::LOG_CATEGORIES.contains(category),
                "{category} missing from variables.toml"
            );
        }
    }

    #[test]
    fn setting_rules_follow_the_table() {
        let m = ThrustModel::instantiate();
        let fixed = var("m");
        let tunable = var("Kp1");
        let start = |v: &Variable| match v.kind {
            Kind::Real { start, .. } => start,
            Kind::Enumeration { .. } => unreachable!(),
        };
        assert!(m
            .check_real(fixed.vr, start(fixed), Phase::Initialization)
            .is_ok());
        let err = m
            .check_real(fixed.vr, start(fixed), Phase::Stepping)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("`m`") && err.contains("before fmi2ExitInitializationMode"),
            "{err}"
        );
        assert!(m
            .check_real(tunable.vr, start(tunable), Phase::Stepping)
            .is_ok());
        assert!(m
            .check_real(vr::X, 0.0, Phase::Instantiated)
            .unwrap_err()
            .to_string()
            .contains("output"));
        assert!(m
            .check_real(vr::V_REF, f64::NAN, Phase::Stepping)
            .unwrap_err()
            .to_string()
            .contains("finite"));
        assert!(m
            .check_real(var("scheme").vr, 1.0, Phase::Instantiated)
            .unwrap_err()
            .to_string()
            .contains("fmi2SetInteger"));
        assert!(m
            .check_real(99_999, 1.0, Phase::Instantiated)
            .unwrap_err()
            .to_string()
            .contains("unknown value reference 99999"));
        let Kind::Real { max, .. } = tunable.kind else {
            unreachable!()
        };
        assert!(m
            .check_real(tunable.vr, max * 2.0 + 1.0, Phase::Stepping)
            .is_err());
    }

    #[test]
    fn enumerations_are_integers_from_one() {
        let mut m = ThrustModel::instantiate();
        let scheme = var("scheme");
        let Kind::Enumeration { names, start } = scheme.kind else {
            unreachable!()
        };
        assert_eq!(m.get_integer(scheme.vr).ok(), Some(start));
        assert!(m.check_integer(scheme.vr, 0, Phase::Instantiated).is_err());
        let err = m
            .check_integer(scheme.vr, names.len() as i32 + 1, Phase::Instantiated)
            .unwrap_err()
            .to_string();
        assert!(err.contains(&format!("1 = {}", names[0])), "{err}");
        assert!(m.check_integer(scheme.vr, 1, Phase::Stepping).is_err());
        m.set_integer(scheme.vr, 1);
        assert_eq!(m.get_integer(scheme.vr).ok(), Some(1));
        assert!(m
            .get_integer(vr::X)
            .unwrap_err()
            .to_string()
            .contains("fmi2GetReal"));
    }

    #[test]
    fn steps_match_the_simulator() {
        let mut m = ThrustModel::instantiate();
        m.set_real(vr::V_REF, 0.05);
        m.exit_initialization(0.0).unwrap();
        let mut sim = Simulator::new(
            Params::default(),
            Inputs {
                v_ref: 0.05,
                ..start_inputs()
            },
            0.0,
        );
        for k in 0..50 {
            let t = k as f64 * 0.01;
            m.do_step(t, 0.01).unwrap();
            sim.advance((t + 0.01) - sim.time());
        }
        let mut x = [0.0];
        m.get_reals(&[vr::X], &mut x).unwrap();
        assert_eq!(x[0], sim.outputs().x);
        assert!(x[0] > 0.0);
    }

    #[test]
    fn divergence_is_reported() {
        let mut m = ThrustModel::instantiate();
        m.exit_initialization(0.0).unwrap();
        m.sim.inputs.F_L = f64::NAN;
        assert!(m
            .do_step(0.0, 0.01)
            .unwrap_err()
            .to_string()
            .contains("not finite"));
    }
}
