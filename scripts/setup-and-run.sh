#!/usr/bin/env bash
# One command from a fresh clone to the results: installs what is needed, builds the release
# binary and the FMU, and reproduces the paper into out/.
#
#   bash scripts/setup-and-run.sh            # -> out/ (figures, report, JSON) + target/fmu/TbmThrust.fmu
#
# SKIP_APT=1 never calls apt-get. The Python environment (.venv) is only needed for the FMU
# tests and the Python examples; set WITH_PYTHON=1 to create it here too.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

# ---- Debian packages (same list as scripts/test.sh; the lead finalises it) -------------------
APT_PACKAGES=(fonts-dejavu-core)
# ------------------------------------------------------------------------------------------
missing=()
for p in "${APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ] && [ "${SKIP_APT:-0}" != 1 ] && command -v apt-get >/dev/null; then
    sudo=""; [ "$(id -u)" -ne 0 ] && sudo="sudo"
    echo "==> apt-get install ${missing[*]}"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

command -v cargo >/dev/null || { echo "error: cargo not found (install rustup)" >&2; exit 1; }

# cargo-zigbuild and zig (PyPI wheel), so that the FMU's Linux binary loads on glibc >= 2.17.
bash scripts/install-zig.sh
export TBM_FMU_LINUX_BUILD=zigbuild

echo "==> cargo build --release (binary target/release/tbm-thrust and FMU target/fmu/TbmThrust.fmu)"
cargo build --release
[ -f target/fmu/TbmThrust.fmu ] || { echo "error: target/fmu/TbmThrust.fmu was not built" >&2; exit 1; }

echo "==> tbm-thrust reproduce --out out"
target/release/tbm-thrust reproduce --out out

if [ "${WITH_PYTHON:-0}" = 1 ]; then
    PY="${PYTHON:-python3.11}"
    [ -x .venv/bin/python ] || "$PY" -m venv .venv
    .venv/bin/python -m pip install --quiet --disable-pip-version-check -r fmu-tests/requirements.txt
    .venv/bin/python examples/python/simulate_and_plot.py --out out/examples
fi

echo
echo "done: results in out/, FMU in target/fmu/TbmThrust.fmu"
