"""Touches from a recording: the held presses of a replay track (``whiskercal replay --poses``,
no ``--mount``), for a robot that pressed the whisker on the cylinder by its own program.

A touch is a run of samples in contact, with a tip, while the end effector stands still (it
moves less than :data:`STILL_MM_S` and turns less than :data:`STILL_RAD_S`) for at least
:data:`HOLD_S`; its tip and pose are the run's means. Which touches share a contact's geometry
is not recorded: touches whose tips lie within :data:`SAME_TIP_MM` of each other in the base
frame are taken to share it (and so their tip error), which can only widen the stated
uncertainty.
"""

from __future__ import annotations

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.mountcal.touch import Touch, mean_pose

STILL_MM_S, STILL_RAD_S = 0.5, 0.005
HOLD_S = 0.2
SAME_TIP_MM = 0.5
NO_MOUNT = "none"  # how a replay without --mount names its mount (replay.world)


def touches_from_track(path) -> list[Touch]:
    """The held touches of the replay track at ``path`` (module docstring)."""
    from whiskercal.artifacts.replay_track import read_track

    track = read_track(path)
    mount = str(track.summary.get("world", {}).get("mount", NO_MOUNT))
    if not mount.startswith(NO_MOUNT):
        raise UsageError(f"{path} was replayed with --mount {mount}: replay it with --poses and "
                         "no --mount (mount-cal fits the mount itself)")
    columns = track.columns
    pose = np.column_stack([columns["base_x_mm"], columns["base_y_mm"], columns["base_heading_rad"]])
    tip = np.column_stack([columns["raw_x_mm"], columns["raw_y_mm"]])
    if not np.isfinite(pose).any():
        raise UsageError(f"{path} has no poses: replay the recording with --poses")
    runs = _held_runs(columns["t_s"], pose, tip, columns["contact"] > 0)
    axial = columns["axial_uT"]  # NaN where the recording had no Z axis
    return _grouped([Touch(mean_pose(pose[run]), float(np.mean(columns["z_uT"][run])),
                           float(np.mean(axial[run])), tip[run].mean(axis=0)) for run in runs])


def _held_runs(t_s, pose, tip, contact) -> list[slice]:
    """The runs of samples held still in contact for at least HOLD_S."""
    dt = np.diff(t_s)
    with np.errstate(invalid="ignore", divide="ignore"):
        speed = np.hypot(*np.diff(pose[:, :2], axis=0).T) / dt
        turn = np.abs(np.diff(np.unwrap(np.nan_to_num(pose[:, 2])))) / dt
    still = np.zeros(len(t_s), bool)
    still[1:] = (speed < STILL_MM_S) & (turn < STILL_RAD_S)
    good = still & contact & np.all(np.isfinite(tip), axis=1) & np.all(np.isfinite(pose), axis=1)
    runs, start = [], None
    for index, flag in enumerate([*good, False]):
        if flag and start is None:
            start = index
        elif not flag and start is not None:
            if t_s[index - 1] - t_s[start] >= HOLD_S:
                runs.append(slice(start, index))
            start = None
    return runs


def _grouped(touches: list[Touch]) -> list[Touch]:
    """Each touch labelled with the first earlier touch whose tip lies within SAME_TIP_MM."""
    from dataclasses import replace

    labelled: list[Touch] = []
    for touch in touches:
        same = next((other.geometry for other in labelled
                     if np.hypot(*(other.tip_mm - touch.tip_mm)) < SAME_TIP_MM), None)
        labelled.append(replace(touch, geometry=same or f"tip {len(labelled)}"))
    return labelled
