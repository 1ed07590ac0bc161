"""The twin's stock mode (``sim://NAME/stage?stock=1[&homing=xy]``) replays the transcripts of stock
grbl 1.1h (tests/data/grbl_transcripts): the same line kinds, codes, messages and states in every
step, and the same machine position where the transcript marks it. Pure Python: runs everywhere."""

import pytest

from grbl_transcript import read_transcript, transcripts
from transcript_compare import differences, replay


@pytest.mark.parametrize("path", transcripts(), ids=lambda path: path.stem)
def test_twin_stock_mode_repeats_grbl(path):
    header, recorded = read_transcript(path)
    replayed = replay(header, f"sim://NAME/stage{header['twin_url']}")
    found = differences(header, recorded, replayed)
    assert not found, "\n".join(found)
