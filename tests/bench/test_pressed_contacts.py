"""A pressed plane read as a stream: readings between solved depths, each measured depth held,
and the errors taken at the held samples (seeded, no twin solves)."""

import numpy as np

from whiskercal.bench import pressed_contacts
from whiskercal.mechfit.table_error import HELD_SAMPLES


def _press():
    fields = np.column_stack([-100.0 * np.arange(1, 5), -50.0 * np.arange(1, 5)])
    tips = np.column_stack([78.0 - np.arange(1, 5), -2.0 * np.arange(1, 5)])
    return pressed_contacts.Press(fields, tips, np.array([False, True, False, True]))


def test_the_stream_holds_each_measured_depth():
    readings, marks = pressed_contacts.stream(_press(), np.random.default_rng(0))
    steps = pressed_contacts.SAMPLES_PER_STEP
    assert len(readings) == 4 * steps + 2 * (HELD_SAMPLES - 1)
    for depth in (1, 3):
        held = np.flatnonzero(marks == depth)
        assert len(held) == HELD_SAMPLES and np.all(np.diff(held) == 1)
    assert np.all(marks[: 2 * steps - 1] == -1)  # pressing in, before the first held depth


def test_errors_are_taken_where_the_contact_is_held():
    press = _press()

    def exact_at_held(readings):  # the true tip wherever the reading is near a held depth
        out = np.full((len(readings), 2), np.nan)
        for k in (1, 3):
            near = np.linalg.norm(readings - press.fields_uT[k], axis=1) < 60.0
            out[near] = press.tips_mm[k]
        return out

    errors = pressed_contacts.pressed_errors(exact_at_held, [press], (-1000.0, 0.0))
    assert errors["n"] == 2 and errors["held"]["n"] == 2
    assert errors["held"]["rmse_mm"] == 0.0
    outside = pressed_contacts.pressed_errors(exact_at_held, [press], (-250.0, 0.0))
    assert outside["n"] == 1  # the deeper depth's Y lies outside the range
