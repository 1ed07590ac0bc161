"""The controller's corner logic on synthetic key points, with a kinematic robot (no twin)."""

import math

import numpy as np
import pytest

from whiskercal.follow import FollowConfig, Follower, surface_step
from whiskercal.runtime import TrackerState


class KinematicRobot:
    """Integrates the commands exactly: a robot with no object, no limits."""

    def __init__(self, pose):
        self._pose = np.asarray(pose, float)
        self.velocity, self.turn = np.zeros(2), 0.0

    def pose(self):
        return self._pose.copy()

    def command(self, velocity_mm_s, turn_rad_s):
        self.velocity, self.turn = np.asarray(velocity_mm_s, float), float(turn_rad_s)

    def step(self, dt_s):
        self._pose[:2] += self.velocity * dt_s
        self._pose[2] += self.turn * dt_s


class NoContact:
    """A tracker that never feels anything (the whisker is off the object)."""

    def update(self, z_uT):
        return TrackerState(False, None, None)


def _follower_that_lost_contact(config):
    """A follower that followed the x axis (object above it) and has just lost the surface."""
    follower = Follower(NoContact(), -5000.0, config, reach_mm=78.0)
    follower.contacted, follower._touching, follower.pressed = True, True, True
    follower.keys.extend(np.column_stack([np.arange(6) * 2.0, np.zeros(6)]))
    follower.tangent = np.array([1.0, 0.0])
    return follower


def test_the_smoothing_spline_steadies_the_predicted_direction_on_noisy_key_points():
    rng = np.random.default_rng(7)
    angles = np.arange(6) * 2.0 / 40.0  # 2 mm apart on a 40 mm corner arc
    exact = 40.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    true_direction = angles[-1] + math.pi / 2 + 1.0 / 40.0  # half a step further round
    misses = {0.0: [], 0.1: []}
    for _ in range(200):
        noisy = exact + rng.normal(0.0, 0.1, exact.shape)  # mm
        for noise_mm in misses:
            end, following = surface_step(noisy, noise_mm)
            step = following - end
            miss = (math.atan2(step[1], step[0]) - true_direction + math.pi) % (2 * math.pi) - math.pi
            misses[noise_mm].append(miss)
    rms = {k: math.degrees(float(np.sqrt(np.mean(np.square(v))))) for k, v in misses.items()}
    assert rms[0.1] < 0.6 * rms[0.0]  # deg: the smoothed spline scatters far less
    assert rms[0.1] < 8.0


def test_a_prediction_that_turns_far_moves_the_direction_only_a_little_but_is_not_ignored():
    config = FollowConfig()
    follower = _follower_that_lost_contact(config)
    turned = follower._turned_toward(np.array([math.cos(1.2), math.sin(1.2)]))  # 69 deg away
    assert math.degrees(math.atan2(turned[1], turned[0])) == pytest.approx(config.key_turn_max_deg, abs=1e-9)


def test_a_heading_that_lags_the_surface_slows_the_tangential_speed_until_it_stops():
    config = FollowConfig()
    follower = _follower_that_lost_contact(config)
    target = follower._target_heading()  # 70 deg: the whisker leans 20 deg back from +y
    speeds = []
    for lag_deg in (0.0, config.slow_heading_deg, 30.0, config.stop_heading_deg, 60.0):
        follower._integral, follower._last_error = 0.0, None
        velocity, turn = follower._action(-5000.0, np.array([0.0, -80.0, target - math.radians(lag_deg)]))
        speeds.append(float(velocity @ follower.tangent))
        if lag_deg:  # turning toward the surface's heading; faster once it stands still
            limit = config.turn_max_rad_s if lag_deg < config.stop_heading_deg else config.edge_turn_max_rad_s
            assert turn == pytest.approx(limit)
    assert speeds[0] == pytest.approx(config.total_speed_mm_s) == pytest.approx(speeds[1])
    assert speeds[2] == pytest.approx(speeds[0] * (45.0 - 30.0) / (45.0 - 20.0))
    assert speeds[3] == speeds[4] == 0.0


