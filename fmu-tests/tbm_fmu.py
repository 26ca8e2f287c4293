"""Helpers shared by the fmu-tests: an FMI 2.0 Co-Simulation instance wrapper with a logger
that captures every message, the paper's metrics, and the recording-CSV reader.

Everything here talks to the FMU only through fmpy's ctypes binding (FMU2Slave), i.e. the
same C API a Simulink or OpenModelica importer uses.
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import math
from ctypes import byref, c_void_p
from pathlib import Path

import numpy as np
from fmpy import calloc, free
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.logging import addLoggerProxy

STATUS = ["OK", "Warning", "Discard", "Error", "Fatal", "Pending"]
fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal = range(5)


# --------------------------------------------------------------------------------------------
# Logging: fmpy's native proxy formats the variadic FMI logger call and forwards the text to ONE
# process-wide Python function (a static in fmpy's logging library). We install a single
# dispatcher and route each message to the capture of its instance by componentEnvironment,
# falling back to the instance name.


@dataclasses.dataclass
class LogRecord:
    env: int | None
    instance: str | None
    status: int
    category: str | None
    message: str

    def __str__(self) -> str:
        return f"[{STATUS[self.status] if 0 <= self.status < 6 else self.status}] {self.instance} {self.category}: {self.message}"


_CAPTURES_BY_ENV: dict[int, "LogCapture"] = {}
_CAPTURES_BY_NAME: dict[str, "LogCapture"] = {}
UNROUTED: list[LogRecord] = []
_ENV_IDS = itertools.count(0x7B00)


def _decode(b) -> str | None:
    return None if b is None else b.decode("utf-8", errors="replace")


def _dispatch(env, instance, status, category, message):
    rec = LogRecord(env, _decode(instance), int(status), _decode(category), _decode(message) or "")
    cap = _CAPTURES_BY_ENV.get(env) if env is not None else None
    if cap is None and rec.instance is not None:
        cap = _CAPTURES_BY_NAME.get(rec.instance)
    if cap is None:
        UNROUTED.append(rec)
    else:
        cap.records.append(rec)


_DISPATCH = fmi2CallbackLoggerTYPE(_dispatch)


class LogCapture:
    """fmi2CallbackFunctions whose logger records every message of one instance."""

    def __init__(self, instance_name: str):
        self.instance_name = instance_name
        self.env = next(_ENV_IDS)
        self.records: list[LogRecord] = []
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = _DISPATCH
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.callbacks.componentEnvironment = c_void_p(self.env)
        addLoggerProxy(byref(self.callbacks))  # (re)installs _DISPATCH as fmpy's global target
        _CAPTURES_BY_ENV[self.env] = self
        _CAPTURES_BY_NAME[instance_name] = self

    def clear(self) -> None:
        self.records.clear()

    def text(self) -> str:
        return "\n".join(str(r) for r in self.records) or "(nothing logged)"

    def close(self) -> None:
        _CAPTURES_BY_ENV.pop(self.env, None)
        if _CAPTURES_BY_NAME.get(self.instance_name) is self:
            del _CAPTURES_BY_NAME[self.instance_name]


# --------------------------------------------------------------------------------------------
# The FMU


@dataclasses.dataclass
class FmuInfo:
    """An extracted FMU: its model description and name -> (value reference, type) maps."""

    path: Path
    unzipdir: Path
    md: object

    def __post_init__(self):
        self.variables = {v.name: v for v in self.md.modelVariables}
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.outputs = [v.name for v in self.md.modelVariables if v.causality == "output"]
        self.inputs = [v.name for v in self.md.modelVariables if v.causality == "input"]

    @property
    def model_identifier(self) -> str:
        return self.md.coSimulation.modelIdentifier

    def enum_value(self, name: str, item: str) -> int:
        """FMI value of enumeration item `item` of variable `name` (e.g. scheme, adaptive -> 3)."""
        v = self.variables[name]
        for it in v.declaredType.items:
            if it.name == item:
                return int(it.value)
        raise KeyError(f"{name} has no item {item!r}: {[i.name for i in v.declaredType.items]}")


class Instance:
    """One FMI 2.0 CS instance of the FMU, driven the way an importer does it.

    `params` may hold Real parameters by name and enumerations by item name
    (`{"scheme": "single", "Kp1": 700.0}`).
    """

    def __init__(self, fmu: FmuInfo, name: str, logging_on: bool = False, call_logger=None):
        """logging_on=False keeps the debug categories (logEvents, logCalls) off; errors are
        logged and captured in any case (the FMU keeps logStatusError always on)."""
        self.fmu = fmu
        self.name = name
        self.log = LogCapture(name)
        self.slave = FMU2Slave(
            guid=fmu.md.guid,
            unzipDirectory=str(fmu.unzipdir),
            modelIdentifier=fmu.model_identifier,
            instanceName=name,
            fmiCallLogger=call_logger,
        )
        self.slave.instantiate(callbacks=self.log.callbacks, loggingOn=logging_on)
        self.time = 0.0
        self._freed = False

    # -- values by name -----------------------------------------------------------------------
    def vrs(self, names):
        return [self.fmu.vr[n] for n in names]

    def set(self, **values) -> None:
        reals, ints = {}, {}
        for name, value in values.items():
            var = self.fmu.variables[name]
            if var.type == "Real":
                reals[var.valueReference] = float(value)
            else:
                ints[var.valueReference] = (
                    self.fmu.enum_value(name, value) if isinstance(value, str) else int(value)
                )
        if reals:
            self.slave.setReal(list(reals), list(reals.values()))
        if ints:
            self.slave.setInteger(list(ints), list(ints.values()))

    def get(self, names) -> list[float]:
        return self.slave.getReal(self.vrs(names))

    def get1(self, name) -> float:
        return self.get([name])[0]

    # -- life cycle -----------------------------------------------------------------------------
    def initialize(self, start_time=0.0, stop_time=None, params=None, inputs=None, tolerance=None):
        self.slave.setupExperiment(tolerance=tolerance, startTime=start_time, stopTime=stop_time)
        if params:
            self.set(**params)
        self.slave.enterInitializationMode()
        if inputs:
            self.set(**inputs)
        self.slave.exitInitializationMode()
        self.time = start_time

    def step(self, h: float) -> None:
        """doStep(current time, h); the next point is the sum, as a Simulink-like loop does."""
        self.slave.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
        self.time = self.time + h

    def step_to(self, t_next: float) -> None:
        """doStep up to t_next, the way fmpy's simulate_fmu does (points start + n h)."""
        self.slave.doStep(currentCommunicationPoint=self.time, communicationStepSize=t_next - self.time)
        self.time = t_next

    def terminate_and_free(self) -> None:
        if self._freed:
            return
        try:
            self.slave.terminate()
        finally:
            self.free()

    def free(self) -> None:
        if not self._freed:
            self._freed = True
            self.slave.freeInstance()
            self.log.close()


