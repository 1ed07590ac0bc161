"""Conformance script for the stage protocol (docs/protocol.md, "Stage").

Each ``check_*`` function takes an open port (see conformance_ports.py) and asserts what the
protocol promises, with device time measured on ``port.now_s()``. The same functions run against
the host-built firmware and the twin's virtual stage.
"""

from __future__ import annotations

import re
from pathlib import Path

CODE_TABLE = Path(__file__).resolve().parents[2] / "whiskercal" / "protocol" / "protocol_codes.def"
BANNER = "Grbl 1.1h ['$' for help]"
HELP = "[HLP:$$ $I $x=val $X $H ~ ! ? ctrl-x]"  # grbl 1.1's help line, listing what the stage answers
STATUS = re.compile(r"^<(Idle|Run|Hold:[01]|Home|Alarm)((?:\|[A-Za-z]+:[^|>]*)*)>$")
STAGE_SETTINGS = (20, 22, 100, 101, 110, 111, 120, 121, 130, 131, 200, 201, 202)


class StageLink:
    """Lines to and from a stage port, with waits in device seconds."""

    def __init__(self, port) -> None:
        self.port = port
        self.pending = bytearray()
        self.pushed: list[str] = []  # ALARM:N and [MSG:...] lines seen while waiting for others

    def read_line(self, timeout_s: float = 2.0) -> str | None:
        """Next line (without CR LF), or None after ``timeout_s`` device seconds."""
        deadline = self.port.now_s() + timeout_s
        while b"\n" not in self.pending:
            remaining = deadline - self.port.now_s()
            if remaining <= 0:
                return None
            self.port.timeout = min(remaining, 0.05)
            self.pending += self.port.read(max(1, self.port.in_waiting))
        line, _, rest = bytes(self.pending).partition(b"\n")
        self.pending = bytearray(rest)
        return line.decode("ascii", errors="replace").rstrip("\r")

    def lines_for(self, seconds: float) -> list[str]:
        """All lines that arrive within ``seconds`` of device time."""
        lines, deadline = [], self.port.now_s() + seconds
        while (remaining := deadline - self.port.now_s()) > 0:
            line = self.read_line(remaining)
            if line is not None:
                lines.append(line)
        return lines

    def command(self, line: str, timeout_s: float = 2.0) -> tuple[list[str], str]:
        """Send a line; return the lines before its answer and the answer (``ok``/``error:N``)."""
        self.port.write(line.encode("ascii") + b"\n")
        before = []
        while True:
            reply = self.read_line(timeout_s)
            assert reply is not None, f"no ok/error for {line!r} within {timeout_s} s (got {before})"
            if reply == "ok" or reply.startswith("error:"):
                return before, reply
            if reply.startswith("ALARM:") or reply.startswith("[MSG:"):
                self.pushed.append(reply)
            before.append(reply)

    def status(self, timeout_s: float = 0.5) -> tuple[str, dict[str, list[float]]]:
        """Ask ``?``; return the state and the numeric fields of the report."""
        self.port.write(b"?")
        while True:
            line = self.read_line(timeout_s)
            assert line is not None, f"no status report within {timeout_s} s"
            if line.startswith("<"):
                return parse_status(line)
            self.pushed.append(line)

    def wait_state(self, wanted: str, timeout_s: float, poll_s: float = 0.05) -> dict[str, list[float]]:
        """Poll ``?`` until the state is ``wanted``; return that report's fields."""
        deadline = self.port.now_s() + timeout_s
        seen = []
        while self.port.now_s() < deadline:
            state, fields = self.status()
            if state == wanted:
                return fields
            seen.append(state)
            self.lines_for(poll_s)
        raise AssertionError(f"state {wanted} not reached within {timeout_s} s; saw {seen[-5:]}")

    def settle(self, quiet_s: float = 0.1, longest_s: float = 3.0) -> None:
        """Read until nothing arrives for ``quiet_s`` (the power-up banner, say); keep it in ``pushed``."""
        deadline = self.port.now_s() + longest_s
        while self.port.now_s() < deadline:
            line = self.read_line(quiet_s)
            if line is None:
                return
            self.pushed.append(line)

    def reset(self) -> list[str]:
        """Soft reset; return the lines up to and including the banner (later pushes: ``pushed``)."""
        self.settle()  # so that an earlier banner is not taken for the answer to this reset
        self.port.write(b"\x18")
        lines = []
        while True:
            line = self.read_line(2.0)
            assert line is not None, f"no banner after soft reset; got {lines}"
            lines.append(line)
            if line == BANNER:
                break
        self.pushed += self.lines_for(0.05)  # [MSG:...] after the banner
        return lines

    def fresh(self, go_to_start: bool = True) -> None:
        """Soft reset, unlock, go to (10, 10) mm: every check starts from the same state at rest,
        also on a board that kept its position from an earlier check."""
        self.reset()
        _, answer = self.command("$X")
        assert answer == "ok", f"$X answered {answer}"
        if go_to_start:
            assert self.command("G90G0X10Y10")[1] == "ok"
            self.wait_state("Idle", timeout_s=10.0)


