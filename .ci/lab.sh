#!/usr/bin/env bash
# The lab bench (issue 31): gonio-lab's tests, `gonio acquire` against an emulated autocollimator
# on a pseudo-terminal (python3), the operator view under tmux, and `gonio import elcomat`.
# Runs from the repository root; installs what is missing; idempotent.
set -euo pipefail
cd "$(dirname "$0")/.."

need=()
command -v python3 >/dev/null || need+=(python3)
command -v tmux >/dev/null || need+=(tmux)
command -v socat >/dev/null || need+=(socat)
if [ ${#need[@]} -gt 0 ]; then
    echo "== installing ${need[*]}"
    SUDO=""
    [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1 && SUDO="sudo"
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}"
fi

echo "== lab: clippy"
cargo clippy --release -p gonio-lab --all-targets -- -D warnings
echo "== lab: tests"
cargo test --release -p gonio-lab
cargo test --release -p gonio --test acquire_cli --test import_elcomat_cli --test fuzz_regressions
