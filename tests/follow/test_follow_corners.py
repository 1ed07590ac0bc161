"""The controller's phases and corner rules, driven through its public interface: a scripted
world (``follow_script``: a kinematic robot, straight surfaces, trackers that hold the tip)
feeds it samples, and the tests read the phases, the transitions and the commands it returns."""

import math

import numpy as np
import pytest
from follow_script import (REACH_MM, TARGET_UT, HeldAt, MovesWith, NoContact, Scene, SlowedAlong,
                           angle_deg, following_along_x, lost_at_the_end, unit)

from whiskercal.follow import FollowConfig, surface_step
from whiskercal.follow.controller import _catch_up_share
from whiskercal.follow.phases import RULES, TURNING


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


def _allowed(scene):
    """Every logged change of phase is one its rule allows."""
    for transition in scene.transitions():
        rule = RULES[transition.rule]
        assert transition.source in rule.sources
        assert rule.target in (None, transition.target)
    return [t.rule for t in scene.transitions()]


def test_it_approaches_presses_to_the_target_and_then_follows_a_flat_surface():
    scene = following_along_x(seconds=6.0)
    assert _allowed(scene) == ["touched", "target reached"]
    phases = [step.phase for step in scene.steps]
    first_press, first_follow = phases.index("press"), phases.index("follow")
    assert set(phases[:first_press]) == {"approach"} and set(phases[first_press:first_follow]) == {"press"}
    zs = [scene.world.z_uT() for _ in scene.run(2.0)]
    assert abs(np.mean(zs) - TARGET_UT) < 0.05 * abs(TARGET_UT)  # µT: the PID holds the target
    assert scene.free_tip()[0] > 30.0  # mm: and it moved along (+x)
    assert angle_deg(scene.follower.tangent) == pytest.approx(0.0, abs=0.5)


def test_while_pressing_it_turns_toward_the_surface_but_does_not_move_along_it():
    config = FollowConfig()
    scene = Scene([((-50.0, 0.0), (400.0, 0.0))], [0.0, 0.0], [1.0, 0.0], config)
    pose = scene.robot.pose()
    scene.robot.place([*pose[:2], pose[2] - math.radians(30.0)])  # lagging 30° (clockwise)
    pressed = []
    for _ in range(int(10.0 * config.rate_hz)):
        pose = scene.robot.pose()
        step = scene.step()
        if step.phase == "follow":
            break
        if step.phase == "press" and np.isfinite(step.contact_mm[0]):
            pressed.append((pose, step, scene.follower.tangent))
    assert len(pressed) > 10
    # the first direction is the approach's; the key points' chord along the surface then
    # leaves the heading lagging, and it turns toward it at the most
    assert max(step.turn_rad_s for _, step, _ in pressed) == pytest.approx(config.turn_max_rad_s)
    for pose, step, tangent in pressed:  # turning about the contact, pressing along the normal
        arm = pose[:2] - step.contact_mm
        own = step.velocity_mm_s - step.turn_rad_s * np.array([-arm[1], arm[0]])
        assert own @ tangent == pytest.approx(0.0, abs=1e-9)
        assert own @ np.array([-tangent[1], tangent[0]]) > 0.0


def test_the_tangential_speed_falls_with_the_heading_lag_until_it_stops():
    config = FollowConfig()
    shares = [_catch_up_share(math.radians(lag), config) for lag in (0.0, 20.0, 30.0, 45.0, 60.0)]
    assert shares == pytest.approx([1.0, 1.0, (45.0 - 30.0) / (45.0 - 20.0), 0.0, 0.0])


def test_a_tip_missing_for_a_few_samples_holds_still_and_does_not_count_as_lost():
    config = FollowConfig()
    scene = following_along_x(config)
    scene.tracker.inner = NoContact()
    held = int(round(config.lost_after_s * config.rate_hz))
    steps = scene.run(held / config.rate_hz)
    assert all(step.phase == "follow" and not np.any(step.velocity_mm_s) for step in steps)
    step = scene.step()
    assert step.phase == "back-off" and [t.rule for t in step.transitions] == ["contact lost"]


