"""``whiskercal sim serve`` run as a subprocess for the firmware tests: started, its JSON read,
stopped however the test ends."""

from __future__ import annotations

import contextlib
import json
import subprocess
import sys


# real seconds the served rig lives at most: past the tests' client timeouts added up (a busy
# host once ran a 30 s rig out mid-read and closed its ptys); a test's end stops it anyway
SERVE_LIMIT_S = 300


@contextlib.contextmanager
def sim_serve(*options: str):
    """Yield the JSON ``sim serve --json`` prints (its pty paths) while it runs in real time."""
    process = subprocess.Popen([sys.executable, "-m", "whiskercal", "sim", "serve", "--json",
                                "--speed", "1", "--duration", str(SERVE_LIMIT_S), *options],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        text = ""
        while not text.rstrip().endswith("}"):
            line = process.stdout.readline()
            assert line, f"sim serve ended early: {process.stderr.read()}"
            text += line
        yield json.loads(text)
    finally:
        process.terminate()
        process.wait(5)
