#!/usr/bin/env bash
# Samples per second of each OMC method on the Cornell box (256², max_depth 8) and the caustic
# scene (128²): median of 3 runs, time from the EXR header (rendering only, no scene load).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
bin=target/release/mixmc-omc
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '| scene | method | spp | median seconds | M samples/s | relative to PT |\n|---|---|---:|---:|---:|---:|\n'
for scene in cornell-box:256:8 caustic:128:32; do
  IFS=: read -r name res spp <<< "$scene"
  pt_rate=""
  for method in pt lt ibpt bpt; do
    secs=()
    for run in 1 2 3; do
      "$bin" "fixtures/scenes/$name.json" -o "$tmp/x.exr" --method "$method" --spp "$spp" --seed "$run" -q > "$tmp/out.txt"
      secs+=("$(sed -E 's/.* spp in ([0-9.]+) s.*/\1/' "$tmp/out.txt")")
    done
    med=$(printf '%s\n' "${secs[@]}" | sort -g | sed -n 2p)
    rate=$(python3 -c "print(f'{$res*$res*$spp/$med/1e6:.3f}')")
    [[ -z $pt_rate ]] && pt_rate=$rate
    rel=$(python3 -c "print(f'{$rate/$pt_rate:.2f}')")
    printf '| %s | %s | %s | %s | %s | %s |\n' "$name" "$method" "$spp" "$med" "$rate" "$rel"
  done
done
