#!/usr/bin/env python3
"""Co-simulate the TbmThrust FMU with a TBM shield + cutterhead FMU made by another exporter
(pythonfmu): the shield turns the cylinder motion (x, v) into the load F_L, which goes back into
the cylinder. A plain Gauss-Seidel master written with FMPy's FMU2Slave, 1 ms steps.

    python examples/python/cosim_with_load.py --out out/examples

Builds machines/ShieldCutterhead.py into <out>/ShieldCutterhead.fmu, runs 10 s of the paper's
start-up (v_ref 0.05 m/s from rest), writes <out>/cosim_with_load.png and .csv.
"""

import argparse
import shutil
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


class Fmu:
    """A co-simulation instance with variables by name."""

    def __init__(self, path, name):
        md = read_model_description(str(path), validate=False)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.unzipdir = extract(str(path))
        self.slave = FMU2Slave(guid=md.guid, unzipDirectory=self.unzipdir,
                               modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.slave.instantiate()
        self.t = 0.0

    def set(self, **values):
        self.slave.setReal([self.vr[k] for k in values], list(values.values()))

    def get(self, *names):
        return self.slave.getReal([self.vr[k] for k in names])

    def init(self, **inputs):
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        self.set(**inputs)
        self.slave.exitInitializationMode()

    def step(self, t_next):
        self.slave.doStep(currentCommunicationPoint=self.t, communicationStepSize=t_next - self.t)
        self.t = t_next

    def close(self):
        self.slave.terminate()
        self.slave.freeInstance()
        shutil.rmtree(self.unzipdir, ignore_errors=True)


def build_shield(out):
    from pythonfmu.builder import FmuBuilder

    return Path(FmuBuilder.build_FMU(HERE / "machines" / "ShieldCutterhead.py", dest=out))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fmu", type=Path, default=ROOT / "target" / "fmu" / "TbmThrust.fmu")
    ap.add_argument("--out", type=Path, default=Path("out") / "examples")
    ap.add_argument("--v-ref", type=float, default=0.05, help="[m/s]")
    ap.add_argument("--duration", type=float, default=10.0, help="[s]")
    ap.add_argument("--step", type=float, default=0.001, help="communication step [s]")
    a = ap.parse_args(argv)
    if not a.fmu.is_file():
        sys.exit(f"error: {a.fmu} not found; build it with `cargo build --release`")
    a.out.mkdir(parents=True, exist_ok=True)

    shield = Fmu(build_shield(a.out), "shield")
    cyl = Fmu(a.fmu, "cylinder")
    shield.init(x=0.0, v=0.0)
    f_l = shield.get("F_L")[0]  # face preload at rest
    cyl.init(v_ref=a.v_ref, F_L=f_l)

    n = int(round(a.duration / a.step))
    rows = [(0.0, *cyl.get("x", "v", "e_x", "p"), f_l)]
    for k in range(n):
        t_next = (k + 1) * a.step
        cyl.set(F_L=f_l)  # load of the last point, held over the step
        cyl.step(t_next)
        x, v, e_x, p = cyl.get("x", "v", "e_x", "p")
        shield.set(x=x, v=v)  # Gauss-Seidel: the shield sees the new motion
        shield.step(t_next)
        f_l = shield.get("F_L")[0]
        rows.append((t_next, x, v, e_x, p, f_l))
    cyl.close()
    shield.close()

    r = np.array(rows)
    header = "time,x,v,e_x,p,F_L"
    np.savetxt(a.out / "cosim_with_load.csv", r, delimiter=",", header=header, comments="", fmt="%.12e")
    t = r[:, 0]
    fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    ax[0].plot(t, r[:, 2] * 1e3, label="v (TbmThrust FMU)")
    ax[0].axhline(a.v_ref * 1e3, c="k", ls="--", lw=1, label="v_ref")
    ax[0].set_ylabel("velocity [mm/s]")
    ax[1].plot(t, r[:, 5] / 1e3, c="tab:green", label="F_L (ShieldCutterhead FMU, pythonfmu)")
    ax[1].set_ylabel("load [kN]")
    ax[2].plot(t, r[:, 3] * 1e3, c="tab:red", label="e_x")
    ax[2].set_ylabel("tracking error [mm]")
    ax[2].set_xlabel("time [s]")
    for x in ax:
        x.grid(alpha=0.3)
        x.legend(loc="best")
    fig.suptitle("Thrust cylinder FMU + shield/cutterhead load FMU, Gauss-Seidel master")
    fig.tight_layout()
    fig.savefig(a.out / "cosim_with_load.png", dpi=110)
    print(f"load at rest {r[0, 5]:.0f} N, at {a.duration:g} s {r[-1, 5]:.0f} N; "
          f"e_x max {1e3 * r[:, 3].max():.4f} mm, final x {r[-1, 1]:.4f} m")
    print(f"wrote {a.out / 'cosim_with_load.png'} and {a.out / 'cosim_with_load.csv'}")


if __name__ == "__main__":
    main()
