#!/usr/bin/env bash
# THE test command of the project (README "Two commands"; CI runs it through .ci/run).
#
# On a fresh Debian machine with rustup/cargo and Python 3.11 it installs what it needs
# (idempotent: a second run only checks), then runs, and fails on the first failure:
#   1. cargo fmt --all -- --check
#   2. cargo clippy --workspace --all-targets -- -D warnings
#   3. cargo build --release              (also packages target/fmu/TbmThrust.fmu)
#   4. cargo test --workspace --release
#   5. pytest fmu-tests                   (in .venv, from fmu-tests/requirements.txt)
#
# Environment:
#   PYTHON=python3.11      interpreter used to create .venv
#   SKIP_APT=1             never call apt-get (report missing packages instead)
#   PYTEST_ARGS="-k cosim" extra pytest arguments
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

# ---- Debian packages the build and the tests need --------------------------------------------
#   fonts-dejavu-core : a TrueType font for the plots the CLI draws (plotters/ab_glyph)
#   libclang-dev      : bindgen in fmi-sim, the second, independent FMU importer of the tests
#   python3-venv      : only if `python -m venv` lacks ensurepip (Debian's own python3.11)
#   binutils          : objdump / nm, which tests/fmu_package.rs reads the FMU binary with
APT_PACKAGES=(fonts-dejavu-core libclang-dev binutils)
# The second importer (tests/fmi_sim.rs), pinned; about 5 minutes to build on 2 cores.
FMI_SIM_VERSION=0.7.0
# ------------------------------------------------------------------------------------------

log() { printf '\n==> %s\n' "$*"; }
started=$(date +%s)
step_time() { printf '    (%ss since start)\n' "$(( $(date +%s) - started ))"; }

APT_UPDATED=0
apt_install() {
    local missing=()
    for p in "$@"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    if [ "${SKIP_APT:-0}" = 1 ] || ! command -v apt-get >/dev/null; then
        echo "warning: missing Debian packages (not installed, SKIP_APT or no apt-get): ${missing[*]}" >&2
        return 0
    fi
    local sudo=""
    [ "$(id -u)" -ne 0 ] && sudo="sudo"
    log "apt-get install ${missing[*]}"
    if [ $APT_UPDATED = 0 ]; then
        $sudo apt-get update -qq
        APT_UPDATED=1
    fi
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# ---- 0. toolchain and environment -----------------------------------------------------------
log "environment"
apt_install "${APT_PACKAGES[@]}"
command -v cargo >/dev/null || { echo "error: cargo not found (install rustup)" >&2; exit 1; }
for comp in rustfmt clippy; do
    if ! cargo "${comp/rustfmt/fmt}" --version >/dev/null 2>&1; then
        command -v rustup >/dev/null && rustup component add "$comp"
    fi
done
cargo --version
if ! cargo install --list | grep -q "^fmi-sim v$FMI_SIM_VERSION:"; then
    log "cargo install fmi-sim --version $FMI_SIM_VERSION"
    cargo install fmi-sim --version "$FMI_SIM_VERSION" --locked
fi

PYTHON="${PYTHON:-}"
if [ -z "$PYTHON" ]; then
    for c in python3.11 python3; do
        if command -v "$c" >/dev/null && "$c" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
            PYTHON="$c"
            break
        fi
    done
fi
[ -n "$PYTHON" ] || { echo "error: Python >= 3.11 not found (set PYTHON=...)" >&2; exit 1; }

VENV="$ROOT/.venv"
REQ="$ROOT/fmu-tests/requirements.txt"
STAMP="$VENV/.requirements.sha256"
want=$( (sha256sum "$REQ"; "$PYTHON" --version) | sha256sum | cut -d' ' -f1)
if [ ! -x "$VENV/bin/python" ] || [ "$(cat "$STAMP" 2>/dev/null)" != "$want" ]; then
    log "creating .venv from fmu-tests/requirements.txt with $PYTHON"
    rm -rf "$VENV"
    if ! "$PYTHON" -m venv "$VENV" 2>/dev/null; then
        rm -rf "$VENV"
        apt_install python3-venv "python3.$("$PYTHON" -c 'import sys; print(sys.version_info[1])')-venv"
        "$PYTHON" -m venv "$VENV"
    fi
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade pip
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$REQ"
    echo "$want" > "$STAMP"
fi
"$VENV/bin/python" --version

# The portable Linux FMU binary (glibc 2.17) is linked by cargo-zigbuild with zig from PyPI;
# here it must be that build, not the native fallback (fmu-package/build.rs).
PYTHON="$PYTHON" bash "$ROOT/scripts/install-zig.sh"
export TBM_FMU_LINUX_BUILD=zigbuild
step_time

# ---- 1-4. Rust ------------------------------------------------------------------------------
log "cargo fmt --all -- --check"
cargo fmt --all -- --check
log "cargo clippy --workspace --all-targets -- -D warnings"
cargo clippy --workspace --all-targets -- -D warnings
step_time
log "cargo build --release"
cargo build --release
[ -f target/fmu/TbmThrust.fmu ] || { echo "error: cargo build --release did not produce target/fmu/TbmThrust.fmu" >&2; exit 1; }
step_time
log "cargo test --workspace --release"
cargo test --workspace --release
step_time

# ---- 5. FMU tests (pytest + fmpy) -----------------------------------------------------------
log "pytest fmu-tests"
set +e
TBM_NO_BUILD=1 "$VENV/bin/python" -m pytest fmu-tests ${PYTEST_ARGS:-}
rc=$?
set -e
if [ $rc -eq 5 ]; then
    echo "error: pytest collected no tests (exit 5); that is a failure here" >&2
    exit 1
fi
step_time
exit $rc
