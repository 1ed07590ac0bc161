"""Small stand-ins for the stage and sensor clients that honour the documented client API.

The fake rig is deliberately simple physics: z grows linearly with how far the plane is pushed
past the undeflected tip. It tests the run loop's logic (search, moves, records, checkpoint,
safety), not the whisker.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.rig.sensor import SampleBlock
from whiskercal.rig.stage import StageIdentity, StageStatus
from whiskercal.study.config import PlaneGeometry, load_config

STATIC_Y_UT = 1160.0
LSB_UT = 0.6


@dataclass
class FakeRig:
    """Shared state of the fake stage and sensor: position (mm) and simulated time (s)."""

    geometry: PlaneGeometry
    uT_per_mm: float = -250.0
    rate_hz: float = 300.0
    seed: int = 0
    fail_after_s: float | None = None

    def __post_init__(self):
        self.position = np.array([10.0, 10.0])
        self.time_s = 0.0
        self.rng = np.random.default_rng(self.seed)
        self.seq = 0

    def z_uT(self, position) -> float:
        guess = self.geometry.contact_guess_stage_mm()
        depth = float(self.geometry.depth_of_stage_mm(position, guess)[0])
        return self.uT_per_mm * max(depth, 0.0)


class FakeStage:
    def __init__(self, rig: FakeRig, travel_mm=(200.0, 200.0)):
        self.rig = rig
        self.travel = travel_mm
        self.target = rig.position.copy()
        self.feed_mm_s = 1.0
        self.transport = type("T", (), {"now_s": staticmethod(lambda: rig.time_s)})()
        self.homed = False

    def identify(self):
        return StageIdentity("1.1h.0", "fake", "V", "whiskercal-stage-1", True)

    def home(self):
        self.homed = True

    def settings(self):
        return {130: self.travel[0], 131: self.travel[1], 20: 1}

    def move_to(self, x, y, feed_mm_min):
        self.target = np.array([x, y], float)
        self.feed_mm_s = feed_mm_min / 60.0

    def status(self):
        idle = bool(np.allclose(self.rig.position, self.target))
        return StageStatus("Idle" if idle else "Run", self.rig.position.copy(),
                           self.rig.position.copy(), self.feed_mm_s * 60)

    def wait_idle(self, timeout_s=60.0, on_poll=None):
        while True:
            status = self.status()
            if on_poll is not None:
                on_poll(status)
            if status.idle:
                return status
            if on_poll is None:
                self.advance(0.02)

    def advance(self, dt_s):
        step = self.target - self.rig.position
        distance = float(np.linalg.norm(step))
        travel = self.feed_mm_s * dt_s
        self.rig.position = self.target.copy() if distance <= travel else \
            self.rig.position + step / distance * travel

    def hold(self):
        self.target = self.rig.position.copy()

    def reset(self):
        self.target = self.rig.position.copy()

    def unlock(self):
        pass


class FakeSensor:
    def __init__(self, rig: FakeRig, stage: FakeStage):
        self.rig, self.stage = rig, stage
        self.started = False
        self.dropped = self.corrupt = 0

    def identify(self):
        return "fake"

    def configure(self, **settings):
        self.settings = settings

    def start(self):
        self.started = True

    def stop(self):
        self.started = False

    def _samples(self, n):
        rig = self.rig
        rows = []
        for _ in range(n):
            rig.time_s += 1.0 / rig.rate_hz
            if rig.fail_after_s is not None and rig.time_s > rig.fail_after_s:
                from whiskercal.errors import DeviceError
                raise DeviceError("sensor on fake: port vanished")
            self.stage.advance(1.0 / rig.rate_hz)
            y = STATIC_Y_UT + rig.z_uT(rig.position) + rig.rng.normal(0, 5.0)
            rows.append([rig.seq, rig.time_s, 0.0, y, 0.0])
            rig.seq += 1
        rows = np.array(rows, float).reshape(-1, 5)
        counts = np.round(rows[:, 2:5] / LSB_UT).astype(np.int64)
        return SampleBlock(seq=rows[:, 0].astype(np.int64), t_s=rows[:, 1], counts=counts,
                           field_uT=counts * LSB_UT, status=np.zeros(len(rows), np.uint8))

    def sync(self):
        """Nothing is ever buffered here: the next sample read is the first fresh one."""
        return self.rig.time_s + 1.0 / self.rig.rate_hz

    def read(self, n, timeout_s=1.0):
        return self._samples(n)

    def read_available(self):
        return self._samples(0)


def fake_rig(config, **kwargs):
    rig = FakeRig(PlaneGeometry.from_config(config), **kwargs)
    stage = FakeStage(rig)
    return rig, stage, FakeSensor(rig, stage)


class FakeCalibration:
    """A calibration that maps z to the point the fake rig's plane passes through at that depth.

    Raw tips are exact up to the stream's noise; the "filter" is a plain running mean. It stands
    in for ``whiskercal.runtime`` where the test is about the study's bookkeeping, not the model.
    """

    def __init__(self, geometry: PlaneGeometry, uT_per_mm: float = -250.0, threshold_uT=300.0,
                 z_limit_uT=None):
        self.geometry, self.uT_per_mm, self.threshold_uT = geometry, uT_per_mm, threshold_uT
        self.z_limit_uT = z_limit_uT
        self.target_z_uT = None

    def tip(self, z_uT):
        if self.z_limit_uT is not None and abs(z_uT) > self.z_limit_uT:
            return None
        tip0 = np.array([self.geometry.tip_reach_mm, 0.0])
        return tip0 + (z_uT / self.uT_per_mm) * self.geometry.push_whisker

    def tracker(self, out_of_range="nan"):
        calibration = self

        class Tracker:
            contact, total, count = False, np.zeros(2), 0

            def update(self, z_uT):
                self.contact = self.contact or abs(z_uT) > calibration.threshold_uT
                if not self.contact:
                    return type("S", (), {"contact": False, "raw_tip_mm": None, "filtered_tip_mm": None})
                raw = calibration.tip(z_uT)
                if raw is None:
                    return type("S", (), {"contact": True, "raw_tip_mm": None, "filtered_tip_mm": None})
                self.total, self.count = self.total + raw, self.count + 1
                return type("S", (), {"contact": True, "raw_tip_mm": raw,
                                      "filtered_tip_mm": self.total / self.count})

        return Tracker()


def fake_config(tmp_path, text=""):
    """Three short trials with a quick search; ``text`` adds TOML lines."""
    path = tmp_path / "study.toml"
    path.write_text("[trials]\ndepths_mm = [5.0, 10.0, 15.0]\ntravel_mm = 10.0\n"
                    "slide_start_mm = -5.0\nspeed_mm_s = 20.0\n"
                    "[contact]\nsearch_step_mm = 0.5\nsamples_per_step = 3\nbaseline_samples = 30\n"
                    + text)
    return load_config(path)


def run_on_clients(stage, sensor, config, writer, world=None):
    """``StudyRun`` on ready clients (fakes or serial clients) inside a rig session."""
    from whiskercal.session import RigSession
    from whiskercal.study.run import StudyRun, session_config

    with RigSession.open(None, None, session_config(config), stage_client=stage,
                         sensor_client=sensor) as rig:
        return StudyRun(rig, config, writer, world=world).run()
