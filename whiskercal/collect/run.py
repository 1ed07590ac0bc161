"""One collection run from ports to file: open, identify, check, checkpoint, collect, summarize.

This is what ``whiskercal collect`` calls; it holds no click code, so scripts and tests use it
directly with port URLs or open pyserial objects.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable

from whiskercal.artifacts.raw_grid import RawHeader, read_raw_grid
from whiskercal.collect.checkpoint import Checkpoint, recorded_fingerprint
from whiskercal.collect.config import CollectConfig
from whiskercal.collect.estimate import limit_problems
from whiskercal.collect.faults import check_touched, frame_loss, frame_loss_warning
from whiskercal.collect.journal import journal_path
from whiskercal.collect.loop import Collector, Devices, Progress
from whiskercal.collect.plan import GridPlan, rig_frame
from whiskercal.collect.twin_truth import twin_truth
from whiskercal.errors import UsageError, WhiskercalError
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.session import RigSession, SessionConfig


@dataclass
class RunSummary:
    """What ``--json`` prints: counts, times (s), frame errors, baseline drift (µT), the file.

    ``stage_time_s`` runs on the stage's clock from the session's opening (homing and both
    baselines in it); ``points_time_s`` on the sensor's clock from the rod leaving the first
    baseline to the last point's last sample (None before a point is taken).
    """

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
    frame_loss: float = 0.0  # (dropped + corrupt) / frames sent, this session
    beyond_guard: int = 0    # planned points skipped past an overload, this session
    # sensor clock from the rod leaving the baseline to the last point's last sample, this session
    points_time_s: float | None = None
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """Plain values for JSON."""
        return asdict(self)


def session_config(config: CollectConfig) -> SessionConfig:
    """What the rig session needs from a collection config."""
    sensor = config.sensor
    return SessionConfig(frame=rig_frame(config),
                         sensor=SensorConfig(sensor.rate_hz, sensor.gain, sensor.res, sensor.osr,
                                             sensor.filt),
                         home=config.motion.home, move_timeout_s=config.motion.move_timeout_s,
                         travel_mm=config.safety.travel_mm, home_setting="motion.home")


def check_limits(plan: GridPlan, travel_mm: tuple[float, float]) -> None:
    """Refuse, before anything moves, a plan that leaves the stage's travel (mm).

    Raises
    ------
    UsageError
        Naming the first waypoint outside the travel.
    """
    problems = limit_problems(plan, travel_mm, plan.config.safety.margin_mm)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise UsageError(f"plan leaves the stage travel: {problems[0]}{more}; "
                         "move rig.origin_stage_mm")


ENCODERS = "measured (AS5600 on both axes)"
OPEN_LOOP_WARNING = ("the stage reports no encoders (a stock grbl board): missed steps cannot be "
                     "detected, so every point's position is the commanded one (open loop)")


def make_header(plan: GridPlan, devices: Devices, sensor_id: str,
                twin_sensor: dict | None = None) -> RawHeader:
    """The dataset header: plan, full config (with a plan summary) and device identities."""
    config = plan.config.to_dict()
    config["plan"] = {"points": len(plan), "order": "columns in +x, each in -y",
                      "frame": "rod centre, whisker frame, mm",
                      "tip_sweep": {"first_index": plan.sweep_from, "points": plan.sweep_count}}
    config["devices"] = {"stage": devices.stage, "sensor": devices.sensor,
                         "stage_settings": {str(k): v for k, v in devices.stage_settings.items()},
                         "encoders": ENCODERS if devices.has_encoder else "none"}
    if twin_sensor is not None:  # the twin's whole build, so fit can find its truth by any id
        config["devices"]["twin_sensor"] = twin_sensor
    return RawHeader(plan_stage_mm=plan.stage_mm, plan_rod_center_mm=plan.rod_center_mm,
                     config=config, sensor_id=sensor_id, rod_radius_mm=plan.config.rig.rod_radius_mm)


def twin_sensor_description(rig: RigSession) -> dict | None:
    """The twin sensor's full description (``twin.sensor_file``) on a sim:// port, else None."""
    sensor = getattr(getattr(rig.sensor_port, "world", None), "sensor", None)
    if sensor is None:
        return None
    from whiskercal.twin.sensor_file import sensor_to_dict

    return sensor_to_dict(sensor)


def refuse_other_fixture(rig: RigSession) -> None:
    """Refuse a simulated stage that carries an object other than the rod (the plane study's
    plane): its contacts would be stored as rod positions of a grid. An empty stage is let run,
    so that collect can say nothing was touched."""
    world = getattr(rig.sensor_port, "world", None)  # one world behind both sim:// ports
    fixture = getattr(getattr(world, "config", None), "fixture", None)
    if fixture is not None and fixture.name not in ("rod", "none"):
        raise UsageError(f"the simulated stage carries the {fixture.name} scene, not the rod: a "
                         "calibration grid is collected with scene=rod (the plane is for "
                         "`optimal-depth run`)")


def _sensor_id(config: CollectConfig, rig: RigSession) -> str:
    if config.rig.sensor_id:
        return config.rig.sensor_id
    world = getattr(rig.sensor_port, "world", None)
    twin_id = getattr(getattr(world, "sensor", None), "sensor_id", None)
    return str(twin_id or rig.devices.sensor)


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


def refuse_to_replace(out: Path, resume: bool, force: bool) -> None:
    """The output rule for a raw dataset and its journal, before any port opens
    (``h5io.refuse_to_replace_run``)."""
    from whiskercal.artifacts.h5io import refuse_to_replace_run

    refuse_to_replace_run(out, resume, force, "raw dataset", journal=journal_path(out))


