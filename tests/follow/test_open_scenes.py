"""The open scenes with a parameter (corner:deg=N, step:mm=H): their outlines, the twin's pieces
(inside the solid, their union its surface), what a run's coverage counts, bad parameters."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.artifacts.contour_run import ContourRunFile
from whiskercal.cli import cli
from whiskercal.contour.metrics import distances_mm
from whiskercal.contour.summary import reachable
from whiskercal.errors import UsageError
from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import outline, recorded
from whiskercal.twin.params import DEFAULT_SENSOR


def _in_free_space(corner_deg, points):
    """Inside the corner scene's free wedge (above the first wall, right of the second)?"""
    direction = np.array([math.cos(math.radians(corner_deg)), math.sin(math.radians(corner_deg))])
    return (points[:, 1] > 1e-9) & (points @ np.array([direction[1], -direction[0]]) > 1e-9)


@pytest.mark.parametrize("corner_deg", [60.0, 90.0, 120.0])
def test_a_corner_scene_is_two_walls_meeting_at_the_angle_asked(corner_deg):
    scene = outline(f"corner:deg={corner_deg:g}")
    assert not scene.closed and scene.perimeter_mm == pytest.approx(450.0)
    first, second = scene.core_mm[0] - scene.core_mm[1], scene.core_mm[2] - scene.core_mm[1]
    opening = math.degrees(math.acos(first @ second / np.linalg.norm(first) / np.linalg.norm(second)))
    assert opening == pytest.approx(corner_deg)
    again = recorded(scene.name, scene.core_mm, scene.radius_mm)  # as a run file gives it back
    assert type(again) is type(scene) and len(again.obstacle()) == 3
    for piece in scene.obstacle():  # every piece lies in the solid
        assert not np.any(_in_free_space(corner_deg, piece.vertices_mm))
    # the walls' surface is covered: points just behind it lie in some piece
    along = second / np.linalg.norm(second)
    behind = np.vstack([np.column_stack([np.linspace(0.0, 300.0, 61), np.full(61, -0.01)]),
                        np.linspace(0.0, 150.0, 31)[:, None] * along + 0.01 * np.array([-along[1], along[0]])])
    assert all(any(piece.reaches(point[None]) for piece in scene.obstacle()) for point in behind)


def test_a_step_scene_has_its_step_where_asked():
    scene = outline("step:mm=12.5")
    assert not scene.closed
    for point, expected_mm in (((225.0, 20.0), 7.5),   # above the step's top (y = 12.5)
                               ((140.0, 5.0), 5.0),     # by the foot: nearer the wall than the face
                               ((0.0, 8.0), 8.0)):      # above the wall beyond it (y = 0)
        distance, _ = distances_mm(np.array([point]), scene.dense())
        assert distance[0] == pytest.approx(expected_mm, abs=0.05)
    assert scene.perimeter_mm == pytest.approx(147 + 9.5 + 300 + 1.5 * math.pi, abs=1e-3)


@pytest.mark.parametrize("name", ["corner:deg=59", "corner:deg=121", "corner:mm=90", "corner",
                                  "step:mm=2", "step:mm=x", "step:deg=20", "stair:mm=20"])
def test_a_bad_scene_is_refused_with_one_line(tmp_path, name):
    with pytest.raises(UsageError):
        outline(name)
    out = tmp_path / "run.h5"
    result = CliRunner().invoke(cli, ["contour", "run", "--shape", name, "--artifact",
                                      str(tmp_path / "unread.h5"), "--out", str(out)])
    assert result.exit_code == 2 and len(result.stderr.strip().splitlines()) == 1
    assert name in result.stderr and not out.exists()


def test_a_whisker_pressed_on_a_corner_scenes_first_wall_touches_it():
    heading = math.radians(-110.0)  # leaning 20° back from the wall's inward normal (-y)
    robot = MobileSensor(DEFAULT_SENSOR, outline("corner:deg=60"), np.array([150.0, 62.0, heading]), seed=3)
    sample = robot.step(0.0)
    assert sample.kind == "tip" and sample.contact_mm[1] == pytest.approx(0.0, abs=1e-6)


def test_an_open_scenes_coverage_counts_from_where_the_run_first_touched_it():
    scene = outline("corner:deg=90")
    dense = scene.dense()
    touched = np.full((3, 2), np.nan)
    touched[1:] = [[250.0, 0.0], [200.0, 0.0]]
    run = ContourRunFile(scene.name, scene.core_mm, scene.radius_mm, -5000.0, 1, True, 1.0, "s",
                         {"true_contact_mm": touched}, {})
    part = reachable(run, dense)
    assert part[0] == pytest.approx([250.0, 0.0], abs=0.05)
    assert len(part) / len(dense) == pytest.approx((250.0 + 150.0) / 450.0, abs=0.01)


@pytest.mark.parametrize("name, inside, beyond", [("corner:deg=90", (0.0, 149.0), (0.0, 151.0)),
                                                  ("step:mm=20", (-149.0, 0.0), (-151.0, 0.0)),
                                                  ("wall", (-5.0, 149.5), (-5.0, 150.5))])
def test_an_open_scene_ends_past_its_last_side(name, inside, beyond):
    # a run ends once the twin's tip passes it: the solid goes on there only so that no
    # false edge stands at the end
    scene = outline(name)
    assert not scene.past_end(np.array(inside)) and scene.past_end(np.array(beyond))
