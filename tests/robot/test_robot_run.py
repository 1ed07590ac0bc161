"""``contour run --robot`` against the twin's rosbridge server on loopback: a short run round
the octagon, and each safety behaviour (dry run, watchdog, zero twist on every way out, limits,
the workspace box, a lost connection leaving a readable partial run)."""

import threading
import time

import numpy as np
import pytest
from click.testing import CliRunner
from served_twin import CALIBRATION, following_calibration, serve, twin_server

from whiskercal.cli import cli
from whiskercal.contour import read_contour_run
from whiskercal.contour.metrics import contour_metrics
from whiskercal.contour.on_robot import RobotSetup, contour_on_robot
from whiskercal.errors import UsageError
from whiskercal.robot import ConnectionLostError, Safety, WatchdogError, WorkspaceError
from whiskercal.twin.outlines import outline

pytestmark = pytest.mark.timeout(90)


def _run(server, out, duration_s: float, lines=None, calibration=CALIBRATION, **setup):
    """contour_on_robot against ``server``; the record (raises what stopped it)."""
    setup.setdefault("safety", Safety(watchdog_s=0.5))
    echo = (lines.append if lines is not None else (lambda line: None))
    return contour_on_robot(RobotSetup(server.url, **setup), calibration, out,
                            duration_s=duration_s, echo=echo)


def _stopped(server) -> bool:
    """The last twist the twin took is zero, and its base no longer moves."""
    (vx, vy), turn = server.last_twist
    before = server.mobile.pose()
    time.sleep(0.1)
    return vx == vy == turn == 0.0 and np.allclose(server.mobile.pose(), before)


def _later(seconds: float, action) -> threading.Timer:
    timer = threading.Timer(seconds, action)
    timer.start()
    return timer


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_a_short_run_goes_along_the_octagon_with_no_truth_in_the_client(tmp_path):
    calibration = following_calibration()
    server = twin_server("octagon", 300.0, seed=1)
    with serve(server):
        record = _run(server, tmp_path / "run.h5", 7.0, calibration=calibration)
        assert _stopped(server)  # the run's end sends the zero twist too
    run = read_contour_run(tmp_path / "run.h5")
    columns = run.columns
    assert run.complete and run.shape == "unknown" and np.isnan(columns["true_tip_mm"]).all()
    following = (columns["phase"] == "follow") & np.isfinite(columns["estimate_mm"][:, 0])
    assert following.sum() > 200 and abs(run.config["robot"]["rate_hz"] - 300.0) < 1.0
    # against the served outline, world frame, no alignment: the in-process loop's accuracy
    metrics = contour_metrics(columns["estimate_mm"][following], outline("octagon").dense())
    assert metrics["mean_error_mm"] < 0.3
    assert abs(run.config["robot"]["rest_uT"][0] - server.rest_uT[1]) < 2.0
    assert run.config["robot"]["sent"] >= len(columns["t_s"]) and record.path


def test_a_recorded_robot_run_holds_each_sample_and_the_base_pose_through_the_mount(tmp_path):
    from whiskercal.mount import Mount
    from whiskercal.recording import read_poses, read_recording

    server = twin_server("octagon", 100.0)
    mount, bag = Mount(x_mm=12.0, y_mm=-3.5, yaw_deg=90.0), tmp_path / "robot-bag"
    (bag).mkdir()  # an earlier bag: refused without force, replaced with it
    with pytest.raises(UsageError, match="already exists: pass --force"):
        contour_on_robot(RobotSetup(server.url), CALIBRATION, tmp_path / "r.h5", duration_s=1.0,
                         record=bag)
    with serve(server):
        record = contour_on_robot(RobotSetup(server.url, mount=mount, dry_run=True,
                                             safety=Safety(watchdog_s=0.5)),
                                  CALIBRATION, tmp_path / "run.h5", duration_s=1.0,
                                  echo=lambda line: None, record=bag, force=True)
    columns, rest = record.columns, record.config["robot"]["rest_uT"]
    assert record.config["robot"]["record"] == str(bag)
    stream = read_recording(bag)
    assert len(stream) == len(columns["t_s"]) > 50 and stream.axes == 3
    np.testing.assert_allclose(stream.y_uT - rest[0], columns["z_uT"], atol=1e-6)
    poses = read_poses("auto", bag)
    assert len(poses) == len(columns["t_s"])
    # the robot held still (a dry run): every pose is the run's own base pose, not the effector's
    np.testing.assert_allclose(poses.pose, columns["pose"], atol=1e-6)
    assert np.linalg.norm(poses.pose[0, :2] - server.mobile.pose()[:2]) > 1.0


def test_a_dry_run_prints_every_twist_and_sends_none(tmp_path):
    server = twin_server("octagon", 100.0)
    lines: list[str] = []
    with serve(server):
        start = server.mobile.pose()
        _run(server, tmp_path / "dry.h5", 1.0, lines, dry_run=True)
        time.sleep(0.1)
        assert server.twists == 0 and np.allclose(server.mobile.pose(), start)
    assert len(lines) > 100 and all("dry run: not sent" in line for line in lines)
    assert read_contour_run(tmp_path / "dry.h5").config["robot"]["sent"] == 0
    # a robot's run holds no object: the twin's report says so in one line
    report = CliRunner().invoke(cli, ["contour", "report", str(tmp_path / "dry.h5"), "--out",
                                      str(tmp_path / "rep")])
    assert report.exit_code == 2 and "run on a robot" in report.stderr


