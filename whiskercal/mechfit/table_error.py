"""An estimate of the (Y, Z) table's tip error made without the truth: its own ambiguity.

One reading of Y and Z carries one sample's noise. The table's tip loads whose fields lie within
that noise of each other cannot be told apart by the runtime, so the spread of their tips is an
error the table must make: on a smooth one-to-one map it is the noise carried through the map's
slope (hundredths of a millimetre on the default sensor); where different loads give the same
(Y, Z) (a thin wire bent both ways past the axis) it is the distance between the branches.
It cannot see a model that is wrong everywhere in the same way (a suspension fitted wrong): the
fit's residual and identification profile are the checks for that (``fit.field_table``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

# loads used at most (a random, seeded subset keeps the estimate well under a second)
MAX_POINTS = 4000


def ambiguity_tip_error_mm(fields_uT: np.ndarray, tips_mm: np.ndarray, sample_noise_uT,
                           seed: int = 0) -> float:
    """RMS distance (mm) between a load's tip and the tips of the loads whose (Y, Z) lie within
    one sample's noise ``sample_noise_uT`` (Y, Z µT) of its own; NaN with under two loads."""
    fields, tips = np.asarray(fields_uT, float), np.asarray(tips_mm, float)
    keep = np.all(np.isfinite(fields), axis=1) & np.all(np.isfinite(tips), axis=1)
    fields, tips = fields[keep], tips[keep]
    if len(fields) < 2:
        return float("nan")
    scaled = fields / np.broadcast_to(np.asarray(sample_noise_uT, float), (2,))
    tree = cKDTree(scaled)
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(fields), min(MAX_POINTS, len(fields)), replace=False)
    squares = []
    for index in chosen:
        near = tree.query_ball_point(scaled[index], 1.0)
        squares.append(np.mean(np.sum((tips[near] - tips[index]) ** 2, axis=1)))
    return float(np.sqrt(np.mean(squares)))
