"""The tool table's radius of the tools a Klartext program calls, given from outside the
program (``--tool-radius T5=4.0``): under RL / RR the TNC offsets by R + DR TAB + DR of TOOL
CALL (TNC 640 User's Manual, 5.3 "Tool compensation"), and the table's R + DR is not in the
program text. The program is read again with them, so radius compensation is followed."""

from __future__ import annotations

from postproc.errors import InputError

from ...ir import Toolpath
from .parse import read_klartext


def parse_tool_radii(items: list[str] | None, option: str = "--tool-radius") -> dict[str, float]:
    """'NAME=R' options (R: the table's radius plus its DR, mm) -> {name: R}."""
    out: dict[str, float] = {}
    for item in items or []:
        name, eq, value = item.partition("=")
        try:
            radius = float(value)
        except ValueError:
            radius = float("nan")
        if not eq or not name.strip() or not radius >= 0.0:
            raise InputError(f"{option}: expected TOOL=RADIUS (T5=4.0: the tool table's R + DR of tool 5, mm, >= 0), got '{item}'")
        out[name.strip().strip('"')] = radius
    return out


def with_tool_radii(tp: Toolpath, radii: dict[str, float]) -> Toolpath:
    """``tp`` read again with the tool table's radii ``radii``; ``tp`` where none is given."""
    if not radii:
        return tp
    if tp.dialect != "heidenhain":
        raise InputError(f"--tool-radius gives the tool table's radius of a Klartext program (RL / RR); {tp.sources[0].path} is {tp.dialect}")
    return read_klartext(tp.sources[0], radii)
