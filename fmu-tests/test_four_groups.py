"""System-level TBM case: four thrust-cylinder FMU instances (the four thrust groups, top /
right / bottom / left) push one shield body, and the synchronisation error between the groups at
start-up is compared for the single-pump and the adaptive dual-pump schemes.

Shield (Python rigid body, axial degree of freedom X, V):
    m_s dV/dt = sum_i f_i - R(X, V)
    f_i = k_c (x_i - X + d0) + c_c (v_i - V)             stiff thrust-shoe coupling of group i
    R(X, V) = 4 F_target(X, V)                            4x the shield/cutterhead load law of
                                                          examples/python/machines/ShieldCutterhead.py
    F_L,i = f_i + s_i R / 4,  s = (+10 %, 0, -10 %, 0)     tilted face: the top group carries 10 %
                                                          more than the mean share, the bottom 10 %
                                                          less (sum s_i = 0: the moment goes into the
                                                          bore, the axial balance is unchanged)
d0 = F_pre / k_c is the pre-compression that holds the face preload at rest.

Master: Gauss-Seidel with communication step H: the four cylinders step with the loads of the
previous point, then the shield is integrated over the step with 10 semi-implicit Euler
sub-steps, the groups' motion interpolated linearly. Synchronisation error:
e_sync(t) = max_i x_i(t) - min_i x_i(t); load imbalance: max_i F_L,i - min_i F_L,i.
"""

import math
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import ShieldCutterhead as shield_model  # noqa: E402
from tbm_fmu import Instance, finite  # noqa: E402

GROUPS = ["top", "right", "bottom", "left"]
TILT = np.array([0.10, 0.0, -0.10, 0.0])
M_SHIELD = 2000.0  # kg
K_C = 5.0e6  # N/m   coupling stiffness per group (hydraulic stiffness of one cylinder ~2.2e6 N/m)
C_C = 5.0e3  # N s/m coupling damping per group
V_REF = 0.05  # m/s
H = 0.001  # s
T_START_UP = 5.0  # s
SUB = 10


def run_four_groups(fmu, scheme, h=H, t_end=T_START_UP, main_command=None):
    p = shield_model.DEFAULTS
    params = {"scheme": scheme} | ({"main_command": main_command} if main_command else {})
    d0 = p["F_pre"] / K_C
    groups = [Instance(fmu, f"group_{g}_{scheme}") for g in GROUPS]
    try:
        X = V = 0.0
        loads = p["F_pre"] * (1.0 + TILT)
        for g, f in zip(groups, loads):
            g.initialize(0.0, t_end, params=params, inputs={"v_ref": V_REF, "F_L": f})
        n = int(round(t_end / h))
        t = np.arange(n + 1) * h
        xs = np.empty((n + 1, 4))
        es = np.empty((n + 1, 4))
        fl = np.empty((n + 1, 4))
        shield_x = np.empty(n + 1)
        xv = np.array([g.get(["x", "v", "e_x"]) for g in groups])
        xs[0], es[0], fl[0], shield_x[0] = xv[:, 0], xv[:, 2], loads, X
        dt = h / SUB
        for k in range(n):
            for g, f in zip(groups, loads):
                g.set(F_L=f)
                g.step_to(t[k + 1])
            new = np.array([g.get(["x", "v", "e_x"]) for g in groups])
            for j in range(SUB):  # shield over [t_k, t_k+1], groups' motion interpolated
                a = (j + 1) / SUB
                x_i = (1 - a) * xv[:, 0] + a * new[:, 0]
                v_i = (1 - a) * xv[:, 1] + a * new[:, 1]
                f_i = K_C * (x_i - X + d0) + C_C * (v_i - V)
                R = 4.0 * shield_model.target_load(X, V)[0]
                V += dt * (f_i.sum() - R) / M_SHIELD
                X += dt * V
            xv = new
            f_i = K_C * (xv[:, 0] - X + d0) + C_C * (xv[:, 1] - V)
            R = 4.0 * shield_model.target_load(X, V)[0]
            loads = f_i + TILT * R / 4.0
            xs[k + 1], es[k + 1], fl[k + 1], shield_x[k + 1] = xv[:, 0], xv[:, 2], loads, X
        return {"t": t, "x": xs, "e_x": es, "F_L": fl, "X": shield_x,
                "sync": xs.max(axis=1) - xs.min(axis=1), "imbalance": fl.max(axis=1) - fl.min(axis=1)}
    finally:
        for g in groups:
            g.terminate_and_free()


