"""Parameter studies of the TbmThrust FMU on a Dask cluster.

Runs a grid or a Monte Carlo sample over any FMU parameters and (constant) inputs with fmpy,
one co-simulation per case, on `dask.distributed`: a `LocalCluster` on this machine's cores by
default, or an existing cluster (`scheduler="tcp://HOST:8786"`). The FMU is sent to the
workers as bytes (no shared disk), and so is the code that runs a case (see `runner.py`).
Each case gives one row: its values, `status` ("ok" / "failed"), `error` (the FMU's one-line
reason for a failed case) and the paper's metrics (`runner.METRICS`).

    from tbm_thrust_study import grid, run_study, write_csv
    cases = grid(F_L=[8e3, 10e3, 12e3], air_fraction=[0.0, 0.005, 0.01])
    rows = run_study("target/fmu/TbmThrust.fmu", cases, n_workers=2)
    write_csv(rows, "out/study/results.csv")

Command line: `python -m tbm_thrust_study --help` (with `python/` on PYTHONPATH).
"""

from __future__ import annotations

import csv
import itertools
import math
import os
import time
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from . import runner
from .runner import METRICS, fmu_digest, run_case

__all__ = ["grid", "monte_carlo", "run_study", "run_sequential", "write_csv", "read_csv", "METRICS"]

#: Columns of every row besides the case's own values.
FIXED_COLUMNS = ("case", "status", "error")


def grid(**axes: Sequence) -> list[dict]:
    """Every combination of the given values (the last name varies fastest)."""
    names = list(axes)
    for name in names:
        if len(axes[name]) == 0:
            raise ValueError(f"grid axis {name} has no values")
    return [dict(zip(names, combo)) for combo in itertools.product(*(axes[n] for n in names))]


def monte_carlo(n: int, seed: int = 0, **distributions) -> list[dict]:
    """`n` cases drawn independently (numpy's PCG64 with `seed`): each keyword is
    ("uniform", low, high), ("normal", mean, sd), ("lognormal", median, sigma) or
    ("choice", [values]); a plain number holds that value in every case."""
    if n < 1:
        raise ValueError("a Monte Carlo study needs at least one case")
    rng = np.random.default_rng(seed)
    columns = {}
    for name, spec in distributions.items():
        if not isinstance(spec, (tuple, list)):
            columns[name] = [spec] * n
            continue
        kind, *args = spec
        if kind == "uniform":
            columns[name] = rng.uniform(args[0], args[1], n).tolist()
        elif kind == "normal":
            columns[name] = rng.normal(args[0], args[1], n).tolist()
        elif kind == "lognormal":
            columns[name] = (args[0] * np.exp(rng.normal(0.0, args[1], n))).tolist()
        elif kind == "choice":
            columns[name] = [args[0][i] for i in rng.integers(0, len(args[0]), n)]
        else:
            raise ValueError(f"{name}: unknown distribution {kind!r} (uniform, normal, lognormal, choice)")
    return [{name: columns[name][i] for name in columns} for i in range(n)]


def _read_fmu(fmu) -> bytes:
    if isinstance(fmu, (bytes, bytearray)):
        return bytes(fmu)
    path = Path(fmu)
    if not path.is_file():
        raise FileNotFoundError(f"FMU {path} not found (build it with `cargo build --release`)")
    return path.read_bytes()


def run_sequential(fmu, cases: Sequence[dict], stop_time: float = 20.0, step: float = 0.01,
                   progress: bool = False) -> list[dict]:
    """The plain loop: every case in this process, one after the other."""
    data = _read_fmu(fmu)
    digest = fmu_digest(data)
    bar = _bar(len(cases), "sequential", progress)
    rows = []
    for i, values in enumerate(cases):
        rows.append(run_case(data, digest, i, dict(values), stop_time, step))
        bar.update(1)
    bar.close()
    return rows