def test_after_losing_contact_it_backs_off_then_comes_in_along_the_last_key_points_normal():
    config = FollowConfig(search_turns=0)  # the first search line only (turns: below)
    follower = _follower_that_lost_contact(config)
    # the whisker had swung 40 deg past the heading the surface asks for (70 deg)
    robot = KinematicRobot([10.0 - 78.0 * math.cos(0.5), -78.0 * math.sin(0.5), 0.5])
    dt, phases, tips = 1.0 / config.rate_hz, [], []
    for _ in range(int(20 * config.rate_hz)):
        phases.append(follower.update(0.0, robot).phase)
        robot.step(dt)
        pose = robot.pose()
        tips.append(pose[:2] + 78.0 * np.array([math.cos(pose[2]), math.sin(pose[2])]))
    held = int(round(config.lost_after_s * config.rate_hz))  # a short gap is not a loss
    assert phases[:held] == ["follow"] * held and phases[held] == "back-off"
    assert "search" in phases
    assert phases.count("back-off") == int(config.backoff_s * config.rate_hz)
    heading = robot.pose()[2]
    assert math.degrees(heading) == pytest.approx(70.0, abs=2.0)
    # the free tip was brought to 10 mm short of the last key point (10, 0) on the line of that
    # heading, outside the object, and then moved along that line toward the key point
    along = np.array([math.cos(heading), math.sin(heading)])
    start = np.array([10.0, 0.0]) - config.search_standoff_mm * along
    assert min(np.linalg.norm(np.array(tips) - start, axis=1)) < 0.6
    offset = tips[-1] - start
    assert abs(offset @ np.array([-along[1], along[0]])) < 0.6  # mm off the line
    assert offset @ along > 5.0


def test_while_pressing_it_turns_toward_the_surface_but_does_not_move_along_it():
    config = FollowConfig()
    follower = _follower_that_lost_contact(config)
    lagging = follower._target_heading() - math.radians(30.0)
    velocity, turn = follower._action(-3000.0, np.array([0.0, -80.0, lagging]), moving=False)
    assert turn == config.turn_max_rad_s  # the heading follows the sliding tip
    assert velocity @ follower.tangent == pytest.approx(0.0, abs=1e-12)
    assert velocity @ np.array([0.0, 1.0]) > 0.0  # pressing toward the object (above the x axis)


def test_a_tip_missing_for_a_few_samples_holds_still_and_does_not_count_as_lost():
    config = FollowConfig()
    follower = _follower_that_lost_contact(config)
    robot = KinematicRobot([0.0, -80.0, follower._target_heading()])
    steps = [follower.update(0.0, robot) for _ in range(int(round(config.lost_after_s * config.rate_hz)))]
    assert all(step.phase == "follow" and not np.any(step.velocity_mm_s) for step in steps)
    assert follower._backing == 0  # not backing off: the contact is not lost yet
    assert follower.update(0.0, robot).phase == "back-off"


def test_a_search_that_passes_the_last_key_point_without_a_contact_stops_for_good():
    config = FollowConfig(search_turns=0)  # no turns about the key point (below)
    follower = _follower_that_lost_contact(config)
    robot = KinematicRobot([10.0 - 78.0 * math.cos(1.2), -78.0 * math.sin(1.2), 1.2])
    dt, phases = 1.0 / config.rate_hz, []
    for _ in range(int(30 * config.rate_hz)):  # no object: the surface is never found again
        phases.append(follower.update(0.0, robot).phase)
        robot.step(dt)
    pose = robot.pose()
    tip = pose[:2] + 78.0 * np.array([math.cos(pose[2]), math.sin(pose[2])])
    along = np.array([math.cos(pose[2]), math.sin(pose[2])])
    assert follower.gave_up and phases[-1] == "gave-up" and "search" in phases
    assert (tip - np.array([10.0, 0.0])) @ along == pytest.approx(config.search_standoff_mm, abs=0.1)
    assert not np.any(robot.velocity) and robot.turn == 0.0  # stopped
    assert follower.update(-5000.0, robot).phase == "gave-up"  # and stays stopped


