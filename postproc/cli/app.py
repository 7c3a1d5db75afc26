"""The Typer app every command registers on, its consoles, and the one place that maps the
library's typed exceptions to exit codes.

Exit status (spec/cli.md): 0 success, 1 the job ran and found a problem the user must
act on, 2 bad input or usage (message on stderr naming file, line/row and column).
"""

from __future__ import annotations

import functools

import typer
from rich.console import Console

from postproc import __version__
from postproc.errors import JobError, PostprocError

app = typer.Typer(
    name="postproc",
    help="Rewrite robot and five-axis toolpaths so the machine cuts where the CAM program says.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
# Messages carry user text (effect specs use [brackets]): never interpret it as markup.
out = Console(markup=False, highlight=False, soft_wrap=True)
err = Console(stderr=True, markup=False, highlight=False, soft_wrap=True)


def exit_code(exc: PostprocError) -> int:
    if isinstance(exc, JobError):
        return 1
    return 2


def handles_errors(func):
    """Map the library's typed exceptions to the spec's exit codes, message on stderr."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except PostprocError as exc:
            err.print(f"error: {exc}", style="bold red")
            raise typer.Exit(exit_code(exc)) from None

    return wrapper


def _version(value: bool):
    if value:
        out.print(f"postproc {__version__}", highlight=False)
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version and exit."),
):
    """postproc command line."""
