"""Scenes by name: what ``sim://NAME/stage?scene=...`` and ``whiskercal sim serve --scene`` ask for."""

from __future__ import annotations

from whiskercal.errors import UsageError
from whiskercal.twin.scenes.empty import NoFixture
from whiskercal.twin.scenes.plane import PlaneFixture
from whiskercal.twin.scenes.rod import DEFAULT_ROD_RADIUS_MM, RodFixture

# name -> scene class; each builds itself from the URL-level options (``from_options``)
SCENES = {scene.name: scene for scene in (RodFixture, PlaneFixture, NoFixture)}


def scene_names() -> tuple[str, ...]:
    """The names a URL or the command line may give, in the order the docs list them."""
    return tuple(SCENES)


def fixture_for_scene(scene: str, rod_radius_mm: float = DEFAULT_ROD_RADIUS_MM):
    """The scene called ``scene`` (``rod``, ``plane`` or ``none``), with the URL's options."""
    if scene not in SCENES:
        raise UsageError(f"unknown scene {scene!r}; use one of {', '.join(SCENES)}.")
    return SCENES[scene].from_options({"rod_radius_mm": rod_radius_mm})
