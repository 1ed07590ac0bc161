"""Run the stage and sensor conformance scripts against the host-built firmware and the twin.

A failure names the check and the board: firmware and twin must answer alike, as
docs/protocol.md says.
"""

import pytest

import sensor_script
import stage_script
from conformance_ports import BACKENDS, emulation_or_skip, open_emulated, open_firmware, open_hardware, open_twin


def _open(backend: str, board: str):
    if backend == "firmware":
        return open_firmware("stage_stepper" if board == "stage" else "whisker_nano")
    if backend == "hardware":
        return open_hardware(board)
    if backend == "avr":
        return open_emulated(board)
    return open_twin(board)


@pytest.fixture
def port(request):
    backend, board = request.param
    opened = _open(backend, board)
    yield opened
    opened.close()


# The compiled images on simavr: seconds of the host's time a check, so the whole suite runs them
# (make test-all) and the fast tier the same scripts against the other backends.
EMULATED_BOARDS = ("sensor", "stage")


def _cases(board, checks):
    backends = BACKENDS + (("avr",) if board in EMULATED_BOARDS else ())
    cases = [pytest.param((backend, board), check, id=f"{backend}-{check.__name__[6:]}",
                          marks=[pytest.mark.slow] if backend == "avr" else [])
             for backend in backends for check in checks]
    # The same scripts against flashed boards: opt-in, the stage moves (and homes) for real.
    return cases + [pytest.param(("hardware", board), check, id=f"hardware-{check.__name__[6:]}",
                                 marks=pytest.mark.hardware) for check in checks]


@pytest.mark.parametrize("port,check", _cases("stage", stage_script.STAGE_CHECKS), indirect=["port"])
def test_stage(port, check):
    check(port)


# Faults injected the way each backend offers them: (firmware simulator options, twin URL query).
STAGE_FAULTS = {
    100: (("--stall-x", "60"), "fault=stall@1.0"),
    101: (("--no-magnet-y",), "fault=encoder_magnet@0.2"),
    102: (("--silent-x",), "fault=encoder_bus@0.2"),
}


@pytest.mark.parametrize("backend", BACKENDS + (pytest.param("avr", marks=pytest.mark.slow),))
@pytest.mark.parametrize("code", sorted(STAGE_FAULTS))
def test_stage_fault_alarms(backend, code):
    firmware_options, twin_query = STAGE_FAULTS[code]
    if backend == "firmware":
        port = open_firmware("stage_stepper", *firmware_options)
    elif backend == "avr":
        emulation_or_skip("stage")
        port = open_twin("stage", twin_query + "&firmware=avr")
    else:
        port = open_twin("stage", twin_query)
    try:
        stage_script.check_fault_alarm(port, code)
    finally:
        port.close()


@pytest.mark.parametrize("port,check", _cases("sensor", sensor_script.SENSOR_CHECKS), indirect=["port"])
def test_sensor(port, check):
    check(port)


# Lines whose answers (and the lines printed before them) must be identical on both boards, byte
# for byte. The '$' lines come first, while the stage is at rest (a moving stage answers most of
# them with error:8).
STAGE_LINES = ("$", "$100=-5", "$100=x", "$Q", "$X", "G21", "G17", "G94", "G17G21G90G94", "G17G17", "G90G91",
               "G90", "G91", "G90", "G1X1", "G1", "G1X1F0", "G0", "G0X1Y1", "G0X250", "M3", "G0X1X2", "G0G1X1",
               "G38.2X1", "1X", "X", "G0Z1", "G1X1F-1", "G4", "G4G4P1", "G4P-1", "G4P0.1", "G0G4P0.1",
               "G4P0.1X11", "")


def test_stage_firmware_and_twin_answer_alike():
    firmware, twin = open_firmware("stage_stepper"), open_twin("stage")
    try:
        assert _answers(firmware, STAGE_LINES) == _answers(twin, STAGE_LINES)
    finally:
        firmware.close()
        twin.close()


def test_stage_image_on_simavr_answers_as_the_host_build():
    emulated = open_emulated("stage")
    try:
        answers = _answers(emulated, STAGE_LINES)
    finally:
        emulated.close()
    host = open_firmware("stage_stepper")
    try:
        assert answers == _answers(host, STAGE_LINES)
    finally:
        host.close()


def _answers(port, lines):
    link = stage_script.StageLink(port)
    link.fresh()
    return [(line, *link.command(line)) for line in lines]


SENSOR_LINES = ("ID", "id", " ID ", "CFG?", "cfg?", "GAIN 3", "GAIN  3", "GAIN 3 4", "GAIN 03", "RATE 0300",
                "GAIN", "GAIN ", "START", "START", "GAIN 1", "STOP", "STOP", "RES 3", "CFG?", "FILT 8", "OSR -1",
                "RATE 1", "RATE 500", "RATE 300", "X" * 32, "X" * 33, "GAIN\t3", "RES 2", "GAIN 7", "CFG?")


def test_sensor_firmware_and_twin_answer_alike():
    answers = []
    for port in (open_firmware("whisker_nano"), open_twin("sensor")):
        try:
            link = sensor_script.SensorLink(port)
            answers.append([(line, link.command(line)) for line in SENSOR_LINES])
        finally:
            port.close()
    assert answers[0] == answers[1]


def test_sensor_image_on_simavr_answers_as_the_host_build():
    port = open_emulated("sensor")
    try:
        link = sensor_script.SensorLink(port)
        emulated = [(line, link.command(line)) for line in SENSOR_LINES]
    finally:
        port.close()
    host = open_firmware("whisker_nano")
    try:
        link = sensor_script.SensorLink(host)
        assert emulated == [(line, link.command(line)) for line in SENSOR_LINES]
    finally:
        host.close()