def open_checkpoint(out: Path, header: RawHeader, resume: bool, force: bool = False) -> Checkpoint:
    """A new checkpoint, or the resumed one; an existing run is replaced only with ``force``."""
    if not out.parent.is_dir():
        raise UsageError(f"{out.parent}: no such directory for the output file")
    refuse_to_replace(out, resume, force)  # again: the file may have appeared since the start
    if resume:
        return Checkpoint.resume(out, header)
    return Checkpoint.start(out, header)


def collect(stage_port, sensor_port, out: str | Path, plan: GridPlan, resume: bool = False,
            force: bool = False, on_progress: Callable[[Progress], None] | None = None,
            stop_requested: Callable[[], bool] | None = None,
            stage_client=None, sensor_client=None) -> RunSummary:
    """Collect the plan's grid into ``out`` (or continue it with ``resume``; an existing finished
    dataset is replaced only with ``force``, see :func:`refuse_to_replace`).

    ``stage_port``/``sensor_port`` are URLs, device names or open pyserial objects; tests may
    pass ready clients instead (``stage_client``/``sensor_client``), which are left open.
    However the run ends, the stage is halted if it moves and the sensor stream is stopped
    (``RigSession``).

    Raises
    ------
    WhiskercalError
        Device failures, alarms, the overload guard, a refused resume; every point taken
        before the failure is in the file, and the message says how to continue.
    """
    out = Path(out)
    refuse_to_replace(out, resume, force)
    if resume:
        check_resumable(out, plan)
    with RigSession.open(stage_port, sensor_port, session_config(plan.config),
                         stage_client=stage_client, sensor_client=sensor_client) as rig:
        return _session(rig, out, plan, resume, on_progress, stop_requested, force=force)


def _session(rig: RigSession, out: Path, plan: GridPlan, resume: bool, on_progress,
             stop_requested, force: bool = False) -> RunSummary:
    """Check, open the checkpoint and run the collector on an open rig session."""
    refuse_other_fixture(rig)
    check_limits(plan, rig.travel_mm)
    header = make_header(plan, rig.devices, _sensor_id(plan.config, rig),
                         twin_sensor_description(rig))
    checkpoint = open_checkpoint(out, header, resume, force)
    if checkpoint.complete:  # killed after completing, before the journal was removed
        checkpoint.close()
        journal_path(out).unlink(missing_ok=True)
        raise UsageError(f"{out}: the run is already complete; nothing to resume")
    collector = Collector(rig, plan, checkpoint, truth=twin_truth(rig.sensor_port),
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
    summary = _summary(collector, checkpoint, out)
    if complete:
        grid = read_raw_grid(out)
        check_touched(grid.z_uT, grid.z_std_uT, str(out))
    return summary


def _with_saved_points(error: WhiskercalError, taken: int, planned: int, out: Path) -> WhiskercalError:
    """The same error (same class, code and exit code) with what was saved and how to go on."""
    wrapped = type(error).__new__(type(error))
    wrapped.__dict__.update(vars(error))
    Exception.__init__(wrapped, f"{error} [{taken} of {planned} points saved in {out}; "
                                "continue with --resume]")
    return wrapped


def _summary(collector: Collector, checkpoint: Checkpoint, out: Path) -> RunSummary:
    drift = None
    if {"before", "after"} <= set(checkpoint.baselines):
        drift = float(checkpoint.baselines["after"].field_uT[1]
                      - checkpoint.baselines["before"].field_uT[1])
    session = collector.rig.summary()
    kept, dropped, corrupt = collector.recorder.total_frames, session.dropped, session.corrupt
    warnings = [frame_loss_warning(kept, dropped, corrupt, collector.config.safety.max_frame_loss),
                None if collector.rig.devices.has_encoder else OPEN_LOOP_WARNING,
                _beyond_guard_warning(collector)]
    return RunSummary(points=len(checkpoint.taken), planned=len(collector.plan),
                      complete=checkpoint.complete, stopped=collector.stopped,
                      taken_this_run=collector.taken_now, stage_time_s=session.stage_time_s,
                      wall_time_s=session.wall_time_s, dropped=session.dropped,
                      corrupt=session.corrupt, baseline_drift_uT=drift, output=str(out),
                      frame_loss=frame_loss(kept, dropped, corrupt),
                      beyond_guard=len(collector.beyond_guard),
                      points_time_s=collector.points_time_s,
                      warnings=[w for w in warnings if w])


def _beyond_guard_warning(collector: Collector) -> str | None:
    skipped = collector.beyond_guard
    if not skipped:
        return None
    columns = len({round(float(collector.plan.rod_center_mm[i, 0]), 6) for i in skipped})
    return (f"{len(skipped)} planned points lie beyond the overload guard (|z| over "
            f"{collector.config.safety.overload_z_uT:g} µT) at the deep end of {columns} columns "
            "and were skipped: the grid stops where this build nears the sensor's safe range")


def read_stage_settings(stage_port) -> tuple[dict[int, float], tuple[float, float] | None]:
    """Open the stage only to read its settings (for ``--dry-run``), then close it.

    Returns the settings and the travel in stage coordinates (mm; None when the board does not
    state $130/$131): the board's own on whiskercal's firmware, the part of grbl's workspace
    from whiskercal's origin up on a stock board (``rig.machine_space``, its layout before homing).
    """
    from whiskercal.rig.machine_space import machine_space
    from whiskercal.rig.stage import StageClient

    with StageClient(stage_port) as stage:
        whiskercal_firmware = stage.identify().whiskercal_firmware
        settings = stage.settings()
    if 130 not in settings or 131 not in settings:
        return settings, None
    if whiskercal_firmware:
        return settings, (settings[130], settings[131])
    return settings, machine_space(settings).travel_mm
