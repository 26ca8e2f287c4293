"""One co-simulation run of the FMU and its metrics, and the per-process FMU cache.

This module is what the Dask workers execute. It depends on fmpy and numpy only, and the
study ships it to the workers by value (cloudpickle), so a worker of an existing cluster needs
fmpy and numpy installed but not this package, and the FMU travels as bytes (no shared disk).

A run (`run_case`) is the FMU driven the way fmpy's `simulate_fmu` drives a Co-Simulation FMU:
start values set in Instantiated mode (parameters, and the inputs `v_ref`, `F_L` held
constant), fmi2SetupExperiment with the stop time, initialisation, then fmi2DoStep from
t_n = start + n h to t_(n+1), the outputs read after every step. Each worker process keeps
one instance per FMU and calls fmi2Reset between runs (the FMU returns to every start value,
so a run does not depend on which runs the process did before; the tests check that).
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
import time
from ctypes import byref, c_void_p

import numpy as np

#: Outputs recorded in every run (SI units).
RECORDED = ("e_x", "x", "p", "Q1", "Q2", "P_hyd1", "P_hyd2")

#: Metric columns of a result row, with their units (README and the CSV header use these).
METRICS = (
    "e_max_mm",  # Eq. (34): max of e_x over (0, T] [mm]
    "e_min_mm",  # Eq. (35): min [mm]
    "e_mean_mm",  # Eq. (36): mean [mm]
    "e_sd_mm",  # Eq. (37): sample standard deviation [mm]
    "recovery_s",  # time after which e_x stays within 10 % of its start-up excursion [s]
    "overshoot_mm",  # how far the piston ran ahead of the reference [mm]
    "x_end_m",  # displacement at the stop time [m]
    "p_max_MPa",  # peak chamber pressure [MPa]
    "flow_ratio",  # steady main:auxiliary flow ratio, mean Q1 / mean Q2 over the second half [1]
    "energy_kJ",  # hydraulic energy of both pumps, integral of P_hyd1 + P_hyd2 [kJ]
)

_LOCAL_CACHE: dict = {}


def fmu_digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _process_cache() -> dict:
    """A dict that lives as long as this process: on a Dask worker it hangs on the worker
    object (module globals are copied with the function when it is shipped by value)."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        return _LOCAL_CACHE
    cache = getattr(worker, "_tbm_thrust_study_cache", None)
    if cache is None:
        cache = {}
        worker._tbm_thrust_study_cache = cache
    return cache


class _Slot:
    """One extracted FMU and one instance of it in this process, with a log capture."""

    def __init__(self, data: bytes, digest: str):
        from fmpy import calloc, extract, free, read_model_description
        from fmpy.fmi2 import (
            FMU2Slave,
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )
        from fmpy.logging import addLoggerProxy

        root = os.path.join(tempfile.gettempdir(), "tbm_thrust_study", f"{digest[:16]}-{os.getpid()}")
        os.makedirs(root, exist_ok=True)
        archive = os.path.join(root, "model.fmu")
        with open(archive, "wb") as f:
            f.write(data)
        self.unzipdir = extract(archive, unzipdir=os.path.join(root, "unzipped"))
        self.md = read_model_description(archive, validate=False)
        self.variables = {v.name: v for v in self.md.modelVariables}
        self.messages: list[str] = []

        def on_message(env, instance, status, category, message):
            if status >= 2:  # Discard, Error, Fatal: the reason a call was refused
                self.messages.append((message or b"").decode("utf-8", errors="replace"))

        # Kept as attributes: ctypes callbacks must outlive the instance.
        self._logger = fmi2CallbackLoggerTYPE(on_message)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.callbacks.componentEnvironment = c_void_p(None)
        addLoggerProxy(byref(self.callbacks))
        self.slave = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=self.unzipdir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName="study",
        )
        self.slave.instantiate(callbacks=self.callbacks, loggingOn=False)
        self.fresh = True

    def vr(self, name: str) -> int:
        try:
            return self.variables[name].valueReference
        except KeyError:
            raise ValueError(f"the FMU has no variable {name!r}") from None


def _slot(data: bytes, digest: str) -> _Slot:
    cache = _process_cache()
    slot = cache.get(digest)
    if slot is None:
        slot = _Slot(data, digest)
        cache[digest] = slot
    return slot