class Touching:
    """A tracker that always feels a tip 70 mm along the whisker, 30 mm to its right."""

    def update(self, z_uT):
        return TrackerState(True, np.array([70.0, -30.0]), np.array([70.0, -30.0]))


def test_backing_off_goes_on_for_its_whole_time_even_if_the_wire_still_touches():
    config = FollowConfig()
    follower = _follower_that_lost_contact(config)
    follower._backing, follower._touching = 30, False  # backing off, 30 samples left
    follower.tracker = Touching()
    robot = KinematicRobot([0.0, -80.0, follower._target_heading()])
    phases = [follower.update(-5000.0, robot).phase for _ in range(31)]
    assert phases[:30] == ["back-off"] * 30 and phases[30] != "back-off"


def test_a_search_that_finds_nothing_turns_toward_the_object_about_the_last_key_point():
    config = FollowConfig()
    follower = _follower_that_lost_contact(config)  # followed the x axis, the object above it
    robot = KinematicRobot([10.0 - 78.0 * math.cos(1.2), -78.0 * math.sin(1.2), 1.2])
    dt, lines = 1.0 / config.rate_hz, []
    for _ in range(int(90 * config.rate_hz)):  # no object: nothing is ever found
        step = follower.update(0.0, robot)
        if step.phase == "search" and not step.turn_rad_s and np.any(step.velocity_mm_s):
            lines.append((robot.pose(), step.velocity_mm_s))  # coming in along the whisker
        robot.step(dt)
    assert follower.gave_up
    headings = sorted({round(math.degrees(pose[2])) for pose, _ in lines})
    # the surface's direction turned by 45° toward the object (counter-clockwise) each time
    assert headings == [70, 115, 160, 205, 250]
    for pose, velocity in lines:  # each line runs through the last key point (10, 0)
        along = np.array([math.cos(pose[2]), math.sin(pose[2])])
        tip = pose[:2] + 78.0 * along
        assert abs((tip - [10.0, 0.0]) @ np.array([-along[1], along[0]])) < 0.6
        np.testing.assert_allclose(velocity, config.approach_speed_mm_s * along, atol=0.2)  # within 2°


class HeldAt:
    """A tracker whose tip stays at one world point (a tip held in a concave corner) or, with
    ``world_mm`` None, at one point of the whisker frame (a tip that moves with the sensor)."""

    def __init__(self, robot, world_mm=None):
        self.robot, self.world_mm = robot, world_mm

    def update(self, z_uT):
        if self.world_mm is None:
            tip = np.array([78.0, 0.0])
        else:
            x, y, heading = self.robot.pose()
            c, s = math.cos(heading), math.sin(heading)
            tip = np.array([[c, s], [-s, c]]) @ (np.asarray(self.world_mm) - [x, y])
        return TrackerState(True, tip, tip)


def _following_along_x(tracker_at):
    """A follower following the x axis toward -x, the object below (y < 0), at its target."""
    config = FollowConfig()
    heading = math.radians(-110.0)  # leaning 20° back from the inward normal (-y)
    robot = KinematicRobot([26.7, 73.3, heading])  # the free tip near the origin
    follower = Follower(tracker_at(robot), -5000.0, config, reach_mm=78.0)
    follower.contacted, follower._touching, follower.pressed = True, True, True
    follower.keys.extend(np.column_stack([12.0 - np.arange(6) * 2.0, np.zeros(6)]))
    follower.tangent = np.array([-1.0, 0.0])
    return follower, robot, config


