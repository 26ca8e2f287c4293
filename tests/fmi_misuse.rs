//! Misuse of the packaged FMU through its C ABI: every refused call returns the documented
//! status, says why through the logger (always with a "%s" format), and leaves the
//! instance usable.

mod common;

use common::fmi2::{packaged, Instance};
use std::ffi::{c_int, CString};
use std::ptr::{null, null_mut};
use tbm_thrust::fmi::types::*;
use tbm_thrust::variables::{by_name, vr, Kind, VARIABLES};

type S = Fmi2Status;

fn vr_of(name: &str) -> u32 {
    by_name(name).unwrap().vr
}

/// (start, max) of a Real variable.
fn range_of(name: &str) -> (f64, f64) {
    match by_name(name).unwrap().kind {
        Kind::Real { start, max, .. } => (start, max),
        Kind::Enumeration { .. } => panic!("{name} is not Real"),
    }
}

fn max_of(name: &str) -> f64 {
    range_of(name).1
}

/// Asserts `status` and that the logged error messages contain every one of `needles`.
fn refused(inst: &Instance, status: S, expected: S, needles: &[&str]) {
    assert_eq!(status, expected);
    let errors = inst.errors();
    for needle in needles {
        assert!(
            errors.contains(needle),
            "expected {needle:?} in the logged errors:\n{errors}"
        );
    }
}

#[test]
fn illegal_call_sequences_are_refused_and_explained() {
    let inst = packaged().instance("sequence");
    let a = inst.api();
    let c = inst.c;
    unsafe {
        refused(
            &inst,
            inst.do_step(0.0, 0.01),
            S::Error,
            &["fmi2DoStep: Illegal call sequence", "Instantiated"],
        );
        refused(
            &inst,
            inst.get_reals(&[vr::X]).unwrap_err(),
            S::Error,
            &["fmi2GetReal: Illegal call sequence"],
        );
        refused(
            &inst,
            (a.exit_initialization_mode)(c),
            S::Error,
            &["fmi2ExitInitializationMode: Illegal"],
        );
        refused(
            &inst,
            (a.terminate)(c),
            S::Error,
            &["fmi2Terminate: Illegal call sequence"],
        );
        inst.initialize(0.0, None);
        refused(
            &inst,
            (a.setup_experiment)(c, 0, 0.0, 0.0, 0, 0.0),
            S::Error,
            &["fmi2SetupExperiment: Illegal"],
        );
        refused(
            &inst,
            (a.enter_initialization_mode)(c),
            S::Error,
            &["StepComplete"],
        );
        refused(
            &inst,
            (a.cancel_step)(c),
            S::Error,
            &["fmi2CancelStep", "never enters"],
        );
        assert_eq!(
            inst.do_step(0.0, 0.01),
            S::Ok,
            "still usable after refused calls"
        );
        assert_eq!((a.terminate)(c), S::Ok);
        refused(
            &inst,
            inst.set_real(&[vr::V_REF], &[0.01]),
            S::Error,
            &["fmi2SetReal: Illegal", "Terminated"],
        );
        refused(
            &inst,
            inst.do_step(0.01, 0.01),
            S::Error,
            &["fmi2DoStep: Illegal"],
        );
        assert!(
            inst.get_real(vr::X).is_finite(),
            "getters work after fmi2Terminate"
        );
        assert_eq!((a.reset)(c), S::Ok);
        refused(
            &inst,
            inst.get_reals(&[vr::X]).unwrap_err(),
            S::Error,
            &["Instantiated"],
        );
        inst.initialize(0.0, None);
        assert_eq!(
            inst.get_real(vr::X_REF),
            0.0,
            "fmi2Reset restarts from the start values"
        );
    }
    assert_eq!(inst.do_step(0.0, 0.01), S::Ok);
    let all = inst.messages();
    assert!(all.iter().all(|e| e.instance == "sequence"), "{all:?}");
}

