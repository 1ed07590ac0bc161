"""One collection run from ports to file: open, identify, check, checkpoint, collect, summarize.

This is what ``whiskercal collect`` calls; it holds no click code, so scripts and tests use it
directly with port URLs or open pyserial objects.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable

from whiskercal.artifacts.raw_grid import RawHeader
from whiskercal.collect.checkpoint import Checkpoint, recorded_fingerprint
from whiskercal.collect.config import CollectConfig
from whiskercal.collect.estimate import limit_problems
from whiskercal.collect.journal import journal_path
from whiskercal.collect.loop import Collector, Devices, Progress, identify
from whiskercal.collect.plan import GridPlan
from whiskercal.collect.twin_truth import twin_truth
from whiskercal.errors import UsageError, WhiskercalError

# grbl settings the run reads from the stage: travel X/Y ($130/$131).
_TRAVEL_SETTINGS = (130, 131)


@dataclass
class RunSummary:
    """What ``--json`` prints: counts, times (s), frame errors, baseline drift (µT), the file."""

    points: int
    planned: int
    complete: bool
    stopped: bool
    taken_this_run: int
    stage_time_s: float
    wall_time_s: float
    dropped: int
    corrupt: int
    baseline_drift_uT: float | None
    output: str

    def to_dict(self) -> dict[str, Any]:
        """Plain values for JSON."""
        return asdict(self)


def stage_travel_mm(devices: Devices, config: CollectConfig) -> tuple[float, float]:
    """The stage's own travel ($130/$131) when it reports one, else the configured travel, mm."""
    values = [devices.stage_settings.get(n) for n in _TRAVEL_SETTINGS]
    if all(v is not None for v in values):
        return float(values[0]), float(values[1])
    return config.safety.travel_mm


def check_limits(plan: GridPlan, devices: Devices) -> None:
    """Refuse, before anything moves, a plan that leaves the stage's travel.

    Raises
    ------
    UsageError
        Naming the first waypoint outside the travel.
    """
    travel = stage_travel_mm(devices, plan.config)
    problems = limit_problems(plan, travel, plan.config.safety.margin_mm)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise UsageError(f"plan leaves the stage travel: {problems[0]}{more}; "
                         "move rig.origin_stage_mm")


def make_header(plan: GridPlan, devices: Devices, sensor_id: str) -> RawHeader:
    """The dataset header: plan, full config (with a plan summary) and device identities."""
    config = plan.config.to_dict()
    config["plan"] = {"points": len(plan), "order": "columns in +x, each in -y",
                      "frame": "rod centre, whisker frame, mm"}
    config["devices"] = {"stage": devices.stage, "sensor": devices.sensor,
                         "stage_settings": {str(k): v for k, v in devices.stage_settings.items()}}
    return RawHeader(plan_stage_mm=plan.stage_mm, plan_rod_center_mm=plan.rod_center_mm,
                     config=config, sensor_id=sensor_id, rod_radius_mm=plan.config.rig.rod_radius_mm)


def _sensor_id(config: CollectConfig, devices: Devices, port) -> str:
    if config.rig.sensor_id:
        return config.rig.sensor_id
    world = getattr(port, "world", None)
    twin_id = getattr(getattr(world, "sensor", None), "sensor_id", None)
    return str(twin_id or devices.sensor)


def check_resumable(out: Path, plan: GridPlan) -> None:
    """Refuse ``--resume`` before any port opens when the recorded plan or config differs.

    Raises
    ------
    UsageError
        When there is nothing to resume or the fingerprints differ.
    """
    expected = make_header(plan, Devices({}, "", False), "").fingerprint  # devices excluded
    if recorded_fingerprint(out) != expected:
        raise UsageError(f"{out}: cannot resume: it was recorded with a different plan or "
                         "configuration (start a new file or use the original config)")


def open_checkpoint(out: Path, header: RawHeader, resume: bool) -> Checkpoint:
    """A new checkpoint, or the resumed one; refuses to overwrite an existing run."""
    if not out.parent.is_dir():
        raise UsageError(f"{out.parent}: no such directory for the output file")
    if resume:
        return Checkpoint.resume(out, header)
    if out.exists():
        raise UsageError(f"{out} already exists; continue it with --resume or choose another --out")
    if journal_path(out).exists():
        raise UsageError(f"{journal_path(out)} is the journal of an interrupted run of {out}; "
                         "continue it with --resume, or delete the journal to discard it")
    return Checkpoint.start(out, header)


