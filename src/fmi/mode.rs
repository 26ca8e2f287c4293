//! The FMI 2.0 Co-Simulation state machine: the instance's mode and, per function, the
//! bitmask of modes in which the call is legal (as `MASK_fmi2*` in Reference-FMUs'
//! fmi2Functions.c). A call outside its mask returns fmi2Error, changes nothing and logs
//! "Illegal call sequence".
//!
//! `StepInProgress` and `StepCanceled` never occur: fmi2DoStep computes synchronously.

use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mode {
    Instantiated,
    InitializationMode,
    StepComplete,
    /// fmi2DoStep returned fmi2Discard.
    StepFailed,
    Terminated,
    /// A computation failed (fmi2Error with the model possibly inconsistent).
    Error,
}

pub const INSTANTIATED: u32 = 1 << Mode::Instantiated as u32;
pub const INITIALIZATION_MODE: u32 = 1 << Mode::InitializationMode as u32;
pub const STEP_COMPLETE: u32 = 1 << Mode::StepComplete as u32;
pub const STEP_FAILED: u32 = 1 << Mode::StepFailed as u32;
pub const TERMINATED: u32 = 1 << Mode::Terminated as u32;
pub const ERROR: u32 = 1 << Mode::Error as u32;

pub const ANY: u32 =
    INSTANTIATED | INITIALIZATION_MODE | STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR;
pub const SETUP_EXPERIMENT: u32 = INSTANTIATED;
pub const ENTER_INITIALIZATION_MODE: u32 = INSTANTIATED;
pub const EXIT_INITIALIZATION_MODE: u32 = INITIALIZATION_MODE;
pub const TERMINATE: u32 = STEP_COMPLETE | STEP_FAILED;
pub const GET_VALUES: u32 = INITIALIZATION_MODE | STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR;
pub const SET_VALUES: u32 = INSTANTIATED | INITIALIZATION_MODE | STEP_COMPLETE;
pub const GET_OUTPUT_DERIVATIVES: u32 = STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR;
pub const DO_STEP: u32 = STEP_COMPLETE;
/// fmi2CancelStep is legal only in StepInProgress, which this FMU never enters.
pub const CANCEL_STEP: u32 = 0;
pub const GET_STATUS: u32 = STEP_COMPLETE | STEP_FAILED | TERMINATED;

const ALL: [Mode; 6] = [
    Mode::Instantiated,
    Mode::InitializationMode,
    Mode::StepComplete,
    Mode::StepFailed,
    Mode::Terminated,
    Mode::Error,
];

impl Mode {
    pub fn allowed(self, mask: u32) -> bool {
        mask & (1 << self as u32) != 0
    }

    /// The modes of `mask`, for the "Illegal call sequence" message.
    pub fn describe_mask(mask: u32) -> String {
        if mask == 0 {
            return "StepInProgress, which this FMU never enters (fmi2DoStep is synchronous)"
                .into();
        }
        let names: Vec<String> = ALL
            .iter()
            .filter(|m| m.allowed(mask))
            .map(|m| format!("{m:?}"))
            .collect();
        names.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_name_their_modes() {
        assert!(Mode::StepComplete.allowed(DO_STEP));
        assert!(!Mode::Instantiated.allowed(DO_STEP));
        assert!(!Mode::StepFailed.allowed(CANCEL_STEP));
        assert_eq!(Mode::describe_mask(TERMINATE), "StepComplete, StepFailed");
        assert!(Mode::describe_mask(CANCEL_STEP).contains("never"));
        assert!(ALL.iter().all(|m| m.allowed(ANY)));
    }
}
