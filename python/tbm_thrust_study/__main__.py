"""Command line of the parameter-study runner.

    PYTHONPATH=python .venv/bin/python -m tbm_thrust_study \\
        --grid F_L=8000:16000:5 --grid air_fraction=0,0.005,0.01 --out out/study
    PYTHONPATH=python .venv/bin/python -m tbm_thrust_study \\
        --mc 200 --uniform F_L=8000,16000 --normal beta_e=1.056e9,5e7 --seed 1 --out out/mc
    ... --scheduler tcp://HOST:8786      # an existing Dask cluster instead of a LocalCluster

Writes OUT/results.csv (one row per run), OUT/metric_map.png (grids) or OUT/histogram.png
(Monte Carlo) and prints a summary. Bad arguments give one line on stderr and exit code 2; a
failed case is a row with status "failed", not an error of the study.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import columns_of, grid, monte_carlo, run_sequential, run_study, write_csv
from .runner import METRICS

DEFAULT_FMU = Path(__file__).resolve().parents[2] / "target" / "fmu" / "TbmThrust.fmu"


class UsageError(Exception):
    pass


def _number(text: str, what: str):
    try:
        return float(text)
    except ValueError:
        return text.strip()  # an enumeration item, e.g. scheme=single


def _name_value(text: str, option: str) -> tuple[str, str]:
    if "=" not in text:
        raise UsageError(f"{option} {text!r}: expected NAME=VALUES")
    name, value = text.split("=", 1)
    if not name.strip() or not value.strip():
        raise UsageError(f"{option} {text!r}: expected NAME=VALUES")
    return name.strip(), value.strip()


def parse_grid(specs: list[str]) -> dict[str, list]:
    """NAME=v1,v2,... or NAME=lo:hi:n (n evenly spaced values, both ends included)."""
    axes = {}
    for spec in specs:
        name, value = _name_value(spec, "--grid")
        if ":" in value:
            parts = value.split(":")
            if len(parts) != 3:
                raise UsageError(f"--grid {spec!r}: a range is lo:hi:n")
            try:
                lo, hi, n = float(parts[0]), float(parts[1]), int(parts[2])
            except ValueError:
                raise UsageError(f"--grid {spec!r}: a range is lo:hi:n with numbers") from None
            if n < 1:
                raise UsageError(f"--grid {spec!r}: n must be at least 1")
            axes[name] = [lo + (hi - lo) * k / (n - 1) for k in range(n)] if n > 1 else [lo]
        else:
            axes[name] = [_number(v, name) for v in value.split(",") if v.strip()]
    return axes


def parse_distributions(args) -> dict:
    dists = {}
    for option, kind, n_args in (("uniform", "uniform", 2), ("normal", "normal", 2), ("lognormal", "lognormal", 2)):
        for spec in getattr(args, option) or []:
            name, value = _name_value(spec, f"--{option}")
            try:
                numbers = [float(v) for v in value.split(",")]
            except ValueError:
                raise UsageError(f"--{option} {spec!r}: expected {n_args} numbers") from None
            if len(numbers) != n_args:
                raise UsageError(f"--{option} {spec!r}: expected {n_args} numbers")
            dists[name] = (kind, *numbers)
    for spec in args.choice or []:
        name, value = _name_value(spec, "--choice")
        dists[name] = ("choice", [_number(v, name) for v in value.split(",")])
    return dists


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m tbm_thrust_study", description=__doc__.split("\n\n")[0])
    p.add_argument("--fmu", type=Path, default=DEFAULT_FMU, help="the FMU (default: target/fmu/TbmThrust.fmu)")
    p.add_argument("--grid", action="append", metavar="NAME=VALUES", help="grid axis: v1,v2,... or lo:hi:n")
    p.add_argument("--mc", type=int, metavar="N", help="Monte Carlo study of N runs")
    p.add_argument("--uniform", action="append", metavar="NAME=LO,HI")
    p.add_argument("--normal", action="append", metavar="NAME=MEAN,SD")
    p.add_argument("--lognormal", action="append", metavar="NAME=MEDIAN,SIGMA")
    p.add_argument("--choice", action="append", metavar="NAME=V1,V2,...")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="a value held in every run")
    p.add_argument("--seed", type=int, default=0, help="Monte Carlo seed (default 0)")
    p.add_argument("--stop-time", type=float, default=20.0, help="simulated time per run [s] (default 20)")
    p.add_argument("--step", type=float, default=0.01, help="communication step [s] (default 0.01)")
    p.add_argument("--scheduler", metavar="tcp://HOST:8786", help="an existing Dask scheduler")
    p.add_argument("--workers", type=int, help="LocalCluster worker processes (default: all cores)")
    p.add_argument("--sequential", action="store_true", help="a plain loop in this process, no Dask")
    p.add_argument("--metric", default="e_max_mm", choices=METRICS, help="metric to plot (default e_max_mm)")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    args = p.parse_args(argv)

    try:
        fixed = {}
        for spec in args.set or []:
            name, value = _name_value(spec, "--set")
            fixed[name] = _number(value, name)
        if args.mc is not None:
            if args.grid:
                raise UsageError("use either --grid or --mc, not both")
            dists = parse_distributions(args)
            if not dists:
                raise UsageError("--mc needs at least one --uniform/--normal/--lognormal/--choice")
            cases = monte_carlo(args.mc, args.seed, **dists)
        elif args.grid:
            cases = grid(**parse_grid(args.grid))
        else:
            raise UsageError("give --grid NAME=VALUES (repeatable) or --mc N with distributions")
        cases = [{**fixed, **c} for c in cases]
        if not (args.stop_time > 0 and args.step > 0 and args.step <= args.stop_time):
            raise UsageError("--stop-time and --step must be positive, step <= stop time")
        if not args.fmu.is_file():
            raise UsageError(f"FMU {args.fmu} not found (build it with `cargo build --release`)")
    except (UsageError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

    started = time.perf_counter()
    timings: dict = {}
    try:
        if args.sequential:
            rows = run_sequential(args.fmu, cases, args.stop_time, args.step, progress=not args.no_progress)
        else:
            rows = run_study(args.fmu, cases, scheduler=args.scheduler, n_workers=args.workers,
                             stop_time=args.stop_time, step=args.step, progress=not args.no_progress,
                             timings=timings)
    except OSError as e:
        print(f"error: cannot reach the Dask cluster or read the FMU: {e}", file=sys.stderr)
        return 1
    wall = time.perf_counter() - started

    out = args.out
    table = write_csv(rows, out / "results.csv")
    from .plots import plot_histogram, plot_metric_map

    plots = [plot_histogram(rows, args.metric, out / "histogram.png")] if args.mc is not None else []
    if args.mc is None:
        plots.append(plot_metric_map(rows, args.metric, out / "metric_map.png"))
    failed = [r for r in rows if r["status"] != "ok"]
    print(f"{len(rows)} runs in {wall:.2f} s ({len(rows) / wall:.2f} runs/s), {len(failed)} failed")
    if timings:
        print(f"  Dask: {timings['connect_s']:.2f} s to start / reach the cluster, {timings['runs_s']:.2f} s for the "
              f"runs ({len(rows) / timings['runs_s']:.2f} runs/s once it is up)")
    for r in failed[:5]:
        print(f"  case {r['case']}: {r['error']}")
    print(f"results: {table} (columns: {', '.join(columns_of(rows))})")
    for plot in plots:
        if plot:
            print(f"plot: {plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