#[test]
fn null_pointers_are_refused() {
    let inst = packaged().instance("nulls");
    let a = inst.api();
    let c = inst.c;
    let one = [vr::V_REF];
    unsafe {
        refused(
            &inst,
            (a.set_real)(c, null(), 1, [0.0].as_ptr()),
            S::Error,
            &["fmi2SetReal: vr[] is NULL"],
        );
        refused(
            &inst,
            (a.set_real)(c, one.as_ptr(), 1, null()),
            S::Error,
            &["value[] is NULL"],
        );
        assert_eq!(
            (a.set_real)(c, null(), 0, null()),
            S::Ok,
            "nvr = 0 needs no arrays"
        );
        inst.initialize(0.0, None);
        refused(
            &inst,
            (a.get_real)(c, one.as_ptr(), 1, null_mut()),
            S::Error,
            &["fmi2GetReal: value[] is NULL"],
        );
        refused(
            &inst,
            (a.get_integer)(c, null(), 2, [0; 2].as_mut_ptr()),
            S::Error,
            &["vr[] is NULL"],
        );
        refused(
            &inst,
            (a.get_fmu_state)(c, null_mut()),
            S::Error,
            &["FMUstate is NULL"],
        );
        refused(
            &inst,
            (a.set_fmu_state)(c, null_mut()),
            S::Error,
            &["FMU state is NULL"],
        );
        refused(
            &inst,
            (a.set_fmu_state)(c, c),
            S::Error,
            &["not created by this instance"],
        );
        refused(
            &inst,
            (a.get_real_status)(c, FMI2_LAST_SUCCESSFUL_TIME, null_mut()),
            S::Error,
            &["value is NULL"],
        );
        refused(
            &inst,
            (a.set_debug_logging)(c, 1, 1, null()),
            S::Error,
            &["categories[] is NULL"],
        );
        // A NULL component cannot be logged about, but must not crash.
        assert_eq!((a.do_step)(null_mut(), 0.0, 0.01, 0), S::Error);
        assert_eq!(
            (a.get_real)(null_mut(), one.as_ptr(), 1, [0.0].as_mut_ptr()),
            S::Error
        );
        assert_eq!((a.reset)(null_mut()), S::Error);
        (a.free_instance)(null_mut());
        assert_eq!(inst.do_step(0.0, 0.01), S::Ok);
    }
}

#[test]
fn wrong_variables_and_values_are_refused_atomically() {
    let inst = packaged().instance("values");
    let (scheme, kp1, m) = (vr_of("scheme"), vr_of("Kp1"), vr_of("m"));
    refused(
        &inst,
        inst.set_integer(&[scheme], &[99]),
        S::Error,
        &["`scheme`", "= 99 is not one of", "1 = "],
    );
    refused(
        &inst,
        inst.set_real(&[scheme], &[1.0]),
        S::Error,
        &["`scheme`", "fmi2SetInteger"],
    );
    refused(
        &inst,
        inst.set_real(&[vr::X], &[1.0]),
        S::Error,
        &["`x`", "output and cannot be set"],
    );
    refused(
        &inst,
        inst.set_real(&[9999], &[1.0]),
        S::Error,
        &["unknown value reference 9999"],
    );
    refused(
        &inst,
        inst.set_real(&[vr::V_REF], &[f64::NAN]),
        S::Error,
        &["`v_ref`", "finite"],
    );
    refused(
        &inst,
        inst.set_real(&[vr::F_L], &[f64::INFINITY]),
        S::Error,
        &["`F_L`", "finite"],
    );
    refused(
        &inst,
        inst.set_real(&[kp1], &[max_of("Kp1") * 10.0]),
        S::Error,
        &["`Kp1`", "allowed range"],
    );
    assert_eq!(inst.set_integer(&[scheme], &[1]), S::Ok);
    let (m_start, m_max) = range_of("m");
    assert_eq!(
        inst.set_real(&[m, vr::V_REF], &[(m_start * 1.25).min(m_max), 0.04]),
        S::Ok
    );
    inst.initialize(0.0, None);
    refused(
        &inst,
        inst.set_real(&[m], &[1.0]),
        S::Error,
        &["`m`", "before fmi2ExitInitializationMode"],
    );
    refused(
        &inst,
        inst.set_integer(&[scheme], &[2]),
        S::Error,
        &["`scheme`", "before fmi2ExitInitializationMode"],
    );
    let kp_before = inst.get_real(kp1);
    refused(
        &inst,
        inst.set_real(&[kp1, vr::X], &[kp_before * 0.5, 0.0]),
        S::Error,
        &["`x`"],
    );
    assert_eq!(
        inst.get_real(kp1),
        kp_before,
        "a refused fmi2SetReal changes nothing, not even its valid values"
    );
    assert_eq!(
        inst.set_real(&[kp1], &[kp_before * 0.5]),
        S::Ok,
        "tunable parameters can be set between steps"
    );
    assert_eq!(inst.get_real(kp1), kp_before * 0.5);
    refused(
        &inst,
        inst.get_reals(&[vr::X, scheme]).unwrap_err(),
        S::Error,
        &["fmi2GetReal", "fmi2GetInteger"],
    );
    let mut value = [0];
    let status =
        unsafe { (inst.api().get_integer)(inst.c, [vr::X].as_ptr(), 1, value.as_mut_ptr()) };
    refused(&inst, status, S::Error, &["`x`", "fmi2GetReal"]);
    let status =
        unsafe { (inst.api().get_integer)(inst.c, [scheme].as_ptr(), 1, value.as_mut_ptr()) };
    assert_eq!((status, value[0]), (S::Ok, 1));
    let mut flag = [0];
    let status =
        unsafe { (inst.api().get_boolean)(inst.c, [vr::X].as_ptr(), 1, flag.as_mut_ptr()) };
    refused(
        &inst,
        status,
        S::Error,
        &["fmi2GetBoolean", "`x`", "no Boolean variables"],
    );
    let text = [c"a".as_ptr()];
    let status = unsafe { (inst.api().set_string)(inst.c, [kp1].as_ptr(), 1, text.as_ptr()) };
    refused(
        &inst,
        status,
        S::Error,
        &["fmi2SetString", "no String variables"],
    );
    assert_eq!(inst.do_step(0.0, 0.01), S::Ok);
}