@pytest.mark.parametrize("z_uT, turned_deg", [(-3000.0, 135.0), (-5000.0, -160.0)])
def test_a_tip_held_while_the_sensor_moves_along_turns_the_surface(z_uT, turned_deg):
    follower, robot, config = _following_along_x(lambda robot: HeldAt(robot, (1.0, 0.0)))
    _until_the_surface_turns(follower, robot, z_uT)  # 8 mm/s along: 1.5 mm in 0.19 s
    # the deflection falling (a surface ahead): turned clockwise, away from the object on the
    # left, by 45°; kept (the tip on an edge): counter-clockwise, toward it, by 20° (more would
    # lean the whisker past a rounded edge's normal: it slips off); once: the sensor then only
    # turns about the held tip while its heading catches up
    assert math.degrees(math.atan2(follower.tangent[1], follower.tangent[0])) == pytest.approx(turned_deg)
    np.testing.assert_allclose(np.array(follower.keys), [[1.0, 0.0]], atol=1e-9)


def test_a_tip_that_moves_along_with_the_sensor_is_not_held():
    follower, robot, config = _following_along_x(lambda robot: HeldAt(robot))
    for _ in range(int(2 * config.rate_hz)):
        follower.update(-5000.0, robot)
        robot.step(1.0 / config.rate_hz)
    assert abs(math.degrees(math.atan2(follower.tangent[1], follower.tangent[0]))) > 170.0  # still -x
    assert robot.pose()[0] < 26.7 - 10.0  # and it moved along


def test_a_step_between_key_points_that_turns_sharply_toward_the_object_is_an_edge():
    follower, robot, _ = _following_along_x(lambda robot: HeldAt(robot))
    follower._samples = follower.config.key_every - 1  # the next contact is a key point
    follower._key_point(np.array([0.5, -1.5]), robot.pose())  # down past the edge at x = 2 mm
    np.testing.assert_allclose(follower.tangent, np.array([-1.5, -1.5]) / math.hypot(1.5, 1.5))
    assert len(follower.keys) == 2
    follower.keys.clear()
    follower.keys.extend(np.column_stack([12.0 - np.arange(6) * 2.0, np.zeros(6)]))
    follower.tangent = np.array([-1.0, 0.0])
    follower._samples = follower.config.key_every - 1
    follower._key_point(np.array([0.0, -0.2]), robot.pose())  # 6° off: scatter, not an edge
    assert len(follower.keys) == 6 and follower.tangent[1] > -math.sin(math.radians(10.0)) - 1e-9


def test_following_at_the_target_without_a_new_key_point_turns_toward_the_object():
    follower, robot, config = _following_along_x(lambda robot: HeldAt(robot, (1.0, 0.0)))
    follower.config = config = FollowConfig(stall_travel_mm=1e3)  # the held-tip rule kept out
    angles = []
    for _ in range(int(1.9 * config.rate_hz)):  # the contact stays put on an edge, z at target
        follower.update(-5000.0, robot)
        robot.step(1.0 / config.rate_hz)
        angles.append(round(math.degrees(math.atan2(follower.tangent[1], follower.tangent[0]))))
    # after 1 s, counter-clockwise by 20° (toward the object below); not again within the next
    # second (the time is counted afresh)
    assert angles[int(0.9 * config.rate_hz)] == 180 and set(angles[int(1.1 * config.rate_hz):]) == {-160}


def _angle_deg(direction):
    return math.degrees(math.atan2(direction[1], direction[0]))


def test_a_key_point_that_steps_back_against_the_surface_is_a_tip_held_in_a_concave_corner():
    follower, robot, _ = _following_along_x(lambda robot: HeldAt(robot))  # key points 12 .. 2 mm
    follower._samples = follower.config.key_every - 1  # the next contact is a key point
    follower._key_point(np.array([4.5, 0.5]), robot.pose())  # 2.5 mm back (+x) from the last
    # no surface turns back on itself: the surface ahead turns away from the object (clockwise)
    # by 45°, about the last key point before the step back
    assert _angle_deg(follower.tangent) == pytest.approx(135.0)
    np.testing.assert_allclose(np.array(follower.keys), [[2.0, 0.0]])
    assert follower._turning


