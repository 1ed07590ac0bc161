"""The output rule for a shaft study file: an existing one is refused, --force replaces a finished
one whole, and a partial one is continued with --resume, never replaced."""

import os

import pytest

from whiskercal.artifacts.shaft_study import ShaftStudyWriter
from whiskercal.errors import UsageError

CONFIG = {"trials": {"distances_mm": [10.0]}}


def test_a_finished_file_is_replaced_only_with_force_and_a_partial_one_never(tmp_path):
    out = tmp_path / "shaft.h5"
    ShaftStudyWriter(out, CONFIG, "twin-paper-75mm")
    with pytest.raises(UsageError, match="partial shaft study: continue it with --resume"):
        ShaftStudyWriter(out, CONFIG, "twin-paper-75mm", force=True)
    ShaftStudyWriter(out, CONFIG, "twin-paper-75mm", resume=True).mark_complete()
    with pytest.raises(UsageError, match="already exists: pass --force"):
        ShaftStudyWriter(out, CONFIG, "twin-paper-75mm")
    with pytest.raises(UsageError, match="give one"):
        ShaftStudyWriter(out, CONFIG, "twin-paper-75mm", resume=True, force=True)
    os.link(out, tmp_path / "kept.h5")
    ShaftStudyWriter(out, CONFIG, "other-build", force=True)
    assert os.stat(out).st_ino != os.stat(tmp_path / "kept.h5").st_ino  # replaced, not rewritten
    with pytest.raises(UsageError, match="nothing to resume"):
        ShaftStudyWriter(tmp_path / "none.h5", CONFIG, "twin-paper-75mm", resume=True)
