"""The compensation target a file holds, told by its content (never its suffix): a JSON
model document from ``postproc fit`` (a robot and its error model), or a TOML file with a
``[machine]`` table (a calibrated five-axis machine). Reading a model loads the fitting
stack (scipy.optimize): the command line imports this module when a job runs.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from postproc.errors import ModelFileError
from postproc.fivex.machine import load_machine
from postproc.model.model_io import FORMAT, load_model

from .targets import FiveAxisTarget, RobotTarget

# A TOML text that opens a [machine] table, even one that does not parse: meant as a machine file.
_MACHINE_TABLE = re.compile(r"(?m)^[ \t]*\[[ \t]*machine[ \t]*\]")


def load_target(path: str | Path) -> RobotTarget | FiveAxisTarget:
    """The robot model or the five-axis machine the file at ``path`` holds, by its content."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read model file ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise ModelFileError(f"{path}: not a model file: byte {exc.start} is not UTF-8 text (binary or damaged file)") from None
    if text.lstrip().startswith("{"):  # a JSON document: load_model names what is wrong with it
        return RobotTarget(load_model(path)[0], str(path))
    if _is_machine_toml(text) or _MACHINE_TABLE.search(text):  # a broken machine file: load_machine names the line or key
        machine = load_machine(path)
        return FiveAxisTarget(machine, load_machine(machine.name), str(path))
    raise ModelFileError(f"{path}: neither a model file from 'postproc fit' (JSON, format '{FORMAT}') "
                         "nor a five-axis machine file (TOML with a [machine] table)")


def _is_machine_toml(text: str) -> bool:
    try:
        return isinstance(tomllib.loads(text).get("machine"), dict)
    except tomllib.TOMLDecodeError:
        return False

