"""Every bad call that Python can express: the return status (FMICallException.status)
and the message the FMU sends to the logger callback, and that the instance can be recovered
where the FMI 2.0 standard allows it (fmi2Reset after fmi2Error)."""

import math
import re
from ctypes import byref, c_char_p, c_double, c_uint
from pathlib import Path

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CoSimulation, fmi2ModelExchange

from tbm_fmu import STATUS, Instance, LogCapture, UNROUTED, fmi2Error, fmi2OK

ERROR_CATEGORY = "logStatusError"


# -- helpers -------------------------------------------------------------------------------------
def make(fmu, state, name="bad"):
    """An instance in `state`: instantiated | initializing | running | terminated."""
    inst = Instance(fmu, name, logging_on=True)
    if state == "instantiated":
        return inst
    inst.slave.setupExperiment(startTime=0.0, stopTime=20.0)
    inst.slave.enterInitializationMode()
    if state == "initializing":
        return inst
    inst.slave.exitInitializationMode()
    if state == "running":
        return inst
    inst.slave.doStep(0.0, 0.01)
    inst.time = 0.01
    inst.slave.terminate()
    assert state == "terminated"
    return inst


def expect_error(inst, call, *patterns, status=fmi2Error):
    """`call` must raise FMICallException with `status`, and the FMU must have logged a message
    with that status, category logStatusError, our instance name, matching every regex."""
    inst.log.clear()
    with pytest.raises(FMICallException) as info:
        call()
    assert info.value.status == status, (
        f"{info.value.function} returned {STATUS[info.value.status]}, expected {STATUS[status]}")
    recs = [r for r in inst.log.records if r.status == status]
    assert recs, (f"{info.value.function} returned {STATUS[status]} but logged no {STATUS[status]} message; "
                  f"log:\n{inst.log.text()}")
    matching = [r for r in recs if all(re.search(p, r.message, re.IGNORECASE) for p in patterns)]
    assert matching, (f"{info.value.function}: no logged message matches {patterns}; log:\n{inst.log.text()}")
    rec = matching[0]
    assert rec.category == ERROR_CATEGORY, f"category {rec.category!r}, expected {ERROR_CATEGORY!r}: {rec}"
    assert rec.instance == inst.name, f"logged with instance name {rec.instance!r}, expected {inst.name!r}"
    return rec


def recovers(inst):
    """After fmi2Error the standard allows fmi2Reset; then the instance must run normally."""
    inst.log.clear()
    inst.slave.reset()
    inst.initialize(0.0, 20.0, inputs={"v_ref": 0.05, "F_L": 12000.0})
    for k in range(10):
        inst.step_to((k + 1) * 0.01)
    x, e = inst.get(["x", "e_x"])
    assert math.isfinite(x) and math.isfinite(e) and x > 0, f"after fmi2Reset the run is broken: x={x}, e_x={e}"
    assert not [r for r in inst.log.records if r.status >= fmi2Error], inst.log.text()


@pytest.fixture
def cleanup():
    made = []
    yield made
    for inst in made:
        try:
            inst.free()
        except Exception:
            pass


def vr(fmu, name):
    return fmu.vr[name]


