"""Command-line interface (typer): one module per command or command group, all registered
on the one app of ``cli.app``. Thin wrappers over the library; exit codes are decided in
``cli.app.handles_errors`` only.

Exit status (spec/cli.md): 0 success, 1 the job ran and found a problem the user must
act on, 2 bad input or usage (message on stderr naming file, line/row and column).
"""

from __future__ import annotations

# Imported for their registrations, in the order `postproc --help` lists the commands.
from . import (
    cam,  # noqa: F401  freecad-install-post
    compensate,  # noqa: F401
    data,  # noqa: F401  import-ur10, simulate
    diagnose,  # noqa: F401  diagnose, ladder, similarity
    effect,  # noqa: F401  effect new, effect check
    evaluate,  # noqa: F401
    fit,  # noqa: F401
    fivex,  # noqa: F401  rtcp-calibrate
    place,  # noqa: F401
    predict,  # noqa: F401
    programs,  # noqa: F401  inspect, convert, roundtrip
    robot,  # noqa: F401  robots, fk, ik
    suggest,  # noqa: F401  suggest-poses
    validate,  # noqa: F401
)
from .app import app

__all__ = ["app", "main"]


def main() -> None:
    app()