def expect_status(call, status: int):
    """Runs `call`; returns the FMICallException status (OK/Warning return normally)."""
    try:
        call()
    except FMICallException as e:
        assert e.status == status, f"expected {STATUS[status]}, got {STATUS[e.status]} ({e})"
        return e.status
    assert status in (fmi2OK, fmi2Warning), f"expected {STATUS[status]}, the call returned OK/Warning"
    return fmi2OK


# --------------------------------------------------------------------------------------------
# Metrics and recordings


def error_stats_mm(e_x) -> dict:
    """Eq. (34)-(37): max, min, mean, sample SD of e_x in mm over the samples after t = 0
    (the same convention as src/metrics.rs: e_x[0] at t = 0 is excluded)."""
    e = np.asarray(e_x[1:], dtype=float) * 1e3
    return {"max": float(e.max()), "min": float(e.min()), "mean": float(e.mean()), "sd": float(e.std(ddof=1))}


def read_recording(path: Path) -> dict[str, np.ndarray]:
    """Reads a recording CSV of the contract: '#' comment lines, one header row, SI values."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = [r for r in csv.reader(line for line in f if not line.startswith("#")) if r]
    header, data = rows[0], np.array(rows[1:], dtype=float)
    return {name.strip(): data[:, i] for i, name in enumerate(header)}


def rel_mismatch(a: np.ndarray, b: np.ndarray, rtol: float, floor: float):
    """Worst |a - b| / (rtol |b| + floor) over the samples (<= 1 passes), and its index."""
    err = np.abs(a - b) / (rtol * np.abs(b) + floor)
    i = int(np.argmax(err))
    return float(err[i]), i


def finite(*arrays) -> bool:
    return all(np.all(np.isfinite(np.asarray(a, dtype=float))) for a in arrays)


def fmt_mm(v: float) -> str:
    return f"{v * 1e3:.4f} mm" if math.isfinite(v) else str(v)