#[test]
fn bad_communication_steps_are_refused() {
    let inst = packaged().instance("steps");
    inst.initialize(0.0, Some(0.05));
    refused(
        &inst,
        inst.do_step(0.0, 0.0),
        S::Error,
        &["communicationStepSize = 0 s must be positive"],
    );
    refused(
        &inst,
        inst.do_step(0.0, -0.01),
        S::Error,
        &["must be positive"],
    );
    refused(
        &inst,
        inst.do_step(0.0, f64::NAN),
        S::Error,
        &["communicationStepSize = NaN", "finite"],
    );
    refused(
        &inst,
        inst.do_step(f64::INFINITY, 0.01),
        S::Error,
        &["currentCommunicationPoint = inf"],
    );
    refused(
        &inst,
        inst.do_step(0.0, 1e7),
        S::Error,
        &["longest accepted step"],
    );
    refused(
        &inst,
        inst.do_step(0.5, 0.01),
        S::Error,
        &[
            "currentCommunicationPoint = 0.5 s",
            "ended at 0 s",
            "tolerance",
        ],
    );
    assert_eq!(inst.do_step(0.0, 0.02), S::Ok);
    assert_eq!(
        inst.do_step(0.02 + 1e-12, 0.02),
        S::Ok,
        "a point within the tolerance is accepted"
    );
    refused(
        &inst,
        inst.do_step(0.04, 0.02),
        S::Error,
        &["would pass stopTime = 0.05 s"],
    );
    assert_eq!(
        inst.do_step(0.04 + 1e-12, 0.01),
        S::Ok,
        "a step ending at the stop time is accepted"
    );
    let mut t = 0.0;
    let status = unsafe { (inst.api().get_real_status)(inst.c, FMI2_LAST_SUCCESSFUL_TIME, &mut t) };
    assert_eq!(status, S::Ok);
    assert!((t - 0.05).abs() < 1e-11, "{t}");
}

