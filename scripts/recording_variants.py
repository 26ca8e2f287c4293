#!/usr/bin/env python3
"""Write variants of labelled recordings, to see whether `diagnose` holds when a bench
logs differently from the recordings at hand.

    python3 scripts/recording_variants.py CASES_DIR OUT_DIR

CASES_DIR holds NNN.csv with its truth NNN.json (the layout `score.py` reads). For every
recording OUT_DIR/VARIANT/ gets NNN.csv and a copy of NNN.json, for each variant:

    every2   every second sample (half the logging rate)
    every5   every fifth sample (a fifth of the rate; 20 Hz from 100 Hz)
    no_uc    without the drive commands uc1, uc2 (a bench that logs the flow setpoints only)
    no_u     without the commanded flows u1, u2
    no_drive without uc1, uc2, u1, u2 (a bench that logs neither: only a pump's ripple can
             be tested)
    offset   the time stamps shifted by 1234.5 s (a logger clock that does not start at 0)
    noisy    x, p, Q1, Q2 with added white noise of the truth's `noise_floor_rmse` (twice the
             noise power; the truth's floor is kept, so the scorer still reads the
             recording's own), seeded per recording
    columns  the columns in reverse order (a logger that writes them otherwise)

Each OUT_DIR/VARIANT is then a case directory for `score.py --cases`. Standard library only.
"""
import json
import os
import random
import shutil
import sys

NOISY = ("x", "p", "Q1", "Q2")


def noisier(header, rows, floors, seed):
    """`rows` with white noise of standard deviation `floors[c]` added to each column c
    of NOISY that the recording has."""
    rng = random.Random(seed)
    cols = [(header.index(c), floors[c]) for c in NOISY if c in header and c in floors]
    out = []
    for r in rows:
        r = list(r)
        for i, sd in cols:
            r[i] = "%.9g" % (float(r[i]) + rng.gauss(0.0, sd))
        out.append(r)
    return out


def variants(header, rows, floors, seed):
    """(name, header, rows) of every variant of one recording; `floors` the truth's noise
    floor per signal (empty without a truth)."""
    def without(cols):
        keep = [i for i, c in enumerate(header) if c not in cols]
        return [header[i] for i in keep], [[r[i] for i in keep] for r in rows]

    t = header.index("time")
    shifted = [r[:t] + ["%.6f" % (float(r[t]) + 1234.5)] + r[t + 1:] for r in rows]
    return [
        ("every2", header, rows[::2]),
        ("every5", header, rows[::5]),
        ("no_uc", *without({"uc1", "uc2"})),
        ("no_u", *without({"u1", "u2"})),
        ("no_drive", *without({"uc1", "uc2", "u1", "u2"})),
        ("offset", header, shifted),
        ("noisy", header, noisier(header, rows, floors, seed)),
        ("columns", header[::-1], [r[::-1] for r in rows]),
    ]


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: recording_variants.py CASES_DIR OUT_DIR")
    cases, out = sys.argv[1], sys.argv[2]
    names = sorted(f[:-4] for f in os.listdir(cases) if f.endswith(".csv"))
    if not names:
        sys.exit("no NNN.csv in %s" % cases)
    written = set()
    for name in names:
        with open(os.path.join(cases, name + ".csv"), encoding="utf-8") as f:
            lines = f.read().splitlines()
        comments = [line for line in lines if line.startswith("#")]
        body = [line for line in lines if line and not line.startswith("#")]
        header = body[0].split(",") if body else []
        if "time" not in header:
            sys.exit("%s.csv: no header with a time column" % name)
        rows = [line.split(",") for line in body[1:]]
        truth = os.path.join(cases, name + ".json")
        floors = {}
        if os.path.exists(truth):
            with open(truth, encoding="utf-8") as f:
                floors = json.load(f).get("noise_floor_rmse", {})
        seed = sum(ord(c) for c in name)
        for variant, h, rs in variants(header, rows, floors, seed):
            written.add(variant)
            target = os.path.join(out, variant)
            os.makedirs(target, exist_ok=True)
            with open(os.path.join(target, name + ".csv"), "w", encoding="utf-8") as f:
                f.write("\n".join(comments + [",".join(h)] + [",".join(r) for r in rs]) + "\n")
            if os.path.exists(truth):
                shutil.copy(truth, os.path.join(target, name + ".json"))
    print("%d recordings x %d variants written to %s" % (len(names), len(written), out))


if __name__ == "__main__":
    main()
