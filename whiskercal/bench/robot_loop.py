"""The robot's whole path against the in-process loop: ``contour run --robot`` through the
twin's rosbridge server (``sim serve --robot``, its own process: WebSocket, JSON, tracker,
follower, and the twin answering in wall time) round each object at the sensor's 300 Hz and
the paper's 30 Hz, beside the in-process run on the same seed at the same rate.

Each robot run is compared with the served outline (the twin's object where ``sim serve``
says it stands), in the world frame with no alignment, by ``contour.summary``; the in-process
run likewise. Rows also give the loop's latency (a sample's arrival to its twist sent), the
transit (its stamp to its arrival), the samples the loop took against the stream's, and what
the server reports (the samples it skipped when its solver fell behind the wall clock).
"""

from __future__ import annotations

import dataclasses
import json
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

from whiskercal.errors import UsageError

ROW_KEYS = ("mean_error_mm", "std_error_mm", "max_error_mm", "coverage", "time_to_go_round_s",
            "contacts", "contacts_lost", "gave_up", "z_mean_follow_uT")
SHAPES = ("octagon", "cylinder", "rounded-rect")
RATES_HZ = (300.0, 30.0)
# the bench shares its machine with whatever else runs: a watchdog looser than a lab's default,
# so that a busy machine shows as lag and late samples in the rows rather than a stopped run
WATCHDOG_S = 1.0


def run(quick: bool = False, progress=None, artifact: str | Path | None = None,
        duration_s: float | None = None, seed: int = 1) -> dict:
    """Rows for each shape and rate (``quick``: the octagon only, 10 s); ``artifact``: a calibration
    with a target (default: the recorded default grid fitted as ``fit`` ships it, with its
    (Y, Z) table, its target chosen as ``contour-target`` does)."""
    folder = Path(tempfile.mkdtemp(prefix="whiskercal-robot-loop-"))
    if artifact is None:
        from whiskercal.bench.contour_target import calibrations_with_target

        artifact = calibrations_with_target(folder)["yz-table"]
    duration_s = duration_s or (10.0 if quick else 140.0)  # the octagon goes round, with time to spare
    rows = []
    for shape in SHAPES[:1] if quick else SHAPES:
        for rate in RATES_HZ:
            rows.append(compare(shape, rate, artifact, duration_s, seed, folder))
            if progress is not None:
                progress(rows[-1])
    return {"rows": rows, "duration_s": duration_s, "seed": seed, "artifact": str(artifact)}


def compare(shape: str, rate_hz: float, artifact, duration_s: float, seed: int, folder: Path) -> dict:
    """One row: the run through rosbridge and the in-process run, each summarized."""
    from whiskercal.contour import contour_record, summarize
    from whiskercal.follow import FollowConfig

    config = FollowConfig().replace(rate_hz=rate_hz)
    robot, served = robot_run(shape, rate_hz, artifact, duration_s, seed, folder)
    in_process = summarize(contour_record(shape, artifact, config=config, duration_s=duration_s,
                                          seed=seed))
    row = {"shape": shape, "rate_hz": rate_hz, "seed": seed,
           **{f"robot_{key}": robot["summary"][key] for key in ROW_KEYS},
           **{f"in_process_{key}": in_process[key] for key in ROW_KEYS},
           "latency_ms": robot["latency_ms"], "samples": robot["samples"],
           "stopped_by": robot["stopped_by"],
           "samples_expected": int(round(duration_s * rate_hz)), "server": served}
    row["mean_error_difference_mm"] = row["robot_mean_error_mm"] - row["in_process_mean_error_mm"]
    return row


def robot_run(shape: str, rate_hz: float, artifact, duration_s: float, seed: int,
              folder: Path) -> tuple[dict, dict]:
    """``sim serve --robot`` in its own process and ``contour run --robot`` against it: the
    run's summary against the served outline, and what the server reports."""
    from whiskercal.contour import read_contour_run
    from whiskercal.contour.on_robot import RobotSetup, contour_on_robot
    from whiskercal.robot import RobotError, Safety

    server = subprocess.Popen(
        [sys.executable, "-m", "whiskercal", "sim", "serve", "--robot", "--shape", shape,
         "--port", "0", "--rate-hz", f"{rate_hz:g}", "--seed", str(seed), "--duration",
         f"{duration_s + 30:g}", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True)
    out = folder / f"{shape}-{rate_hz:g}.h5"
    try:
        info = _announcement(server)
        try:
            contour_on_robot(RobotSetup(info["robot"], safety=Safety(watchdog_s=WATCHDOG_S)),
                             artifact, out, duration_s=duration_s, echo=lambda line: None)
        except RobotError:  # the row says what stopped it (config.robot.stopped_by)
            pass
        record = read_contour_run(out)
    finally:
        server.send_signal(signal.SIGINT)  # Ctrl-C: it reports what it served, and ends
        _, err = server.communicate(timeout=30)
    return _measured(record, shape, info), {"report": err.strip().splitlines()[-1:]}


def _announcement(server) -> dict:
    """The JSON ``sim serve`` prints once its port is bound."""
    lines = []
    for line in server.stdout:
        lines.append(line)
        if line.startswith("}"):
            return json.loads("".join(lines))
    raise UsageError(f"sim serve --robot printed no address: {server.stderr.read().strip()}")


def _measured(record, shape: str, info: dict) -> dict:
    """The robot run summarized against the served outline (``outline_pose`` 0,0,0: the twin's
    object where it builds it)."""
    from whiskercal.contour import summarize
    from whiskercal.twin.outlines import outline

    if info["outline_pose"] != "0,0,0":
        raise UsageError(f"the served outline stands at {info['outline_pose']}, not at the origin")
    served = outline(shape)
    placed = dataclasses.replace(record, shape=shape, core_mm=served.core_mm, radius_mm=served.radius_mm)
    robot = record.config["robot"]
    return {"summary": summarize(placed), "latency_ms": robot["latency_ms"],
            "samples": int(len(record.columns["t_s"])), "stopped_by": robot["stopped_by"]}