def test_after_losing_contact_it_backs_off_then_comes_in_along_the_last_key_points_normal():
    config = FollowConfig(search_turns=0)  # the first search line only (turns: below)
    scene = lost_at_the_end(config)
    last_key = np.array(scene.follower.keys[-1])
    scene.world.segments = []  # the surface is gone
    steps = scene.run(20.0)
    phases = ["back-off"] + [step.phase for step in steps]
    backing = int(config.backoff_s * config.rate_hz)
    assert phases[:backing] == ["back-off"] * backing and phases[backing] == "search"
    assert [t.rule for t in steps[backing - 1].transitions] == ["backed off"]
    heading = scene.robot.pose()[2]
    assert math.degrees(heading) == pytest.approx(70.0, abs=2.0)
    # the free tip was brought to 10 mm short of the last key point on the line of that heading,
    # outside the object, and then moved along that line toward the key point
    along = unit(heading)
    start = last_key - config.search_standoff_mm * along
    offset = scene.free_tip() - start
    assert abs(offset @ np.array([-along[1], along[0]])) < 0.6  # mm off the line
    assert offset @ along > 5.0


def test_backing_off_goes_on_for_its_whole_time_even_if_the_wire_still_touches():
    config = FollowConfig()
    scene = lost_at_the_end(config)
    scene.tracker.inner = MovesWith(scene.robot, scene.free_tip())  # a tip felt all along
    steps = scene.run(config.backoff_s + 0.1)
    phases = ["back-off"] + [step.phase for step in steps]
    backing = int(config.backoff_s * config.rate_hz)
    assert phases[:backing] == ["back-off"] * backing and phases[backing] == "press"
    assert [t.rule for t in steps[backing - 1].transitions] == ["touched"]


def test_a_search_that_passes_the_last_key_point_without_a_contact_stops_for_good():
    config = FollowConfig(search_turns=0)  # no turns about the key point (below)
    scene = lost_at_the_end(config)
    last_key = np.array(scene.follower.keys[-1])
    scene.world.segments = []  # the surface is never found again
    phases = [step.phase for step in scene.run(30.0)]
    along = unit(scene.robot.pose()[2])
    assert scene.follower.gave_up and phases[-1] == "stopped" and "search" in phases
    assert _allowed(scene)[-1] == "not found"
    assert (scene.free_tip() - last_key) @ along == pytest.approx(config.search_standoff_mm, abs=0.1)
    assert not np.any(scene.robot.velocity) and scene.robot.turn == 0.0  # stopped
    assert scene.step(TARGET_UT).phase == "stopped"  # and stays stopped


def test_a_search_that_finds_nothing_turns_toward_the_object_about_the_last_key_point():
    config = FollowConfig()
    scene = lost_at_the_end(config)  # followed +x, the object above it
    last_key = np.array(scene.follower.keys[-1])
    scene.world.segments = []  # nothing is ever found
    lines = []
    for _ in range(int(90 * config.rate_hz)):
        pose = scene.robot.pose()
        step = scene.step()
        if step.phase == "search" and not step.turn_rad_s and np.any(step.velocity_mm_s):
            lines.append((pose, step.velocity_mm_s))  # coming in along the whisker
    assert scene.follower.gave_up
    headings = sorted({round(math.degrees(pose[2])) for pose, _ in lines})
    # the surface's direction turned by 45° toward the object (counter-clockwise) each time
    assert headings == [70, 115, 160, 205, 250]
    for pose, velocity in lines:  # each line runs through the last key point
        along = unit(pose[2])
        tip = pose[:2] + REACH_MM * along
        assert abs((tip - last_key) @ np.array([-along[1], along[0]])) < 0.6
        np.testing.assert_allclose(velocity, config.approach_speed_mm_s * along, atol=0.2)  # within 2°


def _held(scene, tracker, z_uT, seconds=0.5):
    """Swap in ``tracker`` and feed ``z_uT`` (a number, or a function of the sample's index)
    until a rule turns the surface's direction or ``seconds`` pass; the steps."""
    scene.tracker.inner = tracker
    before, steps = angle_deg(scene.follower.tangent), []
    for index in range(int(seconds * scene.config.rate_hz)):
        steps.append(scene.step(z_uT(index) if callable(z_uT) else z_uT))
        if abs((angle_deg(scene.follower.tangent) - before + 180.0) % 360.0 - 180.0) > 15.0:
            break
    return steps


@pytest.mark.parametrize("z_uT, turned_deg, rule", [(-3000.0, 135.0, "held ahead"),
                                                    (TARGET_UT, -160.0, "edge held")])
