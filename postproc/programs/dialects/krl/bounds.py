"""KRL FOR loops whose bounds name an INT set to a constant: run as the controller runs them.

``n = 30000`` then ``FOR i = 1 TO n ... LIN gfPoint[i] ... ENDFOR`` (as CAM systems write
point lists) is deterministic: KSS 8.x, Operating and Programming Instructions for System
Integrators, "FOR ... TO ... ENDFOR": the loop runs from the start value to the end value
(both evaluated when the loop starts); "Variables and declarations": an INT declared in a
DEF's declaration section is local to it, so only that DEF changes it.

A bound name is taken as known when it is an INT declared in the first DEF, every
assignment of it anywhere in the program is a literal integer in that DEF's straight-line
code, one of them comes before the loop, no call gets it and the program has no GOTO that
may jump; its value is the last such assignment before the FOR line. Anything else keeps
the loop listed once, with a note that says why (as before).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .counters import Assign
from .loops import ForLoop, for_values
from .state import number

_INT = re.compile(r"[ \t]*[+-]?\d+[ \t]*")


@dataclass
class NamedFor:
    loop: ForLoop  # as read (values None)
    bounds: list  # start, end[, step] expression trees
    names: set[str]  # the names the bounds use, upper case


def known_value(name: str, line: int, assigns: list[Assign], local_ints: set[str], calls_text: list[tuple[int, str]]) -> tuple[int | None, str]:
    """The value ``name`` holds at ``line`` under the rule above, or None and why not."""
    if name not in local_ints:
        return None, f"{name} is not an INT declared in this DEF (another program may change it)"
    mine = [a for a in assigns if a.name == name]
    if any(not (a.straight and _INT.fullmatch(a.rhs)) for a in mine):
        return None, f"{name} is set by something else than a literal integer in straight-line code"
    before = [a for a in mine if a.line < line]
    if not before:
        return None, f"{name} is not set before the loop"
    if any(re.search(rf"\b{re.escape(name)}\b", args, re.IGNORECASE) for _, args in calls_text):
        return None, f"{name} is passed to a call (it may be changed there)"
    return int(before[-1].rhs), ""


def planned(named: NamedFor, assigns: list[Assign], local_ints: set[str], calls_text: list[tuple[int, str]], has_goto: bool) -> tuple[ForLoop | None, str]:
    """The loop with its passes, or None and why its count stays unknown."""
    if has_goto:
        return None, "the program has a GOTO that may jump"
    values: dict[str, float] = {}
    for name in sorted(named.names):
        value, why = known_value(name, named.loop.first_line, assigns, local_ints, calls_text)
        if value is None:
            return None, why
        values[name] = float(value)
    bounds = [number(b, lambda text: values.get(text or "", float("nan"))) for b in named.bounds] + ([1.0] if len(named.bounds) < 3 else [])
    passes = for_values(*bounds[:3])
    if passes is None:
        return None, "its bounds are not integers, or it would run too many passes"
    lp = named.loop
    return ForLoop(lp.first_line, lp.last_line, lp.counter, passes), ""
