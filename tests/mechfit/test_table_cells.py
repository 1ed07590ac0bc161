"""The (Y, Z) table's cells: fine enough to read the model's own loads back (``tabulate``).

Synthetic loads (seeded) stand in for a model's: tips (mm) smooth in (Y, Z) µT, or, as a long
soft wire bent nearly square gives them, moving by millimetres over the last few hundred µT of
Z where the loads crowd."""

from __future__ import annotations

import numpy as np

from whiskercal.mechfit.tables import (DEFAULT_SHAPE, MAX_REFINE, READ_BACK_MM, REFINE_GAIN,
                                       read_back_mm, tabulate)

Y_RANGE = (-1000.0, 0.0)
Z_MAX_UT = 30000.0


def _loads(tip_of, count: int = 4000, seed: int = 3):
    """Loads crowding toward the top of Z, as a wire bent toward square gives them."""
    rng = np.random.default_rng(seed)
    y = rng.uniform(*Y_RANGE, count)
    z = Z_MAX_UT * (1.0 - rng.uniform(0.0, 1.0, count) ** 2)
    fields = np.column_stack([y, z])
    return fields, tip_of(y, z)


def _smooth(y, z):
    return np.column_stack([60.0 + 1e-3 * y, -20.0 - 1e-3 * z])


def _steep(y, z):
    """The tip swings 12 mm over about 400 µT of Z below the top."""
    swing = 6.0 * np.tanh((z - 29000.0) / 200.0)
    return np.column_stack([60.0 + 1e-3 * y + swing, -100.0 - swing])


def test_a_smooth_table_keeps_the_default_cells():
    fields, tips = _loads(_smooth)
    table = tabulate(fields, tips, Y_RANGE)
    assert table.tips_mm.shape[:2] == DEFAULT_SHAPE
    assert read_back_mm(table, fields, tips) < READ_BACK_MM


def test_a_tip_that_moves_fast_in_z_gets_finer_z_cells_and_reads_its_loads_back():
    fields, tips = _loads(_steep)
    coarse = tabulate(fields, tips, Y_RANGE, DEFAULT_SHAPE)
    table = tabulate(fields, tips, Y_RANGE)
    y_cells, z_cells = table.tips_mm.shape[:2]
    assert y_cells == DEFAULT_SHAPE[0]  # Y was never the coarse axis
    assert DEFAULT_SHAPE[1] < z_cells <= MAX_REFINE * (DEFAULT_SHAPE[1] - 1) + 1
    # each finer step kept reads the loads back at least REFINE_GAIN closer
    assert read_back_mm(table, fields, tips) * REFINE_GAIN < read_back_mm(coarse, fields, tips)


def test_folded_loads_stop_the_refinement_where_it_no_longer_helps():
    fields, tips = _loads(_smooth)
    # the same readings, half of them with a tip 5 mm away: no cell size resolves that
    folded = tips.copy()
    folded[::2] += 5.0
    table = tabulate(fields, folded, Y_RANGE)
    assert table.tips_mm.shape[:2] == DEFAULT_SHAPE
    assert read_back_mm(table, fields, folded) > 1.0
