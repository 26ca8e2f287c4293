"""DNV's libcosim (the Open Simulation Platform's co-simulation engine, through `libcosimpy`
from PyPI) as one more importer of the FMU.

libcosim reads FMI 2.0 through FMI Library and ignores Enumeration variables: `scheme` and
`controller` are not in its variable list and cannot be set, so a libcosim run always uses
their start values (adaptive, PID). The tests check that fallback, and that the paper run in
libcosim (10 ms steps, inputs at their start values 0.05 m/s and 12 kN) agrees with fmpy's.
libcosim counts time in integer nanoseconds and converts each step to seconds, so its step
sizes differ from 0.01 s in the last bits (e.g. 0.010000000000001563 s); its communication
points are still n x 10 ms, and the FMU's steps end there (it follows the master's clock), so
the runs agree bit for bit (measured; the test holds it).
"""

from __future__ import annotations

import numpy as np
import pytest

libcosim = pytest.importorskip("libcosimpy", reason="libcosimpy is in fmu-tests/requirements.txt")

from libcosimpy.CosimExecution import CosimExecution  # noqa: E402
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level  # noqa: E402
from libcosimpy.CosimObserver import CosimObserver  # noqa: E402
from libcosimpy.CosimSlave import CosimLocalSlave  # noqa: E402

from conftest import PAPER  # noqa: E402
from tbm_fmu import error_stats_mm  # noqa: E402

STEP_NS = 10_000_000  # 10 ms
N_STEPS = 2000  # 20 s


def load(fmu_path):
    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(step_size=STEP_NS)
    index = execution.add_local_slave(local_slave=CosimLocalSlave(fmu_path=str(fmu_path), instance_name="cylinder"))
    names = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    return execution, index, names, observer


@pytest.fixture(scope="module")
def libcosim_run(fmu_path, summary):
    """The default run in libcosim, e_x and x read after every 10 ms step."""
    import time

    execution, index, names, observer = load(fmu_path)
    vrs = [names["e_x"], names["x"]]
    t0 = time.perf_counter()
    samples = [observer.last_real_values(index, vrs)] if execution.step(1) else []
    assert samples, f"libcosim's first step failed: {execution.status()}"
    for _ in range(N_STEPS - 1):
        assert execution.step(1), f"libcosim step failed: {execution.status()}"
        samples.append(observer.last_real_values(index, vrs))
    summary["libcosim_paper_run_s (20 s, 2000 steps of 10 ms)"] = round(time.perf_counter() - t0, 3)
    status = execution.status()
    assert status.current_time == N_STEPS * STEP_NS, status
    e_x, x = np.array(samples).T
    return {"names": names, "e_x": e_x, "x": x}


def test_libcosim_ignores_the_enumerations(fmu, fmu_path):
    execution, index, names, _ = load(fmu_path)
    assert {"v_ref", "F_L", "x", "e_x", "F_stop"} <= set(names), sorted(names)
    assert "scheme" not in names and "controller" not in names, "libcosim now reads Enumerations: update the docs"
    scheme_vr = fmu.vr["scheme"]
    single = fmu.enum_value("scheme", "single")
    assert execution.integer_initial_value(index, scheme_vr, single) is False, (
        "libcosim accepted an initial value for the Enumeration `scheme`")


def test_libcosim_runs_the_paper_case_like_fmpy(libcosim_run, fmu):
    """Default start values = the paper's case, so libcosim's run is the adaptive start-up:
    x(20 s) about 1 m, equal to fmpy's run (held inputs, 10 ms steps) at every point."""
    from fmpy import simulate_fmu

    ref = simulate_fmu(str(fmu.path), stop_time=PAPER["duration"], output_interval=PAPER["dt"], output=["e_x", "x"])
    x = libcosim_run["x"]
    assert abs(x[-1] - 1.0) < 0.01, f"x(20 s) = {x[-1]} m in libcosim"
    for name in ("x", "e_x"):
        diff = float(np.max(np.abs(libcosim_run[name] - ref[name][1:])))
        assert diff == 0.0, f"{name}: libcosim and fmpy differ by up to {diff:.3e} (SI units)"
    # fmpy's first sample is t = 0; libcosim's observer is read after each step.
    got = error_stats_mm(np.concatenate([[0.0], libcosim_run["e_x"]]))
    want = error_stats_mm(ref["e_x"])
    bad = {k: (got[k], want[k]) for k in want if abs(got[k] - want[k]) > 0.01 * abs(want[k])}
    assert not bad, f"libcosim vs fmpy start-up metrics [mm] differ by more than 1 %: {bad}"
