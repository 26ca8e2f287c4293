//! The FMI 2.0 Co-Simulation functions, generic over the model. The exported C symbols
//! (see [`crate::fmi2_cosimulation_exports`]) only forward here inside [`guard`].
//!
//! # Safety
//! Every function takes the importer's pointers as FMI 2.0 defines them: a component from
//! fmi2Instantiate (or NULL), arrays of at least the given length (or NULL, which is
//! refused), NUL-terminated strings (or NULL).

// The Safety section above covers every function of this module.
#![allow(clippy::missing_safety_doc)]

use super::instance::{reject, time_tolerance, Instance, Outcome, Problem};
use super::log::{self, Logger};
use super::mode::{self, Mode};
use super::model::{CoSimModel, Phase};
use super::resource::decode_resource_location;
use super::snapshot;
use super::types::*;
use std::ffi::{c_int, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;

/// Runs `f`, returning `fallback` if it panics: nothing unwinds across the C boundary.
pub fn guard<T>(fallback: T, f: impl FnOnce() -> T) -> T {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or(fallback)
}

/// Runs an FMI call on component `c` (see [`Instance::call`]); NULL or a foreign pointer
/// gives fmi2Error without a message (there is no logger to send it to).
unsafe fn call<M: CoSimModel>(
    c: Fmi2Component,
    function: &str,
    mask: u32,
    args: impl FnOnce() -> String,
    body: impl FnOnce(&mut Instance<M>) -> Outcome,
) -> Fmi2Status {
    match Instance::<M>::from_component(c) {
        Some(instance) => instance.call(function, mask, args, body),
        None => Fmi2Status::Error,
    }
}

/// A string argument, or None for NULL.
unsafe fn string<'a>(s: Fmi2String) -> Option<&'a str> {
    (!s.is_null()).then(|| CStr::from_ptr(s).to_str().unwrap_or("<not UTF-8>"))
}

/// The importer's array `p[0..n]`; n = 0 gives an empty slice whatever `p` is.
unsafe fn slice<'a, T>(p: *const T, n: usize, what: &str) -> Result<&'a [T], Problem> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return reject(format!("{what} is NULL but {n} values were announced."));
    }
    if !p.is_aligned() || n > isize::MAX as usize / size_of::<T>().max(1) {
        return reject(format!("{what} is not a valid array of {n} values."));
    }
    Ok(std::slice::from_raw_parts(p, n))
}

/// Writes `values` to the importer's array `out` (checked like [`slice`]).
unsafe fn write_out<T: Copy>(out: *mut T, values: &[T], what: &str) -> Outcome {
    slice(out.cast_const(), values.len(), what)?;
    if !values.is_empty() {
        ptr::copy_nonoverlapping(values.as_ptr(), out, values.len());
    }
    Ok(())
}

unsafe fn out_param<'a, T>(p: *mut T, what: &str) -> Result<&'a mut T, Problem> {
    match p.as_mut() {
        Some(r) if p.is_aligned() => Ok(r),
        _ => reject(format!("{what} is NULL.")),
    }
}

fn finite(value: f64, what: &str) -> Outcome {
    if value.is_finite() {
        Ok(())
    } else {
        reject(format!("{what} = {value} is not a finite number."))
    }
}

// ----------------------------------------------------------------------------------------
// Life cycle
// ----------------------------------------------------------------------------------------

/// fmi2Instantiate: NULL if `functions` is NULL, or after logging why, if the name is
/// missing, the type is not Co-Simulation or the GUID is not this build's.
pub unsafe fn instantiate<M: CoSimModel>(
    instance_name: Fmi2String,
    fmu_type: c_int,
    guid: Fmi2String,
    resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    let Some(functions) = functions.as_ref() else {
        return ptr::null_mut();
    };
    let name = string(instance_name).unwrap_or("");
    let logger = Logger::new(
        functions.logger,
        functions.component_environment,
        if name.is_empty() { "?" } else { name },
        M::LOG_CATEGORIES,
        logging_on != FMI2_FALSE,
    );
    if let Err(message) = check_instantiation::<M>(name, fmu_type, string(guid)) {
        logger.log(
            Fmi2Status::Error,
            log::status_category(Fmi2Status::Error),
            &format!("fmi2Instantiate: {message}"),
        );
        return ptr::null_mut();
    }
    let location = string(resource_location).map(decode_resource_location);
    let instance = Instance::<M>::new(logger, location);
    instance.event(&format!(
        "fmi2Instantiate: instance \"{name}\" created; resources at {}",
        instance
            .resource_location
            .as_deref()
            .unwrap_or("(no fmuResourceLocation given)")
    ));
    Box::into_raw(instance).cast()
}

