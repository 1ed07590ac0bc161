"""Ctrl-C as a terminal delivers it, to code run in a fresh interpreter."""

from __future__ import annotations

import signal
import subprocess
import sys


def printed_with_ctrl_c_as_from_a_terminal(code: str) -> str:
    """What ``code`` prints, run in a fresh interpreter whose SIGINT is as a terminal's process
    has it (default, unblocked): a test worker's own may be ignored or blocked by what ran in it
    before, and the handler is then rightly never called."""
    def as_a_terminal():
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGINT])

    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, preexec_fn=as_a_terminal, check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout
