"""A calibration fitted on the recorded twin grid, and a long synthetic stream made from the twin."""

import json
from pathlib import Path

import numpy as np
import pytest

from recorded_fits import recorded_fit
from replay_session import REST_UT

from whiskercal import runtime
from whiskercal.fit import options_from_args
from whiskercal.twin import truth
from whiskercal.twin.params import SENSORS

DATASET = Path(__file__).parents[2] / "data" / "twin-paper-75mm"
NOISE_UT = 5.6        # the sensor's noise at rest, same session
RATE_HZ = 167.0       # the authors' logged rate


@pytest.fixture(scope="session")
def artifact() -> Path:
    """data/twin-paper-75mm fitted with its golden file's fit arguments (what regress fits),
    with the level set's lookup and without the (Y, Z) table: a replayed log streams Y alone
    (the table adds about a minute), and the synthetic stream below runs 25 % past the level
    set's calibrated range, which the mechanics' wider range would carry past the twin's tip
    curve."""
    golden = json.loads((DATASET / "golden.json").read_text())
    fit_args = [*golden["pipeline"]["fit_args"], "--tip-model", "level-set", "--no-field-table"]
    # the follow and contour tests' plain calibration is this fit too: made once per process
    return recorded_fit(DATASET.name, options_from_args(fit_args))


@pytest.fixture(scope="session")
def calibration(artifact):
    return runtime.load(artifact)


def contact_profile(n: int, z_low_uT: float, seed: int) -> np.ndarray:
    """Noise-free z (n,) µT: rest, then presses of random depth down to ``z_low_uT`` (past the
    calibrated range on some), each ramping in, holding, and ramping out."""
    rng = np.random.default_rng(seed)
    z = np.zeros(n)
    start = 300
    while start < n - 600:
        depth = rng.uniform(0.15, 1.0) * z_low_uT
        ramp, hold = rng.integers(100, 400), rng.integers(200, 1200)
        shape = np.concatenate([np.linspace(0, 1, ramp), np.ones(hold), np.linspace(1, 0, ramp)])
        stop = min(start + len(shape), n)
        z[start:stop] = depth * shape[:stop - start]
        start = stop + rng.integers(100, 500)
    return z


@pytest.fixture(scope="session")
def synthetic(calibration):
    """A 40,000-sample log (seeded): time s, raw Y µT, noise-free z µT and the true tips (mm)
    of the twin sensor the grid came from; z runs to 25 % past the calibrated range's far end."""
    sensor = SENSORS["twin-paper-75mm"]
    n = 40_000
    z_low = 1.25 * calibration.z_range_uT[0]
    z_true = contact_profile(n, z_low, seed=17)
    rng = np.random.default_rng(18)
    reading = REST_UT + z_true + rng.normal(0.0, NOISE_UT, n)
    return {"t_s": np.arange(n) / RATE_HZ, "reading_uT": reading, "z_true_uT": z_true,
            "tip_true_mm": truth.true_tip(sensor, z_true), "sensor": sensor}
