"""Measure how far a dataset's study moves when it is recorded again on a twin that differs from
the recorded one only in the last digits: the evidence behind whiskercal/regress/rerecorded.py.

Run: .venv/bin/python scripts/rerecord_spread.py [--only NAME] [--ulps 0 1 -1 2 -2 3 -3]

Another machine's libm, numpy or numba rounds some results differently in the last place, and
the study's stick-slip slides carry such a difference into whole slips. This records the study of
a dataset in data/ again, with the same seeds and commands as scripts/record_data.py but the twin
whisker's Young's modulus moved by k units in the last place for each k, recomputes the golden
quantities with the recorded grid (static contacts, unaffected), and prints per re-recording
tolerance class the largest move against the recorded golden results and the class's bound.
k = 0 is the control: it must move nothing. About a minute per k.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from record_data import DATASETS, dataset_commands

from whiskercal.regress.golden import Dataset, read_golden
from whiskercal.regress.pack import compact_copy
from whiskercal.regress.pipeline import recompute
from whiskercal.regress.rerecorded import (compare_rerecorded, lookup_slope_mm_per_uT,
                                           rerecorded_rules, rerecorded_tolerance, z_step_uT)

DATA = Path(__file__).resolve().parent.parent / "data"
MOVED_RUN = "--run-on-moved-twin"  # internal: run one whiskercal command on the moved twin


def _moved(value: float, ulps: int) -> float:
    """``value`` moved by ``ulps`` units in the last place (toward +inf when positive)."""
    for _ in range(abs(ulps)):
        value = math.nextafter(value, math.copysign(math.inf, ulps))
    return value


def run_on_moved_twin(ulps: int, argv: list[str]) -> None:
    """Run a whiskercal command in this process, every twin sensor's whisker moved by ``ulps``."""
    from whiskercal.cli import cli
    from whiskercal.twin import params

    shipped = params.sensor_by_id

    def moved_sensor(sensor_id: str):
        sensor = shipped(sensor_id)
        modulus = _moved(sensor.whisker.youngs_modulus_n_per_mm2, ulps)
        whisker = dataclasses.replace(sensor.whisker, youngs_modulus_n_per_mm2=modulus)
        return dataclasses.replace(sensor, whisker=whisker)

    params.sensor_by_id = moved_sensor
    cli(argv, prog_name="whiskercal")


def rerecord_study(spec: dict, ulps: int, scratch: Path, fit_pipeline: dict) -> dict:
    """The golden quantities of the dataset with its study recorded again on the moved twin."""
    source = DATA / spec["name"]
    directory = scratch / f"ulps{ulps:+d}" / spec["name"]
    directory.mkdir(parents=True)
    shutil.copy(source / "raw_grid.h5", directory / "raw_grid.h5")
    recorded = directory.parent / "plane_study-recorded.h5"
    study = dataset_commands(spec, source, directory.parent / "unused.h5", recorded)[1]
    subprocess.run([sys.executable, __file__, MOVED_RUN, str(ulps), *study[1:]], check=True,
                   capture_output=True)
    compact_copy(recorded, directory / "plane_study.h5")
    quantities, _ = recompute(Dataset(directory), fit_pipeline, directory.parent)
    return {name: None if isinstance(v, float) and math.isnan(v) else v
            for name, v in quantities.items()}


def report(golden: dict, runs: dict[int, dict], z_step: float) -> None:
    """Per class: its bound, the largest move over all runs and where; then what left its bound."""
    rules = rerecorded_rules(z_step, lookup_slope_mm_per_uT(golden))
    largest: dict[str, tuple[float, float, str]] = {}
    for ulps, quantities in runs.items():
        for name, value in golden.items():
            tolerance = rerecorded_tolerance(name, rules)
            new = quantities.get(name)
            numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool)
                          for v in (value, new))
            move = abs(new - value) if numbers else 0.0
            bound = tolerance.abs_tol + tolerance.rel_tol * (abs(value) if numbers else 0.0)
            if move >= largest.get(tolerance.name, (-1.0,))[0]:
                largest[tolerance.name] = (move, bound, f"{name} (k={ulps:+d})")
    print(f"{'class':24} {'largest move':>13} {'bound':>10}  where")
    for name, (move, bound, where) in sorted(largest.items()):
        print(f"{name:24} {move:13.3g} {bound:10.3g}  {where if move > 0 else ''}")
    for ulps, quantities in runs.items():
        beyond = compare_rerecorded(golden, quantities, z_step)
        print(f"k={ulps:+d}: {len(beyond)} beyond the re-recording bounds")
        for change in beyond:
            print("   ", change.describe())


def main() -> None:
    if sys.argv[1:2] == [MOVED_RUN]:
        run_on_moved_twin(int(sys.argv[2]), sys.argv[3:])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="twin-short-60mm", help="The dataset to record again.")
    parser.add_argument("--ulps", type=int, nargs="+", default=[0, 1, -1, 2, -2, 3, -3],
                        help="Moves of the whisker's Young's modulus, in units in the last place.")
    args = parser.parse_args()
    spec = next(s for s in DATASETS if s["name"] == args.only)
    golden = read_golden(Dataset(DATA / spec["name"]))
    with tempfile.TemporaryDirectory(prefix="whiskercal-spread-") as scratch:
        runs = {}
        for ulps in args.ulps:
            print(f"recording the study again with the whisker moved by {ulps:+d} ulp", flush=True)
            runs[ulps] = rerecord_study(spec, ulps, Path(scratch), golden.pipeline)
    report(golden.quantities, runs, z_step_uT(DATA / spec["name"] / "plane_study.h5"))


if __name__ == "__main__":
    main()
