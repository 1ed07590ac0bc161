"""The error budget's pure parts: the fluctuation measure, the nuisance levels, the row tables
(``run_case`` replaced by a recorder, no contour run) and the speed chart."""

from pathlib import Path

import numpy as np
import pytest

from whiskercal.bench import error_budget
from whiskercal.twin.nuisances import REALISTIC, Nuisances


def test_the_fluctuation_is_the_std_of_first_differences_over_root_two_inside_the_mask():
    rng = np.random.default_rng(3)
    z = np.concatenate([rng.normal(-900.0, 50.0, 4000), np.full(20, 1e6)])  # µT
    mask = np.arange(z.size) < 4000  # the wild tail is out of contact
    assert error_budget.fluctuation_uT({"z_uT": z}, mask) == pytest.approx(50.0, rel=0.05)
    # a step between two contacts is not a fluctuation: pairs must be in contact on both sides
    gap = mask.copy()
    gap[2000] = False
    z[2000] = 5e5
    assert error_budget.fluctuation_uT({"z_uT": z}, gap) == pytest.approx(50.0, rel=0.05)
    assert np.isnan(error_budget.fluctuation_uT({"z_uT": z}, np.arange(z.size) < 2))


def test_a_nuisance_row_has_that_nuisance_alone_at_its_realistic_level():
    assert error_budget.level_of("none") == Nuisances()
    assert error_budget.level_of("all") == REALISTIC
    drift = error_budget.level_of("drift")
    assert drift.drift == REALISTIC.drift and drift.robot == Nuisances().robot


@pytest.fixture
def recorded(monkeypatch):
    calls = []

    def run_case(artifact, shape, nuisances, countermeasures, duration_s, speed_mm_s=None,
                 mount=None, **_):
        calls.append((shape, nuisances, countermeasures, speed_mm_s, mount))
        return {"mean_error_mm": 0.1 * len(calls)}

    monkeypatch.setattr(error_budget, "run_case", run_case)
    return calls


def test_budget_rows_run_each_nuisance_with_its_countermeasure_off_then_on(recorded):
    seen = []
    rows = error_budget.budget_rows(Path("cal.h5"), ("cylinder", "octagon"), 4.0,
                                    ("none", "drift"), progress=seen.append)
    assert seen == rows and len(rows) == 2 * 2 * 2
    assert [(r["case"], r["nuisance"], r["countermeasure_on"]) for r in rows[:4]] == [
        ("cylinder", "none", False), ("cylinder", "none", True),
        ("cylinder", "drift", False), ("cylinder", "drift", True)]
    assert [r["level"] for r in rows[:4]] == ["off", "off", "realistic", "realistic"]
    assert rows[3]["countermeasure"] == error_budget.COUNTERMEASURES["drift"]
    assert rows[2]["countermeasure"] == "none"
    assert [call[2] for call in recorded[:2]] == [False, True]
    assert recorded[2][1] == error_budget.level_of("drift")


def test_the_mount_row_drives_through_the_nominal_mount_then_the_fitted_one(recorded, monkeypatch):
    from whiskercal.bench.mount_cal import NOMINAL
    from whiskercal.mount import Mount

    true, fitted = Mount(1.5, 28.0, 92.0), Mount(1.4, 28.1, 91.9)
    monkeypatch.setattr(error_budget, "calibrated_mount", lambda artifact: {"true": true, "fitted": fitted})
    rows = error_budget.budget_rows(Path("cal.h5"), ("cylinder",), 4.0, ("drift", "mount", "all"))
    mounts = [call[4] for call in recorded]
    assert mounts[:2] == [None, None]  # drift alone: the sensor where the drawing says
    for (given, error), expected in zip(mounts[2:], (NOMINAL, fitted, NOMINAL, fitted)):
        assert given == expected
        assert error == pytest.approx((true.x_mm - given.x_mm, true.y_mm - given.y_mm,
                                       true.yaw_deg - given.yaw_deg))
    assert recorded[2][1] == error_budget.level_of("none")  # the mount is no sensor nuisance
    assert [r["countermeasure"] for r in rows[2:4]] == ["none", error_budget.COUNTERMEASURES["mount"]]


