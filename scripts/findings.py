#!/usr/bin/env python3
"""The eleven bad-input findings of docs/robustness.md ("Before and after"), run against a
`tbm-thrust` binary: one line per case, `bad` where the binary shows the finding.

    python3 scripts/findings.py target/release/tbm-thrust
    python3 scripts/findings.py /tmp/old/target/release/tbm-thrust   # a build of an older commit

Exit code 1 when any case is bad. Needs /usr/bin/time for the memory cases."""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile

BIN = os.path.abspath(sys.argv[1])
CORPUS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "crates", "bench", "tests", "corpus")
WORK = tempfile.mkdtemp(prefix="tbm-findings-")
RESULTS = []


def run(args, timeout=120, close_stdout=False, limit_kb=None):
    """Runs the binary in its own process group; returns (exit code or "timeout", stdout,
    stderr, peak RSS in kB)."""
    cmd = ["/usr/bin/time", "-f", "RSS=%M", BIN] + args
    if limit_kb:
        cmd = ["sh", "-c", f'ulimit -v {limit_kb}; exec "$@"', "sh"] + cmd
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=WORK, start_new_session=True)
    if close_stdout:
        p.stdout.close()
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        return "timeout", "", "", 0
    out, err = (out or b"").decode(errors="replace"), err.decode(errors="replace")
    rss = int(re.findall(r"RSS=(\d+)", err)[-1]) if "RSS=" in err else 0
    err = re.sub(r"(Command (exited with non-zero status|terminated by signal) \d+\n)?RSS=\d+\n?", "", err)
    return p.returncode, out, err, rss


def first(text):
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return (lines[0][:110] + ("..." if len(lines[0]) > 110 else "")) if lines else ""


def case(finding, name, bad, what):
    RESULTS.append((finding, name, bad))
    print(f"{finding:>3} {'BAD ' if bad else 'ok  '} {name}: {what}", flush=True)


def corpus(name):
    return os.path.join(CORPUS, name)


def recording(seconds, name):
    path = os.path.join(WORK, name)
    code, _, err, _ = run(["simulate", "--duration", str(seconds), "--scheme", "single", "--out", path])
    assert code == 0, err
    return path


def edited(base, name, edit):
    """A copy of recording `base` with `edit(header, rows)` applied to its data rows."""
    lines = open(base).read().splitlines()
    h = next(i for i, l in enumerate(lines) if l.startswith("time"))
    names = lines[h].split(",")
    rows = [l.split(",") for l in lines[h + 1:]]
    rows = edit(names, rows) or rows
    path = os.path.join(WORK, name)
    open(path, "w").write("\n".join(lines[: h + 1] + [",".join(r) for r in rows]) + "\n")
    return path


def set_col(col, f):
    def e(names, rows):
        j = names.index(col)
        for k, r in enumerate(rows):
            r[j] = repr(f(k, float(r[j])))
    return e


def verdict(args):
    code, out, err, _ = run(args)
    if code != 0:
        return code, first(err)
    path = args[args.index("--json") + 1]
    return 0, json.load(open(path))["verdict"]


base = recording(10, "base.csv")
short = recording(5, "short.csv")
j = lambda n: os.path.join(WORK, n)

# 1. A huge finite cell: diagnose panicked, identify fitted RMSE inf.
for col, value in [("p", "1e160"), ("F_L", "1.7e308")]:
    rec = edited(short, f"huge_{col}.csv", set_col(col, lambda k, v: float(value) if k == 200 else v))
    code, out, err, _ = run(["diagnose", rec, "--json", j(f"huge_{col}.json")])
    case(1, f"diagnose, one {col} cell of {value}", code != 0 or "spike" not in out, f"exit {code}, spike named: {'spike' in out} {first(err) or first(out)}")
code, out, err, _ = run(["identify", corpus("huge_p.csv"), "--quiet", "--json", j("huge.json")])
rmse = [f["rmse"] for f in json.load(open(j("huge.json")))["fit"].values()] if code == 0 else []
case(1, "identify huge_p.csv", code != 0 or not all(isinstance(r, float) for r in rmse), f"exit {code}, rmse {rmse}")

# 2. A closed stdout.
for name, args in [
    ("simulate | head", ["simulate", "--duration", "1", "--out", j("pipe.csv")]),
    ("identify | true", ["identify", corpus("clean.csv"), "--quiet"]),
    ("diagnose | true", ["diagnose", base]),
]:
    code, _, err, _ = run(args, close_stdout=True)
    case(2, name, code != 0 or "panicked" in err, f"exit {code} {first(err)}")

