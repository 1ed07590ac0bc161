"""The twin through the same door as a robot: ``contour run --record`` writes the stream and the
base poses as a ROS 2 bag, and ``replay`` of that bag with those poses places every contact
where the run's own follower estimated it."""

import json

import numpy as np
from click.testing import CliRunner
from tests_follow_artifact import calibration_path

from whiskercal.cli import cli
from whiskercal.contour import read_contour_run


def _invoke(*args):
    result = CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return result


def test_a_recorded_run_replays_to_its_own_estimates(tmp_path):
    artifact, bag = calibration_path(), tmp_path / "run-bag"
    _invoke("-q", "contour", "run", "--shape", "cylinder", "--artifact", artifact, "--duration", 6,
            "--seed", 1, "--out", tmp_path / "run.h5", "--record", bag, "--json")
    run = read_contour_run(tmp_path / "run.h5")
    rest = run.config["record"]["rest_field_uT"]
    assert (bag / "metadata.yaml").is_file() and (bag / "run-bag.mcap").is_file()
    result = _invoke("replay", bag, "--artifact", artifact, "--out", tmp_path / "out",
                     "--rest-uT", rest[1], "--axial-rest-uT", rest[2], "--poses", "auto",
                     "--max-pose-gap-ms", 1, "--json")
    summary = json.loads(result.output)
    assert summary["samples"] == len(run.columns["t_s"]) and summary["axes"] == 3
    assert summary["world"]["samples_without_pose"] == 0
    track = np.genfromtxt(tmp_path / "out" / "track.csv", delimiter=",", names=True)
    replayed = np.column_stack([track["world_x_mm"], track["world_y_mm"]])
    estimate = np.asarray(run.columns["estimate_mm"], float)
    both = np.isfinite(estimate[:, 0]) & np.isfinite(replayed[:, 0])
    assert np.count_nonzero(both) > 0.5 * len(estimate)
    assert np.max(np.linalg.norm(replayed[both] - estimate[both], axis=1)) < 0.01
    # every estimate the run made has its replayed point (the follower drops some, never adds)
    assert np.all(np.isfinite(replayed[np.isfinite(estimate[:, 0])]))


def test_an_existing_bag_is_refused_before_the_run_and_force_replaces_it(tmp_path):
    (tmp_path / "bag").mkdir()
    result = CliRunner().invoke(cli, ["contour", "run", "--shape", "cylinder", "--artifact",
                                      str(calibration_path()), "--duration", "1", "--out",
                                      str(tmp_path / "run.h5"), "--record", str(tmp_path / "bag")])
    assert result.exit_code == 2 and "already exists: pass --force to replace it" in result.output
    assert not (tmp_path / "run.h5").exists()
    forced = CliRunner().invoke(cli, ["contour", "run", "--shape", "cylinder", "--artifact",
                                      str(calibration_path()), "--duration", "1", "--out",
                                      str(tmp_path / "run.h5"), "--record", str(tmp_path / "bag"),
                                      "--force"])
    assert forced.exit_code == 0, forced.output
    assert (tmp_path / "bag" / "bag.mcap").is_file()  # the empty folder replaced by the bag