# -- value references, types, variability ------------------------------------------------------------
CASES = [
    # id, state, call(inst, fmu), patterns
    ("unknown_vr_getReal", "running", lambda i, f: i.slave.getReal([999]), [r"999", r"value ?reference|\bvr\b"]),
    ("unknown_vr_setReal", "running", lambda i, f: i.slave.setReal([999], [1.0]), [r"999"]),
    ("unknown_vr_getInteger", "running", lambda i, f: i.slave.getInteger([998]), [r"998"]),
    ("wrong_type_getInteger_of_Real", "running", lambda i, f: i.slave.getInteger([vr(f, "x")]), [r"\bx\b|\b100\b", r"integer|real|type"]),
    ("wrong_type_setReal_of_enumeration", "instantiated", lambda i, f: i.slave.setReal([vr(f, "scheme")], [1.0]), [r"scheme|\b400\b", r"integer|real|enum|type"]),
    ("wrong_type_getBoolean", "running", lambda i, f: i.slave.getBoolean([vr(f, "x")]), [r"boolean|\bx\b|100"]),
    ("wrong_type_setString", "instantiated", lambda i, f: i.slave.setString([vr(f, "m")], ["50"]), [r"string|\bm\b|200"]),
    ("enumeration_out_of_range", "instantiated", lambda i, f: i.slave.setInteger([vr(f, "scheme")], [7]), [r"scheme|400", r"7"]),
    ("set_output", "running", lambda i, f: i.slave.setReal([vr(f, "x")], [0.1]), [r"\bx\b|\b100\b", r"output|not allowed|cannot|can't"]),
    ("set_output_before_init", "instantiated", lambda i, f: i.slave.setReal([vr(f, "e_x")], [0.1]), [r"e_x|108", r"output|not allowed|cannot|can't"]),
    ("set_fixed_parameter_after_init", "running", lambda i, f: i.slave.setReal([vr(f, "m")], [60.0]), [r"\bm\b|\b200\b", r"fixed|initiali[sz]"]),
    ("set_fixed_enum_after_init", "running", lambda i, f: i.slave.setInteger([vr(f, "scheme")], [1]), [r"scheme|400", r"fixed|initiali[sz]"]),
    ("set_fixed_beta_e_after_init", "running", lambda i, f: i.slave.setReal([vr(f, "beta_e")], [1e9]), [r"beta_e|211", r"fixed|initiali[sz]"]),
    ("nan_input", "running", lambda i, f: i.slave.setReal([vr(f, "v_ref")], [math.nan]), [r"nan|finite", r"v_ref|\b1\b"]),
    ("inf_input", "running", lambda i, f: i.slave.setReal([vr(f, "F_L")], [math.inf]), [r"inf|finite", r"F_L|\b2\b"]),
    ("nan_parameter", "instantiated", lambda i, f: i.slave.setReal([vr(f, "Kp1")], [math.nan]), [r"nan|finite", r"Kp1|420"]),
    ("neg_inf_tunable_after_init", "running", lambda i, f: i.slave.setReal([vr(f, "Gamma_x")], [-math.inf]), [r"inf|finite", r"Gamma_x|504"]),
    # -- steps -----------------------------------------------------------------------------------
    ("zero_step", "running", lambda i, f: i.slave.doStep(0.0, 0.0), [r"step"]),
    ("negative_step", "running", lambda i, f: i.slave.doStep(0.0, -0.01), [r"step"]),
    ("nan_step", "running", lambda i, f: i.slave.doStep(0.0, math.nan), [r"step|nan|finite"]),
    ("inf_step", "running", lambda i, f: i.slave.doStep(0.0, math.inf), [r"step|inf|finite"]),
    ("step_past_stop_time", "running", lambda i, f: i.slave.doStep(0.0, 100.0), [r"stop ?time|20|beyond|past|exceed"]),
    ("wrong_communication_point", "running", lambda i, f: i.slave.doStep(0.5, 0.01), [r"communication ?point|current", r"0\.5|expected"]),
    ("nan_communication_point", "running", lambda i, f: i.slave.doStep(math.nan, 0.01), [r"communication ?point|current|nan|finite"]),
    # -- call sequence ---------------------------------------------------------------------------
    ("doStep_before_init", "instantiated", lambda i, f: i.slave.doStep(0.0, 0.01), [r"fmi2DoStep", r"illegal|not allowed|sequence|state"]),
    ("doStep_in_init_mode", "initializing", lambda i, f: i.slave.doStep(0.0, 0.01), [r"fmi2DoStep", r"illegal|not allowed|sequence|state"]),
    ("exit_init_without_enter", "instantiated", lambda i, f: i.slave.exitInitializationMode(), [r"fmi2ExitInitializationMode", r"illegal|not allowed|sequence|state"]),
    ("enter_init_twice", "initializing", lambda i, f: i.slave.enterInitializationMode(), [r"fmi2EnterInitializationMode", r"illegal|not allowed|sequence|state"]),
    ("setupExperiment_after_init", "running", lambda i, f: i.slave.setupExperiment(startTime=0.0), [r"fmi2SetupExperiment", r"illegal|not allowed|sequence|state"]),
    ("getReal_before_init_mode", "instantiated", lambda i, f: i.slave.getReal([vr(f, "x")]), [r"fmi2GetReal", r"illegal|not allowed|sequence|state"]),
    ("doStep_after_terminate", "terminated", lambda i, f: i.slave.doStep(0.01, 0.01), [r"fmi2DoStep", r"illegal|not allowed|sequence|state"]),
    ("setReal_input_after_terminate", "terminated", lambda i, f: i.slave.setReal([vr(f, "v_ref")], [0.01]), [r"fmi2SetReal", r"illegal|not allowed|sequence|state"]),
    ("terminate_twice", "terminated", lambda i, f: i.slave.terminate(), [r"fmi2Terminate", r"illegal|not allowed|sequence|state"]),
    ("cancelStep_without_pending_step", "running", lambda i, f: i.slave.cancelStep(), [r"fmi2CancelStep"]),
    # -- optional functions this FMU does not provide refuse loudly ----------------------------------
    ("setRealInputDerivatives_unsupported", "running", lambda i, f: i.slave.setRealInputDerivatives([vr(f, "v_ref")], [1], [0.0]), [r"fmi2SetRealInputDerivatives"]),
    ("getRealOutputDerivatives_unsupported", "running", lambda i, f: i.slave.getRealOutputDerivatives([vr(f, "x")], [1]), [r"fmi2GetRealOutputDerivatives"]),
    ("getDirectionalDerivative_unsupported", "running", lambda i, f: i.slave.getDirectionalDerivative([vr(f, "x")], [vr(f, "v_ref")], [1.0]), [r"fmi2GetDirectionalDerivative|directional"]),
    # -- logging -----------------------------------------------------------------------------------
    ("unknown_log_category", "instantiated", lambda i, f: i.slave.setDebugLogging(True, ["bogusCategory"]), [r"bogusCategory"]),
    ("unknown_log_category_with_percent", "running", lambda i, f: i.slave.setDebugLogging(True, ["%s%n%d%%"]), [re.escape("%s%n%d%%")]),
    # -- NULL pointers (ctypes None) ----------------------------------------------------------------
    ("null_vr_array", "running", lambda i, f: i.slave.fmi2GetReal(i.slave.component, None, 1, (c_double * 1)()), [r"null|vr|value ?reference"]),
    ("null_value_array", "running", lambda i, f: i.slave.fmi2GetReal(i.slave.component, (c_uint * 1)(100), 1, None), [r"null|value"]),
    ("null_setReal_values", "running", lambda i, f: i.slave.fmi2SetReal(i.slave.component, (c_uint * 1)(1), 1, None), [r"null|value"]),
    ("null_categories", "running", lambda i, f: i.slave.fmi2SetDebugLogging(i.slave.component, 1, 2, None), [r"null|categor"]),
    ("null_category_entry", "running", lambda i, f: i.slave.fmi2SetDebugLogging(i.slave.component, 1, 1, (c_char_p * 1)(None)), [r"null|categor"]),
    ("null_FMUstate_pointer", "running", lambda i, f: i.slave.fmi2GetFMUstate(i.slave.component, None), [r"null|state"]),
    ("null_serialized_size_pointer", "running", lambda i, f: _size_null(i), [r"null|size"]),
    ("deserialize_garbage", "running", lambda i, f: i.slave.deSerializeFMUstate(b"not a state" * 5), [r"state|serial|invalid|corrupt|size"]),
    ("setFMUstate_null", "running", lambda i, f: i.slave.fmi2SetFMUstate(i.slave.component, None), [r"null|state"]),
]