def parse_status(line: str) -> tuple[str, dict[str, list[float]]]:
    """``<State|Name:a,b,...|...>`` -> (state, {name: [numbers]}); asserts the grammar."""
    match = STATUS.match(line)
    assert match, f"malformed status report {line!r}"
    fields = {}
    for field in match.group(2).split("|")[1:]:
        name, _, values = field.partition(":")
        fields[name] = [float(v) for v in values.split(",")] if name != "Pn" else []
    return match.group(1), fields


def close_to(values: list[float], expected: tuple[float, float], tolerance_mm: float) -> bool:
    return all(abs(v - e) <= tolerance_mm for v, e in zip(values[:2], expected))


# -- checks --------------------------------------------------------------------------------------
def check_reset_prints_banner(port) -> None:
    link = StageLink(port)
    lines = link.reset()
    assert lines[-1] == BANNER
    state, _ = link.status()
    assert state in ("Idle", "Alarm"), state


def check_power_up_lock_refuses_gcode_until_unlock(port) -> None:
    link = StageLink(port)
    link.reset()
    state, _ = link.status()
    if state == "Alarm":  # locked since power-up: homing is enabled by default
        assert link.command("G0X1")[1] == "error:9"
        assert link.command("$X")[1] == "ok"
    state, _ = link.status()
    assert state == "Idle"


def check_build_info(port) -> None:
    link = StageLink(port)
    link.fresh()
    lines, answer = link.command("$I")
    assert answer == "ok"
    assert any(re.fullmatch(r"\[VER:1\.1h\.[^:\]]+:[^\]]*\]", line) for line in lines), lines
    assert any(line.startswith("[OPT:") for line in lines), lines
    assert "[PROTO:whiskercal-stage-1]" in lines, lines


def check_status_report_fields(port) -> None:
    link = StageLink(port)
    link.fresh()
    state, fields = link.status()
    assert state == "Idle"
    assert len(fields["MPos"]) == 3 and fields["MPos"][2] == 0.0, fields
    assert len(fields["FS"]) == 2 and fields["FS"][0] == 0.0, fields
    assert len(fields["Enc"]) == 2, fields  # encoders are present by default ($200=1)


def check_move_reaches_target_with_encoder_agreement(port) -> None:
    link = StageLink(port)
    link.fresh()
    start = link.status()[1]["MPos"]
    target = (start[0] + 10.0, start[1] + 5.0)
    assert link.command(f"G90G0X{target[0]:.3f}Y{target[1]:.3f}")[1] == "ok"
    state, fields = link.status()
    assert state in ("Run", "Idle"), state
    fields = link.wait_state("Idle", timeout_s=5.0)
    assert close_to(fields["MPos"], target, 0.001), fields
    assert close_to(fields["Enc"], target, 0.5), fields  # within the $202 default tolerance


def check_status_answered_while_moving(port) -> None:
    link = StageLink(port)
    link.fresh()
    x0 = link.status()[1]["MPos"][0]
    assert link.command(f"G1X{x0 + 60:.3f}F3000")[1] == "ok"
    link.lines_for(0.5)
    state, fields = link.status(timeout_s=0.1)
    assert state == "Run", state
    assert x0 < fields["MPos"][0] < x0 + 60, fields
    assert 0 < fields["FS"][0] <= 3000, fields
    link.wait_state("Idle", timeout_s=5.0)


def check_soft_limits_refuse_without_moving(port) -> None:
    link = StageLink(port)
    link.fresh()
    before = link.status()[1]["MPos"]
    assert link.command("G90G0X250")[1] == "error:15"
    assert link.command("G90G0Y-1")[1] == "error:15"
    link.lines_for(0.2)
    state, fields = link.status()
    assert state == "Idle" and fields["MPos"] == before, (state, fields)


