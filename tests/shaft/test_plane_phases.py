"""The shaft localizer over the recorded flat-plane study's tangential contacts (twin truth)."""

from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).parents[2] / "data" / "twin-short-60mm"


@pytest.mark.slow
def test_tangential_contacts_are_called_shaft_and_never_wrongly_localized(tmp_path):
    from whiskercal import runtime
    from whiskercal.artifacts.plane_study import read_study
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import fit, options_from_args
    from whiskercal.shaftstudy.plane_phases import track_plane_trial

    artifact = tmp_path / "cal.h5"
    # the shaft localizer is what is tested; the (Y, Z) table would add half a minute
    options = options_from_args(["--trace-length-mm", "63", "--no-field-table"])
    fit(read_raw_grid(DATA / "raw_grid.h5"), options).write(artifact)
    study = read_study(DATA / "plane_study.h5")
    deepest = study.trials[-1]  # 40 mm: the whisker lies along the plane for 2 191 samples
    row = track_plane_trial(study, deepest, runtime.load(artifact))
    assert row.samples_on_shaft > 1000
    # against the twin's truth: never called a tip contact (the tip tracker would be trusted)
    assert row.called_tip == 0.0 and row.called_shaft > 0.99
    # a line contact the point-contact model does not describe: withheld, not guessed
    assert row.localized_share == 0.0 and np.isnan(row.median_error_mm)
