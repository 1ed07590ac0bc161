"""The MuJoCo engine against the exact elastica and against the quasi-static engine.

Tolerances come from the discretization, which is second order in the segment length l = L/N:
the tip error of the hinge chain measured 4.9e-3, 1.22e-3, 3.04e-4 and 7.6e-5 of L at 10, 20,
40 and 80 segments for the worst load (alpha = 10), a factor 4.0 per doubling. The bounds below
are that 1/N² law with a margin of about 1.6 at 40 segments (5e-4·L = 0.0375 mm), not a fit to
the measured numbers.
"""

import sys

import numpy as np
import pytest

pytest.importorskip("mujoco")

from whiskercal.errors import UsageError  # noqa: E402
from whiskercal.twin.physics.mechanics import solve_rod  # noqa: E402
from whiskercal.twin.engines.mujoco_engine import MujocoWhisker  # noqa: E402
from whiskercal.twin.engines.mujoco_model import RodSpec, build_mjcf  # noqa: E402
from whiskercal.twin.engines.mujoco_reference import cantilever_tip, suspended_tip  # noqa: E402
from whiskercal.twin.physics.whisker import WhiskerParams  # noqa: E402

LENGTH_MM = 75.0
CLAMPED = RodSpec(LENGTH_MM, 0.25, 75_000.0)
SUSPENDED = RodSpec(LENGTH_MM, 0.25, 75_000.0, root_offset_mm=3.0,
                    root_rotational_stiffness_n_mm_per_rad=0.5,
                    root_translational_stiffness_n_per_mm=0.05)
ALPHAS = (0.5, 1.0, 2.0, 5.0, 10.0)
TOLERANCE_AT_40_L = 5e-4
# Root rotation at 40 segments: measured within 4e-5 rad (suspension) and 1.7e-4 rad (rod).
ROOT_ROTATION_TOLERANCE_RAD = 5e-4


def _cantilever_error_l(engine: MujocoWhisker, alpha: float) -> float:
    result = engine.solve_tip_load([0.0, alpha * CLAMPED.force_scale_n])
    return float(np.linalg.norm(result.tip_mm / LENGTH_MM - cantilever_tip(alpha)))


@pytest.fixture(scope="module")
def chain40() -> MujocoWhisker:
    return MujocoWhisker(CLAMPED, 40, "chain")


def test_chain_matches_the_exact_elastica_at_40_segments(chain40):
    errors = [_cantilever_error_l(chain40, alpha) for alpha in ALPHAS]
    assert max(errors) < TOLERANCE_AT_40_L


def test_chain_converges_at_second_order():
    errors = [_cantilever_error_l(MujocoWhisker(CLAMPED, n, "chain"), 10.0) for n in (10, 20, 40)]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    # Second order halves the error twice per doubling; 3.5 leaves room for the higher terms.
    assert np.all(ratios > 3.5)


def test_chain_on_the_suspension_matches_the_exact_reference():
    engine = MujocoWhisker(SUSPENDED, 40, "chain")
    for alpha in (0.5, 2.0):
        load_n = alpha * SUSPENDED.force_scale_n
        result = engine.solve_tip_load([0.0, load_n])
        reference = suspended_tip(SUSPENDED, load_n)
        assert np.linalg.norm(result.tip_mm - reference.tip_mm) < TOLERANCE_AT_40_L * LENGTH_MM
        rotation_error = abs(result.root_rotation_rad - reference.root_rotation_rad)
        assert rotation_error < ROOT_ROTATION_TOLERANCE_RAD
        # The slides are linear springs: their shift is exact up to the settling tolerance.
        assert np.allclose(result.root_shift_mm, reference.root_shift_mm, atol=1e-6)


