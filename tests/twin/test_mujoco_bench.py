"""The engines benchmark: JSON-able rows, errors measured against the references."""

import json
import sys

import numpy as np
import pytest

pytest.importorskip("mujoco")

from whiskercal.bench.engines import run  # noqa: E402
from whiskercal.twin.engines.mujoco_reference import cantilever_tip  # noqa: E402


@pytest.fixture(scope="module")
def progress_rows() -> list:
    return []


@pytest.fixture(scope="module")
def report(progress_rows) -> dict:
    return run(segments=(10, 20), rk4_steps=(8, 32), alphas=(1.0, 5.0),
               representations=("chain",), repeats=1, progress=progress_rows.append)


def test_progress_sees_every_row(report, progress_rows):
    assert progress_rows == report["rows"]


def test_report_is_json_and_has_a_row_per_case_set_engine_and_resolution(report):
    json.dumps(report)
    keys = {(r["case_set"], r["engine"], r["resolution"]) for r in report["rows"]}
    expected = {(c, "quasi-static", s) for c in ("cantilever", "suspended") for s in (8, 32)}
    expected |= {(c, "mujoco-chain", n)
                 for c in ("cantilever", "suspended", "rod") for n in (10, 20)}
    expected |= {("rod", "mujoco-chain-contact", n) for n in (10, 20)}
    assert keys == expected
    assert report["pareto"]["x"] == "time_per_case_s"
    assert report["skipped"] == []


def _row(report: dict, case_set: str, engine: str, resolution: int) -> dict:
    return next(r for r in report["rows"]
                if (r["case_set"], r["engine"], r["resolution"]) == (case_set, engine, resolution))


def test_errors_are_measured_against_the_exact_elastica(report):
    row = _row(report, "cantilever", "mujoco-chain", 10)
    for case, alpha in zip(row["cases"], (1.0, 5.0)):
        exact_mm = cantilever_tip(alpha) * 75.0
        error_mm = np.linalg.norm(np.array(case["tip_mm"]) - exact_mm)
        assert case["error_mm"] == pytest.approx(error_mm)
    assert row["max_error_fraction_of_length"] == pytest.approx(row["max_error_mm"] / 75.0)
    assert row["time_per_case_s"] > 0


def test_finer_resolutions_are_more_accurate(report):
    def error(case_set, engine, resolution):
        return _row(report, case_set, engine, resolution)["max_error_mm"]

    for case_set in ("cantilever", "suspended", "rod"):
        assert error(case_set, "mujoco-chain", 20) < error(case_set, "mujoco-chain", 10) / 3
    assert error("rod", "mujoco-chain-contact", 20) < error("rod", "mujoco-chain-contact", 10) / 3
    assert error("cantilever", "quasi-static", 32) < error("cantilever", "quasi-static", 8) / 10


def test_without_mujoco_the_quasi_static_rows_remain(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # makes `import mujoco` fail
    report = run(segments=(10,), rk4_steps=(8,), alphas=(1.0,), repeats=1)
    assert {r["engine"] for r in report["rows"]} == {"quasi-static"}
    assert report["skipped"] == ["mujoco: not installed (pip install whiskercal[bench])"]
