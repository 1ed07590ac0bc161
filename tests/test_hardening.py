"""Faults a fuzzer does not reach: a full disk or a read-only folder while writing, an existing
output, a second collect on one file, Ctrl-C in the contour loop, malformed files of a known
schema. Each ends in one clear error (or a whole partial result), never a traceback or a crash."""

from __future__ import annotations

import dataclasses
import errno
import os
import shutil
import signal
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from whiskercal import atomic, runtime
from whiskercal.artifacts import h5io
from whiskercal.artifacts.calibration import read_calibration, write_calibration
from whiskercal.cli import cli
from whiskercal.collect.checkpoint import Checkpoint
from whiskercal.collect.journal import Journal, journal_path
from whiskercal.errors import ArtifactError, UsageError, WhiskercalError
from ctrl_c import printed_with_ctrl_c_as_from_a_terminal

REPO = Path(__file__).resolve().parents[1]
CAL = REPO / "tests" / "fixtures" / "calibration-1.3.0-target.h5"


def _full_disk(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_full_disk_while_writing_an_artifact_is_one_error_and_keeps_the_old_file(tmp_path,
                                                                                    monkeypatch):
    data = read_calibration(CAL)
    out = tmp_path / "cal.h5"
    write_calibration(out, data)
    before = out.read_bytes()
    monkeypatch.setattr(atomic, "_fsync_path", _full_disk)  # the flush finds the disk full
    with pytest.raises(ArtifactError, match="No space left on device"):
        write_calibration(out, data)
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.h5"]  # no partial file left


def test_a_full_disk_mid_write_leaves_the_old_text_whole(tmp_path, monkeypatch):
    out = atomic.write_text(tmp_path / "summary.json", "old")

    class FullFile:
        def __init__(self, *args, **kwargs):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        write = _full_disk

    monkeypatch.setattr(atomic, "open", FullFile, raising=False)
    with pytest.raises(UsageError, match="cannot write .*No space left on device"):
        atomic.write_text(out, "new")
    assert out.read_text() == "old" and len(list(tmp_path.iterdir())) == 1


def test_hdf5_files_are_built_in_memory_and_never_written_by_hdf5_itself(tmp_path, monkeypatch):
    seen = []
    real = h5py.File

    def spy(name, *args, **kwargs):
        seen.append(name)
        return real(name, *args, **kwargs)

    monkeypatch.setattr(h5py, "File", spy)
    h5io.write_whole(tmp_path / "x.h5", lambda handle: handle.create_group("g"))
    assert seen and all(not isinstance(name, (str, os.PathLike)) for name in seen)
    with real(tmp_path / "x.h5") as handle:
        assert "g" in handle


def test_a_read_only_folder_is_one_line_for_every_atomic_writer(tmp_path, monkeypatch):
    def read_only(*args, **kwargs):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))

    monkeypatch.setattr(atomic.tempfile, "mkstemp", read_only)
    with pytest.raises(UsageError, match="cannot write .*Permission denied"):
        atomic.write_bytes(tmp_path / "a.png", b"png")
    result = CliRunner().invoke(cli, ["report", str(CAL), "--out", str(tmp_path / "r.html")])
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == [
        f"error: cannot write {tmp_path / 'r.html'}: Permission denied"]


def test_a_set_of_outputs_is_replaced_together_or_not_at_all(tmp_path):
    paths = {name: tmp_path / name for name in ("track.csv", "track.h5", "summary.json")}
    for path in paths.values():
        path.write_text("old")
    with pytest.raises(OSError):
        with atomic.atomic_set(paths) as scratch:
            scratch["track.csv"].write_text("new")
            scratch["track.h5"].write_text("new")
            _full_disk()  # the third file does not fit
    assert [path.read_text() for path in paths.values()] == ["old"] * 3
    assert len(list(tmp_path.iterdir())) == 3  # no scratch files left
    with atomic.atomic_set(paths) as scratch:
        for path in scratch.values():
            path.write_text("new")
    assert [path.read_text() for path in paths.values()] == ["new"] * 3