def check_gcode_errors(port) -> None:
    link = StageLink(port)
    link.fresh()
    assert link.command("G1X1")[1] == "error:22"     # G1 without a feed rate
    assert link.command("M3")[1] == "error:20"       # unsupported
    assert link.command("G0X1X2")[1] == "error:25"   # repeated word
    assert link.command("G0G1X1")[1] == "error:24"   # two motion commands
    assert link.command("$Q")[1] == "error:3"        # unknown system command
    assert link.command("G0X" + "1" * 85)[1] == "error:11"  # longer than 80 characters
    assert link.command("")[1] == "ok"


def table_codes(kind: str) -> set[int]:
    """Numbers of one KIND in the shared code table (whiskercal/protocol/protocol_codes.def)."""
    rows = re.findall(r"^X\((\w+),\s*(\d+),", CODE_TABLE.read_text(), re.MULTILINE)
    return {int(number) for row_kind, number in rows if row_kind == kind}


def check_every_error_is_in_the_code_table(port) -> None:
    link = StageLink(port)
    link.fresh()
    known = table_codes("STAGE_ERROR")
    for line in ("G4", "G4P-1", "G1X1F-1", "G2X1", "X", "1X", "G0Z1", "$100=x", "$999=1", "G0X1Y"):
        answer = link.command(line)[1]
        assert answer.startswith("error:"), (line, answer)
        assert int(answer[6:]) in known, f"{line!r} answered {answer}, which the code table lacks"


def check_feed_hold_and_resume(port) -> None:
    link = StageLink(port)
    link.fresh()
    x0 = link.status()[1]["MPos"][0]
    assert link.command(f"G1X{x0 + 80:.3f}F3000")[1] == "ok"
    link.wait_state("Run", timeout_s=1.0)
    link.lines_for(0.3)
    port.write(b"!")
    state, _ = link.status()
    assert state in ("Hold:0", "Hold:1"), state
    held = link.wait_state("Hold:0", timeout_s=2.0)["MPos"]  # GRBL 1.1: Hold:0 = hold complete
    link.lines_for(0.3)
    assert link.status()[1]["MPos"] == held, "the stage moved during Hold:0"
    assert x0 < held[0] < x0 + 80
    port.write(b"~")
    fields = link.wait_state("Idle", timeout_s=5.0)
    assert close_to(fields["MPos"], (x0 + 80, fields["MPos"][1]), 0.001), fields


def check_reset_while_moving_alarms(port) -> None:
    link = StageLink(port)
    link.fresh()
    x0 = link.status()[1]["MPos"][0]
    assert link.command(f"G1X{x0 + 80:.3f}F3000")[1] == "ok"
    link.wait_state("Run", timeout_s=1.0)
    lines = link.reset()
    assert "ALARM:3" in lines and lines[-1] == BANNER, lines
    first = link.status()
    link.lines_for(0.3)
    second = link.status()
    assert first[0] == second[0] == "Alarm"
    assert first[1]["MPos"] == second[1]["MPos"], "motion continued after the reset"
    assert link.command("G0X1")[1] == "error:9"


def check_settings_list_and_set(port) -> None:
    link = StageLink(port)
    link.fresh()
    lines, answer = link.command("$$")
    assert answer == "ok"
    values = dict(re.fullmatch(r"\$(\d+)=([-\d.]+)", line).groups() for line in lines)
    assert set(STAGE_SETTINGS) <= {int(n) for n in values}, values
    assert float(values["130"]) > 0 and float(values["100"]) > 0
    old = values["130"]
    assert link.command("$130=150")[1] == "ok"
    assert "$130=150.000" in link.command("$$")[0]
    assert link.command(f"$130={old}")[1] == "ok"
    assert link.command("$100=-5")[1] == "error:4"


def check_homing_sets_machine_zero(port) -> None:
    link = StageLink(port)
    link.fresh()
    assert link.command("$H", timeout_s=60.0)[1] == "ok"  # answered once homing is done
    state, fields = link.status()
    assert state == "Idle"
    assert fields["MPos"][:2] == [0.0, 0.0], fields
    assert close_to(fields["Enc"], (0.0, 0.0), 0.5), fields
    assert link.command("G0X5Y5")[1] == "ok"
    assert close_to(link.wait_state("Idle", timeout_s=5.0)["MPos"], (5.0, 5.0), 0.001)


