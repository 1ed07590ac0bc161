"""Record the datasets in data/ on the digital twin, through the full serial path.

Run: .venv/bin/python scripts/record_data.py [--out data] [--only NAME]

For each dataset this runs `whiskercal collect` and `whiskercal optimal-depth run` against
sim:// ports (the same commands and serial protocols as on a real rig; the sensor is chosen
with the URL's `sensor=` option and every random thing with its `seed=`), rewrites both files
compactly (whiskercal.regress.pack), writes the dataset's README with the exact commands, seeds,
twin parameters and whiskercal version, and finally writes the golden results with
`whiskercal regress OUT --update`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from whiskercal import __version__
from whiskercal.regress.golden import DEFAULT_PIPELINE
from whiskercal.regress.pack import compact_copy
from whiskercal.twin.sensor_file import resolve_sensor

HERE = Path(__file__).resolve().parent

# name, twin sensor, world seeds (grid, study), config files in the dataset directory (or None).
DATASETS = (
    {"name": "twin-paper-75mm", "sensor": "twin-paper-75mm", "seeds": (101, 102),
     "collect_config": "collect.toml", "study_config": None,
     # a shaft study (docs/shaft.md): seed, config file in the dataset directory
     "shaft": (103, "shaft_study.toml")},
    {"name": "twin-short-60mm", "sensor": "twin-short-60mm", "seeds": (201, 202),
     "collect_config": "collect.toml", "study_config": "study.toml"},
    # a build described only in a file, calibrated from its trace length (collect.toml)
    {"name": "twin-long-110mm", "sensor": "sensors/long-110mm.toml", "seeds": (301, 302),
     "collect_config": "collect.toml", "study_config": "study.toml"},
)


def _run(argv: list[str]) -> tuple[dict, float]:
    """Run a whiskercal command with --json; return its JSON output and wall time (s)."""
    started = time.perf_counter()
    done = subprocess.run(argv, check=True, capture_output=True, text=True, cwd=HERE.parent)
    return json.loads(done.stdout), time.perf_counter() - started


def dataset_commands(spec: dict, directory: Path, raw: Path, study: Path) -> list[list[str]]:
    """The collect and study commands of one dataset (URLs carry the sensor and seed)."""
    grid_seed, study_seed = spec["seeds"]
    world = spec["name"].replace("-", "_")
    collect = ["whiskercal", "collect",
               "--stage", f"sim://{world}_grid/stage?sensor={spec['sensor']}&seed={grid_seed}",
               "--sensor", f"sim://{world}_grid/sensor", "--out", str(raw), "--json"]
    if spec["collect_config"]:
        collect += ["--config", str(directory / spec["collect_config"])]
    run = ["whiskercal", "optimal-depth", "run",
           "--stage",
           f"sim://{world}_study/stage?scene=plane&sensor={spec['sensor']}&seed={study_seed}",
           "--sensor", f"sim://{world}_study/sensor", "--out", str(study), "--json"]
    if spec["study_config"]:
        run += ["--config", str(directory / spec["study_config"])]
    commands = [collect, run]
    if spec.get("shaft"):
        seed, config = spec["shaft"]
        commands.append(["whiskercal", "shaft-study", "run", "--stage",
                         f"sim://{world}_shaft/stage?sensor={spec['sensor']}&seed={seed}",
                         "--sensor", f"sim://{world}_shaft/sensor",
                         "--config", str(directory / config),
                         "--out", str(study.with_name("shaft_study.h5")), "--json"])
    return commands


def record(spec: dict, out: Path) -> None:
    """Record one dataset into out/NAME (raw_grid.h5, plane_study.h5, README.md)."""
    directory = out / spec["name"]
    directory.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="whiskercal-record-") as scratch:
        raw, study = Path(scratch) / "raw_grid.h5", Path(scratch) / "plane_study.h5"
        commands = dataset_commands(spec, directory, raw, study)
        outputs = []
        for command in commands:
            print("$", shlex.join(command), flush=True)
            outputs.append(_run([sys.executable, "-m", *command]))
        recorded = [raw, study] + ([study.with_name("shaft_study.h5")] if spec.get("shaft") else [])
        for path in recorded:
            compact_copy(path, directory / path.name)
        sizes = {p.name: (p.stat().st_size, (directory / p.name).stat().st_size) for p in recorded}
    shown = [shlex.join(_relative(c, directory, out)) for c in commands]
    (directory / "README.md").write_text(_readme(spec, shown, outputs, sizes), encoding="utf-8")


def _relative(command: list[str], directory: Path, out: Path) -> list[str]:
    """The command as the README shows it: paths relative to the repository root."""
    root = out.resolve().parent
    shown = []
    for arg in command:
        path = Path(arg)
        if path.name in ("raw_grid.h5", "plane_study.h5", "shaft_study.h5"):
            arg = f"RECORDED/{path.name}"
        elif path.is_absolute() and path.resolve().is_relative_to(root):
            arg = str(path.resolve().relative_to(root))
        shown.append(arg)
    return shown


def _readme(spec: dict, commands: list[str], outputs: list, sizes: dict) -> str:
    sensor = resolve_sensor(HERE.parent / spec["sensor"] if spec["sensor"].endswith(".toml")
                            else spec["sensor"])
    (grid, grid_wall), (study, study_wall) = outputs[:2]
    grid_seed, study_seed = spec["seeds"]
    lines = [
        f"# {spec['name']}",
        "",
        f"Recorded on the digital twin's sensor `{sensor.sensor_id}` through the full serial path "
        f"(sim:// ports, the same protocols as a real rig) by `scripts/record_data.py` with "
        f"whiskercal {__version__}, {time.strftime('%Y-%m-%d', time.gmtime())}.",
        "",
        "## Commands",
        "",
        "```",
        *commands,
        "```",
        "",
        "`RECORDED/` is the scratch directory the commands wrote to; the files were then "
        "compacted into this directory (see Storage). To record again: "
        f"`.venv/bin/python scripts/record_data.py --only {spec['name']}`, then review "
        "`git diff data/` and the changes `whiskercal regress data --update` lists.",
        "",
        f"World seeds: {grid_seed} (grid), {study_seed} (study): every random number of the twin "
        "(sensor noise, stage) comes from them. Everything not named in the URLs or config files "
        "is the default (docs/twin.md: rod radius 1.5 mm, backlash 0.02 mm, no faults).",
        "",
        "## Results of the recording",
        "",
        f"- grid: {grid['points']} points, {grid['stage_time_s']:.0f} s of rig time in "
        f"{grid_wall:.0f} s wall time, {grid['dropped']} frames dropped, {grid['corrupt']} corrupt, "
        f"baseline drift {grid['baseline_drift_uT']:.2f} µT",
        f"- study: depths {', '.join(f'{d:g}' for d in study['trials_done'])} mm, "
        f"{study['stage_time_s']:.0f} s of rig time in {study_wall:.0f} s wall time, "
        f"{study['dropped']} frames dropped, {study['corrupt']} corrupt",
        *([f"- shaft study (seed {spec['shaft'][0]}, `{spec['shaft'][1]}`): trials "
           f"{', '.join(outputs[2][0]['trials_done'])}"] if spec.get("shaft") else []),
        "",
        "## Storage",
        "",
        "Both files were rewritten by `whiskercal.regress.pack.compact_copy`: every array "
        "gzip-compressed (lossless), the twin's ground truth positions and the plane's per-sample "
        "line point as float32 (spacing under 1e-5 mm). The golden results (`golden.json`) are "
        "computed from these files. Sizes (bytes, as recorded -> stored):",
        "",
        *[f"- {name}: {before:,} -> {after:,}" for name, (before, after) in sizes.items()],
        "",
        "## Golden results",
        "",
        "`golden.json`: every quantity `whiskercal regress` checks, with its tolerance class and "
        "the reason for each class. The pipeline it records: `whiskercal fit raw_grid.h5 "
        f"{' '.join(DEFAULT_PIPELINE['fit_args'])}`, then the study report (margin weight "
        f"{DEFAULT_PIPELINE['margin_weight_mm']} mm) and the runtime's view of the chosen target.",
        "",
        "## Twin parameters",
        "",
        "```json",
        json.dumps(dataclasses.asdict(sensor), indent=1, default=str),
        "```",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE.parent / "data",
                        help="Directory of the datasets (default: data/).")
    parser.add_argument("--only", help="Record only the dataset of this name.")
    args = parser.parse_args()
    for spec in DATASETS:
        if args.only in (None, spec["name"]):
            record(spec, args.out)
    print("$ whiskercal regress", args.out, "--update", flush=True)
    subprocess.run([sys.executable, "-m", "whiskercal", "regress", str(args.out), "--update"],
                   check=True)


if __name__ == "__main__":
    main()
