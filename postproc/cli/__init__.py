"""Command-line interface (typer): one module per command or command group, all registered
on the one app of ``cli.app``. Thin wrappers over the library; exit codes are decided in
``cli.app.handles_errors`` only.

Exit status (spec/cli.md): 0 success, 1 the job ran and found a problem the user must
act on, 2 bad input or usage (message on stderr naming file, line/row and column).
"""

from __future__ import annotations

# Imported for their registrations, in the order `postproc --help` lists the commands.
from . import robot  # noqa: F401  robots, fk, ik
from . import fit  # noqa: F401
from . import evaluate  # noqa: F401
from . import validate  # noqa: F401
from . import diagnose  # noqa: F401  diagnose, ladder, similarity
from . import data  # noqa: F401  import-ur10, simulate
from . import suggest  # noqa: F401  suggest-poses
from . import compensate  # noqa: F401
from . import predict  # noqa: F401
from . import programs  # noqa: F401  inspect, convert, roundtrip
from . import fivex  # noqa: F401  rtcp-calibrate
from . import cam  # noqa: F401  freecad-install-post
from . import place  # noqa: F401
from . import effect  # noqa: F401  effect new, effect check
from .app import app

__all__ = ["app", "main"]


def main() -> None:
    app()