/// Why fmi2Instantiate refuses; logged as one line.
#[derive(Debug)]
enum InstantiationError {
    MissingName,
    ModelExchange,
    NotAType(c_int),
    MissingGuid,
    WrongGuid { given: String, built: &'static str },
}

impl std::fmt::Display for InstantiationError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InstantiationError::MissingName => write!(f, "Missing instance name."),
            InstantiationError::ModelExchange => write!(
                f,
                "fmuType fmi2ModelExchange is not supported: this FMU implements only Co-Simulation."
            ),
            InstantiationError::NotAType(other) => write!(
                f,
                "fmuType {other} is not an fmi2Type; this FMU implements only Co-Simulation (1)."
            ),
            InstantiationError::MissingGuid => write!(f, "Missing GUID."),
            InstantiationError::WrongGuid { given, built } => write!(
                f,
                "Wrong GUID {given}: this binary was built as {built}; its modelDescription.xml comes from another build."
            ),
        }
    }
}

fn check_instantiation<M: CoSimModel>(
    name: &str,
    fmu_type: c_int,
    guid: Option<&str>,
) -> Result<(), InstantiationError> {
    if name.is_empty() {
        return Err(InstantiationError::MissingName);
    }
    match fmu_type {
        FMI2_CO_SIMULATION => {}
        FMI2_MODEL_EXCHANGE => return Err(InstantiationError::ModelExchange),
        other => return Err(InstantiationError::NotAType(other)),
    }
    match guid {
        None => Err(InstantiationError::MissingGuid),
        Some(g) if g == M::GUID => Ok(()),
        Some(g) => Err(InstantiationError::WrongGuid {
            given: g.to_string(),
            built: M::GUID,
        }),
    }
}

pub unsafe fn free_instance<M: CoSimModel>(c: Fmi2Component) {
    if let Some(instance) = Instance::<M>::from_component(c) {
        instance.event("fmi2FreeInstance: instance freed.");
    }
    Instance::<M>::free(c);
}

pub unsafe fn set_debug_logging<M: CoSimModel>(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    let on = logging_on != FMI2_FALSE;
    call::<M>(
        c,
        "fmi2SetDebugLogging",
        mode::ANY,
        || format!("loggingOn={on}, nCategories={n}"),
        |s| {
            let names: Vec<String> = slice(categories, n, "categories[]")?
                .iter()
                .map(|&p| {
                    string(p)
                        .map(str::to_string)
                        .ok_or("categories[] holds a NULL string.")
                })
                .collect::<Result<_, _>>()
                .or_else(reject)?;
            if names.is_empty() {
                s.log.switch_all(on);
                Ok(())
            } else {
                s.log.switch(on, &names).or_else(reject)
            }
        },
    )
}

pub unsafe fn setup_experiment<M: CoSimModel>(
    c: Fmi2Component,
    tolerance_defined: Fmi2Boolean,
    start_time: f64,
    stop_time_defined: Fmi2Boolean,
    stop_time: f64,
) -> Fmi2Status {
    let stop = (stop_time_defined != FMI2_FALSE).then_some(stop_time);
    let args = || {
        format!(
            "startTime={start_time}, stopTime={}",
            stop.map_or("undefined".into(), |t| t.to_string())
        )
    };
    call::<M>(
        c,
        "fmi2SetupExperiment",
        mode::SETUP_EXPERIMENT,
        args,
        |s| {
            finite(start_time, "startTime")?;
            if let Some(stop) = stop {
                finite(stop, "stopTime")?;
                if stop < start_time {
                    return reject(format!(
                        "stopTime = {stop} s is before startTime = {start_time} s."
                    ));
                }
            }
            if tolerance_defined != FMI2_FALSE {
                s.event("fmi2SetupExperiment: the tolerance is not used (fixed-step solver on a 1 kHz grid).");
            }
            s.clock.start_time = start_time;
            s.clock.time = start_time;
            s.clock.stop_time = stop;
            Ok(())
        },
    )
}