def test_chain_matches_the_quasi_static_rod_contact():
    whisker = WhiskerParams(root_rotational_stiffness_n_mm_per_rad=0.5,
                            root_translational_stiffness_n_per_mm=0.05)
    engine = MujocoWhisker(RodSpec.from_whisker(whisker), 40, "chain")
    for center in [(30.0, -9.0), (60.0, -6.0)]:
        eq = solve_rod(whisker, center, 1.0)
        assert eq.kind == "shaft"
        result = engine.solve_point_load(eq.contact_arc_mm, eq.force_n)
        assert np.linalg.norm(result.tip_mm - eq.tip_mm) < TOLERANCE_AT_40_L * LENGTH_MM
        assert abs(result.root_rotation_rad - eq.root_rotation_rad) < ROOT_ROTATION_TOLERANCE_RAD


def test_chain_meets_the_rod_through_mujoco_contact():
    # Measured 0.011 and 0.0004 mm at 40 segments for these rods (contact penetration ~2e-3 mm
    # adds to the discretization), root rotation within 1.7e-4 rad; the chain's bounds hold.
    whisker = WhiskerParams(root_rotational_stiffness_n_mm_per_rad=0.5,
                            root_translational_stiffness_n_per_mm=0.05)
    engine = MujocoWhisker(RodSpec.from_whisker(whisker), 40, "chain", rod_radius_mm=1.0)
    for center in [(30.0, -9.0), (60.0, -6.0)]:
        eq = solve_rod(whisker, center, 1.0)
        result = engine.solve_rod(center)
        assert np.linalg.norm(result.tip_mm - eq.tip_mm) < TOLERANCE_AT_40_L * LENGTH_MM
        assert abs(result.root_rotation_rad - eq.root_rotation_rad) < ROOT_ROTATION_TOLERANCE_RAD


def test_solves_are_deterministic(chain40):
    load = [0.0, 3.0 * CLAMPED.force_scale_n]
    first = chain40.solve_tip_load(load)
    chain40.solve_tip_load([0.0, -load[1]])  # a different case in between
    again = chain40.solve_tip_load(load)
    fresh = MujocoWhisker(CLAMPED, 40, "chain").solve_tip_load(load)
    assert np.array_equal(first.shape_mm, again.shape_mm)
    assert np.array_equal(first.shape_mm, fresh.shape_mm)
    assert first.steps == again.steps == fresh.steps


def test_flex_matches_the_exact_elastica_and_stays_inextensible():
    # Measured 2.6e-4·L at alpha = 1 with 20 segments (the chain: 3.6e-4·L) and an edge stretch
    # of 8e-6.
    engine = MujocoWhisker(CLAMPED, 20, "flex")
    assert _cantilever_error_l(engine, 1.0) < 1e-3
    segments = np.linalg.norm(np.diff(engine.data.flexvert_xpos[1:, :2], axis=0), axis=1)
    assert np.max(np.abs(segments * 20 - 1.0)) < 1e-4


def test_shape_runs_from_clamp_to_tip_with_segment_lengths(chain40):
    result = chain40.solve_tip_load([0.0, CLAMPED.force_scale_n])
    steps = np.linalg.norm(np.diff(result.shape_mm, axis=0), axis=1)
    assert result.shape_mm.shape == (41, 2)
    assert np.allclose(result.shape_mm[0], [0.0, 0.0])
    assert np.allclose(steps, LENGTH_MM / 40, rtol=1e-9)
    assert np.array_equal(result.tip_mm, result.shape_mm[-1])


def test_bad_inputs_are_refused(chain40):
    with pytest.raises(UsageError, match="at least 2 segments"):
        build_mjcf(CLAMPED, 1)
    with pytest.raises(UsageError, match="unknown MuJoCo representation"):
        MujocoWhisker(CLAMPED, 10, "cable")
    with pytest.raises(UsageError, match="off the shaft"):
        chain40.solve_point_load(80.0, [0.0, 0.001])
    with pytest.raises(UsageError, match="must be positive"):
        RodSpec(75.0, -0.25, 75_000.0)


def test_a_missing_mujoco_is_one_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # makes `import mujoco` fail
    with pytest.raises(UsageError, match="MuJoCo is not installed"):
        MujocoWhisker(CLAMPED, 10)
