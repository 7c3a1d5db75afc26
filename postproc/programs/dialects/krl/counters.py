"""KRL WHILE and REPEAT loops over an integer counter, run as the controller runs them.

KUKA System Software 8.x, Operating and Programming Instructions for System Integrators:
"WHILE ... ENDWHILE": ``WHILE Condition`` checks the condition before each pass and runs the
body while it is TRUE; "REPEAT ... UNTIL": the body runs, then ``UNTIL Condition`` is checked
and the loop ends when it is TRUE (at least one pass); "Variables and declarations": a
variable declared in a DEF's declaration section is local to it (no other program, the
submit interpreter included, can change it); ``EXIT`` leaves a loop, ``RETURN`` the routine.

A WHILE / REPEAT of the first DEF's straight-line code is run pass by pass (like a FOR,
loops.py) when its condition compares a counter with a literal (``I < 5``, ``I <> 0`` ...),
the counter is an INT declared in that DEF, set by literal integers in straight-line code
only, and changed in the program only by one ``I = I + k`` / ``I = I - k`` (k a literal
integer) at the body's top level; the body holds no EXIT, RETURN, GOTO or label, and no call
gets the counter. Motions after the update in the body see the counter's new value
(``NAME[I]``). Anything else keeps the body listed once with a note, as before.
"""

from __future__ import annotations

import operator
import re
from dataclasses import dataclass

from lark import Tree

from .loops import MAX_ROWS, ForLoop

_COMPARE = {"==": operator.eq, "<>": operator.ne, "<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}
_INT = re.compile(r"[+-]?\d+")


@dataclass
class CounterLoop:
    kind: str  # "WHILE" or "REPEAT"
    first_line: int
    last_line: int  # ENDWHILE / UNTIL
    condition: object  # the expression's tree
    straight: bool  # the loop itself is in the first DEF's straight-line code


@dataclass
class Assign:
    name: str  # upper case, the whole left side
    line: int
    rhs: str  # the right side's text
    straight: bool  # first DEF, outside every block
    depth: int  # blocks open around it (the DEF not counted)
    routine: int | None


def _comparison(node) -> tuple[str, str, int] | None:
    """(counter, operator, literal) of ``I op n`` (or ``n op I``, turned round)."""
    if not (isinstance(node, Tree) and node.data == "cmp_expr" and len(node.children) == 3):
        return None
    left, op, right = node.children
    name = _name(left)
    value = _literal(right)
    if name is None or value is None:
        name, value = _name(right), _literal(left)
        op = {"<": ">", ">": "<", "<=": ">=", ">=": "<="}.get(str(op), str(op))
    return (name, str(op), value) if name is not None and value is not None else None


def _name(node) -> str | None:
    if isinstance(node, Tree) and node.data == "lvalue" and len(node.children) == 1:
        return str(node.children[0]).upper()
    return None


def _literal(node) -> int | None:
    sign = 1
    if isinstance(node, Tree) and node.data == "neg":
        sign, node = -1, node.children[0]
    if isinstance(node, Tree) and node.data == "number" and _INT.fullmatch(str(node.children[0])):
        return sign * int(str(node.children[0]))
    return None


def plan(loop: CounterLoop, assigns: list[Assign], local_ints: set[str], body_text: list[str], calls_text: list[tuple[int, str]]) -> tuple[ForLoop | None, str]:
    """The loop as passes (a ForLoop with the counter's value at each pass's start and the
    update's line and step), or None and why it is not run."""
    found = _comparison(loop.condition)
    if not loop.straight:
        return None, "the loop is inside a block or a subprogram"
    if found is None:
        return None, "its condition is not a comparison of a counter with a literal integer"
    counter, op, limit = found
    if counter not in local_ints:
        return None, f"{counter} is not an INT declared in this DEF (another program may change it)"
    inside = [a for a in assigns if a.name == counter and loop.first_line < a.line < loop.last_line]
    if len(inside) != 1 or inside[0].depth != 1:
        return None, f"{counter} is not changed exactly once at the body's top level"
    step = re.fullmatch(rf"[ \t]*{re.escape(counter)}[ \t]*([+-])[ \t]*(\d+)[ \t]*", inside[0].rhs, re.IGNORECASE)
    if step is None:
        return None, f"{counter} is changed by something else than {counter} = {counter} + k"
    k = int(step.group(2)) * (1 if step.group(1) == "+" else -1)
    before = [a for a in assigns if a.name == counter and a.line < loop.first_line]
    others = [a for a in assigns if a.name == counter and a not in inside and not (a.straight and _INT.fullmatch(a.rhs.strip()))]
    if others or not before:
        return None, f"{counter} is not set by literal integers in straight-line code before the loop (or is changed elsewhere)"
    if any(re.search(rf"\b(?:EXIT|RETURN|GOTO)\b|^[ \t]*\w+[ \t]*:(?!=)", code, re.IGNORECASE) for code in body_text):
        return None, "its body has EXIT, RETURN, GOTO or a label"
    if any(re.search(rf"\b{re.escape(counter)}\b", args, re.IGNORECASE) for line, args in calls_text):
        return None, f"{counter} is passed to a call (it may be changed there)"
    values = _passes(loop.kind, int(before[-1].rhs), k, op, limit)
    if values is None:
        return None, f"it would run more than {MAX_ROWS:,} passes"
    return ForLoop(loop.first_line, loop.last_line, counter, values, update=(inside[0].line, k)), ""


def _passes(kind: str, start: int, step: int, op: str, limit: int) -> list[int] | None:
    """The counter at the start of each pass: WHILE tests before a pass (runs while TRUE),
    REPEAT after it (stops when TRUE)."""
    test = _COMPARE[op]
    values, value = [], start
    if kind == "WHILE":
        while test(value, limit):
            values.append(value)
            value += step
            if len(values) > MAX_ROWS:
                return None
        return values
    while True:
        values.append(value)
        value += step
        if test(value, limit):
            return values
        if len(values) > MAX_ROWS:
            return None


def declared_ints(text: str) -> set[str]:
    """INT variables declared in a DEF's declaration section (``DECL INT I, J`` / ``INT I``)."""
    out: set[str] = set()
    for m in re.finditer(r"^[ \t]*(?:DECL[ \t]+)?INT[ \t]+([^;\r\n=]+)", text, re.IGNORECASE | re.MULTILINE):
        out.update(n.strip().upper() for n in m.group(1).split(",") if re.fullmatch(r"[ \t]*[A-Za-z_]\w*[ \t]*", n))
    return out
