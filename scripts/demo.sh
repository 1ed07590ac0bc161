#!/usr/bin/env bash
# The whole calibration pipeline on the digital twin, as on a real rig but with sim:// ports:
# collect the grid, fit it, run and report the flat-plane study, write the HTML report, and load
# the final artifact with whiskercal.runtime. Prints where each output is.
#
#   make demo                        # OUT=out/demo, the full pipeline (about 2 minutes on 2 cores)
#   OUT=/tmp/d PY=.venv/bin/python DEMO_SIZE=small bash scripts/demo.sh
#
# DEMO_SIZE=small runs a reduced grid (5 mm lattice) and a three-depth study with short slides:
# the same steps in about a minute, for tests.
set -euo pipefail
OUT=${OUT:-out/demo}
PY=${PY:-python3}
DEMO_SIZE=${DEMO_SIZE:-full}
SEED=${SEED:-1}
mkdir -p "$OUT"
wcal() { "$PY" -m whiskercal "$@"; }
started=$(date +%s)
step() { echo; echo "== $1 ($(( $(date +%s) - started )) s)"; }
# What each step prints is also kept in $OUT/transcript/NAME.txt: the tutorial's example outputs
# (docs/walkthrough.md) are these, copied by `python scripts/docs_figures.py transcript $OUT`.
TRANSCRIPT="$OUT/transcript"
keep() { local name=$1; shift; "$@" | tee "$TRANSCRIPT/$name.txt"; }

RAW="$OUT/raw_grid.h5"
CAL="$OUT/calibration.h5"
FIT_LOG="$OUT/fit.log"
STUDY="$OUT/plane_study.h5"
STUDY_DIR="$OUT/study"
FINAL="$OUT/calibration-target.h5"
HTML="$OUT/report.html"
CONTOUR="$OUT/contour-cylinder.h5"
CONTOUR_DIR="$OUT/contour"
CONTOUR_S=90
# The demo owns these outputs: a rerun starts them afresh (collect never overwrites a dataset).
rm -rf "$RAW" "$RAW.journal" "$CAL" "$FIT_LOG" "$STUDY" "$STUDY.partial" "$STUDY_DIR" "$FINAL" "$HTML" \
    "$CONTOUR" "$CONTOUR_DIR" "$TRANSCRIPT"
mkdir -p "$TRANSCRIPT"

collect_config=()
study_config=()
if [ "$DEMO_SIZE" = small ]; then
    cat > "$OUT/collect-small.toml" <<'EOF'
# A reduced grid for a quick run: the default bands on a 5 mm lattice (69 points; a 6 mm
# lattice ends too far short of the tip for fit's extrapolation limit).
[grid]
step_mm = 5.0
expected_points = 0
EOF
    cat > "$OUT/study-small.toml" <<'EOF'
# A reduced study for a quick run: three depths, 20 mm slides.
[trials]
depths_mm = [10.0, 20.0, 30.0]
travel_mm = 20.0
slide_start_mm = -10.0
EOF
    collect_config=(--config "$OUT/collect-small.toml")
    CONTOUR_S=20
    study_config=(--config "$OUT/study-small.toml")
fi

step "0/7 check the twin's mechanics against independent references"
wcal twin validate

step "1/7 collect the calibration grid (sim:// stage and sensor)"
keep collect-dry-run wcal collect --dry-run "${collect_config[@]}"
keep collect wcal collect --stage "sim://demo_grid/stage?seed=$SEED" --sensor sim://demo_grid/sensor \
    --out "$RAW" "${collect_config[@]}"

# The fit (the surface, both tip models and the (Y, Z) table: most of a minute) and the study's
# run need nothing of each other: the fit runs beside the study, its output shown when done.
step "2/7 fit the surface and the tip models, build the lookup and the (Y, Z) table (beside 3/7)"
wcal fit "$RAW" --out "$CAL" > "$FIT_LOG" 2>&1 &
fit_pid=$!
trap 'kill "$fit_pid" 2>/dev/null' EXIT  # a failed study run leaves no fit running

step "3/7 run the flat-plane study"
wcal optimal-depth run --stage "sim://demo_study/stage?scene=plane&seed=$((SEED + 1))" \
    --sensor sim://demo_study/sensor --out "$STUDY" "${study_config[@]}"
if ! wait "$fit_pid"; then cat "$FIT_LOG" >&2; exit 1; fi
trap - EXIT
step "2/7 the fit, done"
cat "$FIT_LOG"
cp "$FIT_LOG" "$TRANSCRIPT/fit.txt"

step "4/7 report the study and choose the deflection target"
keep study-report wcal optimal-depth report "$STUDY" --artifact "$CAL" --out "$STUDY_DIR" \
    --out-artifact "$FINAL"

step "5/7 write the HTML report"
keep report wcal report "$FINAL" --raw "$RAW" --study "$STUDY" --out "$HTML"

step "6/7 load the final artifact as a robot does (whiskercal.runtime)"
keep runtime "$PY" - "$FINAL" <<'EOF'
import sys

import numpy as np

from whiskercal import runtime

calibration = runtime.load(sys.argv[1])
low, high = calibration.z_range_uT
print(f"calibrated z range {low:.0f} .. {high:.0f} µT")
for z in np.linspace(low, high, 5):
    x, y = calibration.tip(z)
    print(f"  z {z:8.0f} µT -> tip ({x:6.2f}, {y:6.2f}) mm")
target = calibration.target_z_uT
x, y = calibration.tip(target)
print(f"target z {target:.0f} µT -> tip ({x:.2f}, {y:.2f}) mm")
EOF

step "7/7 follow a cylinder's contour with the final artifact (the paper's closed loop, twin)"
wcal contour run --shape cylinder --artifact "$FINAL" --duration "$CONTOUR_S" --seed "$SEED" \
    --out "$CONTOUR"
wcal contour report "$CONTOUR" --out "$CONTOUR_DIR"

echo
echo "== outputs ($(( $(date +%s) - started )) s in all)"
echo "raw grid           $RAW"
echo "calibration        $CAL"
echo "plane study        $STUDY"
echo "study figures      $STUDY_DIR/"
echo "final artifact     $FINAL   (whiskercal.runtime.load)"
echo "HTML report        $HTML"
echo "contour run        $CONTOUR   (report: $CONTOUR_DIR/contour.html)"
