#!/usr/bin/env bash
# The whole calibration pipeline on the digital twin; prints where each output is.
set -euo pipefail
OUT=${OUT:-out/demo}
PY=${PY:-python3}
mkdir -p "$OUT"
wc() { "$PY" -m whiskercal "$@"; }

echo "== twin validation"
wc twin validate
