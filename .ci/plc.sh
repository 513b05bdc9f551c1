#!/usr/bin/env bash
# The station over Modbus TCP (issue 28): the gonio-plc crate's tests (the simulated PLC on
# 127.0.0.1 port 0: a mount through the wire and every fault), and pymodbus driving
# `gonio simulate station` through the documented registers, from its own virtualenv.
# With GenICam (libaravis) present, the two-process mount through the PLC and the GigE camera.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v python3 >/dev/null || ! python3 -c 'import venv, ensurepip' 2>/dev/null; then
    apt-get update -q && apt-get install -y -q python3 python3-venv
fi
venv=target/plc-venv
if ! "$venv/bin/python" -c 'import pymodbus' 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet 'pymodbus>=3.10,<4'
fi

cargo clippy --release -p gonio-plc --all-targets -- -D warnings
cargo test --release -p gonio-plc
cargo test --release -p gonio --test plc_pymodbus

if pkg-config --exists aravis-0.8 2>/dev/null && [ -d crates/gonio-camera ]; then
    cargo test --release -p gonio --features genicam --test plc_station_cli
fi