def collect(stage_port, sensor_port, out: str | Path, plan: GridPlan, resume: bool = False,
            on_progress: Callable[[Progress], None] | None = None,
            stop_requested: Callable[[], bool] | None = None,
            stage_client=None, sensor_client=None) -> RunSummary:
    """Collect the plan's grid into ``out`` (or continue it with ``resume``).

    ``stage_port``/``sensor_port`` are URLs, device names or open pyserial objects; tests may
    pass ready clients instead (``stage_client``/``sensor_client``), which are left open.

    Raises
    ------
    WhiskercalError
        Device failures, alarms, the overload guard, a refused resume; every point taken
        before the failure is in the file, and the message says how to continue.
    """
    from whiskercal.rig.sensor import SensorClient
    from whiskercal.rig.stage import StageClient

    out = Path(out)
    wall_start = time.monotonic()
    if resume:
        check_resumable(out, plan)
    stage = stage_client or StageClient(stage_port)
    try:
        sensor = sensor_client or SensorClient(sensor_port)
        try:
            return _session(stage, sensor, out, plan, resume, on_progress, stop_requested, wall_start)
        finally:
            if sensor_client is None:
                _close_port(sensor)
    finally:
        if stage_client is None:
            _close_port(stage)


def _close_port(client) -> None:
    close = getattr(client.transport.port, "close", None)
    if close is not None:
        close()


def _session(stage, sensor, out: Path, plan: GridPlan, resume: bool, on_progress, stop_requested,
             wall_start: float) -> RunSummary:
    """Identify, check, open the checkpoint and run the collector on open clients."""
    devices = identify(stage, sensor)
    check_limits(plan, devices)
    header = make_header(plan, devices, _sensor_id(plan.config, devices, sensor.transport.port))
    checkpoint = open_checkpoint(out, header, resume)
    if checkpoint.complete:  # killed after completing, before the journal was removed
        checkpoint.close()
        journal_path(out).unlink(missing_ok=True)
        raise UsageError(f"{out}: the run is already complete; nothing to resume")
    stage_start_s = stage.transport.now_s()
    collector = Collector(stage, sensor, plan, checkpoint, devices,
                          truth=twin_truth(sensor.transport.port, _averaging_s(plan)),
                          on_progress=on_progress, stop_requested=stop_requested)
    try:
        complete = collector.run()
    except WhiskercalError as error:
        checkpoint.close()
        raise _with_saved_points(error, len(checkpoint.taken), len(plan), out) from error
    except BaseException:
        checkpoint.close()  # a second Ctrl-C: the journal already holds every point
        raise
    if complete:
        checkpoint.finish()
    else:
        checkpoint.close()
    return _summary(collector, checkpoint, out, stage.transport.now_s() - stage_start_s,
                    time.monotonic() - wall_start)


def _averaging_s(plan: GridPlan) -> float:
    """How long averaging one point takes on the sensor's clock, s."""
    return plan.config.acquisition.samples_per_point / plan.config.sensor.rate_hz


def _with_saved_points(error: WhiskercalError, taken: int, planned: int, out: Path) -> WhiskercalError:
    """The same error (same class, code and exit code) with what was saved and how to go on."""
    wrapped = type(error).__new__(type(error))
    wrapped.__dict__.update(vars(error))
    Exception.__init__(wrapped, f"{error} [{taken} of {planned} points saved in {out}; "
                                "continue with --resume]")
    return wrapped


def _summary(collector: Collector, checkpoint: Checkpoint, out: Path, stage_s: float,
             wall_s: float) -> RunSummary:
    drift = None
    if {"before", "after"} <= set(checkpoint.baselines):
        drift = float(checkpoint.baselines["after"].field_uT[1]
                      - checkpoint.baselines["before"].field_uT[1])
    return RunSummary(points=len(checkpoint.taken), planned=len(collector.plan),
                      complete=checkpoint.complete, stopped=collector.stopped,
                      taken_this_run=collector.taken_now, stage_time_s=float(stage_s),
                      wall_time_s=float(wall_s), dropped=int(collector.recorder.total_dropped),
                      corrupt=int(collector.recorder.total_corrupt),
                      baseline_drift_uT=drift, output=str(out))


def read_stage_settings(stage_port) -> dict[int, float]:
    """Open the stage only to read its settings (for ``--dry-run``), then close it."""
    from whiskercal.rig.stage import StageClient

    stage = StageClient(stage_port)
    try:
        return stage.settings()
    finally:
        _close_port(stage)

