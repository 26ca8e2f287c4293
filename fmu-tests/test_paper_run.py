"""The paper's start-up run in fmpy against the native `tbm-thrust simulate`, and the
independence of the result from the communication step.

Comparison rule (documented in the README): at every communication point and for every
signal s, |s_fmu - s_native| <= 1e-9 |s_native| + floor_s, with the absolute floor
floor_s = 1e-12 * max_t |s_native(t)| (1e-3 of the relative tolerance at the signal's own
scale), so that samples crossing zero (e_x, u2, Q2 ...) are not judged by a relative error of
a value that is zero up to round-off. The CSV keeps 13 significant digits, far below 1e-9.
"""

import time

import numpy as np
import pytest
from fmpy import simulate_fmu

from conftest import PAPER
from tbm_fmu import error_stats_mm, rel_mismatch

RTOL = 1e-9
FLOOR = 1e-12


def paper_input(v_ref=PAPER["v_ref"], load=PAPER["F_L"], duration=PAPER["duration"]):
    return np.array([(0.0, v_ref, load), (duration, v_ref, load)],
                    dtype=[("time", "f8"), ("v_ref", "f8"), ("F_L", "f8")])


def simulate_paper(fmu, h, output=None, constant_inputs=False, **kw):
    """The paper run in fmpy. The inputs are either an fmpy input signal (what a user passes,
    interpolated by fmpy) or, with constant_inputs, start values held for the whole run.

    The exact comparison uses constant_inputs: fmpy's linear interpolation of a constant input
    signal is not exact to the last bit (0.05 m/s comes back one ulp off at some points), and
    the auxiliary-pump loop amplifies a one-ulp difference in v_ref to ~1e-8 relative in uc2
    within seconds, which would be fmpy's rounding, not the FMU's."""
    start = {"scheme": fmu.enum_value("scheme", PAPER["scheme"]),
             "controller": fmu.enum_value("controller", PAPER["controller"])}
    if constant_inputs:
        start.update(v_ref=PAPER["v_ref"], F_L=PAPER["F_L"])
    return simulate_fmu(
        str(fmu.path),
        start_time=0.0,
        stop_time=PAPER["duration"],
        output_interval=h,
        start_values=start,
        input=None if constant_inputs else paper_input(),
        output=output,
        **kw,
    )


@pytest.fixture(scope="module")
def fmpy_paper(fmu, summary):
    calls = []
    t0 = time.perf_counter()
    res = simulate_paper(fmu, PAPER["dt"], output=["v_ref", "F_L"] + fmu.outputs, constant_inputs=True)
    wall = time.perf_counter() - t0
    summary["fmpy_paper_run_s (20 s, 2000 doSteps of 10 ms, all outputs recorded)"] = round(wall, 3)
    # the same run once more with the FMI call log, to count the calls
    simulate_paper(fmu, PAPER["dt"], output=["e_x"], constant_inputs=True, fmi_call_logger=calls.append)
    n_steps = sum(1 for c in calls if c.startswith("fmi2DoStep"))
    assert n_steps == 2000, f"fmpy made {n_steps} doStep calls, expected 2000"
    bad = [c for c in calls if any(c.rstrip().endswith(f"-> {s}") for s in ("WARNING", "DISCARD", "ERROR", "FATAL"))]
    assert not bad, "FMI calls that did not return OK:\n" + "\n".join(bad[:10])
    return res


def test_fmpy_paper_run_matches_native_simulate(fmpy_paper, native_paper):
    res = fmpy_paper
    t = res["time"]
    assert len(t) == len(native_paper["time"]) == 2001, f"samples: fmpy {len(t)}, native {len(native_paper['time'])}"
    assert np.allclose(t, native_paper["time"], rtol=0, atol=1e-9), "communication points differ from the native samples"
    compared, failures = [], []
    for name in res.dtype.names:
        if name == "time":
            continue
        assert name in native_paper, f"`tbm-thrust simulate` CSV has no column {name!r}"
        ref = native_paper[name]
        got = np.asarray(res[name], dtype=float)
        floor = FLOOR * float(np.max(np.abs(ref))) + 1e-300
        worst, i = rel_mismatch(got, ref, RTOL, floor)
        compared.append(name)
        if worst > 1.0:
            failures.append(f"{name}: at t = {t[i]:.2f} s fmpy {got[i]!r} vs native {ref[i]!r} "
                            f"(|diff| = {abs(got[i] - ref[i]):.3e}, allowed {RTOL * abs(ref[i]) + floor:.3e})")
    assert not failures, "fmpy and native differ beyond 1e-9 relative:\n" + "\n".join(failures)
    assert {"x", "e_x", "p", "Q1", "Q2", "u1", "u2", "x_ref", "v_ref", "F_L"} <= set(compared), compared


def test_paper_run_is_a_real_start_up(fmpy_paper):
    """Guards the comparison above against comparing two empty runs."""
    x, e = fmpy_paper["x"], fmpy_paper["e_x"]
    assert abs(x[-1] - 1.0) < 0.05, f"after 20 s at 0.05 m/s the cylinder should be near 1.0 m, x = {x[-1]:.4f} m"
    s = error_stats_mm(e)
    assert 0.1 < s["max"] < 20.0, f"start-up e_x max = {s['max']:.3f} mm is implausible"
    assert np.all(fmpy_paper["Q2"] >= -1e-9), "the auxiliary pump never sucks oil back"
    assert np.max(fmpy_paper["Q2"]) > 0, "adaptive scheme: the auxiliary pump must deliver flow at start-up"


