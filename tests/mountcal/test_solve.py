"""The mount's least squares on touches made from a known mount (no twin): it recovers the
mount, states an uncertainty that grows with the tip error, and refuses what cannot identify it."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.cli import cli
from whiskercal.errors import UsageError
from whiskercal.mount import Mount, read_mount
from whiskercal.mountcal import Cylinder, parse_cylinder, parse_twin_url, plan_presses, solve_mount

CYLINDER = Cylinder((20.0, -10.0), 80.0)
TRUE = Mount(1.4, 31.2, 92.1)


def _touches(mount: Mount, rng, noise_mm: float = 0.0, geometries=9):
    """Effector poses and base-frame tips that put each tip on the cylinder through ``mount``:
    tips along the whisker's arc at several deflections, met at several tilts round the arc."""
    poses, tips = [], []
    for index in range(36):
        station = math.radians(120.0 + 120.0 * (index // geometries) / 3)
        tilt = math.radians(6.0 + 8.0 * (index % 3))
        swing = math.radians(5.0 + 10.0 * ((index // 3) % 3))
        tip = 76.0 * np.array([math.cos(swing), -math.sin(swing)])
        heading = station + math.pi - tilt
        surface = np.asarray(CYLINDER.center_mm) + CYLINDER.radius_mm * np.array(
            [math.cos(station), math.sin(station)])
        turn = np.array([[math.cos(heading), -math.sin(heading)], [math.sin(heading), math.cos(heading)]])
        base = surface - turn @ tip
        # the effector that puts the base frame there through the mount
        yaw = heading - math.radians(mount.yaw_deg)
        c, s = math.cos(yaw), math.sin(yaw)
        effector = np.array([base[0] - c * mount.x_mm + s * mount.y_mm,
                             base[1] - s * mount.x_mm - c * mount.y_mm, yaw])
        poses.append(effector)
        tips.append(tip + rng.normal(0.0, noise_mm, 2))
    return np.array(poses), np.array(tips)


def test_noise_free_touches_give_the_mount_back():
    poses, tips = _touches(TRUE, np.random.default_rng(0))
    fit = solve_mount(poses, tips, CYLINDER, Mount(0.0, 30.0, 90.0))
    assert abs(fit.mount.x_mm - TRUE.x_mm) < 1e-6 and abs(fit.mount.y_mm - TRUE.y_mm) < 1e-6
    assert abs(fit.mount.yaw_deg - TRUE.yaw_deg) < 1e-6 and max(fit.std) < 1e-6


def test_the_stated_uncertainty_covers_noisy_tips_and_grows_with_the_tip_error():
    rng = np.random.default_rng(7)
    poses, tips = _touches(TRUE, rng, noise_mm=0.05)
    fit = solve_mount(poses, tips, CYLINDER, Mount(0.0, 30.0, 90.0))
    for key, std in zip(("x_mm", "y_mm", "yaw_deg"), fit.std):
        assert abs(getattr(fit.mount, key) - getattr(TRUE, key)) < 4 * std
    shared = solve_mount(poses, tips, CYLINDER, Mount(0.0, 30.0, 90.0), tip_error_mm=0.1,
                         geometries=np.arange(36) % 9)
    assert all(a > b for a, b in zip(shared.std, fit.std))
    assert shared.summary()["std_calibration"]["x_mm"] > 0


def test_too_few_touches_are_one_line():
    poses, tips = _touches(TRUE, np.random.default_rng(0))
    with pytest.raises(UsageError, match="at least 6"):
        solve_mount(poses[:5], tips[:5], CYLINDER)


def test_one_geometry_pressed_from_one_side_is_degenerate():
    poses, tips = _touches(TRUE, np.random.default_rng(0))
    same = np.repeat(poses[:1], 12, axis=0), np.repeat(tips[:1], 12, axis=0)
    with pytest.raises(UsageError, match="degenerate geometry"):
        solve_mount(*same, CYLINDER)


def test_unknown_objects_and_twin_options_are_one_line():
    with pytest.raises(UsageError, match="circle:d=D"):
        parse_cylinder("polygon:n=8,side=70,r=30", None)
    with pytest.raises(UsageError, match="--object-pose"):
        parse_cylinder("circle:d=160", "1,2,3")
    assert parse_cylinder("circle:d=50", "10,-5") == Cylinder((10.0, -5.0), 25.0)
    with pytest.raises(UsageError, match="unknown sim:// option"):
        parse_twin_url("sim://cylinder?mount=1,2,3")
    with pytest.raises(UsageError, match="mount_error"):
        parse_twin_url("sim://cylinder?mount_error=1,2")
    with pytest.raises(UsageError, match="cylinder"):
        parse_twin_url("sim://octagon")
    with pytest.raises(UsageError, match="deflection target"):
        plan_presses(None, [180.0])


@pytest.mark.parametrize("words, message", [
    (["--object", "polygon:n=8,side=70,r=30"], "touches a cylinder"),
    (["--robot", "sim://cylinder?mount_error=9,9,99"], "sim:// option mount_error deg"),
    (["--stations", "0"], "--stations"),
    (["--robot", "sim://cylinder", "--box", "0,1,0,1"], "--box drives a robot"),
])
def test_bad_command_lines_are_one_line(tmp_path, words, message):
    artifact = tmp_path.parent / "missing.h5"
    result = CliRunner().invoke(cli, ["mount-cal", "--artifact", str(artifact), "--out",
                                      str(tmp_path / "mount.toml"), *words])
    assert result.exit_code != 0 and message in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and not (tmp_path / "mount.toml").exists()


def test_an_existing_mount_file_is_refused_without_force(tmp_path):
    out = tmp_path / "mount.toml"
    out.write_text("[mount]\nx_mm = 1.0\n")
    result = CliRunner().invoke(cli, ["mount-cal", "--artifact", str(tmp_path / "cal.h5"),
                                      "--out", str(out)])
    assert result.exit_code != 0 and "--force" in result.stderr
    assert read_mount(out).x_mm == 1.0
