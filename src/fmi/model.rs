//! The small internal API between the generic FMI 2.0 layer and a model (the counterpart
//! of Reference-FMUs' `model.h`). The layer owns the state machine, argument checks,
//! logging and FMU states; the model owns its variables and physics.
//!
//! Every `Err(String)` is a complete sentence for the importer's log; the layer prefixes it
//! with the FMI function name.

use serde::de::DeserializeOwned;
use serde::Serialize;

/// Where the instance is in its life cycle, as far as setting values is concerned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// After fmi2Instantiate (or fmi2Reset), before fmi2EnterInitializationMode.
    Instantiated,
    /// Between fmi2EnterInitializationMode and fmi2ExitInitializationMode.
    Initialization,
    /// After fmi2ExitInitializationMode, between communication steps.
    Stepping,
}

impl Phase {
    /// True before fmi2ExitInitializationMode, when `fixed` parameters may still be set.
    pub fn before_exit_initialization(self) -> bool {
        self != Phase::Stepping
    }
}

/// A co-simulation model behind the FMI 2.0 C API.
///
/// The whole model value is the FMU state: `Clone` gives fmi2GetFMUstate, `Serialize` /
/// `Deserialize` give fmi2SerializeFMUstate, and `PartialEq` lets the layer verify that a
/// serialized state restores exactly.
pub trait CoSimModel: Clone + PartialEq + Serialize + DeserializeOwned + 'static {
    /// The `guid` attribute of the modelDescription; fmi2Instantiate rejects any other.
    const GUID: &'static str;
    /// The modelDescription's `<LogCategories>`; fmi2SetDebugLogging rejects any other.
    const LOG_CATEGORIES: &'static [&'static str];
    /// The longest communication step accepted [s]; longer ones are rejected as absurd.
    const MAX_STEP: f64;
    /// Why the model refuses a call; logged to the importer as one line, its `Display`.
    type Error: std::fmt::Display;

    /// A model holding the start values of every variable.
    fn instantiate() -> Self;

    /// "`name` (vr N, Real output)" for messages, or None for an unknown value reference.
    fn describe(vr: u32) -> Option<String>;

    /// Reads Real variables; `values.len() == vrs.len()`.
    fn get_reals(&self, vrs: &[u32], values: &mut [f64]) -> Result<(), Self::Error>;
    /// Reads one Integer (or enumeration) variable.
    fn get_integer(&self, vr: u32) -> Result<i32, Self::Error>;

    /// Whether `value` may be written to Real variable `vr` now (nothing is changed).
    fn check_real(&self, vr: u32, value: f64, phase: Phase) -> Result<(), Self::Error>;
    /// Writes a value that [`CoSimModel::check_real`] accepted.
    fn set_real(&mut self, vr: u32, value: f64);
    /// Whether `value` may be written to Integer (or enumeration) variable `vr` now.
    fn check_integer(&self, vr: u32, value: i32, phase: Phase) -> Result<(), Self::Error>;
    /// Writes a value that [`CoSimModel::check_integer`] accepted.
    fn set_integer(&mut self, vr: u32, value: i32);

    /// Leaves initialisation: the model starts at `start_time` from the values set so far.
    /// On error nothing changed and the instance stays in initialisation mode.
    fn exit_initialization(&mut self, start_time: f64) -> Result<(), Self::Error>;

    /// Advances from communication point `t` by `h` with the inputs held. An error means
    /// the step could not be completed (the instance then reports fmi2Discard).
    fn do_step(&mut self, t: f64, h: f64) -> Result<(), Self::Error>;
}