def run_study(fmu, cases: Sequence[dict], scheduler: str | None = None, n_workers: int | None = None,
              stop_time: float = 20.0, step: float = 0.01, progress: bool = True, client=None,
              timings: dict | None = None) -> list[dict]:
    """Runs every case on a Dask cluster; the rows come back in case order.

    - `client`: an existing `distributed.Client` (used as is);
    - else `scheduler="tcp://HOST:8786"`: connect to that cluster;
    - else a `LocalCluster` of `n_workers` processes (default: the machine's cores), one
      thread each (an FMU instance is not shared between threads), closed at the end.

    `timings`, if given, receives `connect_s` (starting or reaching the cluster) and `runs_s`
    (shipping the FMU, running every case, collecting the rows) [s].
    """
    import cloudpickle
    from distributed import Client, LocalCluster, as_completed

    data = _read_fmu(fmu)
    digest = fmu_digest(data)
    # Ship the runner's code with the tasks, so workers need fmpy and numpy but not this package.
    cloudpickle.register_pickle_by_value(runner)
    started = time.perf_counter()
    cluster = None
    own_client = client is None
    if client is None:
        if scheduler:
            client = Client(scheduler)
        else:
            cluster = LocalCluster(n_workers=n_workers or os.cpu_count() or 1, threads_per_worker=1,
                                   processes=True, dashboard_address=None)
            client = Client(cluster)
    connected = time.perf_counter()
    try:
        [fmu_future] = client.scatter([data], broadcast=True)
        task = _by_value(runner.run_case)
        futures = [client.submit(task, fmu_future, digest, i, dict(values), stop_time, step, pure=False)
                   for i, values in enumerate(cases)]
        rows: list[dict | None] = [None] * len(cases)
        index = {f.key: i for i, f in enumerate(futures)}
        bar = _bar(len(cases), "co-simulations", progress)
        for future in as_completed(futures):
            rows[index[future.key]] = future.result()
            bar.update(1)
        bar.close()
        if timings is not None:
            timings.update(connect_s=connected - started, runs_s=time.perf_counter() - connected)
        return rows  # type: ignore[return-value]
    finally:
        cloudpickle.unregister_pickle_by_value(runner)
        if own_client:
            client.close()
        if cluster is not None:
            cluster.close()


def _by_value(fn):
    """A copy of `fn` that the standard pickle cannot find by reference, so that Dask, which
    tries the standard pickle first and cloudpickle only when that fails, ships it by value
    (with the runner module's helpers, registered by value) instead of naming a module the
    scheduler and the workers of an existing cluster do not have."""
    import types

    copy = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, fn.__closure__)
    copy.__module__ = "__main__"
    copy.__qualname__ = f"tbm_thrust_study_{fn.__name__}"
    copy.__doc__ = fn.__doc__
    return copy


class _NoBar:
    def update(self, n):
        pass

    def close(self):
        pass


def _bar(total: int, what: str, show: bool):
    if not show:
        return _NoBar()
    from tqdm import tqdm

    return tqdm(total=total, desc=what, unit="run")


def columns_of(rows: Iterable[dict]) -> list[str]:
    """case, the varied values (in first-seen order), status, error, metrics, wall_s."""
    values: list[str] = []
    for row in rows:
        for k in row:
            if k not in FIXED_COLUMNS and k not in METRICS and k != "wall_s" and k not in values:
                values.append(k)
    return ["case", *values, "status", "error", *METRICS, "wall_s"]


def write_csv(rows: Sequence[dict], path) -> Path:
    """One row per run; floats written with repr (they read back bit for bit)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = columns_of(rows)

    def cell(v):
        if isinstance(v, float):
            return repr(v)
        return "" if v is None else str(v)

    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for row in rows:
            w.writerow([cell(row.get(c)) for c in cols])
    return path


def read_csv(path) -> list[dict]:
    """The rows of `write_csv`: numbers as float (int for `case`), text as str."""
    rows = []
    with open(path, newline="", encoding="utf-8") as f:
        for raw in csv.DictReader(f):
            row = {}
            for k, v in raw.items():
                if k == "case":
                    row[k] = int(v)
                elif k in ("status", "error"):
                    row[k] = v
                else:
                    try:
                        row[k] = float(v)
                    except ValueError:
                        row[k] = v
            rows.append(row)
    return rows


def same_results(a: Sequence[dict], b: Sequence[dict]) -> list[str]:
    """Differences between two studies' rows, ignoring wall times; [] when equal bit for bit
    (NaN equals NaN)."""
    diffs = []
    if len(a) != len(b):
        return [f"{len(a)} rows vs {len(b)} rows"]
    for ra, rb in zip(a, b):
        keys = (set(ra) | set(rb)) - {"wall_s"}
        for k in sorted(keys):
            va, vb = ra.get(k), rb.get(k)
            both_nan = isinstance(va, float) and isinstance(vb, float) and math.isnan(va) and math.isnan(vb)
            if not both_nan and va != vb:
                diffs.append(f"case {ra.get('case')}: {k} = {va!r} vs {vb!r}")
    return diffs
