"""kill -9 at random moments while a figure, a report and an artifact are being rewritten: each
file is afterwards the old complete version or the new complete one, never a partial one."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
CALIBRATION = ROOT / "tests" / "fixtures" / "calibration-1.0.0.h5"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PNG_END = b"IEND\xaeB`\x82"
HTML_END = "</html>\n"
KILLS = 6

# Rewrites the three files in turn, forever; prints "cycle" after each full round. The figure is
# large and the page long so that a good part of each round is spent inside a write.
WRITER = """
import sys
from pathlib import Path
from whiskercal import atomic
from whiskercal.artifacts.calibration import read_calibration, write_calibration
from whiskercal.plotting import pyplot, save_png

out, calibration = Path(sys.argv[1]), read_calibration(sys.argv[2])
plt = pyplot()
page = "<html>" + "<p>line of the report</p>" * 400_000 + "</html>\\n"
while True:
    fig, ax = plt.subplots(figsize=(16, 12))
    ax.plot(range(20_000), [i % 97 for i in range(20_000)])
    save_png(fig, out / "figure.png", dpi=150)
    atomic.write_text(out / "report.html", page)
    write_calibration(out / "cal.h5", calibration)
    print("cycle", flush=True)
"""


def _start(out: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-c", WRITER, str(out), str(CALIBRATION)],
                            stdout=subprocess.PIPE, text=True, env=env)


def _check_complete(out: Path) -> None:
    png = (out / "figure.png").read_bytes()
    assert png.startswith(PNG_SIGNATURE) and png.endswith(PNG_END), f"torn PNG, {len(png)} bytes"
    assert (out / "report.html").read_text(encoding="utf-8").endswith(HTML_END), "torn report"
    with h5py.File(out / "cal.h5", "r") as handle:
        assert handle["lookup/z_uT"].shape[0] > 1
        assert handle.attrs["schema"] == "whiskercal.calibration"


@pytest.mark.slow
def test_kill_9_at_random_moments_leaves_every_file_whole(tmp_path):
    rng = np.random.default_rng(20261125)
    cycle_s = None
    for kill in range(KILLS):
        writer = _start(tmp_path)
        try:
            assert writer.stdout.readline().strip() == "cycle"  # every file exists, complete
            started = time.perf_counter()
            assert writer.stdout.readline().strip() == "cycle"
            cycle_s = cycle_s or time.perf_counter() - started  # one round, measured once
            time.sleep(float(rng.uniform(0.0, cycle_s)))
        finally:
            os.kill(writer.pid, signal.SIGKILL)
            writer.wait(timeout=60)
        assert writer.returncode == -signal.SIGKILL
        _check_complete(tmp_path)
    visible = sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("."))
    assert visible == ["cal.h5", "figure.png", "report.html"]
