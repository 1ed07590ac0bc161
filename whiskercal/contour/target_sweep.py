"""The study's rule checked: the same loop at a range of deflection targets, each run measured
against the object's true outline (docs/contour.md, "Target against error")."""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

from whiskercal.follow import FollowConfig
from whiskercal.twin.outlines import SHAPES

ROW_KEYS = ("mean_error_mm", "std_error_mm", "max_error_mm", "aligned_mean_error_mm", "coverage",
            "contacts_lost", "time_to_go_round_s", "z_mean_follow_uT", "tip_contact_share",
            "control_ms_mean", "control_ms_max", "realtime_factor")


def target_sweep(artifact: str | Path, targets_uT: Sequence[float], shapes: Sequence[str] = SHAPES,
                 seeds: Sequence[int] = (1,), duration_s: float = 120.0,
                 config: FollowConfig = FollowConfig(),
                 on_row: Callable[[dict], None] | None = None) -> list[dict]:
    """One row per shape, target (µT) and seed: the run's numbers (``contour.summary``)."""
    from whiskercal.contour import contour_record, summarize

    rows = []
    for shape in shapes:
        for target in targets_uT:
            for seed in seeds:
                summary = summarize(contour_record(shape, artifact, target_z_uT=float(target),
                                                   config=config, duration_s=duration_s, seed=seed))
                row = {"shape": shape, "target_z_uT": float(target), "seed": int(seed),
                       **{key: summary[key] for key in ROW_KEYS}}
                rows.append(row)
                if on_row is not None:
                    on_row(row)
    return rows
