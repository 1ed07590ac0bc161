"""`make demo`'s script runs the whole pipeline on the twin (here its reduced size)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from whiskercal import runtime

ROOT = Path(__file__).resolve().parents[1]
# Only a hang must end the test: the small demo takes about 30 s alone, and a machine busy with
# the rest of the suite (or a fresh checkout compiling the twin's numba kernels) runs it slower.
DEMO_TIMEOUT_S = 600


@pytest.mark.slow
def test_small_demo_runs_every_stage_and_leaves_a_loadable_artifact(tmp_path):
    env = {**os.environ, "OUT": str(tmp_path), "PY": sys.executable, "DEMO_SIZE": "small",
           "CI": "1"}
    done = subprocess.run(["bash", str(ROOT / "scripts" / "demo.sh")], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=DEMO_TIMEOUT_S)
    assert done.returncode == 0, done.stderr[-2000:]
    outputs = ["raw_grid.h5", "calibration.h5", "plane_study.h5", "calibration-target.h5",
               "report.html", "study/errors.png", "contour-cylinder.h5", "contour/contour.png"]
    for name in outputs:
        assert (tmp_path / name).is_file(), name
        assert str(tmp_path / name.split("/")[0]) in done.stdout
    final = runtime.load(tmp_path / "calibration-target.h5")
    assert final.target_z_uT is not None
    assert f"target z {final.target_z_uT:.0f} µT" in done.stdout
    assert done.stdout.count(" µT -> tip (") == 6  # five lookup values and the target's tip
    # what each step printed is kept for the tutorial's example outputs (docs/walkthrough.md)
    for name in ("collect-dry-run", "collect", "fit", "study-report", "report", "runtime"):
        assert (tmp_path / "transcript" / f"{name}.txt").read_text().strip(), name
    assert f"target z {final.target_z_uT:.0f} µT" in (tmp_path / "transcript" / "runtime.txt").read_text()
