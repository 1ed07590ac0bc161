"""Contour following on the twin: run the paper's closed loop around an object and measure the
reconstructed contour against the object's true outline (docs/contour.md)."""

from __future__ import annotations

import contextlib
import signal
import threading
from pathlib import Path
from typing import Callable, Iterator

from whiskercal.artifacts.contour_run import ContourRunFile, read_contour_run, write_contour_run
from whiskercal.contour.run import ContourRun, run_contour
from whiskercal.contour.summary import summarize
from whiskercal.contour.target_sweep import target_sweep
from whiskercal.errors import UsageError
from whiskercal.follow import FollowConfig

__all__ = ["ContourRun", "contour_record", "contour_to_file", "read_contour_run", "run_contour",
           "summarize", "target_sweep"]


def contour_to_file(shape: str, artifact: str | Path, out: str | Path, **options) -> ContourRunFile:
    """Run the loop on the twin against ``shape`` with the calibration ``artifact`` (see
    :func:`contour_record` for the options) and write the run to ``out``, also when stopped
    early (then ``complete`` is False); ``record=PATH`` also writes the stream and the poses as
    a ROS 2 bag there (:mod:`whiskercal.contour.record`; an existing one is replaced only with
    ``force=True``)."""
    from whiskercal.contour.record import record_bag, refuse_existing

    bag = options.pop("record", None)
    force = bool(options.pop("force", False))
    refuse_existing(bag, force)
    asked = options.pop("stop_requested", None)
    with interrupt_as_stop() as interrupted:  # the file is written whole, also after a Ctrl-C
        record = contour_record(shape, artifact, **options,
                                stop_requested=lambda: interrupted() or bool(asked and asked()))
        if bag is not None:
            from whiskercal.twin.params import DEFAULT_SENSOR
            from whiskercal.twin.truth import static_field_uT

            rest = static_field_uT(options.get("sensor") or DEFAULT_SENSOR).tolist()
            record.config["record"] = {"bag": str(bag), "rest_field_uT": rest}
        write_contour_run(out, record)
    record.path = str(out)
    if bag is not None:
        record_bag(bag, record.columns, rest, replace=force)
    return record


@contextlib.contextmanager
def interrupt_as_stop() -> Iterator[Callable[[], bool]]:
    """Turn Ctrl-C (SIGINT) into a request the loop reads between two steps, and yield that test.

    A KeyboardInterrupt raised wherever the signal lands (inside a compiled numba kernel, an
    HDF5 call, halfway through recording a sample) can surface as a SystemError or leave the
    columns of unequal length; asked between steps, the run stops with every sample whole.
    Off the main thread, where no handler can be set, Ctrl-C stays a KeyboardInterrupt; a
    process started with SIGINT ignored keeps ignoring it.
    """
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is signal.SIG_IGN):  # started with Ctrl-C ignored
        yield lambda: False
        return
    requested = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda signum, frame: requested.set())
    try:
        yield requested.is_set
    finally:
        signal.signal(signal.SIGINT, previous)


def _target(calibration, target_z_uT: float | None, artifact) -> float:
    """The deflection target (µT): the one given, else the artifact's; refused before the run
    unless the artifact's lookup answers it (inside its calibrated z range, not 0)."""
    from whiskercal.checks import number

    target = calibration.target_z_uT if target_z_uT is None else number(target_z_uT, "--target-uT")
    if target is None:
        raise UsageError(f"{artifact} has no deflection target: write one with `whiskercal "
                         "optimal-depth report`, or give --target-uT")
    low, high = calibration.z_range_uT
    if target == 0 or not low <= target <= high:
        raise UsageError(f"the deflection target {target:g} µT lies outside {artifact}'s "
                         f"calibrated range [{low:.0f}, {high:.0f}] µT: choose one inside it")
    return float(target)


