"""The recorded datasets can be recorded again, with the same results, and stay small."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from whiskercal.regress.compare import compare
from whiskercal.regress.golden import Dataset, read_golden

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"


def test_the_recorded_data_stay_small_enough_for_git():
    total = sum(p.stat().st_size for p in DATA.rglob("*") if p.is_file())
    assert total < 4.5e6  # bytes; data/README.md gives the budget


@pytest.mark.parametrize("name", ["twin-paper-75mm", "twin-short-60mm"])
def test_each_dataset_readme_says_how_it_was_recorded(name):
    readme = (DATA / name / "README.md").read_text(encoding="utf-8")
    golden = json.loads((DATA / name / "golden.json").read_text(encoding="utf-8"))
    for needed in ("whiskercal collect --stage", "whiskercal optimal-depth run --stage",
                   f"sensor={golden['sensor_id']}", "seed=", "World seeds",
                   f"whiskercal {golden['whiskercal_version']}", '"whisker": {'):
        assert needed in readme, needed


@pytest.mark.slow
def test_recording_again_with_the_same_seeds_gives_the_golden_results(tmp_path):
    name = "twin-short-60mm"
    (tmp_path / name).mkdir()
    for config in (DATA / name).glob("*.toml"):
        shutil.copy(config, tmp_path / name / config.name)
    subprocess.run([sys.executable, str(ROOT / "scripts" / "record_data.py"), "--out",
                    str(tmp_path), "--only", name], check=True, capture_output=True, timeout=120)
    fresh, recorded = read_golden(Dataset(tmp_path / name)), read_golden(Dataset(DATA / name))
    assert compare(recorded.quantities, recorded.classes, fresh.quantities) == []
    assert recorded.pipeline == fresh.pipeline
