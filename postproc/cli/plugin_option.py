"""``--plugins PATH`` for the command line: one decorator adds the option to a command.

The decorated command loads, before it runs, the plugins given by ``--plugins`` (each a
``.py`` file or a folder of them; repeatable), those in ``POSTPROC_PLUGINS`` and those of
installed packages' entry points (``postproc.plugins.load_plugins``). The option is
added to the command's signature here, so that each command in ``postproc.cli`` needs
one line (``@with_plugins``), not a parameter and a call of its own.
"""

from __future__ import annotations

import functools
import inspect
from pathlib import Path
from typing import List, Optional

import typer

from postproc.plugins import ENV, load_plugins

PARAMETER = "plugin_paths"
HELP = (f"Effect, predictor or dialect plugin: a .py file or a folder of them (repeatable; also {ENV}, "
        "and installed packages' postproc.* entry points). See docs/own-effect.md.")


def with_plugins(command):
    """Add ``--plugins`` to a typer command and load the plugins before it runs."""
    signature = inspect.signature(command)
    option = inspect.Parameter(PARAMETER, inspect.Parameter.KEYWORD_ONLY, annotation=Optional[List[Path]],
                               default=typer.Option(None, "--plugins", help=HELP, show_default=False, metavar="PATH"))

    @functools.wraps(command)
    def run(*args, **kwargs):
        load_plugins(kwargs.pop(PARAMETER, None) or ())
        return command(*args, **kwargs)

    run.__signature__ = signature.replace(parameters=[*signature.parameters.values(), option])
    run.__annotations__ = {**command.__annotations__, PARAMETER: Optional[List[Path]]}
    return run