#[test]
fn status_queries_and_unprovided_functions() {
    let inst = packaged().instance("status");
    let (a, c) = (inst.api(), inst.c);
    inst.initialize(0.0, None);
    assert_eq!(inst.do_step(0.0, 0.01), S::Ok);
    unsafe {
        let (mut b, mut i, mut r, mut s) = (7, 7, 0.0, null());
        assert_eq!(
            ((a.get_boolean_status)(c, FMI2_TERMINATED, &mut b), b),
            (S::Ok, FMI2_FALSE)
        );
        assert_eq!(
            ((a.get_real_status)(c, FMI2_LAST_SUCCESSFUL_TIME, &mut r), r),
            (S::Ok, 0.01)
        );
        let discard = |status, needle: &str| {
            assert_eq!(status, S::Discard);
            let log = inst.messages();
            assert!(
                log.iter()
                    .any(|e| e.status == S::Discard as c_int && e.message.contains(needle)),
                "{log:?}"
            );
        };
        discard(
            (a.get_status)(c, FMI2_DO_STEP_STATUS, &mut i),
            "fmi2DoStepStatus is not provided",
        );
        discard(
            (a.get_integer_status)(c, FMI2_DO_STEP_STATUS, &mut i),
            "fmi2GetIntegerStatus",
        );
        discard(
            (a.get_string_status)(c, FMI2_PENDING_STATUS, &mut s),
            "fmi2PendingStatus",
        );
        discard(
            (a.get_real_status)(c, 77, &mut r),
            "77 (not an fmi2StatusKind)",
        );
        let (vrs, dv) = ([vr::X], [1.0]);
        let status = (a.get_directional_derivative)(
            c,
            vrs.as_ptr(),
            1,
            vrs.as_ptr(),
            1,
            dv.as_ptr(),
            [0.0].as_mut_ptr(),
        );
        refused(
            &inst,
            status,
            S::Error,
            &["providesDirectionalDerivative=\"false\""],
        );
        let status =
            (a.set_real_input_derivatives)(c, [vr::V_REF].as_ptr(), 1, [1].as_ptr(), dv.as_ptr());
        refused(&inst, status, S::Error, &["canInterpolateInputs=\"false\""]);
        let status =
            (a.get_real_output_derivatives)(c, vrs.as_ptr(), 1, [1].as_ptr(), [0.0].as_mut_ptr());
        refused(&inst, status, S::Error, &["maxOutputDerivativeOrder=\"0\""]);
    }
    assert_eq!(inst.do_step(0.01, 0.01), S::Ok);
}

#[test]
fn instantiate_refuses_what_it_cannot_run() {
    let fmu = packaged();
    let guid = fmu.guid().to_string();
    let me = fmu
        .instantiate("me", FMI2_MODEL_EXCHANGE, &guid, false)
        .err()
        .unwrap();
    assert!(
        me.iter()
            .any(|e| e.message.contains("only Co-Simulation") && e.format == "%s"),
        "{me:?}"
    );
    let odd = fmu.instantiate("odd", 7, &guid, false).err().unwrap();
    assert!(
        odd.iter().any(|e| e.message.contains("fmuType 7")),
        "{odd:?}"
    );
    let unnamed = fmu
        .instantiate("", FMI2_CO_SIMULATION, &guid, false)
        .err()
        .unwrap();
    assert!(
        unnamed
            .iter()
            .any(|e| e.message.contains("Missing instance name") && e.instance == "?"),
        "{unnamed:?}"
    );
    let name = CString::new("x").unwrap();
    let null_functions =
        unsafe { (fmu.api.instantiate)(name.as_ptr(), 1, name.as_ptr(), null(), null(), 0, 0) };
    assert!(null_functions.is_null());
}