def test_a_tip_held_while_the_sensor_moves_along_turns_the_surface(z_uT, turned_deg, rule):
    scene = following_along_x(toward=-1)  # along -x, the object below
    corner = scene.steps[-1].contact_mm
    _held(scene, HeldAt(scene.robot, corner), z_uT)  # 8 mm/s along: 1.5 mm in 0.19 s
    # the deflection falling (a surface ahead): turned clockwise, away from the object on the
    # left, by 45°; kept (the tip on an edge): counter-clockwise, toward it, by 20° (more would
    # lean the whisker past a rounded edge's normal: it slips off); once: the sensor then only
    # turns about the held tip while its heading catches up
    assert angle_deg(scene.follower.tangent) == pytest.approx(turned_deg, abs=1e-6)
    np.testing.assert_allclose(np.array(scene.follower.keys), [corner], atol=1e-6)
    assert _allowed(scene)[-1] == rule and scene.follower.phase in TURNING


@pytest.mark.parametrize("out_mm, turned_deg, rule", [(1.5, 135.0, "pushed out"),
                                                     (0.5, -160.0, "edge held")])
def test_a_held_contact_pushed_out_of_the_surfaces_line_is_a_concave_corner_not_an_edge(
        out_mm, turned_deg, rule):
    scene = following_along_x(toward=-1)  # along -x, the object below (y < 0)
    last_key = np.array(scene.follower.keys[-1])
    # held with |z| kept at the target, as on an edge; but 1.5 mm out of the surface's line, on
    # the whisker's side (+y): no convex surface puts the contact there, a tip held in a
    # concave corner and pushed along the wire does (its push read as a bend toward the base)
    held = scene.steps[-1].contact_mm + np.array([0.0, out_mm])
    _held(scene, HeldAt(scene.robot, held), TARGET_UT)
    assert _allowed(scene)[-1] == rule and scene.follower.phase in TURNING
    assert angle_deg(scene.follower.tangent) == pytest.approx(turned_deg, abs=1e-6)
    if rule == "pushed out":  # the corner: the last key point on the surface, not the estimate
        np.testing.assert_allclose(np.array(scene.follower.keys), [last_key])


def test_a_tip_that_moves_along_with_the_sensor_is_not_held():
    scene = following_along_x(toward=-1)
    x = scene.robot.pose()[0]
    tracker = SlowedAlong(scene.robot, scene.steps[-1].contact_mm, np.array([-1.0, 0.0]), 1.0)
    _held(scene, tracker, TARGET_UT, seconds=2.0)
    assert abs(angle_deg(scene.follower.tangent)) > 170.0  # still -x
    assert scene.robot.pose()[0] < x - 10.0  # and it moved along
    assert scene.follower.phase.value == "follow"


@pytest.mark.parametrize("bend_deg, edge", [(45.0, True), (6.0, False)])
def test_a_step_between_key_points_that_turns_sharply_toward_the_object_is_an_edge(bend_deg, edge):
    # along -x with the object below, then the surface bends down (toward the object) at x = -20
    down = unit(math.radians(180.0 + bend_deg))
    segments = [((50.0, 0.0), (-20.0, 0.0)), ((-20.0, 0.0), np.array([-20.0, 0.0]) + 100.0 * down)]
    scene = Scene(segments, [0.0, 0.0], [-1.0, 0.0])
    scene.run(12.0, until=lambda step: any(t.rule == "edge step" for t in step.transitions))
    rules = _allowed(scene)
    assert ("edge step" in rules) == edge
    if edge:  # the direction becomes the step at once, the key points start from it
        assert len(scene.follower.keys) == 2
        step = scene.follower.keys[1] - scene.follower.keys[0]
        np.testing.assert_allclose(scene.follower.tangent, step / np.linalg.norm(step))
        assert angle_deg(step) < -150.0  # turned well past the key points' 10° limit


