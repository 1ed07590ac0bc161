"""Record the transcripts of stock grbl 1.1h (tests/data/grbl_transcripts/, README there) from the
real image on simavr: ``sim://NAME/stage?firmware=grbl[&homing=xy]``, one fresh board per scenario.

Needs the images: ``WHISKERCAL_GRBL_SRC=DIR make grbl-sim`` (DIR a checkout of gnea/grbl v1.1h).
Usage: python scripts/record_grbl_transcripts.py [--only NAME ...] [--out DIR]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
import uuid
from pathlib import Path

import serial

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "firmware"))
from grbl_transcript import TRANSCRIPTS, Recorder, write_transcript  # noqa: E402
from whiskercal.twin.devices.avr_harness import grbl_image  # noqa: E402
from whiskercal.twin.devices.grbl_stage import OWNER_SETTINGS  # noqa: E402

OK = r"^(ok|error:\d+|ALARM:\d+)$"
UNLOCK = {"send": "$X\n", "until": OK}
BOOT = {"wait_s": 0.5}
LOCKED = r"^\[MSG:'\$H'\|'\$X' to unlock\]$"  # the last line after a reset into the alarm lock

SCENARIOS: dict[str, dict] = {
    "banner_settings": {
        "homing": "xy", "what": "power-up banner and lock message, $$, $I, a status report",
        "steps": [BOOT, {"send": "$$\n", "until": OK}, {"send": "$I\n", "until": OK}, {"poll": 1}],
    },
    "home_stock_config": {
        "homing": "", "what": "$H with grbl's own config.h: Z is homed first and has no switch",
        "steps": [BOOT, {"send": "$H\n", "until": LOCKED, "timeout_s": 90}, {"poll": 1},
                  {"send": "G90 G0 X-1\n", "until": OK}],
    },
    "home_xy": {
        "homing": "xy", "what": "$H with the XY homing cycle; MPos after it (negative machine space)",
        "steps": [BOOT, {"send": "$H\n", "until": OK, "timeout_s": 90},
                  {"poll": 1, "check_mpos": True}, {"send": "G90 G0 X10\n", "until": OK, "after_s": 0.3},
                  {"send": "\x18", "wait_s": 1.0}, {"send": "\x18", "until": LOCKED}, {"poll": 1, "check_mpos": True}],
    },
    "home_polled": {
        "homing": "xy", "what": "? every second during $H: grbl's homing cycle serves no status request",
        "steps": [BOOT, {"send": "$H\n", "wait_s": 0.5}, {"poll_until": "^Idle$", "every_s": 1.0, "timeout_s": 40,
                                                                 "count_reports": True}],
    },
    "home_xy_origin": {
        "homing": "xy", "origin": "set",
        "what": "$H with the XY cycle and HOMING_FORCE_SET_ORIGIN: machine zero where homing ends",
        "steps": [BOOT, {"send": "$H\n", "until": OK, "timeout_s": 90}, {"poll": 1, "check_mpos": True},
                  {"send": "G90 G0 X10 Y10\n", "until": OK}, {"poll_until": "^Idle$", "every_s": 0.05, "check_mpos": True},
                  {"send": "G90 G0 X-1\n", "until": OK, "after_s": 0.6}],
    },
    "status_wpos": {
        "homing": "xy", "what": "? with $10=1 (MPos) and $10=0 (WPos, WCO every few reports), G92 offset",
        "steps": [BOOT, UNLOCK, {"send": "G91 G1 X-5 Y-3 F600\n", "until": OK},
                  {"poll_until": "^Idle$", "every_s": 0.05}, {"send": "$10=1\n", "until": OK},
                  {"poll": 2, "check_mpos": True}, {"send": "G92 X0 Y0\n", "until": OK},
                  {"poll": 2, "check_mpos": True}, {"send": "$10=0\n", "until": OK},
                  {"poll": 12, "check_mpos": True}, {"send": "G92.1\n", "until": OK},
                  {"poll": 2, "check_mpos": True}],
    },
    "feed_hold": {
        "homing": "xy", "what": "! during a move (Hold:1 decelerating, Hold:0 at rest), then ~",
        "steps": [BOOT, UNLOCK, {"send": "G91 G1 Y-100 F3000\n", "until": OK},
                  {"poll_until": "^Run$", "every_s": 0.01}, {"wait_s": 0.5},
                  {"send": "!", "wait_s": 0.0}, {"poll_until": "^Hold:0$", "every_s": 0.01},
                  {"poll": 3, "every_s": 0.05}, {"send": "~", "wait_s": 0.0},
                  {"poll_until": "^Idle$", "every_s": 0.05, "check_mpos": True}],
    },
    "dwell": {
        "homing": "xy", "what": "G4 P0.5 after a queued move: its ok comes after the move and the dwell",
        "steps": [BOOT, UNLOCK, {"send": "G91 G1 Y-60 F3000\n", "until": OK},
                  {"send": "G4 P0.5\n", "until": OK, "timeout_s": 10}, {"poll": 1, "check_mpos": True}],
    },
    "soft_limit": {
        "homing": "xy", "what": "$20=1 and a target beyond the travel: ALARM:2, reset, banner, $X",
        "steps": [BOOT, UNLOCK, {"send": "$20=1\n", "until": OK},
                  {"send": "G90 G0 X10\n", "until": r"^ALARM:\d+$", "after_s": 0.3},
                  {"poll": 1, "every_s": 0.3}, {"send": "G0 X-1\n", "wait_s": 0.3},
                  {"send": "\x18", "until": LOCKED},
                  {"poll": 1}, UNLOCK, {"poll": 1, "check_mpos": True}],
    },
    "error_codes": {
        "homing": "xy", "what": "refused lines and their codes, locked and unlocked",
        "steps": [BOOT, {"send": "G0 X-1\n", "until": OK}, UNLOCK]
        + [{"send": line + "\n", "until": OK} for line in (
            "G5", "G1 X-1 X-2", "$99=1", "G1 X-1", "G4", "X", "G0 G1 X-1", "$Q", "G4 P-1", "G20 G21",
            "N99999999 G0 X-1", "G2 X-1", "T300", "M100", "G0X-1" + "Y" * 80, "$10=abc", "$22=0", "$H",
            "$22=1")] + [{"poll": 1}],
    },
}


def record(name: str, scenario: dict, out: Path) -> Path:
    """Run one scenario on a fresh emulated board; the transcript's path."""
    homing, origin = scenario["homing"], scenario.get("origin", "")
    query = (f"&homing={homing}" if homing else "") + (f"&origin={origin}" if origin else "")
    url = f"sim://rec{uuid.uuid4().hex[:8]}/stage?firmware=grbl" + query
    port = serial.serial_for_url(url, timeout=1)
    wall = time.perf_counter()
    entries = Recorder(port).run(scenario["steps"])
    wall = time.perf_counter() - wall
    simulated = entries[-1]["t"] if entries else 0.0
    port.close()
    header = {"name": name, "what": scenario["what"], "image": grbl_image(homing, origin).parent.name,
              "grbl": "1.1h.20190825 (gnea/grbl tag v1.1h.20190825), avr-gcc -Os, ATmega328P at 16 MHz",
              "recorded_with": "simavr " + _simavr_version() + ", whiskercal firmware/sim harness, grbl pin map",
              "owner_settings": {f"${n}": v for n, v in sorted(OWNER_SETTINGS.items())},
              "twin_url": "?stock=1" + query,
              "simulated_s": simulated, "wall_s": round(wall, 2), "steps": scenario["steps"]}
    path = out / f"{name}.jsonl"
    write_transcript(path, header, entries)
    return path


def _simavr_version() -> str:
    result = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "libsimavr-dev"], capture_output=True, text=True)
    return result.stdout.strip() or "(version unknown)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--out", type=Path, default=TRANSCRIPTS)
    args = parser.parse_args()
    for homing, origin in (("", ""), ("xy", ""), ("xy", "set")):
        if not grbl_image(homing, origin).is_file():
            sys.exit(f"{grbl_image(homing, origin)} is missing: run WHISKERCAL_GRBL_SRC=DIR make grbl-sim")
    args.out.mkdir(parents=True, exist_ok=True)
    for name, scenario in SCENARIOS.items():
        if args.only and name not in args.only:
            continue
        path = record(name, scenario, args.out)
        print(f"{path}: {path.read_text().count(chr(10)) - 1} entries")


if __name__ == "__main__":
    main()
