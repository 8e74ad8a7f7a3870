#!/usr/bin/env bash
# Install what the tests need beyond Rust: the pinned Python venv in tools/.venv (Mitsuba 3,
# OpenImageIO, OpenCV, NumPy, FLIP) and Debian's libllvm19 for Mitsuba's llvm variants.
# Idempotent: a second run only checks.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
venv="$here/.venv"
stamp="$venv/.requirements"
if [[ ! -x "$venv/bin/python" ]] || ! cmp -s "$here/requirements.txt" "$stamp"; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --upgrade pip
  "$venv/bin/pip" install --quiet -r "$here/requirements.txt"
  cp "$here/requirements.txt" "$stamp"
fi
if ! ldconfig -p 2>/dev/null | grep -q 'libLLVM.so.19\|libLLVM-19'; then
  if command -v apt-get >/dev/null && [[ $(id -u) == 0 ]]; then
    (apt-get install -y -qq libllvm19 >/dev/null 2>&1) || (apt-get update -qq >/dev/null 2>&1 && apt-get install -y -qq libllvm19 >/dev/null 2>&1) \
      || echo "tools/setup.sh: warning: libllvm19 not installed; Mitsuba's llvm variants are unavailable (scalar_rgb still works)" >&2
  fi
fi
"$venv/bin/python" -c "import mitsuba, OpenImageIO, cv2, numpy, flip_evaluator" \
  || { echo "tools/setup.sh: the Python tools did not import" >&2; exit 1; }
