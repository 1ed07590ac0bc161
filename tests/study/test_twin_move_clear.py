"""The study's first move on the twin: from home to the contact search the plane never sweeps
across the whisker (a real whisker would be bent past its root's range and, with a creeping
suspension, the baseline measured right after would be off)."""

import numpy as np

from whiskercal.study.config import PlaneGeometry, load_config
from whiskercal.study.run import run_study
from whiskercal.twin.world import create_world


def test_the_plane_reaches_the_contact_search_without_touching_the_whisker(tmp_path):
    config = load_config(None)
    config["trials"]["depths_mm"] = [10.0]
    world = create_world("study-move-clear", scene="plane", seed=3)
    run_study("sim://study-move-clear/stage", "sim://study-move-clear/sensor", tmp_path / "s.h5",
              config)
    truth = world.truth.arrays()
    geometry = PlaneGeometry.from_config(config)
    search_start = geometry.contact_guess_stage_mm() - float(config["contact"]["search_start_mm"]) \
        * geometry.to_stage_vector(geometry.push_whisker)
    at_start = np.all(np.isclose(truth["stage_mm"], search_start, atol=0.05), axis=1)
    arrived = np.flatnonzero(at_start)[0]
    assert np.all(truth["kind"][:arrived].astype(str) == "free")  # no sample touched, none failed
    assert np.all(truth["root_rotation_rad"][:arrived] == 0.0)
