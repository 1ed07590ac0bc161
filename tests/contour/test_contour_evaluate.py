"""Evaluating a reconstruction against an outline: look-alike reconstructions made here (an
outline sampled at a known pose and scale, with seeded noise), the fits, refusals and readers."""

import json
import math

import h5py
import numpy as np
import pytest
import shapely
from click.testing import CliRunner

from whiskercal.cli import cli
from whiskercal.contour.evaluate import evaluate
from whiskercal.contour.outline_spec import parse_outline
from whiskercal.contour.points import PointSet, read_points
from whiskercal.contour.pose_fit import FitRefusedError, Pose

OCTAGON = "polygon:n=8,side=70,r=30"
# where the look-alike reconstructions lie: a robot's world frame, far from the origin (mm, rad)
PLACED = Pose(437.0, 5.0, math.radians(12.0))


def look_alike(spec: str, pose: Pose, count: int = 2000, noise_mm: float = 0.0, seed: int = 0,
               share: float = 1.0) -> np.ndarray:
    """``count`` points along ``share`` of the outline, placed at ``pose`` (its scale too), with
    Gaussian noise of ``noise_mm`` in x and y."""
    geometry = parse_outline(spec).geometry
    along = np.linspace(0.0, share * geometry.length, count, endpoint=False)
    points = pose.to_points(shapely.get_coordinates(shapely.line_interpolate_point(geometry, along)))
    return points + np.random.default_rng(seed).normal(0.0, noise_mm, points.shape)


def _points(xy) -> PointSet:
    return PointSet(np.asarray(xy, float), "made here", 0)


def test_points_on_the_outline_at_a_given_pose_are_at_zero_and_cover_it():
    summary = evaluate(_points(look_alike(OCTAGON, PLACED)), parse_outline(OCTAGON), "none",
                       PLACED).summary
    assert summary["none"]["max_mm"] < 1e-6 and summary["none"]["coverage"] == 1.0


def test_a_rigid_fit_finds_the_pose_of_points_on_the_outline():
    evaluation = evaluate(_points(look_alike(OCTAGON, PLACED)), parse_outline(OCTAGON), "rigid")
    rigid, pose = evaluation.summary["rigid"], evaluation.poses["rigid"]
    assert rigid["mean_mm"] < 0.01 and rigid["coverage"] == 1.0
    assert abs(pose.x_mm - PLACED.x_mm) < 0.01 and abs(pose.y_mm - PLACED.y_mm) < 0.01
    turn = math.remainder(pose.theta_rad - PLACED.theta_rad, math.pi / 4)  # the octagon's symmetry
    assert abs(math.degrees(turn)) < 0.01


def test_a_reconstruction_too_large_shows_its_size_error_rigidly_and_its_scale_beside():
    bigger = Pose(PLACED.x_mm, PLACED.y_mm, PLACED.theta_rad, 1.15)
    xy = look_alike(OCTAGON, bigger, noise_mm=0.3, seed=7)
    summary = evaluate(_points(xy), parse_outline(OCTAGON), "similarity").summary
    # the octagon's apothem is 84.5 mm: 15 % larger puts the points about 12.7 mm out
    assert summary["rigid"]["mean_mm"] > 8.0 and summary["rigid"]["coverage"] < 0.05
    assert summary["similarity"]["scale"] == pytest.approx(1.15, abs=0.003)
    # with the scale fitted freely only the noise is left: E|N(0, 0.3)| is 0.24 mm
    assert summary["similarity"]["mean_mm"] < 0.3 and summary["similarity"]["coverage"] > 0.99
    assert "paper's metric" in summary["similarity"]["metric"]


def test_a_partial_contour_is_fitted_from_a_given_start():
    xy = look_alike("rounded-rect:w=160,h=160,r=40", PLACED, share=0.6)
    start = Pose(PLACED.x_mm + 5, PLACED.y_mm - 5, PLACED.theta_rad + 0.1)
    summary = evaluate(_points(xy), parse_outline("rounded-rect:w=160,h=160,r=40"), "rigid", start).summary
    assert summary["rigid"]["mean_mm"] < 0.01
    assert summary["rigid"]["coverage"] == pytest.approx(0.6, abs=0.01)


def test_points_in_metres_read_as_mm_are_refused_by_either_fit():
    metres = _points(look_alike(OCTAGON, PLACED) / 1000.0)
    for fit in ("rigid", "similarity"):
        with pytest.raises(FitRefusedError, match="other units"):
            evaluate(metres, parse_outline(OCTAGON), fit)