def contour_record(shape: str, artifact: str | Path, *, sensor=None,
                   target_z_uT: float | None = None, config: FollowConfig = FollowConfig(),
                   speed_mm_s: float | None = None, duration_s: float = 120.0, seed: int = 0,
                   on_progress: Callable[[float], None] | None = None,
                   stop_requested: Callable[[], bool] | None = None,
                   mu_kinetic: float = 0.0, mu_static: float | None = None,
                   mount=None, nuisances=None, rezero: bool = False,
                   scale_filter: bool = True,
                   creep: tuple[float, float] | None = None) -> ContourRunFile:
    """Run the loop on the twin against ``shape`` with the calibration ``artifact``; the run,
    in memory.

    ``sensor`` is the twin's build (default: the default sensor); the artifact must be calibrated
    on the same build. ``target_z_uT`` overrides the artifact's deflection target (which
    ``whiskercal optimal-depth report`` writes); ``speed_mm_s`` the total speed of the config.
    ``mu_static`` (with ``mu_kinetic``): Coulomb stick-slip at the tip; ``mu_kinetic`` alone:
    mu_s = mu_k, the tip sticking inside the cone and sliding on its edge, no stick-slip.
    ``mount``: (nominal ``Mount``, its error (dx mm, dy mm, dyaw deg)) to drive the twin's end
    effector through a mount, the sensor truly at the nominal one moved by the error
    (``contour.mounted``); the run's config records both.
    ``nuisances``: what a real rig adds (``twin.nuisances.Nuisances``; None: off); ``rezero``:
    the tracker re-zeroes its rest out of contact (``runtime.Calibration.tracker``);
    ``scale_filter``: the tracker's filter is scaled to the loop's rate (the same at 300 Hz);
    ``creep``: the suspension's creep (share, time constant s) the tracker undoes.
    """
    import numpy as np

    from whiskercal import runtime
    from whiskercal.checks import number, positive
    from whiskercal.twin.outlines import outline
    from whiskercal.twin.params import DEFAULT_SENSOR

    shape_outline = outline(shape)  # an unknown shape is refused before the artifact loads
    mu_kinetic, friction = _friction(shape_outline,
                                     *_nuisance_friction(nuisances, mu_kinetic, mu_static))
    sensor = sensor or DEFAULT_SENSOR
    calibration = runtime.load(artifact)
    target = _target(calibration, target_z_uT, artifact)
    if calibration.sensor_id != sensor.sensor_id:
        raise UsageError(f"{artifact} was calibrated on sensor {calibration.sensor_id!r}, the twin "
                         f"runs {sensor.sensor_id!r}: calibrate that build or pass its --sensor")
    if speed_mm_s is not None:
        config = config.replace(total_speed_mm_s=positive(speed_mm_s, "--speed", unit="mm/s"))
    positive(duration_s, "--duration", unit="s")
    tip_mm_per_uT = calibration.tip_motion_mm_per_uT(target)  # scales the PID to the build
    rate = _loop_rate(config, nuisances)
    tracker = calibration.tracker(out_of_range="clip", rezero=bool(rezero), creep=creep,
                                  rate_hz=rate if scale_filter or creep else None)
    run = run_contour(shape_outline, sensor, tracker, target, config, duration_s, seed,
                      on_progress, stop_requested, friction, tip_mm_per_uT, mount, nuisances)
    extra = {} if run.mount is None else {"mount": run.mount}
    return ContourRunFile(shape, np.asarray(shape_outline.core_mm), shape_outline.radius_mm,
                          float(target), seed, run.complete, run.wall_s, sensor.sensor_id,
                          run.columns, {"follow": run.config, "artifact": str(artifact),
                                        "tip_mm_per_uT": tip_mm_per_uT,
                                        "mu_kinetic": float(mu_kinetic),
                                        "mu_static": None if friction is None else friction.mu_static,
                                        **extra, **_nuisance_config(nuisances, rezero)},
                          transitions=run.transitions)


def _nuisance_friction(nuisances, mu_kinetic: float, mu_static: float | None):
    """(mu_kinetic, mu_static): the contact nuisance's stick-slip where none was given."""
    contact = None if nuisances is None else nuisances.contact
    if contact is not None and contact.mu_static and not mu_kinetic and mu_static is None:
        return contact.mu_kinetic, contact.mu_static
    return mu_kinetic, mu_static


def _loop_rate(config: FollowConfig, nuisances) -> float:
    """The loop's rate (Hz): the robot nuisance's when it sets one, else the config's."""
    robot_rate = 0.0 if nuisances is None else nuisances.robot.rate_hz
    return robot_rate or config.rate_hz


def _nuisance_config(nuisances, rezero: bool) -> dict:
    """The run config's record of the nuisances and the re-zero (nothing when both are off, so
    that a run without them is recorded as a run on the ideal twin)."""
    recorded = {} if nuisances is None or nuisances.off else {"nuisances": nuisances.to_dict()}
    return {**recorded, **({"rezero": True} if rezero else {})}


def _friction(shape_outline, mu_kinetic, mu_static):
    """The checked coefficients: (mu_kinetic, a ``Coulomb`` or None: frictionless)."""
    from whiskercal.checks import number
    from whiskercal.twin.physics.coulomb import Coulomb

    mu_kinetic = number(mu_kinetic, "--mu-kinetic", low=0.0, high=2.0)
    if not shape_outline.closed and (mu_kinetic or mu_static is not None):
        raise UsageError("friction is not modelled on the wall: leave out --mu-static and --mu-kinetic")
    if mu_static is None:  # no stick-slip: mu_s = mu_k, or frictionless
        return mu_kinetic, Coulomb(mu_kinetic, mu_kinetic) if mu_kinetic else None
    mu_static = number(mu_static, "--mu-static", low=0.0, high=2.0)
    if mu_static < mu_kinetic:
        raise UsageError(f"--mu-static ({mu_static:g}) must be at least --mu-kinetic ({mu_kinetic:g})")
    return mu_kinetic, Coulomb(mu_static, mu_kinetic)