def test_an_existing_output_is_refused_and_force_replaces_it(tmp_path):
    out = tmp_path / "r.html"
    out.write_text("an earlier report")
    refused = CliRunner().invoke(cli, ["report", str(CAL), "--out", str(out)])
    assert refused.exit_code == 2 and "pass --force" in refused.stderr
    assert out.read_text() == "an earlier report"
    forced = CliRunner().invoke(cli, ["report", str(CAL), "--out", str(out), "--force"])
    assert forced.exit_code == 0, forced.output
    assert out.read_text().startswith("<!DOCTYPE html>")


def test_a_second_collect_on_a_file_being_written_gets_the_lock_error(tmp_path):
    out = tmp_path / "raw.h5"
    first = Journal(journal_path(out))  # a run holds its journal while it goes
    first.append({"type": "header", "fingerprint": "x"})
    before = journal_path(out).read_bytes()
    with pytest.raises(UsageError, match="held by another collect run"):
        Checkpoint.resume(out, header=None)
    first.close()
    assert journal_path(out).read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["raw.h5.journal"]  # no .rebuild


CTRL_C_AS_STOP = """
import signal
from whiskercal.contour import interrupt_as_stop

handler = signal.getsignal(signal.SIGINT)
with interrupt_as_stop() as interrupted:
    before = interrupted()
    signal.raise_signal(signal.SIGINT)  # no KeyboardInterrupt is raised here
    after = interrupted()
print(before, after, signal.getsignal(signal.SIGINT) is handler)
"""


def test_ctrl_c_becomes_a_stop_request_between_steps():
    printed = printed_with_ctrl_c_as_from_a_terminal(CTRL_C_AS_STOP)
    assert printed.split() == ["False", "True", "True"]  # asked after it only; handler restored


def test_a_run_stopped_at_once_keeps_one_whole_sample():
    from whiskercal.contour import contour_record

    record = contour_record("cylinder", CAL, duration_s=5.0, stop_requested=lambda: True)
    lengths = {name: len(values) for name, values in record.columns.items()}
    assert set(lengths.values()) == {1} and not record.complete


def _attribute_names(path: Path) -> list[tuple[str, str]]:
    names = [("", key) for key in h5py.File(path).attrs]
    with h5py.File(path) as handle:
        handle.visititems(lambda name, item: names.extend((name, key) for key in item.attrs))
    return names


ATTRIBUTES = _attribute_names(CAL)
BAD_VALUES = ["{not json", np.nan, np.array([1.0, 2.0]), b"\xff\xfe", -1]


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(where=st.sampled_from(ATTRIBUTES), value=st.sampled_from(BAD_VALUES),
       delete=st.booleans())
def test_a_calibration_with_a_bad_attribute_loads_or_fails_with_one_artifact_error(
        tmp_path, where, value, delete):
    path = tmp_path / "bad.h5"
    shutil.copy(CAL, path)
    group, key = where
    with h5py.File(path, "a") as handle:
        attrs = (handle[group] if group else handle).attrs
        if delete:
            del attrs[key]
        else:
            attrs[key] = value
    try:
        runtime.load(path).tracker()
    except WhiskercalError as error:  # settings the model refuses name themselves, not the file
        assert len(str(error).splitlines()) == 1
        assert str(path) in str(error) or not isinstance(error, ArtifactError)


def test_fit_refuses_a_y_flipped_twin_grid_before_fitting():
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit.truth import refuse_z_against_truth

    grid = read_raw_grid(REPO / "data" / "twin-paper-75mm" / "raw_grid.h5")
    refuse_z_against_truth(grid)  # as recorded: z and the truth agree
    with pytest.raises(UsageError, match="reads against the twin's truth"):
        refuse_z_against_truth(dataclasses.replace(grid, z_uT=-grid.z_uT))
