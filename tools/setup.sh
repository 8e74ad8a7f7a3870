#!/usr/bin/env bash
# Install what the tests need beyond Rust: the pinned Python venv in tools/.venv (Mitsuba 3,
# OpenImageIO, OpenCV, NumPy, FLIP; Snakemake and its Slurm executors for workflow/), Debian's
# libllvm19 for Mitsuba's llvm variants, and Debian's Slurm and munge for the single-node test
# cluster of tests/cluster.rs (tools/slurm_cluster.sh; installing starts no service).
# Idempotent: a second run only checks.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
venv="$here/.venv"
stamp="$venv/.requirements"
requirements=("$here/requirements.txt" "$here/requirements-workflow.txt")
if [[ ! -x "$venv/bin/python" ]] || ! cmp -s <(cat "${requirements[@]}") "$stamp"; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --upgrade pip
  "$venv/bin/pip" install --quiet -r "$here/requirements.txt" -r "$here/requirements-workflow.txt"
  cat "${requirements[@]}" >"$stamp"
fi
if ! ldconfig -p 2>/dev/null | grep -q 'libLLVM.so.19\|libLLVM-19'; then
  if command -v apt-get >/dev/null && [[ $(id -u) == 0 ]]; then
    (apt-get install -y -qq libllvm19 >/dev/null 2>&1) || (apt-get update -qq >/dev/null 2>&1 && apt-get install -y -qq libllvm19 >/dev/null 2>&1) \
      || echo "tools/setup.sh: warning: libllvm19 not installed; Mitsuba's llvm variants are unavailable (scalar_rgb still works)" >&2
  fi
fi
slurm=(slurmctld slurmd slurm-client munge)
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v sbatch >/dev/null \
  || ! command -v munged >/dev/null; then
  if command -v apt-get >/dev/null && [[ $(id -u) == 0 ]]; then
    apt=(apt-get install -y -qq --no-install-recommends "${slurm[@]}")
    ("${apt[@]}" >/dev/null 2>&1) || (apt-get update -qq >/dev/null 2>&1 && "${apt[@]}" >/dev/null 2>&1) \
      || { echo "tools/setup.sh: cannot install ${slurm[*]} (tests/cluster.rs needs them)" >&2; exit 1; }
  else
    echo "tools/setup.sh: warning: ${slurm[*]} are missing and need root to install; tests/cluster.rs will fail" >&2
  fi
fi
"$venv/bin/snakemake" --version >/dev/null \
  || { echo "tools/setup.sh: snakemake does not run" >&2; exit 1; }
"$venv/bin/python" -c "import mitsuba, OpenImageIO, cv2, numpy, flip_evaluator" \
  || { echo "tools/setup.sh: the Python tools did not import" >&2; exit 1; }
