"""A small band of the grid collected once per test process on the default twin world, for the
collect tests that only read such a file or tear a copy of it."""

from __future__ import annotations

import uuid

import pytest

from fast_collect import FAST, SMALL_BAND

SMALL = FAST + SMALL_BAND


@pytest.fixture(scope="session")
def small_twin_grid(tmp_path_factory):
    """(raw.h5, its plan) of ``SMALL`` collected on a new default twin world: complete, its
    journal gone. Copy it before changing it."""
    from whiskercal.collect.config import load_config
    from whiskercal.collect.plan import build_plan
    from whiskercal.collect.run import collect

    folder = tmp_path_factory.mktemp("small-grid")
    (folder / "collect.toml").write_text(SMALL)
    plan = build_plan(load_config(folder / "collect.toml"))
    name = f"c{uuid.uuid4().hex[:10]}"
    collect(f"sim://{name}/stage", f"sim://{name}/sensor", folder / "raw.h5", plan)
    return folder / "raw.h5", plan
