//! The C types of the FMI 2.0 API (fmi2TypesPlatform.h, fmi2FunctionTypes.h), written by hand.
//!
//! Enumerations that come *from* the importer (`fmi2Type`, `fmi2StatusKind`) are taken as
//! plain `c_int` and checked, because an out-of-range value in a Rust enum is undefined
//! behaviour.

use std::ffi::{c_char, c_int, c_uint, c_void};

pub type Fmi2Component = *mut c_void;
pub type Fmi2ComponentEnvironment = *mut c_void;
pub type Fmi2FmuState = *mut c_void;
pub type Fmi2ValueReference = c_uint;
pub type Fmi2Real = f64;
pub type Fmi2Integer = c_int;
pub type Fmi2Boolean = c_int;
pub type Fmi2String = *const c_char;
pub type Fmi2Byte = c_char;

pub const FMI2_TRUE: Fmi2Boolean = 1;
pub const FMI2_FALSE: Fmi2Boolean = 0;

/// `fmi2Type`: only Co-Simulation is supported.
pub const FMI2_MODEL_EXCHANGE: c_int = 0;
pub const FMI2_CO_SIMULATION: c_int = 1;

/// `fmi2StatusKind`.
pub const FMI2_DO_STEP_STATUS: c_int = 0;
pub const FMI2_PENDING_STATUS: c_int = 1;
pub const FMI2_LAST_SUCCESSFUL_TIME: c_int = 2;
pub const FMI2_TERMINATED: c_int = 3;

/// `fmi2Status`; ordered so that the worse status compares greater.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Fmi2Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

/// `fmi2CallbackLogger`: printf-style and variadic. This FMU always passes `"%s"` as the
/// format and the message as the single variadic argument.
pub type Fmi2CallbackLogger = Option<
    unsafe extern "C" fn(
        component_environment: Fmi2ComponentEnvironment,
        instance_name: Fmi2String,
        status: c_int,
        category: Fmi2String,
        message: Fmi2String,
        ...
    ),
>;

/// `fmi2CallbackFunctions`. The memory functions are never called
/// (`canNotUseMemoryManagementFunctions="true"`), so they may be NULL.
#[repr(C)]
pub struct Fmi2CallbackFunctions {
    pub logger: Fmi2CallbackLogger,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(Fmi2ComponentEnvironment, c_int)>,
    pub component_environment: Fmi2ComponentEnvironment,
}
