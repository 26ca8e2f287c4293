//! A generic FMI 2.0 Co-Simulation C API, shaped like Reference-FMUs' fmi2Functions.c and
//! knowing nothing about the model behind it:
//!
//! - [`model::CoSimModel`]: the internal API a model implements (variables by value
//!   reference, initialisation, one communication step; the model value is the FMU state);
//! - [`mode`]: the state machine, one bitmask of legal modes per function;
//! - [`instance`]: one `fmi2Component`, the call wrapper that checks the mode, catches
//!   panics and logs;
//! - [`api`]: every FMI function, generic over the model;
//! - [`fmi2_cosimulation_exports!`](crate::fmi2_cosimulation_exports): the `#[no_mangle]`
//!   C symbols for one model type;
//! - [`log`], [`snapshot`], [`resource`], [`types`]: logger, serialized states, the resource
//!   URI, the hand-written C types.
//!
//! The rules (which call is legal when, what is refused and how) are in docs/fmi.md.

pub mod api;
pub mod instance;
pub mod log;
pub mod mode;
pub mod model;
pub mod resource;
pub mod snapshot;
pub mod types;

#[cfg(test)]
mod tests;

/// The FMI 2.0 version string returned by fmi2GetVersion.
pub const VERSION: &std::ffi::CStr = c"2.0";
/// The types platform returned by fmi2GetTypesPlatform.
pub const TYPES_PLATFORM: &std::ffi::CStr = c"default";