def _value(slot: _Slot, name: str, value):
    """('real' | 'int', value reference, FMI value) of a start value given by name; an
    enumeration takes its item name (scheme = "single") or its FMI integer."""
    var = slot.variables.get(name)
    if var is None:
        raise ValueError(f"the FMU has no variable {name!r}")
    if var.causality not in ("parameter", "input"):
        raise ValueError(f"{name} is an {var.causality}, not a parameter or input")
    if var.type == "Real":
        return "real", var.valueReference, float(value)
    if var.type == "Enumeration" and isinstance(value, str):
        for item in var.declaredType.items:
            if item.name == value:
                return "int", var.valueReference, int(item.value)
        items = [i.name for i in var.declaredType.items]
        raise ValueError(f"{name} has no item {value!r} (items: {', '.join(items)})")
    return "int", var.valueReference, int(value)


def metrics(time_s: np.ndarray, out: dict[str, np.ndarray]) -> dict[str, float]:
    """The paper's metrics of one run (the definitions of src/metrics.rs)."""
    e = out["e_x"]
    e_mm = e[1:] * 1e3  # Eq. (34)-(37) exclude the sample at t = 0
    n = len(e)
    steady = float(np.mean(e[3 * n // 4 :]))
    band = max(0.1 * abs(float(np.max(e)) - steady), 20e-6)
    outside = np.nonzero(np.abs(e - steady) > band)[0]
    recovery = float(time_s[min(outside[-1] + 1, n - 1)]) if len(outside) else float(time_s[0])
    half = len(out["Q1"]) // 2
    q2 = float(np.sum(out["Q2"][half:]))
    power = out["P_hyd1"] + out["P_hyd2"]
    return {
        "e_max_mm": float(np.max(e_mm)),
        "e_min_mm": float(np.min(e_mm)),
        "e_mean_mm": float(np.mean(e_mm)),
        "e_sd_mm": float(np.std(e_mm, ddof=1)),
        "recovery_s": recovery,
        "overshoot_mm": max(-float(np.min(e)), 0.0) * 1e3,
        "x_end_m": float(out["x"][-1]),
        "p_max_MPa": float(np.max(out["p"])) * 1e-6,
        "flow_ratio": float(np.sum(out["Q1"][half:])) / q2 if q2 > 0 else math.inf,
        "energy_kJ": float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(time_s))) * 1e-3,
    }


def simulate(slot: _Slot, values: dict, stop_time: float, step: float, start_time: float = 0.0):
    """One run on the process's instance; returns (time, {output: samples})."""
    from fmpy.fmi1 import FMICallException

    slave = slot.slave
    if not slot.fresh:
        slave.reset()
    slot.fresh = False
    slot.messages.clear()
    reals, ints = {}, {}
    for name, value in values.items():
        kind, vr, v = _value(slot, name, value)
        (reals if kind == "real" else ints)[vr] = v
    try:
        if reals:
            slave.setReal(list(reals), list(reals.values()))
        if ints:
            slave.setInteger(list(ints), list(ints.values()))
        slave.setupExperiment(startTime=start_time, stopTime=stop_time)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        n = int(round((stop_time - start_time) / step))
        vrs = [slot.vr(name) for name in RECORDED]
        samples = np.empty((n + 1, len(vrs)))
        samples[0] = slave.getReal(vrs)
        t = start_time
        for k in range(1, n + 1):
            t_next = start_time + k * step
            slave.doStep(currentCommunicationPoint=t, communicationStepSize=t_next - t)
            t = t_next
            samples[k] = slave.getReal(vrs)
        slave.terminate()
    except FMICallException as e:
        reason = slot.messages[-1] if slot.messages else str(e)
        raise RuntimeError(reason) from None
    time_s = start_time + step * np.arange(n + 1)
    return time_s, {name: samples[:, i] for i, name in enumerate(RECORDED)}


def run_case(fmu: bytes, digest: str, case_id: int, values: dict, stop_time: float, step: float) -> dict:
    """One row of the results table: the case's values, status, error and metrics.

    Never raises for a bad case: a value the FMU refuses (out of range, unknown name) or a
    failed step gives status "failed" with the FMU's one-line reason in `error`, and NaN
    metrics, so the study goes on."""
    row = {"case": case_id, **values, "status": "ok", "error": ""}
    started = time.perf_counter()
    try:
        slot = _slot(fmu, digest)
        time_s, out = simulate(slot, values, stop_time, step)
        row.update(metrics(time_s, out))
    except Exception as e:  # noqa: BLE001 - any failure belongs in the row, not the study
        row["status"] = "failed"
        row["error"] = " ".join(str(e).split()) or type(e).__name__
        row.update({m: math.nan for m in METRICS})
    row["wall_s"] = time.perf_counter() - started
    return row
