"""Parameter studies on Dask (python/tbm_thrust_study): a LocalCluster of 2 worker processes
gives the same rows, bit for bit, as a plain sequential loop; a case the FMU refuses is a
"failed" row with the FMU's reason and does not stop the study; the command line writes the
table and the plots, and refuses bad arguments in one line.

The sequential reference runs in a subprocess: fmpy routes every FMU's log messages of a
process to one Python function, and the study's runner installs its own, which would take the
messages away from the other tests' captures in this process.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time

import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "python"))

from tbm_thrust_study import grid, read_csv, run_study, same_results, write_csv  # noqa: E402

STOP_TIME = 2.0  # [s] start-up phase of each run; 200 communication steps of 10 ms
STEP = 0.01
BAD_CASE = 17  # gets beta_e = -1 Pa, outside its range [1e6, 1e11] Pa


def forty_cases() -> list[dict]:
    cases = grid(scheme=["single", "adaptive"], F_L=[7000.0, 9000.0, 11000.0, 13000.0, 15000.0],
                 air_fraction=[0.0, 0.002, 0.005, 0.01])
    assert len(cases) == 40
    cases[BAD_CASE] = {**cases[BAD_CASE], "beta_e": -1.0}
    return cases


def study_cli(*args, timeout=600) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO / "python")}
    return subprocess.run([sys.executable, "-m", "tbm_thrust_study", *args], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def sequential(fmu_path, tmp_path_factory, summary):
    """The 40 cases in a plain loop in one fresh process (`run_sequential`), read back from
    the CSV it writes."""
    out = tmp_path_factory.mktemp("study_seq") / "results.csv"
    code = (
        "import json, sys; sys.path.insert(0, sys.argv[1]);"
        "from tbm_thrust_study import run_sequential, write_csv;"
        "write_csv(run_sequential(sys.argv[2], json.loads(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])),"
        " sys.argv[6])"
    )
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", code, str(REPO / "python"), str(fmu_path), json.dumps(forty_cases()),
                        repr(STOP_TIME), repr(STEP), str(out)], capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - t0
    assert r.returncode == 0, r.stderr[-3000:]
    summary["study_40_runs_2s_sequential_s (fresh process, incl. start-up)"] = round(wall, 2)
    return read_csv(out)


@pytest.fixture(scope="module")
def on_dask(fmu_path, tmp_path_factory, summary):
    """The same 40 cases on a LocalCluster of 2 worker processes, through a CSV round trip."""
    from distributed import Client, LocalCluster

    out = tmp_path_factory.mktemp("study_dask")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        t0 = time.perf_counter()
        rows = run_study(fmu_path, forty_cases(), client=client, stop_time=STOP_TIME, step=STEP, progress=False)
        wall = time.perf_counter() - t0
        workers_used = client.run(lambda dask_worker: hasattr(dask_worker, "_tbm_thrust_study_cache"))
    summary["study_40_runs_2s_dask_2_workers_s (cluster already up)"] = round(wall, 2)
    write_csv(rows, out / "results.csv")
    return rows, read_csv(out / "results.csv"), workers_used


def test_dask_study_matches_sequential_loop_bit_for_bit(sequential, on_dask):
    rows, from_csv, workers_used = on_dask
    assert [r["case"] for r in rows] == list(range(40)), "rows must come back in case order"
    assert sum(r["status"] == "ok" for r in rows) == 39
    assert all(used for used in workers_used.values()), f"not every worker ran a case: {workers_used}"
    diffs = same_results(from_csv, sequential)
    assert not diffs, "Dask and the sequential loop differ:\n" + "\n".join(diffs[:20])
    # Guard against comparing two empty studies: the metrics move with load and air.
    ok = [r for r in rows if r["status"] == "ok"]
    assert len({r["e_max_mm"] for r in ok}) > 30, "the cases gave (nearly) identical metrics"
    for r in ok:
        assert 0.05 < r["e_max_mm"] < 20.0, r
        assert abs(r["x_end_m"] - 0.05 * STOP_TIME) < 0.01, r


def test_refused_case_is_reported_in_its_row(on_dask):
    rows, _, _ = on_dask
    bad = rows[BAD_CASE]
    assert bad["status"] == "failed"
    assert "beta_e" in bad["error"] and "-1" in bad["error"], bad["error"]
    assert "\n" not in bad["error"]
    assert all(math.isnan(bad[m]) for m in ("e_max_mm", "e_sd_mm", "x_end_m"))
    assert rows[BAD_CASE + 1]["status"] == "ok", "the case after the failed one must still run"


def test_air_raises_the_start_up_error(on_dask):
    """A physical check of the table: entrained air softens the oil column, so the adaptive
    start-up error grows with the air fraction at every load."""
    rows, _, _ = on_dask
    ok = [r for r in rows if r["status"] == "ok" and r["scheme"] == "adaptive"]
    for load in {r["F_L"] for r in ok}:
        series = sorted((r["air_fraction"], r["e_max_mm"]) for r in ok if r["F_L"] == load)
        if len(series) == 4:
            assert series[-1][1] > series[0][1], f"F_L = {load} N: {series}"


def test_cli_writes_table_and_plots(fmu_path, tmp_path):
    r = study_cli("--fmu", str(fmu_path), "--workers", "2", "--no-progress", "--stop-time", "1",
                  "--mc", "6", "--uniform", "F_L=8000,16000", "--normal", "beta_e=1.056e9,5e7", "--seed", "3",
                  "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr[-3000:]
    rows = read_csv(tmp_path / "results.csv")
    assert len(rows) == 6 and all(row["status"] == "ok" for row in rows), rows
    assert len({row["F_L"] for row in rows}) == 6
    assert (tmp_path / "histogram.png").stat().st_size > 1000
    assert "6 runs in" in r.stdout


@pytest.mark.parametrize("args, needle", [
    (["--grid", "F_L"], "expected NAME=VALUES"),
    (["--grid", "F_L=1:2"], "lo:hi:n"),
    (["--mc", "5"], "needs at least one"),
    (["--mc", "5", "--uniform", "F_L=1"], "expected 2 numbers"),
    (["--grid", "F_L=1,2", "--fmu", "/nonexistent.fmu"], "not found"),
    ([], "give --grid"),
])
def test_cli_bad_arguments_give_one_line(tmp_path, args, needle):
    r = study_cli(*args, "--out", str(tmp_path), timeout=120)
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0], r.stderr


def test_existing_cluster_needs_neither_the_package_nor_the_fmu_on_disk(fmu_path, tmp_path):
    """`--scheduler tcp://HOST:PORT`: a scheduler and a worker started with `dask scheduler` /
    `dask worker` in another directory, without python/ on their path, run a study: the runner
    code and the FMU bytes travel with the tasks."""
    import json
    import signal

    dask = [sys.executable, "-m", "dask"]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    where = tmp_path / "cluster"
    where.mkdir()
    sched_file = where / "scheduler.json"
    procs = [subprocess.Popen([*dask, "scheduler", "--port", "0", "--no-dashboard", "--scheduler-file",
                               str(sched_file)], cwd=where, env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True)]
    try:
        deadline = time.time() + 60
        while not sched_file.exists() and time.time() < deadline:
            time.sleep(0.2)
        assert sched_file.exists(), "dask scheduler did not start within 60 s"
        address = json.loads(sched_file.read_text())["address"]
        procs.append(subprocess.Popen([*dask, "worker", address, "--nworkers", "1", "--nthreads", "1",
                                       "--no-dashboard"], cwd=where, env=env, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL, start_new_session=True))
        from distributed import Client

        with Client(address, timeout=60) as client:
            client.wait_for_workers(1, timeout=60)

            def probe():
                import importlib.util

                return importlib.util.find_spec("tbm_thrust_study") is None

            assert all(client.run(probe).values()), "the worker can import tbm_thrust_study; the test proves nothing"
        out = tmp_path / "out"
        r = study_cli("--fmu", str(fmu_path), "--scheduler", address, "--no-progress", "--stop-time", "1",
                      "--grid", "F_L=9000,12000", "--grid", "scheme=single,adaptive", "--out", str(out))
        assert r.returncode == 0, r.stderr[-3000:]
        rows = read_csv(out / "results.csv")
        assert [row["status"] for row in rows] == ["ok"] * 4, rows
        assert (out / "metric_map.png").stat().st_size > 1000
    finally:
        for p in reversed(procs):
            os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