class SlowedAlong:
    """A tracker whose tip starts at the world point (1, 0) mm (where the key points of
    ``_following_along_x`` lead) and goes along the x axis at ``share`` of the sensor's own
    motion along it."""

    def __init__(self, robot, share):
        self.robot, self.share, self.x0 = robot, share, None

    def update(self, z_uT):
        x, y, heading = self.robot.pose()
        self.x0 = x if self.x0 is None else self.x0
        world = np.array([1.0 + self.share * (x - self.x0), 0.0])
        c, s = math.cos(heading), math.sin(heading)
        tip = np.array([[c, s], [-s, c]]) @ (world - [x, y])
        return TrackerState(True, tip, tip)


def _until_the_surface_turns(follower, robot, z_uT, seconds=0.5):
    """Follow at ``z_uT`` until a corner rule turns the surface's direction (by more than the
    key points' 10° could), or ``seconds`` pass; return the last step."""
    before = _angle_deg(follower.tangent)
    for _ in range(int(seconds * follower.config.rate_hz)):
        step = follower.update(z_uT, robot)
        if abs((_angle_deg(follower.tangent) - before + 180.0) % 360.0 - 180.0) > 15.0:
            return step
        robot.step(1.0 / follower.config.rate_hz)
    return step


@pytest.mark.parametrize("z_uT, share, turned", [(-5600.0, 0.5, True), (-5400.0, 0.5, False),
                                                 (-5600.0, 1.0, False)])
def test_a_deflection_past_the_target_with_the_tip_lagging_the_motion_is_a_surface_ahead(
        z_uT, share, turned):
    follower, robot, config = _following_along_x(lambda robot: SlowedAlong(robot, share))
    _until_the_surface_turns(follower, robot, z_uT)  # 1.12 (or 1.08) times the target's |z|
    # a tip that goes on with the sensor is pressed harder by a direction not yet the surface's
    # (after a search, say): the surface does not turn (on a long whisker at a small target it
    # used to be read as a concave corner, and the sensor stopped on a convex object)
    assert abs(_angle_deg(follower.tangent)) == pytest.approx(135.0 if turned else 180.0, abs=1.0)


def test_a_held_tip_whose_deflection_rises_as_the_sensor_moves_along_is_a_concave_corner():
    follower, robot, config = _following_along_x(lambda robot: HeldAt(robot, (1.0, 0.0)))
    samples = int(0.5 * config.rate_hz)
    for index in range(samples):  # kept at the target and rising, below the rise rule's 1.1
        follower.update(-5000.0 - 300.0 * index / samples, robot)
        robot.step(1.0 / config.rate_hz)
    assert _angle_deg(follower.tangent) == pytest.approx(135.0)  # away from the object, not an edge


def test_after_a_corner_rule_it_turns_about_the_corner_and_keeps_no_key_point_until_round():
    follower, robot, config = _following_along_x(lambda robot: SlowedAlong(robot, 0.5))
    _until_the_surface_turns(follower, robot, -5600.0)  # the rise rule: the corner is that
    robot.step(1.0 / config.rate_hz)                     # sample's contact
    corner = np.array(follower.keys[-1])
    heading = robot.pose()[2]
    for _ in range(int(1.0 * config.rate_hz)):
        step = follower.update(-5000.0, robot)
        pose = robot.pose()
        # the base moves so that the corner stays put while it turns, and (the PID) along the
        # normal: no motion along the surface
        arm = pose[:2] - corner
        own = step.velocity_mm_s - step.turn_rad_s * np.array([-arm[1], arm[0]])
        assert own @ follower.tangent == pytest.approx(0.0, abs=1e-9)
        # mm/s: the PID's integral of the high samples before the rule (0.19 s, 600 µT over)
        assert np.linalg.norm(own) < config.ki_mm_s2_per_uT * 600.0 * 0.25
        assert np.all(np.isnan(step.contact_mm))  # a held tip's estimate is not on the surface
        robot.step(1.0 / config.rate_hz)
    assert len(follower.keys) == 1 and follower._turning
    assert math.degrees(heading - robot.pose()[2]) > 5.0  # turning clockwise, toward -155°


