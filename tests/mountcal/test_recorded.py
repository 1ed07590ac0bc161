"""mount-cal from a recording: the held touches of a replay track, fitted as pressed ones are."""

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from goals import MARGIN
from test_solve import CYLINDER, TRUE, _touches

from whiskercal.artifacts.replay_track import COLUMNS, write_track
from whiskercal.cli import cli
from whiskercal.errors import UsageError
from whiskercal.mount import Mount, read_mount
from whiskercal.mountcal import Routine, mount_cal_recorded

CAL = Path(__file__).resolve().parents[1] / "fixtures" / "calibration-1.3.0-target.h5"
NO_MOUNT = "none (the poses are the sensor's base frame)"


def _track(path, mount_source=NO_MOUNT, noise_mm=0.02):
    """A replay track of a robot holding each touch 0.5 s at 100 Hz, moving 0.3 s between."""
    rng = np.random.default_rng(3)
    poses, tips = _touches(TRUE, rng)
    rows = []
    for index, (pose, tip) in enumerate(zip(poses, tips)):
        following = poses[(index + 1) % len(poses)]
        rows += [(pose, tip + rng.normal(0.0, noise_mm, 2), 1)] * 50
        rows += [(pose + (following - pose) * k / 30, np.full(2, np.nan), 0) for k in range(30)]
    n = len(rows)
    columns = {name: np.full(n, np.nan) for name in COLUMNS}
    pose, tip = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
    columns.update(t_s=np.arange(n) * 0.01, z_uT=np.full(n, -3000.0),
                   contact=np.array([r[2] for r in rows]), raw_x_mm=tip[:, 0], raw_y_mm=tip[:, 1],
                   base_x_mm=pose[:, 0], base_y_mm=pose[:, 1], base_heading_rad=pose[:, 2],
                   out_of_range=np.zeros(n), extrapolated=np.zeros(n))
    return write_track(path, columns, {"world": {"mount": mount_source}}, "twin-paper-75mm", {}, {})


def test_the_held_touches_of_a_track_give_the_mount(tmp_path):
    result = mount_cal_recorded(_track(tmp_path / "track.h5"), CAL,
                                Routine(CYLINDER, Mount(0.0, 30.0, 90.0)))
    assert len(result.touches) == 36
    for key, std in zip(("x_mm", "y_mm", "yaw_deg"), result.fit.std):
        assert abs(getattr(result.fit.mount, key) - getattr(TRUE, key)) <= MARGIN * std, key
    assert result.fit.std[0] < 1.0  # held means of 50 samples: the fit says something


def test_a_track_replayed_through_a_mount_is_refused(tmp_path):
    track = _track(tmp_path / "track.h5", mount_source="mount.toml")
    with pytest.raises(UsageError, match="no --mount"):
        mount_cal_recorded(track, CAL, Routine(CYLINDER))


def test_the_command_fits_a_track(tmp_path):
    track = _track(tmp_path / "track.h5")
    out = tmp_path / "mount.toml"
    result = CliRunner().invoke(cli, ["mount-cal", "--track", str(track), "--artifact", str(CAL),
                                      "--object", "circle:d=160", "--object-pose", "20,-10",
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert abs(read_mount(out).yaw_deg - TRUE.yaw_deg) < 1.0 and "wrote" in result.stdout
