#!/usr/bin/env bash
# Run each fuzz target for SECONDS (default 600), one at a time on one core, starting from the
# committed seeds in fuzz/seeds/TARGET; the growing corpus goes to fuzz/corpus/TARGET (ignored)
# and crashes to fuzz/artifacts/TARGET. Needs cargo-fuzz; the stable toolchain works with
# RUSTC_BOOTSTRAP=1. Usage: bash fuzz/run.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")"
secs=${1:-600}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(scene_json obj exr_aov scene_xml ply)
export RUSTC_BOOTSTRAP=1
# nv-flip's bundled C++ (tinyexr, miniz) defines one global twice; that is its build, not ours.
export ASAN_OPTIONS=detect_odr_violation=0
cargo fuzz build -O
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t" "artifacts/$t"
  echo "== $t: ${secs} s"
  # The binary itself, not `cargo fuzz run`, so that later edits do not trigger rebuilds.
  "target/x86_64-unknown-linux-gnu/release/$t" "corpus/$t" "seeds/$t" -jobs=1 -workers=1 \
    -max_total_time="$secs" -rss_limit_mb=4096 -timeout=30 -max_len=16384 \
    -artifact_prefix="artifacts/$t/" -print_final_stats=1 || echo "== $t: stopped with a finding (see artifacts/$t)"
done