# 3. NaN from parameters inside their bounds; metrics of a very short run.
for b in ["5e5", "1e7"]:
    code, out, err, _ = run(["simulate", "--set", f"b={b}", "--out", j("b.csv")])
    nan = code == 0 and re.search(r"\bNaN\b|\binf\b", open(j("b.csv")).read() + out, re.I)
    case(3, f"simulate --set b={b}", code != 0 or bool(nan), f"exit {code}, NaN/inf in output: {bool(nan)} {first(out)}")
code, out, err, _ = run(["simulate", "--duration", "0.001", "--out", j("short.csv")])
case(3, "simulate --duration 0.001", bool(re.search(r"NaN|inf", out)), first(out.splitlines()[1] if out.count("\n") > 1 else out))

# 4. Broken sensors judged adequate; a gap interpolated across.
faults = {
    "p sign flipped": set_col("p", lambda k, v: -v),
    "x sign flipped": set_col("x", lambda k, v: -v),
    "Q1 negative": set_col("Q1", lambda k, v: -v),
    "x stuck at 0": set_col("x", lambda k, v: 0.0),
    "one p sample of 1e10 Pa": set_col("p", lambda k, v: 1e10 if k == 300 else v),
}
for name, edit in faults.items():
    rec = edited(base, re.sub(r"\W", "_", name) + ".csv", edit)
    code, v = verdict(["diagnose", rec, "--json", j("f.json")])
    bad = code == 0
    if "1e10" in name:
        _, out, _, _ = run(["diagnose", rec, "--json", j("f.json")])
        bad = "spike" not in out
        v = f"{v}; spike named: {not bad}"
    case(4, f"diagnose, {name}", bad, f"exit {code} {v}")


def gap(names, rows):
    return [r if k < 400 else [f"{float(r[0]) + 5.0:.2f}"] + r[1:] for k, r in enumerate(rows) if k < 400 or k >= 410]


rec = edited(base, "gap.csv", gap)
code, out, err, _ = run(["diagnose", rec, "--json", j("g.json")])
case(4, "diagnose, a 5 s logging gap", code == 0 and "gap" not in out, f"exit {code} {first(err) or 'gap named: ' + str('gap' in out)}")
for name in ["p_sign_flipped.csv", "x_stuck_at_zero.csv", "q1_negative.csv"]:
    code, out, err, _ = run(["identify", corpus(name), "--quiet"])
    case(4, f"identify {name}", code == 0, f"exit {code} {first(err) or 'fitted'}")

# 5. The input destroyed.
for name, args in [
    ("diagnose REC --json REC", lambda r: ["diagnose", r, "--json", r]),
    ("diagnose REC --params-out REC", lambda r: ["diagnose", r, "--params-out", r]),
    ("identify REC --json REC", lambda r: ["identify", r, "--quiet", "--json", r]),
]:
    rec = j("same.csv")
    shutil.copy(base, rec)
    before = open(rec).read()
    code, _, err, _ = run(args(rec))
    case(5, name, open(rec).read() != before, f"exit {code} {first(err)}")
open(j("P.toml"), "w").write("beta_e = 1.1e9\n")
code, _, err, _ = run(["simulate", "--params", j("P.toml"), "--out", j("P.toml")])
case(5, "simulate --params P --out P", open(j("P.toml")).read() != "beta_e = 1.1e9\n", f"exit {code} {first(err)}")

# 6. Output problems found only after the work.
open(j("existing"), "w").write("x")
code, _, err, _ = run(["diagnose", base, "--json", j("r.json"), "--report", j("existing")])
case(6, "diagnose --report EXISTING_FILE", os.path.exists(j("r.json")), f"exit {code}, JSON written first: {os.path.exists(j('r.json'))}")
code, out, err, _ = run(["identify", corpus("clean.csv"), "--json", "/proc/version/fit.json"])
case(6, "identify --json in an unwritable folder", bool(out.strip()), f"exit {code}, fitted first: {bool(out.strip())}")

# 7. Unbounded memory.
code, _, err, rss = run(["diagnose", "/dev/zero"], timeout=10, limit_kb=2_000_000)
case(7, "diagnose /dev/zero", code != 1 or rss > 100_000, f"exit {code}, {rss // 1024} MB, {first(err)}")
code, out, err, rss = run(["simulate", "--duration", "10000", "--out", "/dev/null"], timeout=300)
case(7, "simulate --duration 10000 --out /dev/null", code != 0 or rss > 100_000, f"exit {code}, peak RSS {rss // 1024} MB {first(err)}")
code, out, err, rss = run(["simulate", "--duration", "100000", "--out", "/dev/null"], timeout=30, limit_kb=500_000)
case(7, "simulate --duration 100000 in 500 MB of address space (first 30 s)", code not in (0, 1, "timeout"), f"exit {code} {first(err)}")