def test_a_scale_towards_zero_or_too_few_points_are_refused():
    small = _points(look_alike("circle:d=160", PLACED, noise_mm=0.2, seed=3))
    with pytest.raises(FitRefusedError, match="scales the outline by 0.3"):
        evaluate(small, parse_outline("circle:d=500"), "similarity")
    with pytest.raises(FitRefusedError, match="at least 10 distinct points"):
        evaluate(_points(look_alike(OCTAGON, PLACED, count=9)), parse_outline(OCTAGON), "rigid")
    repeated = np.repeat(look_alike(OCTAGON, PLACED, count=3), 50, axis=0)
    with pytest.raises(FitRefusedError, match="has 3"):
        evaluate(_points(repeated), parse_outline(OCTAGON), "similarity")


def test_a_table_in_metres_evaluates_as_the_same_table_in_mm(tmp_path):
    xy = look_alike(OCTAGON, Pose(537.0, 57.0, 0.2, 1.1), noise_mm=0.5, seed=11)
    np.savetxt(tmp_path / "mm.txt", xy, delimiter=" ")
    np.savetxt(tmp_path / "m.csv", xy / 1000.0, delimiter=", ", fmt="%.17g")
    in_mm = evaluate(read_points(tmp_path / "mm.txt"), parse_outline(OCTAGON), "similarity").summary
    in_m = evaluate(read_points(tmp_path / "m.csv", "m"), parse_outline(OCTAGON), "similarity").summary
    for fit in ("rigid", "similarity"):
        assert in_m[fit]["mean_mm"] == pytest.approx(in_mm[fit]["mean_mm"], abs=1e-6)
    assert in_m["similarity"]["scale"] == pytest.approx(1.1, abs=0.005)


def test_tables_with_and_without_headers(tmp_path):
    xy = look_alike(OCTAGON, PLACED, count=20)
    rows = "".join(f"{x / 1000}, {y / 1000}\n" for x, y in xy)
    (tmp_path / "comment.txt").write_text("# /tip/x, /tip/y\n" + rows)  # the authors' logs' style
    (tmp_path / "named.tsv").write_text("t\ty\tx\n" + "".join(f"0\t{y}\t{x}\n" for x, y in xy))
    for path, units in (("comment.txt", "m"), ("named.tsv", None)):
        assert np.allclose(read_points(tmp_path / path, units).xy_mm, xy, atol=1e-9)
    (tmp_path / "three.csv").write_text("a,b,c\n1,2,3\n")
    with pytest.raises(Exception, match="which columns are x and y"):
        read_points(tmp_path / "three.csv")


def test_a_replay_track_gives_its_world_points_and_counts_those_without(tmp_path):
    xy = look_alike(OCTAGON, PLACED, count=30)
    xy[::3] = np.nan  # samples without a contact have no world point
    rows = "".join(f"{k / 300:.6f},1,{x:.6f},{y:.6f}\n" for k, (x, y) in enumerate(xy))
    (tmp_path / "track.csv").write_text("t_s,contact,world_x_mm,world_y_mm\n" + rows)
    points = read_points(tmp_path / "track.csv")
    assert points.skipped == 10 and len(points.xy_mm) == 20
    with pytest.raises(Exception, match="leave out --units"):
        read_points(tmp_path / "track.csv", "m")
    with h5py.File(tmp_path / "track.h5", "w") as handle:
        handle.attrs["schema"], handle.attrs["schema_version"] = "whiskercal.replay_track", "1.1.0"
        handle["track/world_x_mm"], handle["track/world_y_mm"] = xy[:, 0], xy[:, 1]
    assert np.allclose(read_points(tmp_path / "track.h5").xy_mm, xy[np.isfinite(xy[:, 0])])


def test_a_track_without_world_points_is_refused(tmp_path):
    with h5py.File(tmp_path / "track.h5", "w") as handle:
        handle.attrs["schema"] = "whiskercal.replay_track"
        handle["track/filtered_x_mm"] = np.zeros(3)
    with pytest.raises(Exception, match="no world_x_mm and world_y_mm"):
        read_points(tmp_path / "track.h5")