def test_default_run_is_the_paper_start_up(fmu, fmpy_paper):
    """`simulate_fmu` with nothing set (unconnected inputs, as fmuCheck, fmusim or an OpenModelica
    import with open inputs run it) is the paper's start-up: the start values are v_ref = 0.05 m/s,
    F_L = 12 kN, adaptive, PID, and the default experiment 20 s at 0.01 s. It moves about 1 m."""
    res = simulate_fmu(str(fmu.path))
    t, x = res["time"], res["x"]
    assert abs(t[-1] - 20.0) < 1e-9, f"default experiment should stop at 20 s, ends at {t[-1]} s"
    assert abs(x[-1] - 1.0) < 0.01, f"default run: x(20 s) = {x[-1]:.4f} m, expected about 1 m (0.05 m/s x 20 s)"
    # fmpy's default output interval is stop_time / 500 = 0.04 s or the default experiment's
    # step; compare on the common samples. Other communication points round x_ref's sum
    # differently, so equal to 1e-6 m, not bit for bit.
    every = int(round((t[1] - t[0]) / 0.01))
    ref = fmpy_paper["x"][::every]
    assert len(ref) == len(x), (len(ref), len(x))
    worst = float(np.max(np.abs(x - ref)))
    assert worst < 1e-6, f"the default run differs from the paper run by {worst:.3e} m"


def test_end_stop_reaction_is_its_own_output(fmu):
    """With v_ref = 0 the piston stays at its retracted end stop while the chamber leaks down: the
    net drive A (p - p_t) - F_L goes to about -9.6 kN in 20 s. F_fric holds only the breakaway friction;
    the stop takes the rest as F_stop, and the two add up to the drive."""
    md = {v.name: v for v in fmu.md.modelVariables}
    p_t, area = float(md["p_t"].start), float(md["A"].start)
    breakaway = float(md["F_c"].start)
    res = simulate_fmu(str(fmu.path), start_values={"v_ref": 0.0},
                       output=["x", "p", "F_fric", "F_stop", "F_L"])
    assert np.all(res["x"] == 0.0), "with v_ref = 0 the piston must stay at x = 0"
    drive = area * (res["p"] - p_t) - res["F_L"]
    assert np.allclose(res["F_fric"] + res["F_stop"], drive, rtol=1e-12, atol=1e-6), "F_fric + F_stop is not the drive"
    assert np.all(np.abs(res["F_fric"]) <= breakaway * (1 + 1e-12)), f"|F_fric| beyond breakaway {breakaway} N"
    assert res["F_stop"][-1] < -5000.0, f"F_stop(20 s) = {res['F_stop'][-1]:.0f} N: the retracted stop should hold the load"


# --------------------------------------------------------------------------------------------
# Communication-step independence: 1 ms ... 100 ms. Every step divides 0.1 s, so all runs have
# samples on the 0.1 s grid; each run's e_x there gives Eq. (34)-(37). Steps that divide
# 0.01 s also give the paper's 0.01 s metrics, compared with the native run.

STEPS = [0.001, 0.002, 0.0025, 0.005, 0.01, 0.02, 0.025, 0.05, 0.1]
METRIC_TOL = 0.01  # 1 % of the metric, with a floor of 1e-4 of max e_x for metrics near 0 mm


def grid_samples(res, h, grid):
    every = int(round(grid / h))
    e = np.asarray(res["e_x"], dtype=float)[::every]
    t = np.asarray(res["time"], dtype=float)[::every]
    assert np.allclose(t, np.arange(len(t)) * grid, atol=1e-9), f"h = {h}: samples not on the {grid} s grid"
    assert len(t) == int(round(PAPER["duration"] / grid)) + 1
    return e


def compare_metrics(got, ref, label):
    floor = 1e-4 * abs(ref["max"])
    bad = [f"{k}: {got[k]:.5f} mm vs {ref[k]:.5f} mm" for k in ref
           if abs(got[k] - ref[k]) > METRIC_TOL * max(abs(ref[k]), floor)]
    assert not bad, f"{label}: start-up metrics differ by more than 1 %:\n" + "\n".join(bad)


@pytest.mark.parametrize("h", STEPS, ids=[f"{h * 1e3:g}ms" for h in STEPS])
def test_communication_step_gives_same_start_up_metrics(fmu, fmpy_paper, native_paper, summary, h):
    t0 = time.perf_counter()
    res = simulate_paper(fmu, h, output=["e_x"])
    wall = time.perf_counter() - t0
    summary[f"fmpy_paper_run_s (communication step {h * 1e3:g} ms)"] = round(wall, 3)
    ref_coarse = error_stats_mm(grid_samples(fmpy_paper, 0.01, 0.1))
    got_coarse = error_stats_mm(grid_samples(res, h, 0.1))
    compare_metrics(got_coarse, ref_coarse, f"h = {h * 1e3:g} ms vs 10 ms, e_x on the 0.1 s grid")
    if round(0.01 / h, 9).is_integer():
        got = error_stats_mm(grid_samples(res, h, 0.01))
        ref = error_stats_mm(native_paper["e_x"])
        compare_metrics(got, ref, f"h = {h * 1e3:g} ms vs native, Eq. (34)-(37) at 0.01 s")
        if h == 0.01:
            summary["paper_run_e_x_stats_mm (Eq. 34-37)"] = {k: round(v, 4) for k, v in got.items()}
