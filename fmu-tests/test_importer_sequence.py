"""The call sequence of a Simulink / OpenModelica-like importer, with several instances side by
side and in threads, and FMU state save / serialise / restore / replay."""

import threading

import numpy as np
import pytest

from tbm_fmu import Instance

H = 0.01
OUT = ["x", "v", "p", "Q1", "Q2", "u1", "u2", "x_ref", "e_x", "F_cyl", "P_hyd1", "P_hyd2"]

# Two different machines: the paper's, and a heavier single-pump ADRC one with other inputs.
CONFIG_A = {"params": {"scheme": "adaptive", "controller": "pid"}, "v_ref": 0.05, "F_L": 12000.0}
CONFIG_B = {"params": {"scheme": "single", "controller": "adrc", "m": 80.0, "Kp1": 700.0}, "v_ref": 0.03, "F_L": 9000.0}


def inputs_at(cfg, t):
    """Input schedule an importer feeds through fmi2SetReal before each step: the commanded
    velocity steps down at 2 s and back up at 3.5 s, the load ramps by 10 % from 1 s to 4 s."""
    v = cfg["v_ref"] * (0.5 if 2.0 <= t < 3.5 else 1.0)
    load = cfg["F_L"] * (1.0 + 0.1 * min(max(t - 1.0, 0.0), 3.0) / 3.0)
    return {"v_ref": v, "F_L": load}


def start(fmu, name, cfg, stop_time=None, call_logger=None):
    inst = Instance(fmu, name, call_logger=call_logger)
    inst.initialize(0.0, stop_time, params=cfg["params"], inputs=inputs_at(cfg, 0.0))
    return inst


def advance(inst, cfg, t0, t1, h=H):
    """Importer loop from t0 to t1: set inputs, doStep, get outputs; returns the outputs."""
    n = int(round((t1 - t0) / h))
    rows = []
    for k in range(n):
        inst.set(**inputs_at(cfg, t0 + k * h))
        inst.step_to(t0 + (k + 1) * h)
        rows.append(inst.get(OUT))
    return np.array(rows)


def solo(fmu, name, cfg, t1):
    inst = start(fmu, name, cfg, stop_time=t1)
    try:
        return advance(inst, cfg, 0.0, t1)
    finally:
        inst.terminate_and_free()


def assert_same(a, b, what):
    assert a.shape == b.shape, f"{what}: shapes {a.shape} vs {b.shape}"
    if not np.array_equal(a, b):
        k, j = np.argwhere(a != b)[0]
        raise AssertionError(f"{what}: first difference at step {k + 1} ({(k + 1) * H:.2f} s), "
                             f"{OUT[j]} = {a[k, j]!r} vs {b[k, j]!r}")


def test_importer_call_sequence_two_instances_side_by_side(fmu):
    t_end = 5.0
    ref_a, ref_b = solo(fmu, "solo_a", CONFIG_A, t_end), solo(fmu, "solo_b", CONFIG_B, t_end)
    assert not np.allclose(ref_a, ref_b), "the two configurations should behave differently"

    calls_a, calls_b = [], []
    a = start(fmu, "thrust_a", CONFIG_A, stop_time=t_end, call_logger=calls_a.append)
    b = start(fmu, "thrust_b", CONFIG_B, stop_time=t_end, call_logger=calls_b.append)
    rows_a, rows_b = [], []
    n = int(round(t_end / H))
    for k in range(n):  # interleaved, as a Simulink model with two FMU blocks runs them
        t = k * H
        a.set(**inputs_at(CONFIG_A, t))
        b.set(**inputs_at(CONFIG_B, t))
        a.step_to((k + 1) * H)
        b.step_to((k + 1) * H)
        rows_a.append(a.get(OUT))
        rows_b.append(b.get(OUT))
    a.terminate_and_free()
    b.terminate_and_free()
    assert_same(np.array(rows_a), ref_a, "instance A beside B vs A alone")
    assert_same(np.array(rows_b), ref_b, "instance B beside A vs B alone")

    for calls in (calls_a, calls_b):
        names = [c.split("(")[0] for c in calls]
        first = [n for n in names if n not in ("fmi2SetReal", "fmi2SetInteger")][:4]
        assert first == ["fmi2Instantiate", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
                         "fmi2ExitInitializationMode"], f"unexpected call order: {first}"
        assert names[-2:] == ["fmi2Terminate", "fmi2FreeInstance"], names[-3:]
        assert names.count("fmi2DoStep") == n
        failed = [c for c in calls if any(c.rstrip().endswith(s) for s in ("WARNING", "DISCARD", "ERROR", "FATAL"))]
        assert not failed, "calls that did not return OK:\n" + "\n".join(failed[:5])
    for inst in (a, b):
        bad = [r for r in inst.log.records if r.status != 0]
        assert not bad, f"{inst.name} logged problems:\n{inst.log.text()}"


