#!/usr/bin/env python3
"""Simulate the TbmThrust FMU in FMPy and plot displacement, tracking error and pump flows.

    python examples/python/simulate_and_plot.py --out out/examples
    python examples/python/simulate_and_plot.py --scheme single --load 9000 --out out/examples

Writes <out>/simulate_and_plot.png and <out>/simulate_and_plot.csv (a recording CSV of the
project's contract: time, v_ref, F_L and every output), and prints Eq. (34)-(37) of e_x.
Build the FMU first with `cargo build --release` (it lands in target/fmu/TbmThrust.fmu).
"""

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy import read_model_description, simulate_fmu  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fmu", type=Path, default=ROOT / "target" / "fmu" / "TbmThrust.fmu")
    ap.add_argument("--out", type=Path, default=Path("out") / "examples", help="output directory")
    ap.add_argument("--scheme", choices=["single", "fixed_split", "adaptive"], default="adaptive")
    ap.add_argument("--controller", choices=["pid", "adrc"], default="pid")
    ap.add_argument("--v-ref", type=float, default=0.05, help="commanded velocity [m/s] (step at t = 0)")
    ap.add_argument("--load", type=float, default=12000.0, help="external load F_L [N]")
    ap.add_argument("--duration", type=float, default=20.0, help="[s]")
    ap.add_argument("--step", type=float, default=0.01, help="communication step [s]")
    a = ap.parse_args(argv)
    if not a.fmu.is_file():
        sys.exit(f"error: {a.fmu} not found; build it with `cargo build --release`")
    a.out.mkdir(parents=True, exist_ok=True)

    md = read_model_description(str(a.fmu))
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    enum = {v.name: {i.name: int(i.value) for i in v.declaredType.items}
            for v in md.modelVariables if v.type == "Enumeration"}
    # constant inputs from t = 0: the reference starts from rest, as in the paper
    signals = np.array([(0.0, a.v_ref, a.load), (a.duration, a.v_ref, a.load)],
                       dtype=[("time", "f8"), ("v_ref", "f8"), ("F_L", "f8")])
    res = simulate_fmu(str(a.fmu), stop_time=a.duration, output_interval=a.step, input=signals,
                       start_values={"scheme": enum["scheme"][a.scheme], "controller": enum["controller"][a.controller]},
                       output=["v_ref", "F_L"] + outputs)

    csv = a.out / "simulate_and_plot.csv"
    names = res.dtype.names
    np.savetxt(csv, np.column_stack([res[n] for n in names]), delimiter=",", header=",".join(names),
               comments="", fmt="%.12e")

    t = res["time"]
    e = res["e_x"][1:] * 1e3  # Eq. (34)-(37) over the samples after t = 0, in mm
    stats = dict(max=e.max(), min=e.min(), mean=e.mean(), sd=e.std(ddof=1))
    fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    ax[0].plot(t, res["x_ref"] * 1e3, "k--", lw=1, label="x_ref")
    ax[0].plot(t, res["x"] * 1e3, label="x")
    ax[0].set_ylabel("displacement [mm]")
    ax[1].plot(t, res["e_x"] * 1e3, c="tab:red", label="e_x = x_ref - x")
    ax[1].set_ylabel("tracking error [mm]")
    ax[1].set_title("e_x: max %.3f, min %.3f, mean %.3f, SD %.3f mm" % tuple(stats.values()), fontsize=9)
    ax[2].plot(t, res["Q1"] * 6e4, label="Q1 main pump")
    ax[2].plot(t, res["Q2"] * 6e4, label="Q2 auxiliary pump")
    ax[2].set_ylabel("flow [L/min]")
    ax[2].set_xlabel("time [s]")
    for x in ax:
        x.grid(alpha=0.3)
        x.legend(loc="best")
    fig.suptitle(f"TbmThrust FMU in FMPy: {a.scheme}, {a.controller}, v_ref {a.v_ref} m/s, F_L {a.load / 1e3:g} kN")
    fig.tight_layout()
    png = a.out / "simulate_and_plot.png"
    fig.savefig(png, dpi=110)
    print(f"e_x max {stats['max']:.4f} mm  min {stats['min']:.4f} mm  mean {stats['mean']:.4f} mm  SD {stats['sd']:.4f} mm")
    print(f"wrote {png} and {csv}")


if __name__ == "__main__":
    main()