def test_the_watchdog_stops_a_silent_robot_with_a_zero_twist_and_a_partial_run(tmp_path):
    server = twin_server("octagon", 300.0)
    with serve(server):
        timer = _later(1.5, lambda: setattr(server, "publishing", False))
        with pytest.raises(WatchdogError, match="no field sample for 200 ms"):
            _run(server, tmp_path / "w.h5", 20.0, safety=Safety(watchdog_s=0.2))
        timer.cancel()
        assert _stopped(server)
    run = read_contour_run(tmp_path / "w.h5")
    assert not run.complete and 100 < len(run.columns["t_s"]) < 600
    assert "watchdog" in run.config["robot"]["stopped_by"]


def test_a_pose_topic_nobody_publishes_trips_the_watchdog_before_anything_moves(tmp_path):
    from whiskercal.robot import RobotTopics

    server = twin_server("octagon", 100.0)
    with serve(server):
        with pytest.raises(WatchdogError, match="no pose for 200 ms"):
            _run(server, tmp_path / "p.h5", 5.0, safety=Safety(watchdog_s=0.2),
                 topics=RobotTopics(pose="/elsewhere/pose"))
        (vx, vy), turn = server.last_twist
        assert vx == vy == turn == 0.0  # only zero twists went out


def test_a_lost_connection_ends_non_zero_with_one_line_and_a_readable_partial_run(tmp_path):
    server = twin_server("octagon", 300.0)
    out = tmp_path / "lost.h5"
    with serve(server) as served:
        timer = _later(1.5, served.stop)
        result = CliRunner().invoke(cli, ["-q", "contour", "run", "--robot", server.url,
                                          "--artifact", str(CALIBRATION), "--duration", "20",
                                          "--watchdog-ms", "1000", "--out", str(out)])
        timer.join()
    assert result.exit_code == ConnectionLostError.exit_code, result.output
    assert result.stderr.count("\n") == 1 and "connection" in result.stderr and "lost" in result.stderr
    run = read_contour_run(out)
    assert not run.complete and len(run.columns["t_s"]) > 100


def test_ctrl_c_sends_a_zero_twist_and_keeps_the_partial_run(tmp_path):
    server = twin_server("octagon", 300.0)

    def interrupted(t_s: float) -> None:
        if t_s > 0.5:
            raise KeyboardInterrupt

    with serve(server):
        with pytest.raises(KeyboardInterrupt):
            contour_on_robot(RobotSetup(server.url, safety=Safety(watchdog_s=0.5)), CALIBRATION,
                             tmp_path / "c.h5", duration_s=20.0, on_progress=interrupted)
        assert _stopped(server)
    run = read_contour_run(tmp_path / "c.h5")
    assert not run.complete and len(run.columns["t_s"]) >= 300


def test_an_error_inside_the_loop_still_sends_the_zero_twist(tmp_path):
    from whiskercal import runtime
    from whiskercal.contour.robot_run import RobotLoop, run_on_robot
    from whiskercal.robot import FieldTopic, RobotTopics, RosbridgeLink, RosbridgeRobot

    class Failing:  # a tracker that breaks after a second of samples
        def __init__(self, tracker):
            self.tracker, self.calls = tracker, 0

        def update(self, *values):
            self.calls += 1
            if self.calls > 300:
                raise RuntimeError("a bug")
            return self.tracker.update(*values)

    calibration = runtime.load(CALIBRATION)
    server = twin_server("octagon", 300.0)
    with serve(server):
        link = RosbridgeLink(server.url, RobotTopics())
        with pytest.raises(RuntimeError, match="a bug"):
            with RosbridgeRobot(link, safety=Safety(watchdog_s=0.5)) as robot:
                run_on_robot(robot, FieldTopic(link),
                             lambda rate: Failing(calibration.tracker("clip", rate_hz=rate)),
                             calibration.target_z_uT, RobotLoop(20.0))
        assert server.last_twist is not None and _stopped(server)


def test_commands_are_clipped_to_the_speed_and_turn_limits(tmp_path):
    server = twin_server("octagon", 300.0)
    with serve(server):
        _run(server, tmp_path / "slow.h5", 1.5, safety=Safety(speed_mm_s=1.0, turn_rad_s=0.01))
    robot = read_contour_run(tmp_path / "slow.h5").config["robot"]
    assert robot["clipped"] > 100 and 0.9 < server.fastest_mm_s <= 1.0 + 1e-9


def test_leaving_the_workspace_box_stops_the_run(tmp_path):
    server = twin_server("octagon", 300.0)
    x, y, _ = server.effector_pose()
    box = (x - 100.0, x + 100.0, y + 1.0, y + 100.0)  # the end effector starts just below it
    with serve(server):
        with pytest.raises(WorkspaceError, match="left the workspace box"):
            _run(server, tmp_path / "box.h5", 5.0, safety=Safety(box_mm=box))
        assert _stopped(server)
    assert not read_contour_run(tmp_path / "box.h5").complete