/// Exports every FMI 2.0 Co-Simulation function (and the common ones) as an unmangled C
/// symbol for the model type `$model`, each forwarding to [`api`] inside [`api::guard`].
/// Invoke it once per shared library.
#[macro_export]
macro_rules! fmi2_cosimulation_exports {
    ($model:ty) => {
        /// The C symbols of the FMI 2.0 Co-Simulation API.
        ///
        /// # Safety
        /// Called by an FMI importer with the arguments FMI 2.0 specifies; every pointer is
        /// checked for NULL and every call for its legal state.
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub mod fmi2_exports {
            use super::*;
            use std::ffi::{c_char, c_int};
            use $crate::fmi::api::{self, guard};
            use $crate::fmi::mode;
            use $crate::fmi::types::*;

            type M = $model;
            const E: Fmi2Status = Fmi2Status::Error;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
                $crate::fmi::TYPES_PLATFORM.as_ptr()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> *const c_char {
                $crate::fmi::VERSION.as_ptr()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: Fmi2Component,
                on: Fmi2Boolean,
                n: usize,
                categories: *const Fmi2String,
            ) -> Fmi2Status {
                guard(E, || api::set_debug_logging::<M>(c, on, n, categories))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: Fmi2String,
                fmu_type: c_int,
                guid: Fmi2String,
                resources: Fmi2String,
                functions: *const Fmi2CallbackFunctions,
                _visible: Fmi2Boolean,
                logging_on: Fmi2Boolean,
            ) -> Fmi2Component {
                guard(std::ptr::null_mut(), || {
                    api::instantiate::<M>(name, fmu_type, guid, resources, functions, logging_on)
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
                guard((), || api::free_instance::<M>(c))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: Fmi2Component,
                tolerance_defined: Fmi2Boolean,
                _tolerance: f64,
                start: f64,
                stop_defined: Fmi2Boolean,
                stop: f64,
            ) -> Fmi2Status {
                guard(E, || {
                    api::setup_experiment::<M>(c, tolerance_defined, start, stop_defined, stop)
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
                guard(E, || api::enter_initialization_mode::<M>(c))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
                guard(E, || api::exit_initialization_mode::<M>(c))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
                guard(E, || api::terminate::<M>(c))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
                guard(E, || api::reset::<M>(c))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                value: *mut Fmi2Real,
            ) -> Fmi2Status {
                guard(E, || api::get_real::<M>(c, vr, n, value))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                value: *mut Fmi2Integer,
            ) -> Fmi2Status {
                guard(E, || api::get_integer::<M>(c, vr, n, value))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                value: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                guard(E, || {
                    api::no_variables_of_type::<M>(
                        c,
                        "fmi2GetBoolean",
                        mode::GET_VALUES,
                        "Boolean",
                        vr,
                        n,
                        value.is_null(),
                    )
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                value: *mut Fmi2String,
            ) -> Fmi2Status {
                guard(E, || {
                    api::no_variables_of_type::<M>(
                        c,
                        "fmi2GetString",
                        mode::GET_VALUES,
                        "String",
                        vr,
                        n,
                        value.is_null(),
                    )
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                value: *const Fmi2Real,
            ) -> Fmi2Status {
                guard(E, || api::set_real::<M>(c, vr, n, value))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                value: *const Fmi2Integer,
            ) -> Fmi2Status {
                guard(E, || api::set_integer::<M>(c, vr, n, value))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                value: *const Fmi2Boolean,
            ) -> Fmi2Status {
                guard(E, || {
                    api::no_variables_of_type::<M>(
                        c,
                        "fmi2SetBoolean",
                        mode::SET_VALUES,
                        "Boolean",
                        vr,
                        n,
                        value.is_null(),
                    )
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                value: *const Fmi2String,
            ) -> Fmi2Status {
                guard(E, || {
                    api::no_variables_of_type::<M>(
                        c,
                        "fmi2SetString",
                        mode::SET_VALUES,
                        "String",
                        vr,
                        n,
                        value.is_null(),
                    )
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(
                c: Fmi2Component,
                state: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                guard(E, || api::get_fmu_state::<M>(c, state))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(
                c: Fmi2Component,
                state: Fmi2FmuState,
            ) -> Fmi2Status {
                guard(E, || api::set_fmu_state::<M>(c, state))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(
                c: Fmi2Component,
                state: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                guard(E, || api::free_fmu_state::<M>(c, state))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: Fmi2Component,
                state: Fmi2FmuState,
                size: *mut usize,
            ) -> Fmi2Status {
                guard(E, || api::serialized_fmu_state_size::<M>(c, state, size))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: Fmi2Component,
                state: Fmi2FmuState,
                bytes: *mut Fmi2Byte,
                size: usize,
            ) -> Fmi2Status {
                guard(E, || api::serialize_fmu_state::<M>(c, state, bytes, size))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: Fmi2Component,
                bytes: *const Fmi2Byte,
                size: usize,
                state: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                guard(E, || api::deserialize_fmu_state::<M>(c, bytes, size, state))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: Fmi2Component,
                _unknown: *const Fmi2ValueReference,
                _n_unknown: usize,
                _known: *const Fmi2ValueReference,
                _n_known: usize,
                _dv_known: *const Fmi2Real,
                _dv_unknown: *mut Fmi2Real,
            ) -> Fmi2Status {
                let capability = "providesDirectionalDerivative=\"false\"";
                guard(E, || {
                    api::not_provided::<M>(
                        c,
                        "fmi2GetDirectionalDerivative",
                        mode::GET_VALUES,
                        capability,
                    )
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: Fmi2Component,
                _vr: *const Fmi2ValueReference,
                _n: usize,
                _order: *const Fmi2Integer,
                _value: *const Fmi2Real,
            ) -> Fmi2Status {
                let capability = "canInterpolateInputs=\"false\"";
                guard(E, || {
                    api::not_provided::<M>(
                        c,
                        "fmi2SetRealInputDerivatives",
                        mode::SET_VALUES,
                        capability,
                    )
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: Fmi2Component,
                _vr: *const Fmi2ValueReference,
                _n: usize,
                _order: *const Fmi2Integer,
                _value: *mut Fmi2Real,
            ) -> Fmi2Status {
                let capability = "maxOutputDerivativeOrder=\"0\"";
                guard(E, || {
                    api::not_provided::<M>(
                        c,
                        "fmi2GetRealOutputDerivatives",
                        mode::GET_OUTPUT_DERIVATIVES,
                        capability,
                    )
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DoStep(
                c: Fmi2Component,
                t: Fmi2Real,
                h: Fmi2Real,
                _no_set_prior: Fmi2Boolean,
            ) -> Fmi2Status {
                guard(E, || api::do_step::<M>(c, t, h))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
                guard(E, || {
                    api::not_provided::<M>(
                        c,
                        "fmi2CancelStep",
                        mode::CANCEL_STEP,
                        "synchronous fmi2DoStep",
                    )
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: Fmi2Component,
                kind: c_int,
                value: *mut c_int,
            ) -> Fmi2Status {
                guard(E, || {
                    api::get_status::<M>(c, "fmi2GetStatus", kind, value.is_null())
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: Fmi2Component,
                kind: c_int,
                value: *mut Fmi2Real,
            ) -> Fmi2Status {
                guard(E, || api::get_real_status::<M>(c, kind, value))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: Fmi2Component,
                kind: c_int,
                value: *mut Fmi2Integer,
            ) -> Fmi2Status {
                guard(E, || {
                    api::get_status::<M>(c, "fmi2GetIntegerStatus", kind, value.is_null())
                })
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: Fmi2Component,
                kind: c_int,
                value: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                guard(E, || api::get_boolean_status::<M>(c, kind, value))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: Fmi2Component,
                kind: c_int,
                value: *mut Fmi2String,
            ) -> Fmi2Status {
                guard(E, || {
                    api::get_status::<M>(c, "fmi2GetStringStatus", kind, value.is_null())
                })
            }
        }
    };
}
