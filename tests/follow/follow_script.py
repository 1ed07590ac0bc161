"""A scripted world for driving the follower through its public interface (no twin).

The robot integrates its commands exactly; the whisker's free tip lies ``REACH_MM`` along the
heading from the base; past one of the world's segments (each a surface with the object on its
left, walking from its first point to its second) the tip touches at the free tip's foot on it,
and z is a spring on how far past (µT per mm). Tests swap the
tracker (``Switch.inner``) for one that holds the tip, or takes it away.
"""

import math

import numpy as np

from whiskercal.follow import FollowConfig, Follower
from whiskercal.runtime import TrackerState

REACH_MM = 78.0
TARGET_UT = -5000.0
SPRING_UT_PER_MM = -500.0  # the target at 10 mm beyond the surface


def unit(angle):
    return np.array([math.cos(angle), math.sin(angle)])


def angle_deg(direction):
    return math.degrees(math.atan2(direction[1], direction[0]))


def to_whisker(pose, world_mm):
    """A world point (mm) in the whisker frame of ``pose``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([[c, s], [-s, c]]) @ (np.asarray(world_mm, float) - pose[:2])


class KinematicRobot:
    """Integrates the commands exactly: a robot with no object, no limits."""

    def __init__(self, pose):
        self._pose = np.asarray(pose, float)
        self.velocity, self.turn = np.zeros(2), 0.0

    def pose(self):
        return self._pose.copy()

    def place(self, pose):
        """Put the robot at ``pose`` (x mm, y mm, heading rad)."""
        self._pose = np.asarray(pose, float)

    def command(self, velocity_mm_s, turn_rad_s):
        self.velocity, self.turn = np.asarray(velocity_mm_s, float), float(turn_rad_s)

    def step(self, dt_s):
        self._pose[:2] += self.velocity * dt_s
        self._pose[2] += self.turn * dt_s


class Segments:
    """The scripted surfaces (see the module's docstring); ``segments`` may be changed."""

    def __init__(self, robot, segments):
        self.robot, self.segments = robot, [np.asarray(s, float) for s in segments]

    def touch(self):
        """(the tip, world mm: the free tip's foot on the nearest surface it lies beyond; how
        far beyond, mm), or None."""
        pose = self.robot.pose()
        free = pose[:2] + REACH_MM * unit(pose[2])
        best = None
        for a, b in self.segments:
            edge = (b - a) / np.linalg.norm(b - a)
            inward = np.array([-edge[1], edge[0]])
            depth, share = float((free - a) @ inward), float((free - a) @ edge)
            if 0.0 < depth < 30.0 and 0.0 <= share <= np.linalg.norm(b - a):
                if best is None or depth < best[1]:
                    best = (a + share * edge, depth)
        return best

    def z_uT(self):
        touch = self.touch()
        return 0.0 if touch is None else SPRING_UT_PER_MM * touch[1]

    def update(self, z_uT):
        touch = self.touch()
        if touch is None:
            return TrackerState(False, None, None)
        tip = to_whisker(self.robot.pose(), touch[0])
        return TrackerState(True, tip, tip.copy())


class Switch:
    """A tracker that passes each sample to ``inner`` (swapped by the test)."""

    def __init__(self, inner):
        self.inner = inner

    def update(self, z_uT):
        return self.inner.update(z_uT)


class NoContact:
    """The whisker is off the object."""

    def update(self, z_uT):
        return TrackerState(False, None, None)


class HeldAt:
    """A tip that stays at one world point (held in a corner)."""

    def __init__(self, robot, world_mm):
        self.robot, self.world_mm = robot, world_mm

    def update(self, z_uT):
        tip = to_whisker(self.robot.pose(), self.world_mm)
        return TrackerState(True, tip, tip)


class MovesWith:
    """A tip that stays where it is in the whisker frame (it moves along with the sensor),
    starting at the world point ``world_mm``."""

    def __init__(self, robot, world_mm):
        self.tip = to_whisker(robot.pose(), world_mm)

    def update(self, z_uT):
        return TrackerState(True, self.tip.copy(), self.tip.copy())


class SlowedAlong:
    """A tip that starts at the world point ``start_mm`` and goes along ``direction`` at
    ``share`` of the sensor's own motion along it."""

    def __init__(self, robot, start_mm, direction, share):
        self.robot, self.start, self.direction, self.share = robot, np.asarray(start_mm), direction, share
        self.origin = robot.pose()[:2]

    def update(self, z_uT):
        pose = self.robot.pose()
        world = self.start + self.share * ((pose[:2] - self.origin) @ self.direction) * self.direction
        tip = to_whisker(pose, world)
        return TrackerState(True, tip, tip)


class Scene:
    """A follower, a kinematic robot and the scripted world, stepped together."""

    def __init__(self, segments, start_tip_mm, tangent, config=FollowConfig()):
        tangent = np.asarray(tangent, float) / np.linalg.norm(tangent)
        inward = math.atan2(tangent[0], -tangent[1])
        heading = inward - math.radians(config.tilt_deg)
        # the free tip 5 mm short of the surface, along the approach (the whisker's lean)
        approach = unit(heading + math.radians(config.tilt_deg))
        base = np.asarray(start_tip_mm, float) - 5.0 * approach - REACH_MM * unit(heading)
        self.robot = KinematicRobot([*base, heading])
        self.world = Segments(self.robot, segments)
        self.tracker = Switch(self.world)
        self.follower = Follower(self.tracker, TARGET_UT, config, reach_mm=REACH_MM)
        self.config = config
        self.steps = []

    def free_tip(self):
        pose = self.robot.pose()
        return pose[:2] + REACH_MM * unit(pose[2])

    def step(self, z_uT=None):
        """One sample: z from the world unless given."""
        step = self.follower.update(self.world.z_uT() if z_uT is None else z_uT, self.robot)
        self.steps.append(step)
        self.robot.step(1.0 / self.config.rate_hz)
        return step

    def run(self, seconds, z_uT=None, until=None):
        """Step for ``seconds`` (or until ``until(step)``); the steps taken."""
        taken = []
        for _ in range(int(round(seconds * self.config.rate_hz))):
            taken.append(self.step(z_uT))
            if until is not None and until(taken[-1]):
                break
        return taken

    def transitions(self):
        return [t for step in self.steps for t in step.transitions]


def following_along_x(config=FollowConfig(), toward=+1, seconds=4.0, length_mm=400.0):
    """A scene following the x axis at the target: toward +1, along +x with the object above
    (y > 0); toward -1, along -x with the object below. The surface runs ``length_mm`` from
    where the tip first touches (x = 0)."""
    a, b = np.array([-50.0 * toward, 0.0]), np.array([length_mm * toward, 0.0])
    scene = Scene([(a, b)], [0.0, 0.0], [toward, 0.0], config)
    scene.run(seconds)
    assert scene.follower.phase.value == "follow"
    return scene


def lost_at_the_end(config=FollowConfig(), length_mm=20.0):
    """A scene that followed +x (the object above) to the surface's end at ``length_mm`` and
    has just lost it (the sample that starts the back-off is the last one taken)."""
    a, b = np.array([-50.0, 0.0]), np.array([length_mm, 0.0])
    scene = Scene([(a, b)], [0.0, 0.0], [1.0, 0.0], config)
    scene.run(30.0, until=lambda step: step.phase == "back-off")
    assert scene.steps[-1].phase == "back-off" and scene.steps[-2].phase == "follow"
    return scene
