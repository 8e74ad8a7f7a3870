#!/usr/bin/env bash
# The whole test suite on a fresh machine: install the Python cross-check tools, then run every
# Rust test (units, whole tools, cross-checks against Mitsuba 3 / OpenCV / FLIP) in release mode.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cargo test --release "$@"
