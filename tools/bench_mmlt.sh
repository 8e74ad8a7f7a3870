#!/usr/bin/env bash
# MMLT mutations per second against BPT samples per second, and MMLT's acceptance rate, on the
# 64² twins of the test and paper scenes: median of 3 runs, both methods in the same run of this
# script (compare the ratio: absolute rates depend on the machine's load). MMLT's time is its
# chains' time from the header (`mixmc.chain_seconds`: no bootstrap, no estimate of b); BPT's
# from its header. Usage: tools/bench_mmlt.sh [threads]
set -euo pipefail
cd "$(dirname "$0")/.."
threads=${1:-1}
cargo build --release -q
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
py=tools/.venv/bin/python
attr() { "$py" -c "import OpenImageIO as o, sys; s = o.ImageBuf(sys.argv[1]).spec(); print(s.get_float_attribute(sys.argv[2]))" "$1" "$2"; }
printf '| scene | BPT M samples/s | MMLT M mutations/s | mutations per BPT sample | acceptance |\n|---|---:|---:|---:|---:|\n'
for name in cornell-box caustic cornell-torus cornell-water room bathroom; do
  scene="fixtures/scenes/$name-tiny.json"
  bpt=() mmlt=() acc=()
  for run in 1 2 3; do
    target/release/mixmc-omc "$scene" -o "$tmp/b.exr" --method bpt --spp 16 --seed "$run" --threads "$threads" -q > /dev/null
    bpt+=("$("$py" -c "print(64 * 64 * 16 / $(attr "$tmp/b.exr" mixmc.seconds) / 1e6)")")
    target/release/mixmc-mmlt "$scene" -o "$tmp/m.exr" --mutations-per-pixel 64 --seed "$run" --threads "$threads" -q > /dev/null
    mmlt+=("$("$py" -c "print(64 * 64 * 64 / $(attr "$tmp/m.exr" mixmc.chain_seconds) / 1e6)")")
    acc+=("$(attr "$tmp/m.exr" mixmc.acceptance)")
  done
  med() { printf '%s\n' "$@" | sort -g | sed -n 2p; }
  b=$(med "${bpt[@]}") m=$(med "${mmlt[@]}") a=$(med "${acc[@]}")
  "$py" -c "print(f'| $name | {$b:.3f} | {$m:.3f} | {$m / $b:.1f} | {$a:.3f} |')"
done
