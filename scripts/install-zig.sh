#!/usr/bin/env bash
# Installs what the portable Linux FMU binary is built with (fmu-package/build.rs links it
# against glibc 2.17 through `cargo zigbuild`):
#   - cargo-zigbuild from crates.io (pinned, --locked) into cargo's bin directory;
#   - zig as the `ziglang` wheel from PyPI (pinned) in its own venv, .tools/zig, which the
#     build script finds by itself.
# Idempotent: a second run only checks. Called by scripts/test.sh and scripts/setup-and-run.sh.
#
#   PYTHON=python3.11   interpreter used to create .tools/zig (default: python3.11, python3)
set -euo pipefail

CARGO_ZIGBUILD_VERSION=0.24.1
ZIGLANG_VERSION=0.15.2

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TOOLS="$ROOT/.tools/zig"
STAMP="$TOOLS/ziglang.installed"

if ! cargo install --list | grep -q "^cargo-zigbuild v$CARGO_ZIGBUILD_VERSION:"; then
    echo "==> cargo install cargo-zigbuild --version $CARGO_ZIGBUILD_VERSION --locked"
    cargo install cargo-zigbuild --version "$CARGO_ZIGBUILD_VERSION" --locked
fi

if [ "$(cat "$STAMP" 2>/dev/null)" != "ziglang==$ZIGLANG_VERSION" ]; then
    PY="${PYTHON:-}"
    if [ -z "$PY" ]; then
        for c in python3.11 python3; do
            command -v "$c" >/dev/null && { PY="$c"; break; }
        done
    fi
    [ -n "$PY" ] || { echo "error: no python3 to install the ziglang wheel with (set PYTHON=...)" >&2; exit 1; }
    echo "==> ziglang==$ZIGLANG_VERSION into .tools/zig"
    rm -rf "$TOOLS"
    "$PY" -m venv "$TOOLS" || {
        echo "error: $PY -m venv failed; install python3-venv (Debian) and rerun" >&2
        exit 1
    }
    "$TOOLS/bin/python" -m pip install --quiet --disable-pip-version-check "ziglang==$ZIGLANG_VERSION"
    "$TOOLS/bin/python" -m ziglang version >/dev/null
    echo "ziglang==$ZIGLANG_VERSION" > "$STAMP"
fi
echo "$(cargo-zigbuild --version), zig $("$TOOLS/bin/python" -m ziglang version)"