def test_following_at_the_target_without_a_new_key_point_turns_toward_the_object():
    config = FollowConfig(stall_travel_mm=1e3)  # the held-tip rule kept out
    scene = following_along_x(config, toward=-1)
    corner = scene.steps[-1].contact_mm
    scene.tracker.inner = HeldAt(scene.robot, corner)  # the contact stays put on an edge
    steps = scene.run(1.9, z_uT=TARGET_UT)
    fired = [i for i, step in enumerate(steps) for t in step.transitions if t.rule == "edge dwell"]
    # after about 1 s (the time since the last key point, kept up to 10 samples before the
    # tip stopped), counter-clockwise by 20° (toward the object below); not again within the
    # next second (the time is counted afresh)
    assert 0.85 * config.rate_hz < fired[0] < 1.05 * config.rate_hz
    assert np.all(np.diff(fired) > config.dwell_s * config.rate_hz)
    assert _allowed(scene)[2] == "edge dwell"
    turned = -160.0 if len(fired) == 1 else -140.0
    assert angle_deg(scene.follower.tangent) == pytest.approx(turned, abs=1e-6)


def test_a_key_point_that_steps_back_against_the_surface_is_a_tip_held_in_a_concave_corner():
    scene = following_along_x(toward=-1)
    last_key = np.array(scene.follower.keys[-1])
    back = scene.steps[-1].contact_mm + np.array([4.5, 0.5])  # back (+x) past the last key point
    _held(scene, HeldAt(scene.robot, back), TARGET_UT)
    # no surface turns back on itself: the surface ahead turns away from the object (clockwise)
    # by 45°, about the last key point before the step back
    assert angle_deg(scene.follower.tangent) == pytest.approx(135.0, abs=1e-6)
    np.testing.assert_allclose(np.array(scene.follower.keys), [last_key])
    assert _allowed(scene)[-1] == "step back" and scene.follower.phase.value == "enter-corner"


@pytest.mark.parametrize("z_uT, share, turned", [(-5600.0, 0.5, True), (-5400.0, 0.5, False),
                                                 (-5600.0, 1.0, False)])
def test_a_deflection_past_the_target_with_the_tip_lagging_the_motion_is_a_surface_ahead(
        z_uT, share, turned):
    scene = following_along_x(toward=-1)
    tracker = SlowedAlong(scene.robot, scene.steps[-1].contact_mm, np.array([-1.0, 0.0]), share)
    _held(scene, tracker, z_uT)  # 1.12 (or 1.08) times the target's |z|
    # a tip that goes on with the sensor is pressed harder by a direction not yet the surface's
    # (after a search, say): the surface does not turn (on a long whisker at a small target it
    # used to be read as a concave corner, and the sensor stopped on a convex object)
    assert abs(angle_deg(scene.follower.tangent)) == pytest.approx(135.0 if turned else 180.0, abs=1.0)
    assert ("rise ahead" in _allowed(scene)) == turned


def test_a_held_tip_whose_deflection_rises_as_the_sensor_moves_along_is_a_concave_corner():
    scene = following_along_x(toward=-1)
    samples = int(0.5 * scene.config.rate_hz)
    # kept at the target and rising, below the rise rule's 1.1
    _held(scene, HeldAt(scene.robot, scene.steps[-1].contact_mm),
          lambda index: TARGET_UT - 300.0 * index / samples)
    assert angle_deg(scene.follower.tangent) == pytest.approx(135.0)  # away from the object, not an edge
    assert _allowed(scene)[-1] == "held ahead"


def test_after_a_corner_rule_it_turns_about_the_corner_and_keeps_no_key_point_until_round():
    config = FollowConfig()
    scene = following_along_x(config, toward=-1)
    tracker = SlowedAlong(scene.robot, scene.steps[-1].contact_mm, np.array([-1.0, 0.0]), 0.5)
    _held(scene, tracker, -5600.0)  # the rise rule: the corner is that sample's contact
    corner = np.array(scene.follower.keys[-1])
    heading = scene.robot.pose()[2]
    for _ in range(int(1.0 * config.rate_hz)):
        pose = scene.robot.pose()
        step = scene.step(TARGET_UT)
        # the base moves so that the corner stays put while it turns, and (the PID) along the
        # normal: no motion along the surface
        arm = pose[:2] - corner
        own = step.velocity_mm_s - step.turn_rad_s * np.array([-arm[1], arm[0]])
        assert own @ scene.follower.tangent == pytest.approx(0.0, abs=1e-9)
        assert np.linalg.norm(own) <= config.normal_speed_max_mm_s + 1e-9  # (the PID's)
        assert np.all(np.isnan(step.contact_mm))  # a held tip's estimate is not on the surface
        assert step.phase == "enter-corner"
    assert len(scene.follower.keys) == 1
    assert math.degrees(heading - scene.robot.pose()[2]) > 5.0  # turning clockwise, toward -155°


