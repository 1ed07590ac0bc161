"""Progress of long work on the terminal: one helper, so every command shows it the same way.

A rich progress bar on stderr: items done of the total, the rate, the time spent and the time
left, estimated by rich from the updates of this session. It is drawn only where someone watches:
stderr is a terminal, not in CI, not with ``--quiet`` and not with ``--json`` (whose output is
for scripts). Otherwise :func:`progress_bar` gives None and the command passes no callback.

Library functions report a ``whiskercal.progress.Progress`` record (:meth:`ProgressBar.update`)
or name the step they begin (:meth:`ProgressBar.step`); they never draw.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Callable, Iterator

from rich.console import Console
from rich.progress import (BarColumn, MofNCompleteColumn, Progress as RichProgress, ProgressColumn,
                           TextColumn, TimeElapsedColumn, TimeRemainingColumn)
from rich.text import Text

from whiskercal.cli.app import App
from whiskercal.progress import Progress

# Rich estimates the rate over the updates of this window (s): long enough to hold several
# updates of the slowest long run (a study trial takes up to a minute).
_SPEED_WINDOW_S = 600.0


class _RateColumn(ProgressColumn):
    """Items per second, or per minute when slower than one a second."""

    def __init__(self, unit: str) -> None:
        super().__init__()
        self.unit = unit

    def render(self, task) -> Text:
        speed = task.finished_speed or task.speed
        if not speed:
            return Text(f"-- {self.unit}/s")
        if speed >= 1.0:
            return Text(f"{speed:.2f} {self.unit}/s")
        return Text(f"{speed * 60.0:.1f} {self.unit}/min")


class ProgressBar:
    """One task on a rich progress display (see the module's docstring)."""

    def __init__(self, display: RichProgress, description: str, total: int | None) -> None:
        self._display = display
        self._description = description
        self._task = None if total is None else display.add_task(description, total=total)
        self._key: str | None = None

    @property
    def task(self):
        """The rich task behind the bar (None before the first update)."""
        return None if self._task is None else self._display.tasks[self._task]

    def update(self, record: Progress) -> None:
        """Show where a run is (``collect``, the study): done of total, rate and time left."""
        if self._task is None:
            # items done before this session (a resumed run) are not part of its rate
            self._task = self._display.add_task(self._description, total=record.total,
                                                completed=record.done - record.taken_now)
        self._display.update(self._task, total=record.total, completed=record.done)

    def step(self, key: str, text: str | None = None) -> None:
        """Show that step ``key`` is under way (``text`` says what it does); a new key means
        the previous step is done."""
        if self._task is None:
            self._task = self._display.add_task(self._description, total=None)
        if key != self._key:
            if self._key is not None:
                self._display.advance(self._task)
            self._key = key
        self._display.update(self._task, description=text or key)

    def finish(self) -> None:
        """Mark the last step done."""
        if self._task is not None and self._key is not None:
            self._display.advance(self._task)
            self._key = None
            self._display.update(self._task, description=self._description)


def wanted(app: App, as_json: bool = False) -> bool:
    """True when a progress bar should be drawn (a watched terminal, no ``--json``)."""
    return app.interactive and not as_json


@contextmanager
def progress_bar(app: App, unit: str, *, description: str = "", total: int | None = None,
                 as_json: bool = False, console: Console | None = None,
                 get_time: Callable[[], float] | None = None) -> Iterator[ProgressBar | None]:
    """A progress bar counting ``unit`` ("points", "trials") while the block runs, or None.

    ``total`` is needed by :meth:`ProgressBar.step` users; :meth:`ProgressBar.update` takes it
    from the record. ``console`` (drawn on whatever it is) and ``get_time`` (s) are for tests.
    """
    if console is None and not wanted(app, as_json):
        yield None
        return
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn(unit), _RateColumn(unit), TimeElapsedColumn(), TimeRemainingColumn(),
               TextColumn("left"))
    display = RichProgress(*columns, console=console or Console(stderr=True), get_time=get_time,
                           speed_estimate_period=_SPEED_WINDOW_S, refresh_per_second=4)
    with display:
        yield ProgressBar(display, description, total)
