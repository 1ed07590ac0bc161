"""The shaft-localizer bench's rows on synthetic trials over the angle surface, where the contact
point is known exactly (no shaft study run, no grid fitted)."""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from shaft_synthetic import AngleSurface, contact_path

from whiskercal.artifacts.shaft_study import ShaftTrial
from whiskercal.bench import shaft_localizer as bench
from whiskercal.model.shaft import ShaftLocalizer
from whiskercal.runtime_shaft import SHAFT_SURFACE_MISFIT_LENGTH_MM

LENGTH_MM = 80.0
OFFSET_MM = np.array([123.0, -45.0])  # the object's position is known up to a constant


def _trial(radial_mm, seed=0):
    """Pushed 4 mm in at ``radial_mm``, then slid 10 mm towards the root."""
    surface, path = AngleSurface(), contact_path([radial_mm, 0.0])
    z_true = surface(path)
    z = z_true + np.random.default_rng(seed).normal(0.0, 5.0, len(path))
    return ShaftTrial(name=f"r{radial_mm:g}", radial_mm=radial_mm,
                      stream={"z_uT": z, "position_mm": path + OFFSET_MM},
                      truth={"contact_mm": path, "kind": np.full(len(path), "shaft"),
                             "z_true_uT": z_true})


@pytest.fixture(scope="module")
def trials():
    return [_trial(15.0), _trial(45.0), _trial(70.0)]


def _made(used):
    def make(surface, params):
        used.append(params)
        return ShaftLocalizer(surface, params)
    return make


def test_a_row_pools_the_goal_range_and_keeps_the_root_apart(trials):
    used = []
    row = bench._row("batch-gn-96", 5, _made(used), (AngleSurface(), 0.0), LENGTH_MM, trials)
    assert row["label"] == "batch-gn-96 deg 5" and not row["default"]
    assert row["median_error_mm"] < 0.3 and row["worst_median_error_mm"] >= row["median_error_mm"]
    assert len(row["root_error_mm"]) == 1  # the trial at 15 mm, under a quarter of the length
    assert row["s_per_sample"] == pytest.approx(row["ms_per_sample"] / 1e3)
    by_travel = row["median_error_by_travel_mm"]
    assert list(by_travel) == [f"{b:g}" for b in bench.TRAVEL_BINS_MM]
    # before the localizer's minimum travel there is no estimate to judge
    assert by_travel["1"] is None and by_travel["2"] is None
    assert by_travel["8"] < 0.3
    assert len(used) == len(trials) and used[0].search_x_mm == (5.0, LENGTH_MM)
    assert used[0].noise_uT == pytest.approx(bench.SAMPLE_NOISE_UT) and used[0].systematic_uT == 0.0


def test_the_shaft_surface_row_is_the_default_with_the_runtimes_misfit_length(trials):
    used = []
    row = bench._row("batch-gn-96", bench.SHAFT, _made(used), (AngleSurface(), 3.0), LENGTH_MM,
                     trials[1:2])
    assert row["default"] and row["label"] == "batch-gn-96 shaft surface"
    assert used[0].misfit_length_mm == SHAFT_SURFACE_MISFIT_LENGTH_MM
    assert used[0].systematic_uT == 3.0
    assert used[0].noise_uT == pytest.approx(np.hypot(bench.SAMPLE_NOISE_UT, 3.0))


def test_the_candidates_cross_every_method_with_every_surface():
    quick = bench._candidates(quick=True)
    full = bench._candidates(quick=False)
    assert {(name, surface) for name, surface, _ in quick} == {
        (name, surface) for name in ("batch-gn-96", "batch-gn-48", "particles-1000")
        for surface in (5, bench.SHAFT)}
    assert len(full) == 9 and {surface for _, surface, _ in full} == {5, 7, bench.SHAFT}
    params = replace(bench.ShaftParams(), noise_uT=5.0)
    made = {name: make(AngleSurface(), params) for name, surface, make in quick if surface == 5}
    assert made["batch-gn-48"].params.max_points == 48
    assert made["batch-gn-96"].params.max_points == params.max_points
    assert made["particles-1000"].n == 1000


def test_the_run_charts_every_candidate_on_one_study(monkeypatch, trials):
    monkeypatch.setattr(bench, "_study", lambda quick: trials[1:2])
    grid = SimpleNamespace(sensor=SimpleNamespace(whisker=SimpleNamespace(reach_mm=LENGTH_MM)))
    monkeypatch.setattr(bench, "simulate_grid", lambda: grid)
    monkeypatch.setattr(bench, "_surfaces", lambda grid, quick: {
        5: (AngleSurface(), 0.0), bench.SHAFT: (AngleSurface(), 0.0)})
    monkeypatch.setattr(bench, "_row", lambda name, degree, make, surface, length, trials: {
        "method": name, "degree": degree, "length": length})
    seen = []
    result = bench.run(quick=True, progress=seen.append)
    assert result["trials"] == 1 and seen == result["rows"] and len(seen) == 6
    assert {row["length"] for row in seen} == {LENGTH_MM}
    assert result["supports"]["localizer"] == "batch-gn-96"