@pytest.fixture(scope="module")
def runs(fmu, summary):
    out = {}
    for scheme in ("single", "adaptive"):
        t0 = time.perf_counter()
        out[scheme] = run_four_groups(fmu, scheme)
        summary[f"four_groups_{scheme}_5s_1ms_s"] = round(time.perf_counter() - t0, 2)
    return out


def metrics(r):
    return {
        "sync_max_mm": 1e3 * float(r["sync"].max()),
        "sync_rms_mm": 1e3 * float(np.sqrt(np.mean(r["sync"] ** 2))),
        "e_x_max_mm": 1e3 * float(r["e_x"].max()),
        "imbalance_max_kN": float(r["imbalance"].max()) / 1e3,
        "t_sync_max_s": float(r["t"][np.argmax(r["sync"])]),
    }


def test_four_groups_push_the_shield(runs):
    for scheme, r in runs.items():
        assert finite(r["x"], r["e_x"], r["F_L"], r["X"]), f"{scheme}: non-finite values"
        # the shield follows the groups: after 5 s at 0.05 m/s about 0.25 m
        assert r["X"][-1] == pytest.approx(0.25, abs=0.01), f"{scheme}: shield at {r['X'][-1]:.4f} m after 5 s"
        mean_load = r["F_L"][-500:].mean(axis=0)
        # total thrust balances 4x the advancing load (about 4 x 12 kN)
        assert 44e3 < mean_load.sum() < 50e3, f"{scheme}: total thrust {mean_load.sum() / 1e3:.1f} kN"
        # the tilted face: the top group carries more than the bottom group
        assert mean_load[0] > mean_load[2] + 1500.0, (
            f"{scheme}: top group {mean_load[0]:.0f} N should carry ~2.4 kN more than bottom {mean_load[2]:.0f} N")
        # the groups stay synchronised by the stiff shield to well below a millimetre at steady state
        assert r["sync"][-500:].max() < 1e-3, f"{scheme}: steady sync error {1e3 * r['sync'][-500:].max():.3f} mm"


def test_step_size_converged(fmu, runs):
    """The coupling is explicit: halving the communication step must not change the result much."""
    fine = run_four_groups(fmu, "adaptive", h=H / 2, t_end=2.0)
    coarse = runs["adaptive"]
    n = int(round(2.0 / H))
    a, b = coarse["sync"][: n + 1].max(), fine["sync"][::2][: n + 1].max()
    assert abs(a - b) <= 0.05 * b + 1e-6, f"max sync error {1e3 * a:.4f} mm (1 ms) vs {1e3 * b:.4f} mm (0.5 ms)"
    ea, eb = coarse["e_x"][: n + 1].max(), fine["e_x"][::2][: n + 1].max()
    assert abs(ea - eb) <= 0.02 * eb, f"max e_x {1e3 * ea:.4f} mm (1 ms) vs {1e3 * eb:.4f} mm (0.5 ms)"


@pytest.fixture(scope="module")
def compared(runs, summary, out_dir):
    m = {s: metrics(r) for s, r in runs.items()}
    for s, v in m.items():
        summary[f"four_groups_{s}"] = {k: round(x, 4) for k, x in v.items()}
    plot(runs, m, out_dir / "four_groups_sync.png")
    return m


def test_adaptive_reduces_start_up_error(compared):
    m = compared
    assert m["adaptive"]["e_x_max_mm"] < m["single"]["e_x_max_mm"], (
        f"adaptive start-up e_x max {m['adaptive']['e_x_max_mm']:.3f} mm is not below single's "
        f"{m['single']['e_x_max_mm']:.3f} mm")


def late_sync_mm(r):
    """Mean synchronisation error over 4-5 s [mm]."""
    return 1e3 * r["sync"][r["t"] >= 4.0].mean()