#[test]
fn logging_follows_logging_on_and_the_categories() {
    let fmu = packaged();
    let guid = fmu.guid().to_string();
    let quiet = fmu
        .instantiate("100%s%n", FMI2_CO_SIMULATION, &guid, false)
        .unwrap();
    assert!(
        quiet.messages().is_empty(),
        "loggingOn = false: no event messages"
    );
    refused(
        &quiet,
        quiet.do_step(0.0, 0.01),
        S::Error,
        &["Illegal call sequence"],
    );
    let set = |on: c_int, names: &[&str]| {
        let owned: Vec<CString> = names.iter().map(|n| CString::new(*n).unwrap()).collect();
        let ptrs: Vec<Fmi2String> = owned.iter().map(|n| n.as_ptr()).collect();
        unsafe { (fmu.api.set_debug_logging)(quiet.c, on, ptrs.len(), ptrs.as_ptr()) }
    };
    refused(
        &quiet,
        set(1, &["logEvents", "logNothing"]),
        S::Error,
        &["unknown log category \"logNothing\"", "logCalls"],
    );
    assert_eq!(set(1, &["logCalls"]), S::Ok);
    quiet.initialize(0.0, None);
    let log = quiet.messages();
    assert!(log
        .iter()
        .any(|e| e.category == "logCalls"
            && e.message.starts_with("fmi2SetupExperiment(startTime=0")));
    assert!(
        log.iter().all(|e| e.category == "logCalls"),
        "logEvents stayed off: {log:?}"
    );
    assert!(
        log.iter()
            .all(|e| e.instance == "100%s%n" && e.format == "%s"),
        "the name is an argument, never a format"
    );
    assert_eq!(set(0, &["logCalls", "logStatusError"]), S::Ok);
    quiet.messages();
    assert_eq!(quiet.do_step(5.0, 0.01), S::Error);
    assert!(
        quiet.messages().is_empty(),
        "error category switched off by name"
    );
    assert_eq!(set(1, &[]), S::Ok);
    assert_eq!(quiet.do_step(0.0, 0.01), S::Ok);
    assert!(
        quiet.messages().iter().any(|e| e.category == "logCalls"),
        "fmi2SetDebugLogging(on, 0) switches all on"
    );

    let loud = fmu.instance("loud");
    let events = loud.messages();
    let created = events
        .iter()
        .find(|e| e.category == "logEvents")
        .expect("an event at instantiation");
    assert!(
        created.message.contains("/resources dir"),
        "fmuResourceLocation is percent-decoded: {}",
        created.message
    );
}

#[test]
fn every_variable_reads_back_after_initialisation() {
    let inst = packaged().instance("all");
    inst.initialize(0.0, None);
    for v in VARIABLES {
        match v.kind {
            Kind::Real { .. } => assert!(inst.get_real(v.vr).is_finite(), "{}", v.name),
            Kind::Enumeration { start, .. } => {
                let mut value = [0];
                let status = unsafe {
                    (inst.api().get_integer)(inst.c, [v.vr].as_ptr(), 1, value.as_mut_ptr())
                };
                assert_eq!((status, value[0]), (S::Ok, start), "{}", v.name);
            }
        }
    }
}

#[test]
fn the_call_log_carries_the_status_the_call_returned() {
    let inst = packaged().instance("calls");
    inst.messages();
    // loggingOn = true: every category on, logCalls included.
    assert_eq!(inst.do_step(0.0, 0.01), S::Error);
    let log = inst.messages();
    let about_step: Vec<_> = log
        .iter()
        .filter(|e| e.message.contains("fmi2DoStep"))
        .collect();
    assert_eq!(
        about_step.len(),
        1,
        "a refused call is logged exactly once: {log:?}"
    );
    let line = about_step[0];
    assert_eq!(line.status, S::Error as c_int, "{line:?}");
    assert_eq!(line.category, "logStatusError", "{line:?}");
    assert!(
        line.message
            .starts_with("fmi2DoStep: Illegal call sequence")
            && line.message.contains("Call: fmi2DoStep(")
            && line.message.ends_with("-> fmi2Error."),
        "{line:?}"
    );
    assert!(
        log.iter().all(|e| e.status != S::Ok as c_int),
        "nothing logged as OK for a refused call: {log:?}"
    );

    inst.initialize(0.0, None);
    inst.messages();
    assert_eq!(inst.do_step(0.0, 0.01), S::Ok);
    let log = inst.messages();
    let ok: Vec<_> = log
        .iter()
        .filter(|e| e.category == "logCalls" && e.message.starts_with("fmi2DoStep("))
        .collect();
    assert_eq!(ok.len(), 1, "{log:?}");
    assert_eq!(ok[0].status, S::Ok as c_int);
    assert!(ok[0].message.ends_with("-> fmi2OK"), "{:?}", ok[0]);
    assert!(log.iter().all(|e| e.status == S::Ok as c_int), "{log:?}");

    // A refused value (NaN input) after initialisation: one Error line, never OK.
    assert_eq!(inst.set_real(&[vr::V_REF], &[f64::NAN]), S::Error);
    let log = inst.messages();
    assert_eq!(log.len(), 1, "{log:?}");
    assert_eq!(log[0].status, S::Error as c_int);
    assert!(log[0].message.starts_with("fmi2SetReal: "), "{log:?}");
    assert!(log[0].message.ends_with("-> fmi2Error."), "{log:?}");
}