def test_instances_in_two_threads(fmu):
    t_end = 4.0
    refs = {"A": solo(fmu, "ref_a", CONFIG_A, t_end), "B": solo(fmu, "ref_b", CONFIG_B, t_end)}
    results, errors = {}, []

    def worker(key, cfg):
        try:
            results[key] = solo(fmu, f"thread_{key}", cfg, t_end)
        except Exception as e:  # reported below
            errors.append(f"{key}: {e!r}")

    threads = [threading.Thread(target=worker, args=(k, c)) for k, c in (("A", CONFIG_A), ("B", CONFIG_B))]
    for th in threads:
        th.start()
    for th in threads:
        th.join(timeout=120)
    assert not errors, errors
    for k in refs:
        assert_same(results[k], refs[k], f"instance {k} in a thread vs alone")


@pytest.mark.parametrize("cfg", [CONFIG_A, CONFIG_B], ids=["adaptive_pid", "single_adrc_m80"])
def test_state_get_set_serialize_replay(fmu, cfg):
    t_save, t_end = 3.0, 6.0
    inst = start(fmu, "state", cfg)
    advance(inst, cfg, 0.0, t_save)
    saved = inst.slave.getFMUstate()
    blob = inst.slave.serializeFMUstate(saved)
    assert isinstance(blob, bytes) and len(blob) > 0
    first = advance(inst, cfg, t_save, t_end)

    # 1) fmi2SetFMUstate on the same instance, replay
    inst.slave.setFMUstate(saved)
    inst.time = t_save
    replay = advance(inst, cfg, t_save, t_end)
    assert_same(replay, first, "replay after fmi2SetFMUstate")

    # 2) de-serialise into the same instance
    state2 = inst.slave.deSerializeFMUstate(blob)
    inst.slave.setFMUstate(state2)
    inst.time = t_save
    assert_same(advance(inst, cfg, t_save, t_end), first, "replay after fmi2DeSerializeFMUstate")

    # 3) de-serialise into a fresh instance with default parameters: the state carries all
    fresh = Instance(fmu, "fresh")
    fresh.initialize(0.0)
    state3 = fresh.slave.deSerializeFMUstate(blob)
    fresh.slave.setFMUstate(state3)
    fresh.time = t_save
    assert_same(advance(fresh, cfg, t_save, t_end), first, "replay in a fresh instance from the serialised state")
    blob_again = fresh.slave.serializeFMUstate(state3)
    assert blob_again == blob, "serialising a de-serialised state must give the same bytes"

    for i, s in ((inst, saved), (inst, state2), (fresh, state3)):
        i.slave.freeFMUstate(s)
    inst.terminate_and_free()
    fresh.terminate_and_free()


def test_reset_then_rerun_is_identical(fmu):
    inst = start(fmu, "reset", CONFIG_B)
    first = advance(inst, CONFIG_B, 0.0, 2.0)
    inst.slave.reset()
    inst.initialize(0.0, params=CONFIG_B["params"], inputs=inputs_at(CONFIG_B, 0.0))
    second = advance(inst, CONFIG_B, 0.0, 2.0)
    inst.terminate_and_free()
    assert_same(second, first, "run after fmi2Reset vs first run")


def test_tunable_parameter_changes_between_steps(fmu):
    """A tunable gain set between communication steps takes effect; the run differs from then on."""
    base = solo(fmu, "tune_ref", CONFIG_A, 2.0)
    inst = start(fmu, "tune", CONFIG_A)
    part1 = advance(inst, CONFIG_A, 0.0, 1.0)
    inst.set(Kp1=400.0, Gamma_x=2.0)
    part2 = advance(inst, CONFIG_A, 1.0, 2.0)
    inst.terminate_and_free()
    assert_same(part1, base[:100], "before the gain change")
    assert not np.array_equal(part2, base[100:]), "setting Kp1 and Gamma_x after initialisation had no effect"
