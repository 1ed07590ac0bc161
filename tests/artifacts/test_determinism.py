"""The same raw grid calibrates to bit-identical results in fresh processes."""

import subprocess
import sys
from pathlib import Path

import h5py
import pytest

RAW = Path(__file__).parents[2] / "data" / "twin-paper-75mm" / "raw_grid.h5"


def _lookup(path):
    with h5py.File(path, "r") as handle:
        found = {name: handle[name][()].tobytes() for name in
                 ("lookup/z_uT", "lookup/tip_mm", "lookup/extension_mm", "surface/coefficients")
                 if name in handle}  # the mechanics' lookup has no extension past the grid
    assert {"lookup/z_uT", "lookup/tip_mm", "surface/coefficients"} <= set(found)
    return found


@pytest.mark.slow
def test_two_fresh_processes_write_the_same_lookup_and_z_range(tmp_path):
    outputs = [tmp_path / f"cal-{k}.h5" for k in range(2)]
    # the lookup and the surface are compared; the (Y, Z) table would add a minute to each run
    runs = [subprocess.Popen([sys.executable, "-m", "whiskercal", "fit", str(RAW), "--out",
                              str(out), "--no-field-table", "--json"], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE) for out in outputs]
    for process in runs:
        _, stderr = process.communicate(timeout=120)
        assert process.returncode == 0, stderr.decode()
    first, second = (_lookup(out) for out in outputs)
    assert first == second  # the z range is the lookup's first and last z
