"""What a scene is to the rig: the one small protocol every scene implements.

A scene is what the stage carries past the whisker (a rod, a plate, a shape). The world follows
the end effector's path in small steps (``twin.contact_path``) and at each step asks the scene
two questions: does it reach the free whisker (no solve while nothing touches), and what is the
whisker's equilibrium against it now. The scene picks the contact solve itself, so the world
never asks what kind of scene it carries.

Positions are in the whisker frame, mm: ``tool_mm`` is the end effector's point, where the
scene's own origin rides. A scene may remember the path between steps (the side a rod arrived
from, the direction a plate slides); each world works on its own :meth:`Scene.fresh` copy.

A new scene is a class with these methods in its own module here, and a ``name`` in
``registry.SCENES`` if a ``sim://`` URL should be able to ask for it. A scene whose object moves
on its own (not with the stage) would take the time as well; nothing here assumes it does not.
"""

from __future__ import annotations

from dataclasses import replace
from typing import ClassVar, Mapping, Protocol

import numpy as np

from whiskercal.twin.physics.sensor import SensorPhysics


class Scene(Protocol):
    """What rides on the stage, answering its own contact question (whisker frame, mm)."""

    name: ClassVar[str]  # the scene's name in sim:// URLs and ``fixture_for_scene``

    @classmethod
    def from_options(cls, options: Mapping[str, float]) -> "Scene":
        """The scene built from URL-level options (``rod_radius_mm``), ignoring the others."""

    def fresh(self) -> "Scene":
        """A copy with the same description and no memory of a path (one per world)."""

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """True when the scene, carried to ``tool_mm``, reaches any of the points (n, 2)."""

    def moved(self, from_mm: np.ndarray, to_mm: np.ndarray) -> None:
        """The end effector moved one step (called at every step, touching or not)."""

    def solve(self, physics: SensorPhysics, tool_mm: np.ndarray, previous):
        """The whisker's equilibrium with the scene at ``tool_mm``, continuing from ``previous``.

        Called only while the whisker touches, or ``touches`` said the free whisker is reached.
        Solver errors propagate; the world records them as failed samples.
        """


class SceneBase:
    """Defaults for dataclass scenes: no memory of the path to update, a copy per world.

    A scene that cannot be made from URL options alone (``ShapeFixture``) has no ``name`` and
    stays out of the registry.
    """

    name: ClassVar[str] = ""

    @classmethod
    def from_options(cls, options: Mapping[str, float]) -> "SceneBase":
        """The scene with its defaults (scenes with URL options override this)."""
        return cls()

    def fresh(self) -> "SceneBase":
        """A copy built from the description fields alone (memory fields start over)."""
        return replace(self)

    def moved(self, from_mm: np.ndarray, to_mm: np.ndarray) -> None:
        """Nothing to remember."""
