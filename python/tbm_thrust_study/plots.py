"""Plots of a study's results table (matplotlib, Agg backend: files, no window)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence


def _ok(rows):
    return [r for r in rows if r.get("status") == "ok"]


def _numeric_axes(rows: Sequence[dict], exclude: Sequence[str]) -> list[str]:
    """Varied columns with more than one numeric value, in column order."""
    from . import columns_of

    axes = []
    for c in columns_of(rows):
        if c in exclude or c in ("case", "status", "error", "wall_s"):
            continue
        values = {r.get(c) for r in rows}
        if len(values) > 1 and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            axes.append(c)
    return axes


def plot_metric_map(rows: Sequence[dict], metric: str, path, x: str | None = None, y: str | None = None) -> Path | None:
    """`metric` against the first varied value (x), one line per value of the second (y):
    e.g. the maximum start-up error against the load, one line per air fraction. Returns
    None when nothing was varied."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from .runner import METRICS

    ok = _ok(rows)
    axes = _numeric_axes(ok, METRICS)
    x = x or (axes[0] if axes else None)
    if x is None:
        return None
    y = y or next((a for a in axes if a != x), None)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    groups = sorted({r[y] for r in ok}) if y else [None]
    if y and len(groups) > 12:
        sc = ax.scatter([r[x] for r in ok], [r[metric] for r in ok], c=[r[y] for r in ok], s=14, cmap="viridis")
        fig.colorbar(sc, ax=ax, label=y)
    else:
        for g in groups:
            sel = sorted((r for r in ok if y is None or r[y] == g), key=lambda r: r[x])
            ax.plot([r[x] for r in sel], [r[metric] for r in sel], "o-", ms=4, label=None if y is None else f"{y} = {g:g}")
        if y:
            ax.legend(fontsize=8)
    failed = len(rows) - len(ok)
    ax.set_xlabel(x)
    ax.set_ylabel(metric)
    ax.set_title(f"{metric} vs {x}" + (f" ({failed} failed runs not shown)" if failed else ""), fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_histogram(rows: Sequence[dict], metric: str, path) -> Path:
    """Histogram of `metric` over the successful runs, with mean and 5 / 95 % quantiles."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    values = np.array([r[metric] for r in _ok(rows) if not math.isnan(r[metric])])
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    if len(values):
        ax.hist(values, bins=max(5, min(40, int(np.sqrt(len(values))) * 2)), color="#4477aa", alpha=0.85)
        q5, q95 = np.quantile(values, [0.05, 0.95])
        for v, style, label in ((values.mean(), "-", "mean"), (q5, "--", "5 %"), (q95, "--", "95 %")):
            ax.axvline(v, color="k", ls=style, lw=1, label=f"{label} {v:.4g}")
        ax.legend(fontsize=8)
    ax.set_xlabel(metric)
    ax.set_ylabel("runs")
    ax.set_title(f"{metric} over {len(values)} runs", fontsize=10)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
