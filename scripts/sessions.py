"""The sensor-family bench's calibration sessions, run a part at a time and resumed.

`whiskercal bench --only sensor-family` runs every session (the family and the drawn builds, five
seeds each) in one go, which takes hours. This runs the same sessions (``bench.sessions``) one
after another, appending each row to a JSON-lines file as it ends, so a run can be stopped and
continued, and writes the docs' snapshot (docs/figures/sensor-sessions.json) from whatever rows
there are:

    python scripts/sessions.py run out/sessions.jsonl [--seeds 1,2,3,4,5] [--drawn 30]
                                                       [--builds twin-paper-75mm,drawn-03]
    python scripts/sessions.py snapshot out/sessions.jsonl

Sessions run seed by seed: every build on the first seed, then on the next.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from whiskercal.bench import sensor_family, sessions
from whiskercal.bench.timing import machine_info

ROOT = Path(__file__).resolve().parents[1]
SNAPSHOT = ROOT / "docs" / "figures" / "sensor-sessions.json"


def _rows(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line]


def run(path: Path, seeds: tuple[int, ...], drawn: int, only: tuple[str, ...] = ()) -> None:
    """Every build (those named in ``only``, if any) on every seed not yet in ``path``, each row
    appended as it ends."""
    builds = list(sensor_family.FAMILY) + sessions.draw_builds(drawn, sensor_family.DRAW_SEED)
    unknown = set(only) - {sensor.sensor_id for sensor in builds}
    if unknown:
        raise SystemExit(f"no such build: {', '.join(sorted(unknown))}")
    builds = [sensor for sensor in builds if not only or sensor.sensor_id in only]
    done = {(r["build"], r["seed"]) for r in _rows(path)}
    for seed in seeds:
        for sensor in builds:
            if (sensor.sensor_id, seed) in done:
                continue
            started = time.perf_counter()
            row = {**sessions.session_row(sensor, seed), "wall_s": time.perf_counter() - started}
            with path.open("a", encoding="utf-8") as handle:
                handle.write(json.dumps(row, default=str) + "\n")
            print(f"{sensor.sensor_id} seed {seed}: {row.get('tip_model', row.get('refused'))}",
                  flush=True)


def snapshot(path: Path) -> Path:
    """docs/figures/sensor-sessions.json from the rows in ``path``."""
    rows = _rows(path)
    payload = {"written_by": "python scripts/sessions.py run", "comparison": "sensor-sessions",
               "snapshot_by": "python scripts/sessions.py snapshot",
               "result": {**sessions.summary(rows), "machine": machine_info()}}
    SNAPSHOT.write_text(json.dumps(payload, indent=1, allow_nan=True, default=str) + "\n",
                        encoding="utf-8")
    return SNAPSHOT


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=("run", "snapshot"))
    parser.add_argument("rows", type=Path, help="the JSON-lines file of the sessions' rows")
    parser.add_argument("--seeds", default=",".join(map(str, sensor_family.SESSION_SEEDS)))
    parser.add_argument("--drawn", type=int, default=sensor_family.DRAWN_BUILDS)
    parser.add_argument("--builds", default="", help="only these builds (sensor ids, commas)")
    args = parser.parse_args()
    if args.command == "run":
        run(args.rows, tuple(int(s) for s in args.seeds.split(",")), args.drawn,
            tuple(name for name in args.builds.split(",") if name))
    else:
        print(f"wrote {snapshot(args.rows).relative_to(ROOT)}")


if __name__ == "__main__":
    main()
