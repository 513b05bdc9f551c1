#!/usr/bin/env bash
# CI for gonio's Python module: a virtualenv (target/py-venv) with maturin, pytest, numpy and GTC,
# `pip install .` (maturin builds crates/gonio-py in release), the CLI the tests compare against
# (target/release/gonio), then pytest (python/tests). Idempotent; run from anywhere.
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON:-python3}
if ! command -v "$PY" >/dev/null 2>&1 || ! "$PY" -c 'import venv, ensurepip' >/dev/null 2>&1; then
    echo "== installing python3, python3-venv"
    SUDO=""
    [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1 && SUDO="sudo"
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        python3 python3-venv python3-pip python3-dev
    PY=python3
fi

VENV=target/py-venv
if [ ! -x "$VENV/bin/python" ]; then
    echo "== virtualenv $VENV"
    "$PY" -m venv "$VENV"
fi
# The build backend (maturin, without build isolation) is found on PATH.
export PATH="$PWD/$VENV/bin:$PATH"
echo "== pip install maturin pytest numpy GTC"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.9.4,<2" pytest numpy GTC

# Built with gonio-py in one command: the features of the crates both use are then those
# of the wheel build below, which reuses every artifact but the module itself.
echo "== the CLI the tests compare against (cargo build --release -p gonio -p gonio-py)"
cargo build --release -p gonio -p gonio-py

echo "== pip install . (maturin, release)"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check --no-build-isolation \
    --force-reinstall --no-deps .

echo "== pytest python/tests"
# pytest exits with 5 when no test ran: that fails this script too.
PYTHONDONTWRITEBYTECODE=1 GONIO_BIN="$PWD/target/release/gonio" "$VENV/bin/python" -m pytest -p no:cacheprovider -q python/tests