# 8. The reader: quotes, Excel artefacts, text columns, line endings, decimal commas.
for name in ["quoted_cells.csv", "trailing_comma_rows.csv", "trailing_line_of_commas.csv", "extra_text_column.csv", "cr_only.csv", "crlf_bom.csv"]:
    code, _, err, _ = run(["identify", corpus(name), "--quiet"])
    case(8, f"identify {name}", code != 0, f"exit {code} {first(err)}")
for name in ["german_excel.csv", "quoted_decimal_comma.csv"]:
    code, _, err, _ = run(["identify", corpus(name), "--quiet"])
    case(8, f"identify {name}", "decimal comma" not in err, f"exit {code} {first(err)}")

# 9. Misleading messages.
open(j("s3.toml"), "w").write("scheme = 3\n")
for name, args, want in [
    ("--v-ref -0.05", ["simulate", "--v-ref", "-0.05", "--duration", "1", "--out", j("n.csv")], None),
    ("--set beta_e=NaN", ["simulate", "--set", "beta_e=NaN", "--out", j("n.csv")], "NaN is not"),
    ("scheme = 3", ["simulate", "--params", j("s3.toml"), "--out", j("n.csv")], "number 3"),
    ("x in cm", ["identify", corpus("x_in_cm.csv"), "--quiet"], "like cm"),
    ("a single x glitch of 1e10", ["identify", corpus("x_glitch_1e10.csv"), "--quiet"], None),
    ("a NUL byte", ["identify", corpus("nul_byte.csv"), "--quiet"], "NUL"),
    ("a Latin-1 comment", ["identify", corpus("latin1_comment.csv"), "--quiet"], "line 2"),
]:
    code, _, err, _ = run(args)
    bad = code != 0 if want is None else want not in err
    case(9, name, bad, f"exit {code} {first(err)}")

# 10. identify and diagnose disagree; silent choices between two settings.
def without_f_l(path):
    """`path` with its F_L column replaced by the metadata line `# F_L = notanumber`."""
    lines = open(path).read().splitlines()
    h = next(i for i, l in enumerate(lines) if l.startswith("time"))
    k = lines[h].split(",").index("F_L")
    rows = [",".join(c for i, c in enumerate(l.split(",")) if i != k) for l in lines[h:]]
    out = j("f_l_notanumber.csv")
    open(out, "w").write("\n".join(["# F_L = notanumber"] + lines[:h] + rows) + "\n")
    return out


for name, rec in [
    ("# F_L = notanumber", without_f_l(base)),
    ("all signals constant", edited(base, "constant.csv", lambda names, rows: [[r[0]] + rows[0][1:] for r in rows])),
]:
    a, _, ea, _ = run(["identify", rec, "--quiet"])
    b, _, eb, _ = run(["diagnose", rec, "--json", j("d.json")])
    case(10, f"identify vs diagnose, {name}", (a == 0) != (b == 0), f"identify exit {a}, diagnose exit {b} {first(ea) or first(eb)}")
code, _, err, _ = run(["simulate", "--scheme", "single", "--set", "scheme=adaptive", "--duration", "1", "--out", j("n.csv")])
case(10, "--scheme single --set scheme=adaptive", code == 0, f"exit {code} {first(err)}")
open(j("t.toml"), "w").write("beta_e = 1.1e9\n[params]\nbeta_e = 1.5e9\n")
code, _, err, _ = run(["simulate", "--params", j("t.toml"), "--duration", "1", "--out", j("n.csv")])
case(10, "[params] beta_e after a top-level beta_e", code == 0, f"exit {code} {first(err)}")

# 11. generate without bounds (diagnose's speed is `cargo bench`, its progress a terminal matter).
code, _, err, _ = run(["generate", "--substeps", "100000", "--out", j("gen")], timeout=10)
case(11, "generate --substeps 100000", code != 1, f"exit {code} {first(err)}")

shutil.rmtree(WORK, ignore_errors=True)
bad = [r for r in RESULTS if r[2]]
print(f"{len(RESULTS)} cases, {len(bad)} bad")
sys.exit(1 if bad else 0)