def test_groups_stay_synchronised_and_the_adaptive_scheme_ends_closer(compared, runs, summary):
    """Both schemes keep the groups within a small fraction of the start-up lag, and at 4-5 s
    the adaptive scheme holds them closer than the single pump.

    What this test no longer claims, and why. In the adaptive scheme the main pump tracks the
    reference flow A v_ref (Table 1, the chosen reading, docs/reproduce.md) and only the
    auxiliary pump answers the position error; at start-up its command is held at the
    Eq. 26 limit u2 = u1 for about 0.45 s, so in that time no group corrects its own
    position and the +/-10 % load tilt (different pressure-coupling losses b_p p and
    compression volumes) spreads the groups. The single pump keeps its proportional
    position loop through the start-up. Measured with the default model: RMS
    synchronisation error over 0-5 s 0.0625 mm adaptive against 0.0442 mm single, peak
    0.1875 against 0.1839 mm; the earlier claims (adaptive RMS 30 % below, peak below, 4-5 s
    20 % below single) hold only when the main pump keeps a position loop, which
    test_adaptive_synchronises_better_when_the_main_pump_keeps_its_position_loop checks."""
    m = compared
    for s in ("single", "adaptive"):
        assert 0.0 < m[s]["sync_max_mm"] < 0.1 * m[s]["e_x_max_mm"] + 0.05, (
            f"{s}: groups drift apart by {m[s]['sync_max_mm']:.3f} mm for a lag of {m[s]['e_x_max_mm']:.3f} mm")
    late = {s: late_sync_mm(r) for s, r in runs.items()}
    summary["four_groups_sync_4_5s_mm"] = {s: round(float(v), 4) for s, v in late.items()}
    assert late["adaptive"] < late["single"], (
        f"synchronisation error at 4-5 s: adaptive {late['adaptive']:.4f} mm, single {late['single']:.4f} mm")


def test_adaptive_synchronises_better_when_the_main_pump_keeps_its_position_loop(fmu, runs, summary):
    """With main_command = target (the main pump tracks A (v_ref + K_pos e_x) in the adaptive
    scheme too) every group keeps its own position loop through the start-up, and the
    adaptive scheme synchronises the groups better than the single pump: RMS over 0-5 s 30 %
    below, peak below, 4-5 s 20 % below. (With an earlier version of the model, whose
    auxiliary-pump loop chattered, the adaptive peak was 30 % HIGHER, though shorter, than the
    single pump's; this test is where such a change shows.)"""
    single = metrics(runs["single"])
    target = run_four_groups(fmu, "adaptive", main_command="target")
    m = metrics(target)
    summary["four_groups_adaptive_main_command_target"] = {k: round(x, 4) for k, x in m.items()}
    assert m["sync_rms_mm"] < 0.7 * single["sync_rms_mm"], (
        f"RMS synchronisation error over 0-5 s: adaptive (target) {m['sync_rms_mm']:.4f} mm, "
        f"single {single['sync_rms_mm']:.4f} mm")
    assert m["sync_max_mm"] < single["sync_max_mm"], (
        f"peak synchronisation error: adaptive (target) {m['sync_max_mm']:.4f} mm at {m['t_sync_max_s']:.2f} s, "
        f"single {single['sync_max_mm']:.4f} mm at {single['t_sync_max_s']:.2f} s")
    assert late_sync_mm(target) < 0.8 * late_sync_mm(runs["single"]), (
        f"synchronisation error at 4-5 s: adaptive (target) {late_sync_mm(target):.4f} mm, "
        f"single {late_sync_mm(runs['single']):.4f} mm")


def plot(runs, m, path):
    colors = {"single": "tab:red", "adaptive": "tab:blue"}
    fig, ax = plt.subplots(3, 1, figsize=(10, 10), sharex=True)
    for s, r in runs.items():
        c = colors[s]
        ax[0].plot(r["t"], r["sync"] * 1e3, c=c,
                   label=f"{s}: max {m[s]['sync_max_mm']:.3f} mm at {m[s]['t_sync_max_s']:.2f} s")
        for j, g in enumerate(GROUPS):
            ls = ["-", "--", ":", "-."][j]
            ax[1].plot(r["t"], r["e_x"][:, j] * 1e3, c=c, ls=ls, lw=1, label=f"{s} {g}")
            ax[2].plot(r["t"], r["F_L"][:, j] / 1e3, c=c, ls=ls, lw=1, label=f"{s} {g}")
    ax[0].set_ylabel("sync error max-min x_i [mm]")
    ax[1].set_ylabel("e_x per group [mm]")
    ax[2].set_ylabel("group load F_L,i [kN]")
    ax[2].set_xlabel("time [s]")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7, ncol=2)
    fig.suptitle("Four thrust groups (TbmThrust FMU x4) pushing one shield, face tilted +/-10 %")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    assert path.stat().st_size > 10_000 and not math.isnan(m["single"]["sync_max_mm"])