def _size_null(inst):
    state = inst.slave.getFMUstate()
    try:
        inst.slave.fmi2SerializedFMUstateSize(inst.slave.component, state, None)
    finally:
        inst.slave.freeFMUstate(state)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_call_returns_error_and_logs_why(fmu, cleanup, case):
    name, state, call, patterns = case
    inst = make(fmu, state, name=f"bad_{name}")
    cleanup.append(inst)
    rec = expect_error(inst, lambda: call(inst, fmu), *patterns)
    assert rec.message.strip(), "empty log message"
    recovers(inst)


def test_get_outputs_still_allowed_after_terminate(fmu, cleanup):
    inst = make(fmu, "terminated", "after_terminate")
    cleanup.append(inst)
    x, = inst.get(["x"])
    assert math.isfinite(x)


def test_zero_values_with_null_arrays_is_ok(fmu, cleanup):
    """nvr = 0 with NULL arrays is legal (fmi-library #123: an FMU must not reject it)."""
    inst = make(fmu, "running", "nvr0")
    cleanup.append(inst)
    assert inst.slave.fmi2GetReal(inst.slave.component, None, 0, None) == fmi2OK
    assert inst.slave.fmi2SetReal(inst.slave.component, None, 0, None) == fmi2OK
    inst.step_to(0.01)


