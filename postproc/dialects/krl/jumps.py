"""KRL GOTO: which jumps leave the program's changes straight-line code.

KUKA System Software 8.x, Operating and Programming Instructions for System Integrators,
"GOTO": ``GOTO Marker`` continues the program at ``Marker:`` in the same subprogram or
function; jumps into an IF, a loop or a SWITCH from outside are not allowed.

A jump may run a line again (backwards) or skip lines (forwards). It changes nothing at the
targets only where what it skips changes nothing: a forward jump, not inside a loop (a loop
could run the jump's line again after a change), to a label of the same routine, and every
statement between the jump and the label is one that neither moves nor changes a variable
(block keywords, labels, other jumps, WAIT, HALT, CONTINUE; no function call in a condition). Then whether the controller jumps
or not, the same points and frames are in force at every target after it. Any other GOTO
makes the changes of its routine not straight-line code (state.py / calls.py).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_HARMLESS = re.compile(
    r"^[ \t]*(?:"
    r"[A-Za-z_]\w*[ \t]*:(?![ \t]*=)"  # a label
    r"|GOTO[ \t]+\w+"
    r"|ELSE|ENDIF|ENDSWITCH|DEFAULT|CASE\b[^\n]*|SWITCH\b[^\n]*|IF\b[^\n]*\bTHEN"
    r"|CONTINUE|HALT|WAIT[ \t]+(?:FOR|SEC)\b[^\n]*"
    r")[ \t]*$",
    re.IGNORECASE,
)
_OPENS = re.compile(r"^[ \t]*(?:IF\b|SWITCH\b)", re.IGNORECASE)
_CLOSES = re.compile(r"^[ \t]*(?:ENDIF|ENDSWITCH)\b", re.IGNORECASE)


@dataclass
class Goto:
    line: int  # 1-based line of the GOTO in the program file
    label: str  # upper case
    in_loop: bool  # inside FOR / WHILE / LOOP / REPEAT
    routine: int | None  # index of its DEF (calls.Routine)


def why_not_straight(goto: Goto, labels: dict[tuple[int | None, str], list[int]], code_lines: list[str]) -> str | None:
    """None where the jump changes no point or frame at any target; else why it may."""
    found = labels.get((goto.routine, goto.label), [])
    if len(found) != 1:
        return f"label {goto.label} is not found once in its routine"
    label = found[0]
    if label < goto.line:
        return "it jumps back (the lines after the label may run again after later changes)"
    if goto.in_loop:
        return "it is inside a loop (the loop may run the lines before it again)"
    depth = 0
    for number in range(goto.line + 1, label):
        code = code_lines[number - 1]
        if not code.strip():
            continue
        if not _HARMLESS.match(code) or "(" in code:  # a function in a condition may change anything
            return f"it skips line {number}, which may move or change a variable"
        depth += bool(_OPENS.match(code)) - bool(_CLOSES.match(code))
    if depth > 0:
        return "it jumps into a block"
    return None
