#!/usr/bin/env bash
# CI for the GenICam camera and the station through its PLC with that camera: installs Aravis when
# missing, then builds, lints and runs the camera tests with `--features genicam` (the workspace
# run ignores them without it, saying so). Every test that starts a GigE Vision camera runs it
# in its own network namespace (`unshare -n`), so this needs root or CAP_SYS_ADMIN (as CI has).
set -euo pipefail
cd "$(dirname "$0")/.."

need=()
pkg-config --exists aravis-0.8 2>/dev/null || need+=(libaravis-dev)
pkg-config --exists libusb-1.0 2>/dev/null || need+=(libusb-1.0-0-dev)
command -v arv-fake-gv-camera-0.8 >/dev/null 2>&1 || need+=(aravis-tools)
command -v pkg-config >/dev/null 2>&1 || need+=(pkg-config)
command -v unshare >/dev/null 2>&1 || need+=(util-linux)
command -v ip >/dev/null 2>&1 || need+=(iproute2)
if [ ${#need[@]} -gt 0 ]; then
    echo "== installing ${need[*]}"
    SUDO=""
    [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1 && SUDO="sudo"
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}"
fi

# The whole workspace with the feature on (`--workspace`): the features of every shared
# dependency are then those of the default build before it, so only Aravis's stack,
# gonio-camera and the CLI are compiled again (gonio-camera's Cargo.toml says how).
echo "== cargo clippy --workspace --features gonio/genicam"
cargo clippy --release --workspace --all-targets --features gonio/genicam -- -D warnings
echo "== camera tests (--features genicam): Aravis's fake camera, gonio's, and the station as two processes"
cargo test --release --workspace --features gonio/genicam \
    --test aravis_fake --test fake_gv_camera --test camera --test plc_station_cli
