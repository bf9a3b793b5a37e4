"""Progress of long calls: a tqdm bar where tqdm is installed, else one line per task.

The native layer calls a reporter from the calling thread every 100 ms with what changed:
``start(task, total)``, ``update(position, message)``, ``note(line)`` and ``finish()``. Pass
``progress=False`` to a call for silence, or any object with these four methods.
"""

from __future__ import annotations

import sys
from typing import Any, Optional, Protocol


class Reporter(Protocol):
    """What a long call reports to."""

    def start(self, task: str, total: int) -> None: ...

    def update(self, position: int, message: str) -> None: ...

    def note(self, line: str) -> None: ...

    def finish(self) -> None: ...


class TqdmReporter:
    """A tqdm bar per task (tqdm.auto: a widget in Jupyter, text in a terminal); notes are
    written above the bar."""

    def __init__(self) -> None:
        from tqdm.auto import tqdm

        self._tqdm = tqdm
        self._bar: Optional[Any] = None

    def start(self, task: str, total: int) -> None:
        self.finish()
        self._bar = self._tqdm(total=total, desc=task, leave=False, dynamic_ncols=True)

    def update(self, position: int, message: str) -> None:
        if self._bar is not None:
            self._bar.n = position
            if message:
                self._bar.set_postfix_str(message, refresh=False)
            self._bar.refresh()

    def note(self, line: str) -> None:
        self._tqdm.write(line, file=sys.stderr)

    def finish(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


class LineReporter:
    """Without tqdm: the notes and one line per finished task, on standard error."""

    def __init__(self) -> None:
        self._task: Optional[str] = None
        self._position = 0

    def start(self, task: str, total: int) -> None:
        self._task, self._position = task, 0

    def update(self, position: int, message: str) -> None:
        self._position = position

    def note(self, line: str) -> None:
        print(line, file=sys.stderr)

    def finish(self) -> None:
        if self._task is not None:
            print(f"{self._task}: done ({self._position} steps)", file=sys.stderr)
            self._task = None


def reporter(progress: Any) -> Optional[Any]:
    """The reporter of a call's ``progress`` argument: True → tqdm (or lines), False/None →
    none, else the object given."""
    if progress is True:
        try:
            return TqdmReporter()
        except ImportError:
            return LineReporter()
    if progress is False or progress is None:
        return None
    return progress