pub unsafe fn enter_initialization_mode<M: CoSimModel>(c: Fmi2Component) -> Fmi2Status {
    call::<M>(
        c,
        "fmi2EnterInitializationMode",
        mode::ENTER_INITIALIZATION_MODE,
        String::new,
        |s| {
            s.mode = Mode::InitializationMode;
            Ok(())
        },
    )
}

pub unsafe fn exit_initialization_mode<M: CoSimModel>(c: Fmi2Component) -> Fmi2Status {
    call::<M>(
        c,
        "fmi2ExitInitializationMode",
        mode::EXIT_INITIALIZATION_MODE,
        String::new,
        |s| {
            s.model
                .exit_initialization(s.clock.start_time)
                .or_else(reject)?;
            s.mode = Mode::StepComplete;
            s.event(&format!(
                "fmi2ExitInitializationMode: running from t = {} s.",
                s.clock.start_time
            ));
            Ok(())
        },
    )
}

pub unsafe fn terminate<M: CoSimModel>(c: Fmi2Component) -> Fmi2Status {
    call::<M>(c, "fmi2Terminate", mode::TERMINATE, String::new, |s| {
        s.mode = Mode::Terminated;
        Ok(())
    })
}

/// fmi2Reset: back to Instantiated with every start value; logging settings and FMU
/// states handed out are kept.
pub unsafe fn reset<M: CoSimModel>(c: Fmi2Component) -> Fmi2Status {
    call::<M>(c, "fmi2Reset", mode::ANY, String::new, |s| {
        s.model = M::instantiate();
        s.clock = Default::default();
        s.mode = Mode::Instantiated;
        s.event("fmi2Reset: back to the start values.");
        Ok(())
    })
}

// ----------------------------------------------------------------------------------------
// Getting and setting values
// ----------------------------------------------------------------------------------------

pub unsafe fn get_real<M: CoSimModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut f64,
) -> Fmi2Status {
    call::<M>(
        c,
        "fmi2GetReal",
        mode::GET_VALUES,
        || format!("nvr={n}"),
        |s| {
            let vrs = slice(vr, n, "vr[]")?;
            let mut values = vec![0.0; n];
            s.model.get_reals(vrs, &mut values).or_else(reject)?;
            write_out(value, &values, "value[]")
        },
    )
}

pub unsafe fn get_integer<M: CoSimModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    call::<M>(
        c,
        "fmi2GetInteger",
        mode::GET_VALUES,
        || format!("nvr={n}"),
        |s| {
            let values: Vec<Fmi2Integer> = slice(vr, n, "vr[]")?
                .iter()
                .map(|&r| s.model.get_integer(r))
                .collect::<Result<_, _>>()
                .or_else(reject)?;
            write_out(value, &values, "value[]")
        },
    )
}

pub unsafe fn set_real<M: CoSimModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const f64,
) -> Fmi2Status {
    set_values::<M, f64>(c, "fmi2SetReal", vr, n, value, M::check_real, M::set_real)
}

pub unsafe fn set_integer<M: CoSimModel>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    set_values::<M, Fmi2Integer>(
        c,
        "fmi2SetInteger",
        vr,
        n,
        value,
        M::check_integer,
        M::set_integer,
    )
}

/// A model's check of one value before it is written (`CoSimModel::check_real`, ...).
type Check<M, T> = fn(&M, u32, T, Phase) -> Result<(), <M as CoSimModel>::Error>;

/// Sets `n` values atomically: every value is checked before any is written.
unsafe fn set_values<M: CoSimModel, T: Copy>(
    c: Fmi2Component,
    function: &str,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const T,
    check: Check<M, T>,
    set: fn(&mut M, u32, T),
) -> Fmi2Status {
    call::<M>(
        c,
        function,
        mode::SET_VALUES,
        || format!("nvr={n}"),
        |s| {
            let (vrs, values) = (slice(vr, n, "vr[]")?, slice(value, n, "value[]")?);
            let phase = s.phase();
            for (&r, &v) in vrs.iter().zip(values) {
                check(&s.model, r, v, phase).or_else(reject)?;
            }
            vrs.iter()
                .zip(values)
                .for_each(|(&r, &v)| set(&mut s.model, r, v));
            Ok(())
        },
    )
}

