"""Run the stage and sensor conformance scripts against the host-built firmware and the twin.

A failure names the check and the board: firmware and twin must answer alike, as
docs/protocol.md says.
"""

import pytest

import sensor_script
import stage_script
from conformance_ports import BACKENDS, open_firmware, open_twin


def _open(backend: str, board: str):
    if backend == "firmware":
        return open_firmware("stage_stepper" if board == "stage" else "whisker_nano")
    return open_twin(board)


@pytest.fixture
def port(request):
    backend, board = request.param
    opened = _open(backend, board)
    yield opened
    opened.close()


# Known differences of the twin's virtual stage, to be fixed there (whiskercal/twin/virtual_stage.py):
# it answers "G4" without P with error:28, a code the shared table lacks, and accepts Z words on
# this two-axis stage with "ok".
TWIN_STAGE_DRIFT = "twin: G4 without P gives error:28 (not in the code table); G0Z1 is accepted"


def _cases(board, checks):
    cases = []
    for backend in BACKENDS:
        for check in checks:
            marks = []
            if backend == "twin" and check is stage_script.check_every_error_is_in_the_code_table:
                marks = [pytest.mark.xfail(reason=TWIN_STAGE_DRIFT, strict=True)]
            cases.append(pytest.param((backend, board), check, id=f"{backend}-{check.__name__[6:]}", marks=marks))
    return cases


@pytest.mark.parametrize("port,check", _cases("stage", stage_script.STAGE_CHECKS), indirect=["port"])
def test_stage(port, check):
    check(port)


# Faults injected the way each backend offers them: (firmware simulator options, twin URL query).
STAGE_FAULTS = {
    10: (("--stall-x", "60"), "fault=stall@1.0"),
    11: (("--no-magnet-y",), "fault=encoder_magnet@0.2"),
    12: (("--silent-x",), "fault=encoder_bus@0.2"),
}


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("code", sorted(STAGE_FAULTS))
def test_stage_fault_alarms(backend, code):
    firmware_options, twin_query = STAGE_FAULTS[code]
    port = open_firmware("stage_stepper", *firmware_options) if backend == "firmware" \
        else open_twin("stage", twin_query)
    try:
        stage_script.check_fault_alarm(port, code)
    finally:
        port.close()


@pytest.mark.parametrize("port,check", _cases("sensor", sensor_script.SENSOR_CHECKS), indirect=["port"])
def test_sensor(port, check):
    check(port)


# Lines whose answers must be identical on both boards, byte for byte.
SAME_ANSWERS = ("G21", "G90", "G91", "G90", "G1X1", "G0X1Y1", "G0X250", "M3", "G0X1X2", "G0G1X1", "$Q",
                "G38.2X1", "1X", "X", "G1X1F-1", "$100=-5", "$22=2", "G4P-1", "G4P0.1", "$X", "")
# Known drift, see TWIN_STAGE_DRIFT, plus: "$100=x" (firmware error:2 like grbl, twin error:3) and
# "G1X1F0" (firmware error:22, twin error:4).
DRIFTING_ANSWERS = ("G4", "G0Z1", "$100=x", "G1X1F0")


def _answers(port, lines):
    link = stage_script.StageLink(port)
    link.fresh()
    return [(line, link.command(line)[1]) for line in lines]


@pytest.mark.parametrize("lines", [
    pytest.param(SAME_ANSWERS, id="same"),
    pytest.param(DRIFTING_ANSWERS, id="drifting",
                 marks=pytest.mark.xfail(reason=TWIN_STAGE_DRIFT, strict=True)),
])
def test_stage_firmware_and_twin_answer_alike(lines):
    firmware, twin = open_firmware("stage_stepper"), open_twin("stage")
    try:
        assert _answers(firmware, lines) == _answers(twin, lines)
    finally:
        firmware.close()
        twin.close()
