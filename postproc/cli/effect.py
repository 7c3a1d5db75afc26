"""effect new / effect check: an error effect of the user's own."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from postproc.model.effect_template import write_template
from postproc.model.effects import CATALOG
from postproc.plugins import PluginError, load_plugins

from .app import app, handles_errors, out

effect_app = typer.Typer(help="Write and check an error effect of your own (docs/own-effect.md).", no_args_is_help=True)
app.add_typer(effect_app, name="effect")


@effect_app.command("new")
@handles_errors
def effect_new_cmd(
    name: str = typer.Argument(..., help="The effect's name (lower case, e.g. wrist_cable)."),
    output: Path = typer.Option(Path("."), "-o", "--output", help="FILE.py to write, or a folder to write NAME.py in (an existing file is never overwritten)."),
):
    """Write a commented template effect file (NAME.py), outside the package."""
    path = write_template(name, output)
    out.print(f"wrote {path}; check it with 'postproc effect check {path}', load it with '--plugins {path}'")


@effect_app.command("check")
@handles_errors
def effect_check_cmd(
    file: Path = typer.Argument(..., help="The effect's .py file."),
    robot: str = typer.Option("kr160_r1570", "--robot", help="Robot the checks run on."),
):
    """Contract checks of the effects in FILE: Jacobian, zero parameters, bounds, texts, round trips."""
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.effect_check import check_effect

    records = [r for r in load_plugins([file], environ={}, entry_points=False) if r.kind == "effect"]
    if not records:
        raise PluginError(f"{file}: defines no Effect subclass with a name")
    table = Table(title=f"effect check {file}")
    for col in ("effect", "check", "result", "detail"):
        table.add_column(col)
    failures = []
    for record in records:
        for check in check_effect(CATALOG[record.name], robot):
            table.add_row(record.name, check.name, "ok" if check.ok else "FAILED", check.detail)
            if not check.ok:
                failures.append(f"{record.name}: {check.name}: {check.detail}")
    out.print(table)
    if failures:
        raise PluginError(f"{file}: {len(failures)} check(s) failed:\n  " + "\n  ".join(failures))
