"""The firmware cores' host unit tests (firmware/*/host/test_main.cpp), built with g++ and run."""

import re
import subprocess

import pytest

from firmware_build import BOARDS, host_program


@pytest.mark.parametrize("board", BOARDS)
def test_host_unit_tests_pass(board):
    program = host_program(board, "test")
    result = subprocess.run([str(program)], capture_output=True, text=True, timeout=120)
    summary = re.search(r"^(\d+) passed, (\d+) failed$", result.stdout, re.MULTILINE)
    assert summary, f"{board} host tests printed no summary:\n{result.stdout}\n{result.stderr}"
    passed, failed = int(summary.group(1)), int(summary.group(2))
    assert failed == 0 and result.returncode == 0, result.stdout
    assert passed >= 15, f"only {passed} tests ran:\n{result.stdout}"