def _far_side_search(scene, config):
    """Lose the tip, back off, and meet the object on the whisker's far side (z of the wrong
    sign) once the search has begun; the step that met it."""
    scene.tracker.inner = NoContact()
    scene.run(10.0, until=lambda step: step.phase == "search")
    scene.tracker.inner = MovesWith(scene.robot, scene.free_tip())
    return scene.step(-0.08 * TARGET_UT)  # 400 µT, bent the other way


@pytest.mark.parametrize("past_edge", [True, False])
def test_a_search_meeting_the_object_on_the_far_side_comes_in_further_along(past_edge):
    config = FollowConfig()
    scene = following_along_x(config, toward=-1)
    if past_edge:  # the last rule an edge's: the tip held with the deflection kept
        _held(scene, HeldAt(scene.robot, scene.steps[-1].contact_mm), TARGET_UT)
    angle, last_key = angle_deg(scene.follower.tangent), np.array(scene.follower.keys[-1])
    step = _far_side_search(scene, config)
    assert step.phase == "back-off" and [t.rule for t in step.transitions] == ["far side"]
    # past an edge: the line came in over the edge's rounding; the same direction, 10 mm on.
    # otherwise a surface ahead: the direction turns 45° away (clockwise), 10 mm past the corner
    turned = angle if past_edge else angle - 45.0
    assert angle_deg(scene.follower.tangent) == pytest.approx((turned + 180.0) % 360.0 - 180.0)
    expected = last_key + config.search_standoff_mm * unit(math.radians(turned))
    np.testing.assert_allclose(np.array(scene.follower.keys), [expected], atol=1e-9)


def _at_a_corner_bent(bent: bool):
    """Following along -x (the object below), the whisker placed as pressed at the target or
    straight, and the tip then held (``SlowedAlong`` at half the motion, |z| 1.12 times the
    target's: the rise rule) at the last contact, the corner; (the scene, the corner, the steps).
    bent: the tip 70 mm along the whisker and 30 mm to its right (the chord 23° clockwise of
    the heading, as a whisker pressed at the target is); turning about the corner to the
    heading the 45° turn asks for (-155°) would put the base 2.7 mm above the wall it leaves
    (y = 0 through the corner). Straight (the tip on the whisker's axis): 33 mm above it."""
    scene = following_along_x(toward=-1)
    corner, heading = scene.steps[-1].contact_mm, scene.robot.pose()[2]
    assert math.degrees(heading) == pytest.approx(-110.0, abs=0.5)
    tip_mm = np.array([70.0, -30.0] if bent else [REACH_MM, 0.0])  # the corner seen from the base
    turn = np.array([[math.cos(heading), -math.sin(heading)], [math.sin(heading), math.cos(heading)]])
    scene.robot.place([*(corner - turn @ tip_mm), heading])
    steps = _held(scene, SlowedAlong(scene.robot, corner, np.array([-1.0, 0.0]), 0.5), -5600.0)
    return scene, corner, steps


@pytest.mark.parametrize("bent", [True, False])
def test_a_concave_corner_whose_turn_would_swing_the_base_onto_the_wall_left_backs_out_of_it(bent):
    scene, corner, steps = _at_a_corner_bent(bent)
    config = scene.config
    if not bent:  # turning about the corner
        assert angle_deg(scene.follower.tangent) == pytest.approx(135.0, abs=1.0)  # the rise rule
        assert steps[-1].phase == "follow" and scene.follower.phase.value == "enter-corner"
        return
    assert _allowed(scene)[-2:] == ["rise ahead", "corner too narrow"]
    base = scene.robot.pose()[:2]  # (one sample on from the rule's: 0.03 mm)
    # out of the corner, away from both surfaces: out of the one left (+y) and back along it
    # (+x); backing off along the whisker (-110°) would push the tip into the next surface
    step = scene.step(TARGET_UT)
    assert step.phase == "back-off" and not scene.follower.gave_up
    np.testing.assert_allclose(step.velocity_mm_s, config.approach_speed_mm_s * unit(math.radians(45.0)))
    # the next surface guessed square to the one left, and met where the base, trailing the tip
    # along it as far as it trails it now (52 mm, +x of the corner), clears the one left by
    # corner_clearance_mm
    assert angle_deg(scene.follower.tangent) == pytest.approx(90.0, abs=1e-6)
    (key,) = scene.follower.keys  # (the corner: where the rise rule fired, the tip slowed along -x)
    assert abs(key[0] - corner[0]) < 1.0
    trailing = base[0] - key[0]
    assert trailing == pytest.approx(52.1, abs=0.5)
    assert key[1] == pytest.approx(corner[1] + trailing + config.corner_clearance_mm, abs=0.1)


def test_backing_out_of_a_concave_corner_never_brings_the_base_to_the_wall_left():
    scene, corner, _ = _at_a_corner_bent(True)
    scene.tracker.inner = NoContact()
    assert scene.step().phase == "back-off"
    pose = scene.robot.pose()
    clearance = scene.config.corner_clearance_mm
    scene.robot.place([pose[0], corner[1] + clearance + 0.5, pose[2]])  # (a guess gone wrong)
    assert scene.step().phase == "back-off"
    scene.robot.place([pose[0], corner[1] + clearance - 0.5, pose[2]])
    step = scene.step()
    assert step.phase == "stopped" and scene.follower.gave_up and not np.any(step.velocity_mm_s)
    assert _allowed(scene)[-1] == "near the surface left"


def test_past_a_concave_corner_too_narrow_to_turn_about_it_comes_in_on_the_next_wall():
    scene, corner, _ = _at_a_corner_bent(True)
    # the next wall: x = corner's, walked toward +y, the object on its left (-x)
    scene.world.segments = [np.array([[60.0, 0.0], [corner[0], 0.0]]),
                            np.array([[corner[0], -50.0], [corner[0], 400.0]])]
    scene.tracker.inner = scene.world
    steps, base_y = [], []
    for _ in range(int(60.0 * scene.config.rate_hz)):
        steps.append(scene.step())
        base_y.append(scene.robot.pose()[1])
        if steps[-1].phase == "follow":
            break
    assert [t.rule for t in scene.transitions()][-4:] == ["corner too narrow", "backed off", "touched",
                                                          "target reached"]
    # on the second wall, about 62 mm along it (52 + 10: the test above), and along it (+y)
    came_in = next(step.contact_mm for step in steps if step.phase == "press")
    assert came_in[0] == pytest.approx(corner[0], abs=1e-6)
    assert 55.0 < came_in[1] - corner[1] < 70.0
    scene.run(3.0)
    assert scene.follower.phase.value == "follow"
    assert angle_deg(scene.follower.tangent) == pytest.approx(90.0, abs=2.0)
    # the base never went below the wall it left (y = 0) on the way round
    assert min(base_y) > corner[1]


@pytest.mark.parametrize("gradual", [True, False])
def test_a_deflection_that_falls_by_half_step_by_step_while_touching_backs_out_of_the_corner(gradual):
    # a tip held in a concave corner and pushed along the wire as the sensor moves on: |z| falls
    # over tens of samples, the wire still touching (turning about the corner, or backing off
    # along the whisker with the tip caught between both walls, drove the wire into the solid);
    # a slip falls in one snap and is not that
    config = FollowConfig()
    scene = following_along_x(config, toward=-1)  # along -x, the object below
    scene.tracker.inner = MovesWith(scene.robot, scene.steps[-1].contact_mm)
    scene.run(0.2, z_uT=TARGET_UT)  # following at the target
    corner = np.array(scene.follower.keys[-1])
    falls = np.linspace(TARGET_UT, -2000.0, 25) if gradual else np.array([-2000.0])
    steps = [scene.step(z_uT) for z_uT in falls]
    assert any(step.slip for step in steps)  # either way a slip's fall (|z| under half its most)
    assert (steps[-1].phase == "back-off") == gradual and not scene.follower.gave_up
    if gradual:  # out of the corner away from both walls (+y out of the one left, +x back along it)
        assert _allowed(scene)[-1] == "held in a corner"
        # (the direction followed is the key points' spline's, within a few degrees of -x)
        velocity = steps[-1].velocity_mm_s
        assert np.linalg.norm(velocity) == pytest.approx(config.approach_speed_mm_s)
        assert angle_deg(velocity) == pytest.approx(45.0, abs=5.0)
        (key,) = scene.follower.keys  # (the base trails the tip by 78 sin 20° = 27 mm)
        assert np.linalg.norm(key - corner) == pytest.approx(26.7 + config.corner_clearance_mm, abs=2.0)
        assert angle_deg(key - corner) == pytest.approx(90.0, abs=5.0)