def check_dwell_runs_in_the_queue(port) -> None:
    link = StageLink(port)
    link.fresh()
    started = port.now_s()
    assert link.command("G4P0.5")[1] == "ok"
    assert link.status()[0] == "Run"
    link.wait_state("Idle", timeout_s=3.0, poll_s=0.02)
    assert 0.45 <= port.now_s() - started <= 1.0


def check_dwell_needs_its_value_word(port) -> None:
    link = StageLink(port)
    link.fresh()
    assert link.command("G4")[1] == "error:28"      # grbl: the command's value word is missing
    assert link.command("G4G4P1")[1] == "error:21"  # two commands of modal group 0


def check_plane_and_feed_mode_words(port) -> None:
    """G17 (XY plane) and G94 (feed in mm/min) are grbl 1.1 modal commands: the stage's only modes."""
    link = StageLink(port)
    link.fresh()
    for line in ("G17", "G94", "G17 G21 G90 G94"):
        assert link.command(line)[1] == "ok", line
    assert link.command("G17 G17")[1] == "error:21"   # one command per modal group
    assert link.command("G90 G91")[1] == "error:21"
    x0, y0 = link.status()[1]["MPos"][:2]
    assert link.command(f"G17 G94 G1 X{x0 + 5:.3f} F600")[1] == "ok"
    assert close_to(link.wait_state("Idle", timeout_s=5.0)["MPos"], (x0 + 5, y0), 0.001)


def check_dwell_with_a_motion_word(port) -> None:
    """G4 (group 0) and G0/G1 (group 1) may share a block; grbl dwells first, then moves."""
    link = StageLink(port)
    link.fresh()
    x0, y0 = link.status()[1]["MPos"][:2]
    started = port.now_s()
    assert link.command("G0 G4 P0.1")[1] == "ok"  # no axis words: a dwell, and the mode is G0
    link.wait_state("Idle", timeout_s=3.0, poll_s=0.02)
    assert port.now_s() - started >= 0.1
    assert link.command("G1")[1] == "error:22"    # G1 needs a feed rate even without axis words
    started = port.now_s()
    assert link.command(f"G4 P1.0 X{x0 + 5:.3f}")[1] == "ok"  # dwell, then a move in mode G0
    state, fields = link.status()
    assert state == "Run" and fields["MPos"][:2] == [x0, y0], (state, fields)  # still dwelling
    fields = link.wait_state("Idle", timeout_s=5.0, poll_s=0.02)
    assert port.now_s() - started >= 1.0
    assert close_to(fields["MPos"], (x0 + 5, y0), 0.001), fields


def check_help_at_any_time(port) -> None:
    """``$`` prints the help line and ok in any state; ``$I`` and ``$$`` wait for rest (error:8)."""
    link = StageLink(port)
    link.fresh()
    assert link.command("$") == ([HELP], "ok")
    x0 = link.status()[1]["MPos"][0]
    assert link.command(f"G1X{x0 + 60:.3f}F3000")[1] == "ok"
    link.wait_state("Run", timeout_s=1.0)
    assert link.command("$") == ([HELP], "ok")
    assert link.command("$I")[1] == "error:8"
    assert link.command("$$")[1] == "error:8"
    link.wait_state("Idle", timeout_s=5.0)


def check_fault_alarm(port, code: int, move_mm: float = 80.0) -> None:
    """With a fault injected, a long move (or just waiting) ends in ALARM:code."""
    link = StageLink(port)
    link.fresh(go_to_start=False)  # the fault may lock the stage before any move
    x0 = link.status()[1]["MPos"][0]
    link.command(f"G1X{x0 + move_mm:.3f}F3000")
    lines = link.lines_for(3.0) + link.pushed
    assert f"ALARM:{code}" in lines, lines
    assert link.status()[0] == "Alarm"


STAGE_CHECKS = [check_reset_prints_banner, check_power_up_lock_refuses_gcode_until_unlock,
                check_build_info, check_status_report_fields,
                check_move_reaches_target_with_encoder_agreement, check_status_answered_while_moving,
                check_soft_limits_refuse_without_moving, check_gcode_errors,
                check_every_error_is_in_the_code_table, check_feed_hold_and_resume,
                check_reset_while_moving_alarms, check_settings_list_and_set, check_homing_sets_machine_zero,
                check_dwell_runs_in_the_queue, check_dwell_needs_its_value_word,
                check_plane_and_feed_mode_words, check_dwell_with_a_motion_word, check_help_at_any_time]