def test_plane_rows_keep_the_depths_the_ideal_session_passes(monkeypatch, tmp_path):
    from types import SimpleNamespace

    import whiskercal.runtime
    import whiskercal.study.report

    studies, reports = [], []

    def plane_study(out, nuisances, depths_mm=None, seed=error_budget.PLANE_SEED):
        studies.append((out.name, nuisances, depths_mm))
        return out

    def build_report(study, calibration, countermeasures):
        reports.append((study.name, countermeasures))
        failing = {10.0} if study.name == "plane-none.h5" else {20.0}
        return SimpleNamespace(rows=[
            SimpleNamespace(depth_mm=d, true_filtered_mean_mm=d / 100, contact_fraction=1.0,
                            failing=d in failing, reasons=["deep"] if d in failing else [])
            for d in (10.0, 20.0, 30.0)])

    monkeypatch.setattr(error_budget, "plane_study", plane_study)
    monkeypatch.setattr(whiskercal.study.report, "build_report", build_report)
    monkeypatch.setattr(whiskercal.runtime, "load", lambda path: "calibration")
    rows = error_budget.plane_rows(Path("cal.h5"), tmp_path, ("viscoelastic", "none"))
    assert [name for name, _, _ in studies] == ["plane-none.h5", "plane-viscoelastic.h5"]
    assert studies[1][1] == error_budget.level_of("viscoelastic")
    # the ideal session with the tracker as shipped passes 20 and 30 mm: those are the cases
    assert {r["case"] for r in rows} == {"plane 20 mm", "plane 30 mm"} and len(rows) == 2 * 2 * 2
    off, on = reports[2][1], reports[3][1]
    assert not off.any and on.rezero and on.creep == (REALISTIC.viscoelastic.creep_share,
                                                      REALISTIC.viscoelastic.tau_s)
    assert reports[1][1].creep is None  # the ideal session has no creep to undo
    failing = next(r for r in rows if r["nuisance"] == "viscoelastic" and r["case"] == "plane 20 mm")
    assert failing["failing"] and failing["reasons"] == ["deep"] and failing["mean_error_mm"] == 0.2


def test_speed_rate_rows_jitter_a_tenth_of_each_period_with_every_countermeasure(recorded):
    rows = error_budget.speed_rate_rows(Path("cal.h5"), (2.0, 10.0), (30.0, 300.0), 4.0)
    assert [(r["rate_hz"], r["speed_mm_s"]) for r in rows] == [
        (30.0, 2.0), (30.0, 10.0), (300.0, 2.0), (300.0, 10.0)]
    for (shape, nuisances, on, speed, _), row in zip(recorded, rows):
        assert shape == "cylinder" and on and speed == row["speed_mm_s"]
        assert nuisances.robot.rate_hz == row["rate_hz"]
        assert nuisances.robot.jitter_s == pytest.approx(0.1 / row["rate_hz"])
        assert nuisances.drift == REALISTIC.drift


def test_the_speed_chart_has_one_line_per_rate_in_speed_order(monkeypatch, tmp_path):
    figures, real_save = [], error_budget.save_png
    monkeypatch.setattr(error_budget, "save_png",
                        lambda fig, path: figures.append(fig) or real_save(fig, path))
    rows = [{"rate_hz": rate, "speed_mm_s": speed, "mean_error_mm": speed / rate}
            for rate in (30.0, 300.0) for speed in (10.0, 2.0)]
    path = error_budget.draw({"speed_rate_rows": rows}, tmp_path / "budget.png")
    assert path.read_bytes()[:4] == b"\x89PNG"
    lines = {line.get_label(): line for line in figures[0].axes[0].lines}
    np.testing.assert_array_equal(lines["30 Hz"].get_xdata(), [2.0, 10.0])
    np.testing.assert_allclose(lines["300 Hz"].get_ydata(), [2.0 / 300.0, 10.0 / 300.0])
    assert "goal" in lines
