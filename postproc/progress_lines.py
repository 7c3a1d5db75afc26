"""Progress of a long command on stderr: a rich spinner on a terminal, otherwise a plain
line at most every 10 s (a log file or CI gets a heartbeat, not a screen of redraws)."""

from __future__ import annotations

import contextlib
import time
from typing import Callable, Iterator

from rich.console import Console
from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

PLAIN_EVERY_S = 10.0


@contextlib.contextmanager
def progress_reporter(console: Console, first: str) -> Iterator[Callable[[str], None]]:
    """Yield ``say(message)``: shows the message as the current step."""
    if console.is_terminal:
        with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console, transient=True) as bar:
            task = bar.add_task(first, total=None)
            yield lambda msg: bar.update(task, description=msg)
        return
    start = time.monotonic()
    last = [-PLAIN_EVERY_S]  # when the last line was printed (a cell: the closure updates it)

    def say(msg: str) -> None:
        now = time.monotonic() - start
        if now - last[0] >= PLAIN_EVERY_S:
            last[0] = now
            console.print(f"[{now:6.0f} s] {msg}", highlight=False)

    yield say
