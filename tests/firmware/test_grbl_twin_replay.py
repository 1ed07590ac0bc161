"""The twin's stock mode (``sim://NAME/stage?stock=1[&homing=xy]``) replays the transcripts of stock
grbl 1.1h (tests/data/grbl_transcripts): the same line kinds, codes, messages and states in every
step, and the same machine position where the transcript marks it. Pure Python: runs everywhere."""

import pytest

from grbl_transcript import read_transcript, transcripts
from transcript_compare import differences, replay

# What the twin's stock mode does not repeat yet (its fidelity is being worked on): one reason each.
ALARM_PAUSE = ("grbl sends [MSG:Reset to continue] 500 ms after ALARM:2 and loses a reset sent before it (the "
               "twin sends both at once), and after the reset answers the refused line's ok before the banner")
NOT_YET = {
    "banner_settings": "$$ lists 16 settings; grbl 1.1h lists all 34 ($0-$6, $11-$13, $21, $26, $30-$32 and "
                       "Z's $102/$112/$122/$132 are missing)",
    "error_codes": "$Q is error:3 (grbl: 2), G20 G21 error:20 (21), G2 without F error:20 (22), T300 error:20 (38), "
                   "and N99999999 G0 X-1 is accepted and moves (grbl: error:27)",
    "home_polled": "the twin answers every '?' during homing; grbl's homing cycle answers none until it ends "
                   "(one <Home|...> report with the final MPos, just before the ok)",
    "home_stock_config": "no ok for $H 500 ms after ALARM:9, before the reset's banner",
    "home_xy": ALARM_PAUSE,
    "soft_limit": ALARM_PAUSE,
    "status_wpos": "G92 and G92.1 are refused (error:20)",
}


def _params():
    for path in transcripts():
        reason = NOT_YET.get(path.stem)
        marks = [pytest.mark.xfail(strict=False, reason=reason)] if reason else []
        yield pytest.param(path, marks=marks, id=path.stem)


@pytest.mark.parametrize("path", list(_params()))
def test_twin_stock_mode_repeats_grbl(path):
    header, recorded = read_transcript(path)
    replayed = replay(header, f"sim://NAME/stage{header['twin_url']}")
    found = differences(header, recorded, replayed)
    assert not found, "\n".join(found)