/// Boolean and String access: the model has no such variables, so any value reference is
/// refused with what it is instead.
pub unsafe fn no_variables_of_type<M: CoSimModel>(
    c: Fmi2Component,
    function: &str,
    mask: u32,
    type_name: &str,
    vr: *const Fmi2ValueReference,
    n: usize,
    value_is_null: bool,
) -> Fmi2Status {
    call::<M>(
        c,
        function,
        mask,
        || format!("nvr={n}"),
        |_| {
            let Some(&first) = slice(vr, n, "vr[]")?.first() else {
                return Ok(());
            };
            if value_is_null {
                return reject("value[] is NULL.");
            }
            match M::describe(first) {
            Some(what) => reject(format!("{what} is not a {type_name} variable; this model has no {type_name} variables.")),
            None => reject(format!("unknown value reference {first}.")),
        }
        },
    )
}

// ----------------------------------------------------------------------------------------
// FMU state
// ----------------------------------------------------------------------------------------

/// fmi2GetFMUstate: a new state, or the importer's earlier state overwritten in place.
pub unsafe fn get_fmu_state<M: CoSimModel>(
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    call::<M>(c, "fmi2GetFMUstate", mode::ANY, String::new, |s| {
        let state = out_param(state, "FMUstate")?;
        let snapshot = s.snapshot();
        store_state(s, state, snapshot)
    })
}

/// Puts `snapshot` into `*state`: a new FMU state if it is NULL, else the existing one.
fn store_state<M: CoSimModel>(
    s: &mut Instance<M>,
    state: &mut Fmi2FmuState,
    snapshot: super::instance::Snapshot<M>,
) -> Outcome {
    if state.is_null() {
        *state = s.adopt_state(snapshot);
    } else {
        *s.state_mut(*state)? = snapshot;
    }
    Ok(())
}

pub unsafe fn set_fmu_state<M: CoSimModel>(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    call::<M>(c, "fmi2SetFMUstate", mode::ANY, String::new, |s| {
        let snapshot = s.state_mut(state)?.clone();
        s.restore(&snapshot);
        Ok(())
    })
}

pub unsafe fn free_fmu_state<M: CoSimModel>(
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    call::<M>(c, "fmi2FreeFMUstate", mode::ANY, String::new, |s| {
        let state = out_param(state, "FMUstate")?;
        if !state.is_null() {
            s.release_state(*state)?;
            *state = ptr::null_mut();
        }
        Ok(())
    })
}

fn serialize<M: CoSimModel>(s: &mut Instance<M>, state: Fmi2FmuState) -> Result<Vec<u8>, Problem> {
    snapshot::encode(&*s.state_mut(state)?, M::GUID).or_else(reject)
}

pub unsafe fn serialized_fmu_state_size<M: CoSimModel>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    call::<M>(
        c,
        "fmi2SerializedFMUstateSize",
        mode::ANY,
        String::new,
        |s| {
            let size = out_param(size, "size")?;
            *size = serialize(s, state)?.len();
            Ok(())
        },
    )
}

pub unsafe fn serialize_fmu_state<M: CoSimModel>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    bytes: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    call::<M>(
        c,
        "fmi2SerializeFMUstate",
        mode::ANY,
        || format!("size={size}"),
        |s| {
            let serialized = serialize(s, state)?;
            if size != serialized.len() {
                return reject(format!(
                    "size = {size} but fmi2SerializedFMUstateSize gives {}.",
                    serialized.len()
                ));
            }
            write_out(bytes.cast::<u8>(), &serialized, "serializedState[]")
        },
    )
}

pub unsafe fn deserialize_fmu_state<M: CoSimModel>(
    c: Fmi2Component,
    bytes: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    call::<M>(
        c,
        "fmi2DeSerializeFMUstate",
        mode::ANY,
        || format!("size={size}"),
        |s| {
            let bytes = slice(bytes.cast::<u8>(), size, "serializedState[]")?;
            let state = out_param(state, "FMUstate")?;
            let snapshot = snapshot::decode(bytes, M::GUID).or_else(reject)?;
            store_state(s, state, snapshot)
        },
    )
}

// ----------------------------------------------------------------------------------------
// Derivatives (not provided) and stepping
// ----------------------------------------------------------------------------------------

/// A function whose capability the modelDescription declares absent: fmi2Error saying so.
pub unsafe fn not_provided<M: CoSimModel>(
    c: Fmi2Component,
    function: &str,
    mask: u32,
    capability: &str,
) -> Fmi2Status {
    call::<M>(c, function, mask, String::new, |_| {
        reject(format!("not provided by this FMU ({capability})."))
    })
}

