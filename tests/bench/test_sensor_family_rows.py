"""The sensor-family bench's verdicts from hand-made rows: which builds are silent failures,
meet the goals or miss them for the noise's sake (``measure`` and the sessions replaced: no grid
simulated, no session run)."""

import math
from dataclasses import replace

import pytest

from whiskercal.bench import sensor_family as family
from whiskercal.errors import UsageError


def _table(shipped_mm, floor_mm, held_mm=None, silent=False):
    return {"shipped_realistic": {"rmse_mm": shipped_mm},
            "shipped_realistic_held": {"rmse_mm": shipped_mm if held_mm is None else held_mm},
            "noise_floor": {"one_sample": {"rmse_mm": floor_mm}}, "silent_failure": silent}


ROWS = {  # by build: what measure() would have returned for it
    "good": {"label": "good", "silent_failure": False, "meets_goal": True,
             "field_table": _table(0.2, 0.1)},
    "noisy": {"label": "noisy", "silent_failure": False, "meets_goal": True,
              "field_table": _table(0.5, 0.4, held_mm=0.25)},
    "unwarned": {"label": "unwarned", "silent_failure": True, "meets_goal": False,
                 "field_table": _table(0.6, 0.1, silent=True)},
    "refused": {"build": "refused", "refused": "UsageError: no", "warned": True,
                "silent_failure": False},
}


@pytest.fixture
def result(monkeypatch):
    builds = [replace(family.DEFAULT_SENSOR, sensor_id=build) for build in ROWS]
    monkeypatch.setattr(family, "FAMILY", tuple(builds))
    monkeypatch.setattr(family, "measure", lambda sensor, seed, swept, with_table: ROWS[sensor.sensor_id])
    monkeypatch.setattr(family.sessions, "draw_builds", lambda n, seed: [])
    monkeypatch.setattr(family.sessions, "run_sessions", lambda builds, seeds, progress: [])
    monkeypatch.setattr(family, "machine_info", lambda: {})
    return family.run(variants=("grid",))


def test_the_verdicts_name_each_build_by_what_its_row_shows(result):
    supports = result["supports"]
    assert supports["silent_failures"] == ["unwarned", "unwarned: (Y, Z) table on realistic contacts"]
    assert supports["meeting_goal"] == ["good", "noisy"]
    assert supports["meeting_realistic_goal"] == ["good"]
    assert supports["meeting_realistic_goal_held"] == ["good", "noisy"]
    # missed where a perfect calibration misses too: the noise's, not the fit's
    assert supports["noise_limited_realistic"] == ["noisy"]
    assert result["setup"]["builds"] == list(ROWS) and len(result["rows"]) == len(ROWS)


def test_a_row_without_a_table_ships_nothing_realistic():
    assert family._shipped_realistic_mm({"label": "x"}) == math.inf
    assert family._shipped_realistic_mm(ROWS["noisy"], held=True) == 0.25
    assert math.isnan(family._floor_mm({"label": "x"}))
    assert family._floor_mm(ROWS["noisy"]) == 0.4


def test_a_build_the_fit_refuses_is_warned_not_a_silent_failure(monkeypatch):
    def refuse(sensor, seed, tip_sweep):
        raise UsageError("the grid does not resolve the tip")

    monkeypatch.setattr(family, "calibrate_build", refuse)
    row = family.measure(family.DEFAULT_SENSOR, tip_sweep=False)
    assert row["refused"] == "UsageError: the grid does not resolve the tip"
    assert row["warned"] and not row["silent_failure"] and row["variant"] == "grid"
    assert row["build"] == family.DEFAULT_SENSOR.sensor_id