def test_fixed_parameter_settable_before_and_in_initialisation(fmu, cleanup):
    inst = Instance(fmu, "fixed_ok")
    cleanup.append(inst)
    inst.set(m=60.0, scheme="single")  # Instantiated
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.set(beta_e=1.0e9, controller="adrc")  # Initialization mode
    inst.slave.exitInitializationMode()
    assert inst.slave.getReal([vr(fmu, "m")]) == [60.0]
    assert inst.slave.getInteger([vr(fmu, "scheme"), vr(fmu, "controller")]) == [1, 2]
    inst.set(Kp1=500.0)  # tunable after init: OK
    assert not [r for r in inst.log.records if r.status >= fmi2Error], inst.log.text()


def test_communication_point_tolerance_accepts_accumulated_round_off(fmu, cleanup):
    """A master that sums t += h (0.1 + 0.1 + 0.1 != 0.3) must be accepted."""
    inst = make(fmu, "running", "roundoff")
    cleanup.append(inst)
    t = 0.0
    for _ in range(1000):
        inst.slave.doStep(t, 0.001)
        t += 0.001
    for k in range(1, 31):  # now the other way: points computed as k h from 1.0
        inst.slave.doStep(t, (1.0 + k * 0.1) - t)
        t = 1.0 + k * 0.1
    assert not [r for r in inst.log.records if r.status >= fmi2Error], inst.log.text()


# -- fmi2Instantiate rejections ------------------------------------------------------------------
def raw_slave(fmu, name="raw"):
    return FMU2Slave(guid=fmu.md.guid, unzipDirectory=str(fmu.unzipdir), modelIdentifier=fmu.model_identifier,
                     instanceName=name)


def resources_uri(slave):
    return Path(slave.unzipDirectory, "resources").as_uri().encode()


@pytest.mark.parametrize("case", [
    ("null_instance_name", dict(name=None), r"instance ?name|name"),
    ("empty_instance_name", dict(name=b""), r"instance ?name|name"),
    ("null_guid", dict(guid=None), r"guid|token"),
    ("wrong_guid", dict(guid=b"{00000000-0000-0000-0000-000000000000}"), r"guid|token"),
    ("model_exchange_requested", dict(kind=fmi2ModelExchange), r"model ?exchange|co-?simulation|type"),
], ids=lambda c: c[0])
def test_instantiate_rejects_and_logs(fmu, case):
    label, changes, pattern = case
    slave = raw_slave(fmu)
    cap = LogCapture(f"inst_{label}")
    args = dict(name=f"inst_{label}".encode(), kind=fmi2CoSimulation, guid=slave.guid.encode())
    args.update(changes)
    try:
        c = slave.fmi2Instantiate(args["name"], args["kind"], args["guid"], resources_uri(slave),
                                  byref(cap.callbacks), 0, 1)
        assert c is None, f"fmi2Instantiate with {label} returned an instance"
        recs = [r for r in cap.records if r.status >= fmi2Error]
        assert recs, f"fmi2Instantiate with {label} returned NULL without logging why (routed by componentEnvironment)"
        assert any(re.search(pattern, r.message, re.IGNORECASE) for r in recs), cap.text()
    finally:
        cap.close()
        slave.freeLibrary()


def test_instantiate_with_null_callbacks_does_not_crash(fmu):
    slave = raw_slave(fmu)
    try:
        c = slave.fmi2Instantiate(b"nullcb", fmi2CoSimulation, slave.guid.encode(), resources_uri(slave), None, 0, 1)
        assert c is None, "fmi2Instantiate must refuse functions = NULL (it could never log)"
    finally:
        slave.freeLibrary()


def test_instantiate_with_null_logger_never_logs_through_it(fmu):
    """functions->logger = NULL: the FMU refuses (returns NULL) or runs without logging; a bad
    call must then return fmi2Error without crashing."""
    slave = raw_slave(fmu, "nolog")
    cb = fmi2CallbackFunctions()  # every pointer NULL
    c = slave.fmi2Instantiate(b"nolog", fmi2CoSimulation, slave.guid.encode(), resources_uri(slave), byref(cb), 0, 1)
    if c is None:
        slave.freeLibrary()
        return
    slave.component = c
    slave.callbacks = cb
    with pytest.raises(FMICallException) as info:
        slave.getReal([999])
    assert info.value.status == fmi2Error
    slave.freeInstance()


