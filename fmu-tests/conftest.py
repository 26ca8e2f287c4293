"""Fixtures of the FMU test suite.

Locations (override with environment variables):
  TBM_FMU        the FMU under test              default target/fmu/TbmThrust.fmu
  TBM_BIN        the native command-line tool    default target/release/tbm-thrust
  TBM_TEST_OUT   plots and the figures summary   default out/fmu-tests
  TBM_NO_BUILD=1 do not run `cargo build --release` first (by default it runs once per
                 session, a no-op when nothing changed, so the FMU is never stale)
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
MACHINES = REPO / "examples" / "python" / "machines"
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(MACHINES))

from tbm_fmu import FmuInfo, read_recording  # noqa: E402

#: The paper's start-up run (section 4.2): adaptive scheme, PID loops, 0.05 m/s, 12 kN, 20 s.
PAPER = {"scheme": "adaptive", "controller": "pid", "v_ref": 0.05, "F_L": 12000.0, "duration": 20.0, "dt": 0.01}

_built = False


def _cargo_build() -> None:
    global _built
    if _built or os.environ.get("TBM_NO_BUILD") == "1":
        return
    t0 = time.perf_counter()
    r = subprocess.run(["cargo", "build", "--release"], cwd=REPO, capture_output=True, text=True)
    if r.returncode != 0:
        pytest.fail(f"`cargo build --release` failed:\n{r.stderr[-4000:]}", pytrace=False)
    _built = True
    SUMMARY["cargo_build_release_s"] = round(time.perf_counter() - t0, 2)


SUMMARY: dict = {}


@pytest.fixture(scope="session")
def summary():
    """Measured figures; written to <out>/summary.json at the end of the session."""
    return SUMMARY


def pytest_sessionfinish(session, exitstatus):
    if SUMMARY:
        out = Path(os.environ.get("TBM_TEST_OUT", REPO / "out" / "fmu-tests"))
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").write_text(json.dumps(SUMMARY, indent=2, sort_keys=True) + "\n")


def pytest_terminal_summary(terminalreporter):
    if SUMMARY:
        terminalreporter.section("measured figures (also in out/fmu-tests/summary.json)")
        for k in sorted(SUMMARY):
            terminalreporter.write_line(f"{k} = {SUMMARY[k]}")


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    if "TBM_FMU" in os.environ:
        path = Path(os.environ["TBM_FMU"])
    else:
        _cargo_build()
        path = REPO / "target" / "fmu" / "TbmThrust.fmu"
    if not path.is_file():
        pytest.fail(f"the FMU {path} does not exist after `cargo build --release`", pytrace=False)
    return path


@pytest.fixture(scope="session")
def cli_path() -> Path:
    if "TBM_BIN" in os.environ:
        path = Path(os.environ["TBM_BIN"])
    else:
        _cargo_build()
        path = REPO / "target" / "release" / "tbm-thrust"
    if not path.is_file():
        pytest.fail(f"the command {path} does not exist after `cargo build --release`", pytrace=False)
    return path


@pytest.fixture(scope="session")
def fmu(fmu_path, tmp_path_factory) -> FmuInfo:
    """The FMU extracted once per session, with its model description."""
    from fmpy import extract, read_model_description

    unzipdir = Path(extract(str(fmu_path), unzipdir=str(tmp_path_factory.mktemp("TbmThrust"))))
    md = read_model_description(str(fmu_path), validate=False)
    return FmuInfo(path=fmu_path, unzipdir=unzipdir, md=md)


@pytest.fixture(scope="session")
def out_dir() -> Path:
    out = Path(os.environ.get("TBM_TEST_OUT", REPO / "out" / "fmu-tests"))
    out.mkdir(parents=True, exist_ok=True)
    return out


def native_simulate(cli: Path, out_csv: Path, scheme="adaptive", controller="pid", v_ref=0.05, load=12000.0,
                    duration=20.0, params: Path | None = None) -> tuple[dict, float]:
    """Runs `tbm-thrust simulate`; returns the recording and the wall time [s]."""
    cmd = [str(cli), "simulate", "--scheme", scheme, "--controller", controller, "--v-ref", repr(v_ref),
           "--load", repr(load), "--duration", repr(duration), "--out", str(out_csv)]
    if params is not None:
        cmd += ["--params", str(params)]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    assert r.returncode == 0, f"{' '.join(cmd)} exited {r.returncode}:\n{r.stderr}"
    return read_recording(out_csv), wall


@pytest.fixture(scope="session")
def native_paper(cli_path, tmp_path_factory, summary) -> dict:
    """The native run of the paper case, sampled every 0.01 s."""
    csv = tmp_path_factory.mktemp("native") / "paper.csv"
    rec, wall = native_simulate(cli_path, csv, PAPER["scheme"], PAPER["controller"], PAPER["v_ref"], PAPER["F_L"],
                                PAPER["duration"])
    summary["native_simulate_paper_run_s"] = round(wall, 3)
    return rec


@pytest.fixture(scope="session")
def machine_fmus(tmp_path_factory) -> dict[str, Path]:
    """The pythonfmu machine models (a different exporter) built from examples/python/machines."""
    from pythonfmu.builder import FmuBuilder

    dest = tmp_path_factory.mktemp("machines")
    built = {}
    for name in ["ShieldCutterhead", "ThrustMaster"]:
        built[name] = Path(FmuBuilder.build_FMU(MACHINES / f"{name}.py", dest=dest))
        assert built[name].is_file(), f"pythonfmu did not build {name}.fmu"
    return built