@pytest.mark.parametrize("past_edge", [True, False])
def test_a_search_meeting_the_object_on_the_far_side_comes_in_further_along(past_edge):
    config = FollowConfig()
    follower = _follower_that_lost_contact(config)  # followed +x, the object above, last key (10, 0)
    follower.tracker = Touching()
    follower._touching, follower._past_edge = False, past_edge  # searching
    robot = KinematicRobot([0.0, -80.0, follower._target_heading()])
    assert follower.update(400.0, robot).phase == "back-off"  # z of the wrong sign: the far side
    # past an edge: the line came in over the edge's rounding; the same direction, 10 mm on.
    # otherwise a surface ahead: the direction turns 45° away (clockwise), 10 mm past the corner
    angle = 0.0 if past_edge else -45.0
    assert _angle_deg(follower.tangent) == pytest.approx(angle)
    expected = np.array([10.0, 0.0]) + config.search_standoff_mm * np.array(
        [math.cos(math.radians(angle)), math.sin(math.radians(angle))])
    np.testing.assert_allclose(np.array(follower.keys), [expected], atol=1e-9)


@pytest.mark.parametrize("bent, stops", [(True, True), (False, False)])
def test_a_concave_corner_whose_turn_would_swing_the_base_onto_the_wall_left_stops_the_sensor(bent, stops):
    # bent: the tip 70 mm along the whisker and 30 mm to its right (the chord 23° clockwise of
    # the heading, as a whisker pressed at the target is); turning about the corner to the
    # heading the 45° turn asks for (-155°) would put the base 2.7 mm above the wall it leaves
    # (y = 0 through the corner). Straight (the tip on the whisker's axis): 33 mm above it.
    follower, robot, config = _following_along_x(lambda robot: SlowedAlong(robot, 0.5))
    heading = robot.pose()[2]
    tip_mm = np.array([70.0, -30.0] if bent else [78.0, 0.0])  # the contact (1, 0) seen from the base
    turn = np.array([[math.cos(heading), -math.sin(heading)], [math.sin(heading), math.cos(heading)]])
    robot._pose[:2] = np.array([1.0, 0.0]) - turn @ tip_mm
    step = _until_the_surface_turns(follower, robot, -5600.0)  # the rise rule: a surface ahead
    assert _angle_deg(follower.tangent) == pytest.approx(135.0, abs=1.0)
    assert follower.gave_up == stops
    if stops:  # stopped for good rather than driven into the wall
        assert step.phase == "gave-up" and not np.any(step.velocity_mm_s) and step.turn_rad_s == 0.0
        assert follower.update(-5000.0, robot).phase == "gave-up"
    else:
        assert step.phase == "follow" and follower._turning


@pytest.mark.parametrize("gradual, stops", [(True, True), (False, False)])
def test_a_deflection_that_falls_by_half_step_by_step_while_touching_stops_the_sensor(gradual, stops):
    # a tip held in a concave corner and pushed along the wire as the sensor moves on: |z| falls
    # over tens of samples, the wire still touching (turning about the corner, or backing off
    # with the tip caught between both walls, drove the wire into the solid); a slip falls in
    # one snap and is not that
    follower, robot, config = _following_along_x(lambda robot: HeldAt(robot))
    for _ in range(int(0.2 * config.rate_hz)):  # following at the target
        follower.update(-5000.0, robot)
        robot.step(1.0 / config.rate_hz)
    falls = np.linspace(-5000.0, -2000.0, 25) if gradual else np.array([-2000.0])
    steps = [follower.update(z_uT, robot) for z_uT in falls]
    assert any(step.slip for step in steps)  # either way a slip's fall (|z| under half its most)
    assert follower.gave_up == stops
    assert (steps[-1].phase == "gave-up") == stops
    if stops:
        assert not np.any(steps[-1].velocity_mm_s) and steps[-1].turn_rad_s == 0.0