def test_null_component_is_rejected_without_crash(fmu):
    slave = raw_slave(fmu, "nullc")
    try:
        for fn, args in [("fmi2DoStep", (None, 0.0, 0.01, 1)), ("fmi2GetReal", (None, (c_uint * 1)(100), 1, (c_double * 1)())),
                         ("fmi2Terminate", (None,)), ("fmi2EnterInitializationMode", (None,))]:
            with pytest.raises(FMICallException) as info:
                getattr(slave, fn)(*args)
            assert info.value.status in (fmi2Error, 4), f"{fn}(NULL) returned {STATUS[info.value.status]}"
        slave.fmi2FreeInstance(None)  # must be a no-op
    finally:
        slave.freeLibrary()


# -- logging behaviour -------------------------------------------------------------------------------------
def test_logger_gets_component_environment(fmu, cleanup):
    """The FMU passes the importer's componentEnvironment back to the logger (so an importer with
    many instances can route messages)."""
    UNROUTED.clear()
    inst = make(fmu, "running", "envcheck")
    cleanup.append(inst)
    with pytest.raises(FMICallException):
        inst.slave.getReal([999])
    assert inst.log.records, "nothing logged"
    assert all(r.env == inst.log.env for r in inst.log.records), [(r.env, str(r)) for r in inst.log.records]


def test_log_categories_can_be_switched(fmu, cleanup):
    """loggingOn + fmi2SetDebugLogging(logCalls) gives one message per call; loggingOn = false gives
    none of the debug categories, while errors are still reported."""
    quiet = Instance(fmu, "quiet", logging_on=False)
    cleanup.append(quiet)
    quiet.initialize(0.0, inputs={"v_ref": 0.05})
    for k in range(5):
        quiet.step_to((k + 1) * 0.01)
    debug = [r for r in quiet.log.records if r.status == fmi2OK]
    assert not debug, f"loggingOn = false but debug messages were logged:\n{quiet.log.text()}"
    with pytest.raises(FMICallException):
        quiet.slave.getReal([999])
    assert [r for r in quiet.log.records if r.status == fmi2Error and "999" in r.message], (
        "with loggingOn = false an error must still be reported to the logger")

    chatty = Instance(fmu, "chatty", logging_on=True)
    cleanup.append(chatty)
    chatty.slave.setDebugLogging(True, ["logCalls"])
    chatty.initialize(0.0, inputs={"v_ref": 0.05})
    chatty.log.clear()
    chatty.step_to(0.01)
    calls = [r for r in chatty.log.records if r.category == "logCalls"]
    assert any("fmi2DoStep" in r.message for r in calls), f"logCalls on, but fmi2DoStep was not logged:\n{chatty.log.text()}"
    chatty.slave.setDebugLogging(False, [])
    chatty.log.clear()
    chatty.step_to(0.02)
    assert not [r for r in chatty.log.records if r.category == "logCalls"], chatty.log.text()


def test_refused_call_is_logged_once_with_its_status(fmu, cleanup):
    """With every category on (logCalls included), a refused fmi2DoStep gives one message, at
    status Error, and nothing logged as OK; an accepted one gives one logCalls line ending in
    `-> fmi2OK`. (Before, the call was logged as OK before it ran, then the error after it.)"""
    inst = Instance(fmu, "calllog", logging_on=True)
    cleanup.append(inst)
    inst.log.clear()
    with pytest.raises(FMICallException):
        inst.slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    about = [r for r in inst.log.records if "fmi2DoStep" in r.message]
    assert len(about) == 1, inst.log.text()
    assert about[0].status == fmi2Error and about[0].category == "logStatusError", inst.log.text()
    assert about[0].message.endswith("-> fmi2Error."), inst.log.text()
    assert not [r for r in inst.log.records if r.status == fmi2OK], inst.log.text()

    inst.initialize(0.0, inputs={"v_ref": 0.05})
    inst.log.clear()
    inst.step_to(0.01)
    steps = [r for r in inst.log.records if "fmi2DoStep" in r.message]
    assert len(steps) == 1 and steps[0].status == fmi2OK and steps[0].category == "logCalls", inst.log.text()
    assert steps[0].message.endswith("-> fmi2OK"), inst.log.text()
