"""The recorded datasets can be recorded again, with the same results, and stay small."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from whiskercal.regress.golden import Dataset, read_golden
from whiskercal.regress.rerecorded import compare_rerecorded, z_step_uT

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
# A hang must still end the test; a fresh checkout first compiles the twin's numba kernels
# (about 40 s), and a machine busy with the rest of the suite runs the recording at half speed.
RECORD_TIMEOUT_S = 600


def test_the_recorded_data_stay_small_enough_for_git():
    total = sum(p.stat().st_size for p in DATA.rglob("*") if p.is_file())
    assert total < 5.0e6  # bytes; data/README.md gives the budget


@pytest.mark.parametrize("name", ["twin-paper-75mm", "twin-short-60mm", "twin-long-110mm"])
def test_each_dataset_readme_says_how_it_was_recorded(name):
    readme = (DATA / name / "README.md").read_text(encoding="utf-8")
    golden = json.loads((DATA / name / "golden.json").read_text(encoding="utf-8"))
    for needed in ("whiskercal collect --stage", "whiskercal optimal-depth run --stage",
                   "sensor=", golden["sensor_id"], "seed=", "World seeds",
                   f"whiskercal {golden['whiskercal_version']}", '"whisker": {'):
        assert needed in readme, needed


@pytest.mark.slow
def test_recording_again_with_the_same_seeds_gives_the_golden_results(tmp_path):
    # Within the re-recording bounds (whiskercal/regress/rerecorded.py): the grid and the push-ins
    # to the regress tolerances, the stick-slip slides to what another machine's last digits move.
    name = "twin-short-60mm"
    (tmp_path / name).mkdir()
    for config in (DATA / name).glob("*.toml"):
        shutil.copy(config, tmp_path / name / config.name)
    subprocess.run([sys.executable, str(ROOT / "scripts" / "record_data.py"), "--out",
                    str(tmp_path), "--only", name], check=True, capture_output=True,
                   timeout=RECORD_TIMEOUT_S)
    fresh, recorded = read_golden(Dataset(tmp_path / name)), read_golden(Dataset(DATA / name))
    changes = compare_rerecorded(recorded.quantities, fresh.quantities,
                                 z_step_uT(DATA / name / "plane_study.h5"))
    assert changes == [], "\n".join(change.describe() for change in changes)
    assert recorded.pipeline == fresh.pipeline
