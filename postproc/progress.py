"""Progress of long commands: one helper for every command that can run > 2 s.

On a terminal it is a rich bar with counts and time left; when stdout is not a terminal
(CI, ``| tee``) it writes a plain line on stderr at most every ``PLAIN_EVERY_S`` seconds
(the first one as soon as a step is reported), so a log shows the job is alive.

Library code takes a ``progress`` callable ``(message, done=None, total=None)`` and calls
it at each step; ``report(progress, ...)`` calls one that may only take ``message`` (the
older callbacks) as well. Only the CLI builds a :class:`ProgressLine`.
"""

from __future__ import annotations

import sys
import time
from typing import Callable

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn

#: seconds between two plain progress lines when stdout is not a terminal
PLAIN_EVERY_S = 10.0

ProgressFn = Callable[..., None]


def silent(message: str, done: int | None = None, total: int | None = None) -> None:
    """The default progress callback: says nothing."""


def report(progress: ProgressFn, message: str, done: int | None = None, total: int | None = None) -> None:
    """Call ``progress`` with counts when it takes them, with the message alone otherwise."""
    try:
        progress(message, done, total)
    except TypeError:  # an older one-argument callback
        progress(message)


class ProgressLine:
    """A context manager and a progress callback: rich bar on a terminal, plain lines otherwise.

    ``disable`` silences it (e.g. ``--json`` output that a program reads)."""

    def __init__(self, description: str, *, console: Console | None = None, disable: bool = False, terminal: bool | None = None,
                 every_s: float = PLAIN_EVERY_S, clock=time.monotonic, stream=None):
        self.description = description
        self.disable = disable
        self.terminal = sys.stdout.isatty() if terminal is None else terminal
        self.every_s = every_s
        self.clock = clock
        self.stream = stream
        self.console = console or Console(stderr=True)
        self._bar: Progress | None = None
        self._task = None
        self._started = 0.0
        self._last_line = None

    def __enter__(self) -> "ProgressLine":
        self._started = self.clock()
        if not self.disable and self.terminal:
            self._bar = Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                                 TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(), console=self.console, transient=True)
            self._bar.__enter__()
            self._task = self._bar.add_task(self.description, total=None)
        return self

    def __exit__(self, *exc) -> None:
        if self._bar is not None:
            self._bar.__exit__(*exc)
            self._bar = None

    def __call__(self, message: str, done: int | None = None, total: int | None = None) -> None:
        if self.disable:
            return
        if self._bar is not None:
            fields = {"description": message}
            if total is not None:
                fields["total"] = total
            if done is not None:
                fields["completed"] = done
            self._bar.update(self._task, **fields)
            return
        now = self.clock()
        if self._last_line is not None and now - self._last_line < self.every_s:
            return
        self._last_line = now
        counts = f" [{done}/{total}]" if done is not None and total else ""
        left = ""
        if done and total and done < total:
            left = f", about {(now - self._started) * (total - done) / done:.0f} s left"
        stream = self.stream or sys.stderr
        print(f"{self.description}: {message}{counts} ({now - self._started:.0f} s{left})", file=stream, flush=True)
