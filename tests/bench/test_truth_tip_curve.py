"""The benches' truth for a z lookup: the tip curve's first branch, one tip per z.

On a build whose root carries most of the compliance (the stiff 60 mm wire, k_θ·L/EI 3.8) z
falls to about -27 700 µT and turns back as the wire swings round its root; the second branch's
tips (20-40 mm nearer the root) share z with the first branch's. A lookup measured against
both branches was charged 34 mm RMS for answering the first (docs/calibration.md).
"""

import numpy as np

from whiskercal.bench import sensor_family
from whiskercal.testing.fields import truth_tip_curve
from whiskercal.twin import truth

STIFF_WIRE = next(s for s in sensor_family.FAMILY if s.sensor_id == "stiff-wire-60x0.40")


def test_the_truth_stops_where_z_folds_back():
    z, tips = truth_tip_curve(STIFF_WIRE)
    whole_z, whole_tips = truth.tip_curve(STIFF_WIRE)
    assert np.all(np.diff(z) < 0)  # one tip per z
    assert len(z) < len(whole_z)   # the fold lies within the swept slopes
    # what is left out is the second branch: z back above the fold, tips nearer the root
    beyond = whole_z[len(z):]
    assert beyond.max() > z.min() and whole_tips[len(z):, 0].max() < tips[:, 0].min()