pub unsafe fn do_step<M: CoSimModel>(c: Fmi2Component, t: f64, h: f64) -> Fmi2Status {
    let args = || format!("currentCommunicationPoint={t}, communicationStepSize={h}");
    call::<M>(c, "fmi2DoStep", mode::DO_STEP, args, |s| {
        check_step::<M>(s, t, h)?;
        match s.model.do_step(t, h) {
            Ok(()) => {
                s.clock.time = t + h;
                Ok(())
            }
            Err(message) => {
                s.mode = Mode::StepFailed;
                s.clock.terminated = true;
                Err(Problem::Discard(format!(
                    "{message} The last successful time is {t} s."
                )))
            }
        }
    })
}

/// The step size is positive and not absurd, the step starts where the last one ended
/// (within [`time_tolerance`]) and does not pass the stop time.
fn check_step<M: CoSimModel>(s: &Instance<M>, t: f64, h: f64) -> Outcome {
    finite(t, "currentCommunicationPoint")?;
    finite(h, "communicationStepSize")?;
    if h <= 0.0 {
        return reject(format!("communicationStepSize = {h} s must be positive."));
    }
    if h > M::MAX_STEP {
        return reject(format!(
            "communicationStepSize = {h} s is longer than the longest accepted step, {} s.",
            M::MAX_STEP
        ));
    }
    let expected = s.clock.time;
    if (t - expected).abs() > time_tolerance(expected) {
        return reject(format!(
            "currentCommunicationPoint = {t} s, but the last step ended at {expected} s (tolerance {:e} s).",
            time_tolerance(expected)
        ));
    }
    match s.clock.stop_time {
        Some(stop) if t + h > stop + time_tolerance(stop) => reject(format!(
            "the step to {} s would pass stopTime = {stop} s set in fmi2SetupExperiment.",
            t + h
        )),
        _ => Ok(()),
    }
}

pub unsafe fn get_status<M: CoSimModel>(
    c: Fmi2Component,
    function: &str,
    kind: c_int,
    value_is_null: bool,
) -> Fmi2Status {
    call::<M>(
        c,
        function,
        mode::GET_STATUS,
        || format!("kind={kind}"),
        |_| {
            if value_is_null {
                return reject("value is NULL.");
            }
            Err(Problem::Discard(format!(
            "status kind {} is not provided (fmi2DoStep never returns fmi2Pending); \
             available: fmi2GetRealStatus(fmi2LastSuccessfulTime), fmi2GetBooleanStatus(fmi2Terminated).",
            status_kind_name(kind)
        )))
        },
    )
}

pub unsafe fn get_real_status<M: CoSimModel>(
    c: Fmi2Component,
    kind: c_int,
    value: *mut f64,
) -> Fmi2Status {
    if kind != FMI2_LAST_SUCCESSFUL_TIME {
        return get_status::<M>(c, "fmi2GetRealStatus", kind, value.is_null());
    }
    call::<M>(
        c,
        "fmi2GetRealStatus",
        mode::GET_STATUS,
        || format!("kind={kind}"),
        |s| {
            *out_param(value, "value")? = s.clock.time;
            Ok(())
        },
    )
}

pub unsafe fn get_boolean_status<M: CoSimModel>(
    c: Fmi2Component,
    kind: c_int,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    if kind != FMI2_TERMINATED {
        return get_status::<M>(c, "fmi2GetBooleanStatus", kind, value.is_null());
    }
    call::<M>(
        c,
        "fmi2GetBooleanStatus",
        mode::GET_STATUS,
        || format!("kind={kind}"),
        |s| {
            *out_param(value, "value")? = if s.clock.terminated {
                FMI2_TRUE
            } else {
                FMI2_FALSE
            };
            Ok(())
        },
    )
}

fn status_kind_name(kind: c_int) -> String {
    match kind {
        FMI2_DO_STEP_STATUS => "fmi2DoStepStatus".into(),
        FMI2_PENDING_STATUS => "fmi2PendingStatus".into(),
        FMI2_LAST_SUCCESSFUL_TIME => "fmi2LastSuccessfulTime".into(),
        FMI2_TERMINATED => "fmi2Terminated".into(),
        other => format!("{other} (not an fmi2StatusKind)"),
    }
}
