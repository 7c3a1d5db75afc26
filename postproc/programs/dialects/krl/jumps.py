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


_LABEL = re.compile(r"^[ \t]*([A-Za-z_]\w*)[ \t]*:(?![ \t]*=)[ \t]*$")
_GOTO = re.compile(r"\bGOTO[ \t]+([A-Za-z_]\w*)[ \t]*$", re.IGNORECASE)
_BLOCK_OPEN = re.compile(r"^[ \t]*(?:IF\b[^\n]*\bTHEN|SWITCH\b|FOR\b|WHILE\b|LOOP\b|REPEAT\b)", re.IGNORECASE)
_BLOCK_CLOSE = re.compile(r"^[ \t]*(?:ENDIF|ENDSWITCH|ENDFOR|ENDWHILE|ENDLOOP|UNTIL)\b", re.IGNORECASE)
_CONDITION = re.compile(r"^[ \t]*(?:IF|SWITCH|WHILE|UNTIL|CASE|ELSE)\b", re.IGNORECASE)
_CALL_IN_CONDITION = re.compile(r"([A-Za-z_$][\w$]*)[ \t]*\(")
_LOOP = re.compile(r"^[ \t]*(?:FOR|WHILE|LOOP|REPEAT|ENDFOR|ENDWHILE|ENDLOOP|UNTIL)\b", re.IGNORECASE)


def forward_ranges(code_lines: list[str], first: int, last: int) -> tuple[list[tuple[int, int]] | None, str]:
    """The lines the GOTOs of one routine (lines ``first``..``last``, 1-based, comments cut)
    may skip, as (GOTO line, label line) pairs, when every jump is forward to a label at the
    routine's top level and no loop lies between the first GOTO and the last label; else
    (None, why).

    Then (KSS 8 "GOTO": the program continues at the label, jumps into a block are not
    allowed) a statement strictly between a GOTO and its label may or may not have run when
    the program is past the label, and every other top-level statement runs exactly once, in
    text order, on every way through the routine: its changes are straight-line code."""
    labels: dict[str, list[tuple[int, int]]] = {}
    gotos: list[tuple[int, str]] = []
    depth = 0
    for number in range(first, last + 1):
        code = code_lines[number - 1]
        if (m := _LABEL.match(code)) is not None:
            labels.setdefault(m.group(1).upper(), []).append((number, depth))
        if (m := _GOTO.search(code)) is not None:
            gotos.append((number, m.group(1).upper()))
        depth += bool(_BLOCK_OPEN.match(code)) - bool(_BLOCK_CLOSE.match(code))
    ranges = []
    for line, name in gotos:
        found = labels.get(name, [])
        if len(found) != 1:
            return None, f"label {name} is not found once in its routine"
        label, label_depth = found[0]
        if label < line:
            return None, f"GOTO {name} on line {line} jumps back"
        if label_depth:
            return None, f"label {name} is inside a block"
        ranges.append((line, label))
    if ranges and any(_LOOP.match(code_lines[n - 1]) for n in range(min(g for g, _ in ranges), max(l for _, l in ranges))):
        return None, "a loop lies between its jumps and their labels"
    for number in (n for n in range(first, last + 1) if skipped(ranges, n)):
        calls = {c.upper() for c in _CALL_IN_CONDITION.findall(code_lines[number - 1])} if _CONDITION.match(code_lines[number - 1]) else set()
        if calls - {"VARSTATE"}:  # a function run or not by the jump may change anything
            return None, f"line {number}, which a jump may skip, calls a function in a condition"
    return ranges, ""


def skipped(ranges: list[tuple[int, int]], line: int) -> bool:
    """True where a jump may skip ``line``."""
    return any(g < line < l for g, l in ranges)