def test_a_contour_run_gives_its_estimate_while_following(tmp_path):
    from whiskercal.artifacts.contour_run import ContourRunFile, write_contour_run

    xy = look_alike("circle:d=160", Pose(), count=40, noise_mm=0.3, seed=2)
    phase = np.array(["approach"] * 10 + ["follow"] * 30)
    columns = {name: np.zeros(40) for name in ("t_s", "z_uT", "slip", "control_s")}
    columns.update(estimate_mm=xy, true_tip_mm=xy, true_contact_mm=xy, pose=np.zeros((40, 3)),
                   phase=phase, kind=np.array(["tip"] * 40))
    write_contour_run(tmp_path / "run.h5", ContourRunFile("cylinder", np.zeros((1, 2)), 80.0, -5000.0,
                                                          0, True, 1.0, "twin", columns, {}))
    points = read_points(tmp_path / "run.h5")
    assert np.allclose(points.xy_mm, xy[10:])
    summary = evaluate(points, parse_outline("circle:d=160"), "none").summary
    # the same figure as `contour report`'s, measured its own way (to a densely sampled outline)
    from whiskercal.contour import read_contour_run, summarize

    report = summarize(read_contour_run(tmp_path / "run.h5"))
    assert summary["none"]["mean_mm"] == pytest.approx(report["mean_error_mm"], abs=0.005)
    assert summary["none"]["mean_mm"] > 0.1  # the noise is there to be measured


def test_the_command_prints_both_fits_and_writes_its_files(tmp_path):
    xy = look_alike(OCTAGON, Pose(537.0, 57.0, 0.0, 1.2), noise_mm=0.4, seed=5) / 1000.0
    np.savetxt(tmp_path / "oct.txt", xy, delimiter=", ", fmt="%.17g")
    words = ["contour", "evaluate", str(tmp_path / "oct.txt"), "--outline", OCTAGON, "--units", "m",
             "--fit", "similarity"]
    text = CliRunner().invoke(cli, words, catch_exceptions=False)
    assert text.exit_code == 0 and "rigid" in text.output and "the paper's metric" in text.output
    done = CliRunner().invoke(cli, words + ["--json", "--out", str(tmp_path / "ev")], catch_exceptions=False)
    summary = json.loads(done.output)
    assert summary["fit"] == "similarity" and summary["similarity"]["scale"] == pytest.approx(1.2, abs=0.005)
    assert json.loads((tmp_path / "ev" / "evaluation.json").read_text()) == summary
    assert (tmp_path / "ev" / "evaluation.png").stat().st_size > 0


def test_the_command_places_the_outline_at_the_given_pose(tmp_path):
    np.savetxt(tmp_path / "p.txt", look_alike("circle:d=160", Pose(10.0, -20.0)))
    done = CliRunner().invoke(cli, ["contour", "evaluate", str(tmp_path / "p.txt"), "--outline",
                                    "circle:d=160", "--fit", "none", "--pose", "10,-20,0", "--json"],
                              catch_exceptions=False)
    summary = json.loads(done.output)
    assert summary["none"]["max_mm"] < 1e-6 and summary["none"]["pose"]["x_mm"] == 10.0


def test_the_run_metrics_alignment_refuses_to_shrink_points_onto_the_outline():
    from whiskercal.contour.metrics import aligned_errors_mm
    from whiskercal.twin.outlines import outline

    dense = outline("octagon").dense()
    bigger = look_alike(OCTAGON, Pose(0.0, 0.0, 0.0, 1.15), noise_mm=0.3, seed=7)
    assert np.mean(aligned_errors_mm(bigger, dense)) < 0.3  # a scale of 1/1.15: kept
    metres = bigger / 1000.0 + [0.437, 0.005]  # metres read as mm: shrunk to a dot, refused
    assert np.all(np.isnan(aligned_errors_mm(metres, dense)))


def test_the_run_metrics_give_no_alignment_for_contacts_at_one_place():
    # a run that followed a few samples without moving: no similarity scales a point
    from whiskercal.contour.metrics import aligned_errors_mm, contour_metrics
    from whiskercal.twin.outlines import outline

    dense = outline("octagon").dense()
    one_place = np.repeat(dense[:1] + [0.2, 0.0], 5, axis=0)
    assert np.all(np.isnan(aligned_errors_mm(one_place, dense)))
    metrics = contour_metrics(one_place, dense)
    assert metrics["mean_error_mm"] > 0.0 and math.isnan(metrics["aligned_mean_error_mm"])
