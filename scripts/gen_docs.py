"""Write the generated pages of the user guide from the code itself.

- docs/reference/cli.md: every command of the CLI with its arguments and options, taken
  from the Typer/Click command tree (the same text `postproc CMD --help` prints);
- docs/reference/effects.md: every effect of the catalog with its kind, parameters and
  units, inputs and identifiability notes, taken from the effect classes.

Run: .venv/bin/python scripts/gen_docs.py          (rewrites the pages)
     .venv/bin/python scripts/gen_docs.py --check  (exit 1 when a page is out of date;
                                                     tests/test_docs.py runs it)
"""

from __future__ import annotations

import inspect
import sys
from pathlib import Path

import typer

import postproc
from postproc.cli import app
from postproc.model.effects import CATALOG

ROOT = Path(__file__).resolve().parents[1]
#: The robot whose joint count and names fill the parameter tables (any bundled robot works).
EXAMPLE_ROBOT = "kr160_r1570"


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _param_row(param) -> str:
    if param.param_type_name == "argument":
        name = f"`{param.name.upper()}`"
        kind = "argument" + ("" if param.required else " (optional)")
    else:
        name = ", ".join(f"`{o}`" for o in param.opts + param.secondary_opts)
        kind = "flag" if getattr(param, "is_flag", False) else str(param.bare_type()).lower()
    default = param.default
    default = "" if default is None or default is False or default == () or default == [] else f"`{default}`"
    help_text = getattr(param, "help", "") or ""
    return f"| {name} | {kind} | {default} | {_cell(help_text)} |"


def _command_section(name: str, command) -> list[str]:
    lines = [f"## `postproc {name}`", ""]
    if command.help:
        lines += [inspect.cleandoc(command.help), ""]
    params = [p for p in command.params if p.name not in ("help",)]
    if params:
        lines += ["| argument / option | type | default | meaning |", "| --- | --- | --- | --- |"]
        lines += [_param_row(p) for p in params]
        lines.append("")
    return lines


def _commands(group, prefix: str = "") -> list[tuple]:
    found = []
    for name in sorted(group.commands):
        command = group.commands[name]
        if hasattr(command, "commands"):
            found += _commands(command, f"{prefix}{name} ")
        else:
            found.append((f"{prefix}{name}", command))
    return found


def cli_page() -> str:
    root = typer.main.get_command(app)
    lines = ["# CLI reference", "",
             "Generated from the CLI itself by `scripts/gen_docs.py`; `postproc COMMAND --help` prints the same.",
             "Exit codes: 0 done, 1 the job could not be done as asked (e.g. points that do not converge),",
             "2 bad input (the message names file, line and column, or CSV row and column).", ""]
    for name, command in _commands(root):
        lines += _command_section(name, command)
    return "\n".join(lines).rstrip() + "\n"


def _effect_section(name: str, cls, robot) -> list[str]:
    effect = cls()
    module_doc = inspect.getdoc(sys.modules[cls.__module__]) or ""
    lines = [f"## `{name}`", "", f"*kind:* `{cls.kind}`"]
    if cls.needs:
        lines[-1] += f" · *measurement columns:* {', '.join(cls.needs)}"
    if cls.consumes:
        lines[-1] += f" · *compensation inputs:* {', '.join(cls.consumes)}"
    lines += ["", _cell(cls.summary) or "(no summary)", ""]
    if module_doc:
        lines += ["??? note \"Model and sources (from the effect's module)\"", ""]
        lines += [f"    {line}" if line else "" for line in module_doc.splitlines()] + [""]
    params = effect.params(robot) if effect.resolved else []
    if not effect.resolved:
        lines += ["Its terms are chosen by `fit` (or given as options); see the guide's *Choosing terms*.", ""]
    if params:
        lines += [f"Parameters with default options, on the {robot.name}:", "",
                  "| parameter | unit | typical magnitude | bounds |", "| --- | --- | ---: | --- |"]
        for p in params:
            bounds = "" if p.lower == -float("inf") and p.upper == float("inf") else f"[{p.lower:g}, {p.upper:g}]"
            lines.append(f"| `{p.name}` | {p.unit} | {p.typical:g} | {bounds} |")
        lines.append("")
    if cls.identifiability:
        lines += [f"**Identifiability.** {_cell(cls.identifiability)}", ""]
    return lines


def effects_page() -> str:
    robot = postproc.load_robot(EXAMPLE_ROBOT)
    lines = ["# Effects catalog", "",
             "Generated from the effect classes by `scripts/gen_docs.py`. Combine effects with commas,",
             "options in brackets: `--effects geometric,joint_harmonics[joints=2,3;orders=3,4]`.", ""]
    for name, cls in sorted(CATALOG.items()):
        lines += _effect_section(name, cls, robot)
    return "\n".join(lines).rstrip() + "\n"


PAGES = {"docs/reference/cli.md": cli_page, "docs/reference/effects.md": effects_page}


def main(argv: list[str]) -> int:
    check = "--check" in argv
    stale = []
    for rel, build in PAGES.items():
        path = ROOT / rel
        text = build()
        if check:
            if not path.exists() or path.read_text() != text:
                stale.append(rel)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
    if stale:
        print("out of date (run .venv/bin/python scripts/gen_docs.py): " + ", ".join(stale))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
