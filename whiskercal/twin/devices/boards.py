"""The rig's two boards on one simulated clock, and the open ports that take what they send."""

from __future__ import annotations

from typing import Callable

from whiskercal.twin.devices.clock import SimClock


class Boards:
    """The stage and sensor boards run together on one clock.

    Each board sends through its own serial line; an open port registers a receiver that takes
    the line's bytes as they arrive (see :meth:`attach`). Not thread-safe: the world's lock
    guards every call.
    """

    def __init__(self, clock: SimClock, stage, sensor) -> None:
        self.clock = clock
        self.stage = stage
        self.sensor = sensor
        self._receivers: dict[int, Callable[[], object]] = {}

    def advance_to(self, t: float) -> None:
        """Run both boards, then the clock, up to simulated time ``t`` (s), and deliver bytes."""
        if t <= self.clock.now_s:
            return
        self.stage.advance_to(t)
        self.sensor.advance_to(t)
        self.clock.advance_to(t)
        self._hand_over_bytes()

    def attach(self, board, receiver: Callable[[], object]) -> None:
        """Let ``receiver()`` take what ``board`` sends (an open port; one per board)."""
        self._receivers[id(board)] = receiver

    def detach(self, board) -> None:
        """The board's port was closed: what it sends from now on goes nowhere."""
        self._receivers.pop(id(board), None)

    def _hand_over_bytes(self) -> None:
        # bytes reach the host's receive buffer as they arrive (where a full buffer drops
        # them), so a host that does not read cannot pile up memory here
        for board in (self.stage, self.sensor):
            receiver = self._receivers.get(id(board))
            if receiver is not None:
                receiver()
            else:
                board.line.receive(self.clock.now_s)
