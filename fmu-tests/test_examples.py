"""The Python examples run as a user would run them, so they cannot rot."""

import re
import subprocess
import sys

import numpy as np

from conftest import REPO


def run_example(script, fmu_path, out, *args):
    cmd = [sys.executable, str(REPO / "examples" / "python" / script), "--fmu", str(fmu_path), "--out", str(out), *args]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, f"{script} exited {r.returncode}:\n{r.stdout}\n{r.stderr}"
    return r.stdout


def test_simulate_and_plot(fmu_path, out_dir, native_paper):
    out = out_dir / "examples"
    stdout = run_example("simulate_and_plot.py", fmu_path, out)
    png, csv = out / "simulate_and_plot.png", out / "simulate_and_plot.csv"
    assert png.stat().st_size > 20_000, "plot missing or empty"
    data = np.genfromtxt(csv, delimiter=",", names=True)
    assert len(data) == 2001 and {"x", "e_x", "Q1", "Q2"} <= set(data.dtype.names)
    m = re.search(r"e_x max ([-\d.]+) mm", stdout)
    assert m, stdout
    native_max = 1e3 * native_paper["e_x"][1:].max()
    assert abs(float(m.group(1)) - native_max) < 1e-3, f"example e_x max {m.group(1)} mm vs native {native_max:.4f} mm"


def test_simulate_and_plot_other_case(fmu_path, tmp_path):
    stdout = run_example("simulate_and_plot.py", fmu_path, tmp_path, "--scheme", "single", "--controller", "adrc",
                         "--load", "9000", "--duration", "5")
    assert "e_x max" in stdout and (tmp_path / "simulate_and_plot.png").is_file()


def test_cosim_with_load(fmu_path, out_dir):
    out = out_dir / "examples"
    stdout = run_example("cosim_with_load.py", fmu_path, out, "--duration", "6")
    assert (out / "cosim_with_load.png").stat().st_size > 20_000
    data = np.genfromtxt(out / "cosim_with_load.csv", delimiter=",", names=True)
    assert data["F_L"][0] == 7000.0, "the shield FMU holds the face preload at rest"
    assert 11000.0 < data["F_L"][-1] < 12500.0, f"advancing load {data['F_L'][-1]:.0f} N"
    assert abs(data["x"][-1] - 0.3) < 0.01, f"x(6 s) = {data['x'][-1]:.4f} m"
    assert "e_x max" in stdout
