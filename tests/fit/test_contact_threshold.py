"""The collision threshold ``fit`` chooses for the build (``fit.contact_threshold``): the paper's
300 µT where a tip pushed 3 mm reads more, else the z of that push, never under the noise
floor; against the twin's truth on the recorded 110 mm build."""

import math
from pathlib import Path

import numpy as np
import pytest

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.fit import FitOptions, fit
from whiskercal.fit.contact_threshold import (NOISE_FLOOR_SIGMAS, PAPER_THRESHOLD_UT,
                                              contact_threshold, motion_at,
                                              threshold_from_curve, threshold_warnings)
from whiskercal.twin import truth
from whiskercal.twin.sensor_file import load_sensor

ROOT = Path(__file__).resolve().parents[2]


def _linear(uT_per_mm: float):
    """A tip curve whose |z| grows ``uT_per_mm`` per mm of tip motion, to 10 mm."""
    motion = np.linspace(0.0, 10.0, 101)
    return uT_per_mm * motion, motion


def test_a_build_that_reads_300_uT_within_3_mm_of_tip_motion_keeps_the_papers_threshold():
    chosen = threshold_from_curve(*_linear(400.0), sample_noise_uT=5.6)
    assert (chosen.threshold_uT, chosen.source) == (PAPER_THRESHOLD_UT, "paper")
    assert chosen.tip_motion_mm == pytest.approx(0.75)
    assert threshold_warnings(chosen) == []


def test_a_weaker_build_is_seen_at_3_mm_of_tip_motion():
    chosen = threshold_from_curve(*_linear(50.0), sample_noise_uT=5.6)
    assert chosen.source == "tip motion"
    assert chosen.threshold_uT == pytest.approx(150.0)
    assert chosen.tip_motion_mm == pytest.approx(3.0)
    assert threshold_warnings(chosen) == []


def test_the_noise_floor_bounds_it_below_and_a_deep_threshold_is_warned():
    chosen = threshold_from_curve(*_linear(20.0), sample_noise_uT=5.6)
    assert chosen.source == "noise floor"
    assert chosen.threshold_uT == pytest.approx(NOISE_FLOOR_SIGMAS * 5.6)
    assert chosen.tip_motion_mm == pytest.approx(5.6)
    (line,) = threshold_warnings(chosen)
    assert "112 µT" in line and "5.6 mm" in line


def test_a_given_threshold_is_kept_and_its_tip_motion_reported():
    depth, motion = _linear(20.0)
    assert motion_at(150.0, depth, motion) == pytest.approx(7.5)
    assert math.isnan(motion_at(300.0, depth, motion))  # the curve never reads it
    given = contact_threshold(300.0, None, 5.6)
    assert (given.threshold_uT, given.source) == (300.0, "given")
    assert contact_threshold(None, None, 5.6).threshold_uT == PAPER_THRESHOLD_UT


@pytest.mark.slow
def test_the_long_builds_threshold_sees_contacts_the_papers_misses_on_the_twins_truth():
    sensor = load_sensor(ROOT / "sensors" / "long-110mm.toml")
    result = fit(read_raw_grid(ROOT / "data" / "twin-long-110mm" / "raw_grid.h5"),
                 FitOptions(tip_model="level-set", field_table=False))
    chosen = result.metrics["collision_threshold_uT"]
    assert chosen < PAPER_THRESHOLD_UT
    assert result.artifact_data().collision["threshold_uT"] == chosen
    # on the twin's own frictionless tip curve the chosen threshold is passed where the fitted
    # model says, at under half the tip motion the paper's 300 µT waits for
    z_true, tips_true = truth.tip_curve(sensor)
    depth = np.abs(z_true - z_true[0])
    motion = np.linalg.norm(tips_true - tips_true[0], axis=1)
    seen = motion_at(chosen, depth, motion)
    assert result.metrics["collision_tip_motion_mm"] == pytest.approx(seen, abs=0.3)
    assert seen < 0.5 * motion_at(PAPER_THRESHOLD_UT, depth, motion)
    # this build's noise floor binds (its Y reads 33 µT per mm of tip): said, not silent
    assert result.metrics["collision_threshold_source"] == "noise floor"
    assert any(w.startswith("the collision threshold") for w in result.warnings)
