"""What rides on the stage past the whisker, each scene answering its own contact question.

``base.Scene`` is the protocol; ``rod``, ``plane``, ``shape`` and ``empty`` implement it;
``registry`` finds a scene by the name a ``sim://`` URL gives.
"""

from whiskercal.twin.scenes.base import Scene
from whiskercal.twin.scenes.empty import NoFixture
from whiskercal.twin.scenes.plane import DEFAULT_PLANE_NORMAL_RAD, PlaneFixture
from whiskercal.twin.scenes.registry import SCENES, fixture_for_scene, scene_names
from whiskercal.twin.scenes.rod import DEFAULT_ROD_RADIUS_MM, RodFixture
from whiskercal.twin.scenes.shape import ShapeFixture

__all__ = ["DEFAULT_PLANE_NORMAL_RAD", "DEFAULT_ROD_RADIUS_MM", "SCENES", "NoFixture",
           "PlaneFixture", "RodFixture", "Scene", "ShapeFixture", "fixture_for_scene",
           "scene_names"]
