"""RAPID: which ``ConfL``/``ConfJ`` switch is in force at each motion, by the call structure.

``ConfL\\Off`` holds from where it runs until the next ``ConfL`` runs: in execution order,
not in the order routines are written. A routine written after ``ConfL\\Off`` but called
from ``main`` before it runs with ``ConfL\\On``. So the state is found by walking the
program from ``main``: statements of a routine in text order, a call to a routine of the
program walks that routine with the state at the call and continues with the state it
leaves. A motion reached with the switch both on and off (a routine called from places
with different states, before it sets the switch itself) cannot be given one posture
rule: that is an error naming the motion and the calls. Routines not reached from
``main`` (or a program without ``main``) keep the text order of their module.

Within a routine the statements are taken in text order. A switch inside an IF, a loop or
a TEST, or one written as the statement of a one-line ``IF``, makes the state after it a
run-time matter: that is refused with its line (move the switch out of the block).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from postproc.errors import InputError

_PROC = re.compile(r"^[ \t]*(?:LOCAL[ \t]+)?PROC[ \t]+(\w+)[ \t]*\(", re.IGNORECASE | re.MULTILINE)
_ENDPROC = re.compile(r"^[ \t]*ENDPROC\b", re.IGNORECASE | re.MULTILINE)
_SWITCH = re.compile(r"^[ \t]*(CONFL|CONFJ)[ \t]*\\(ON|OFF)[ \t]*;", re.IGNORECASE | re.MULTILINE)
_ANY_SWITCH = re.compile(r"\b(?:CONFL|CONFJ)[ \t]*\\(?:ON|OFF)\b", re.IGNORECASE)
_OPENS = re.compile(r"^[ \t]*(?:IF\b.*\bTHEN\b|WHILE\b|FOR\b|TEST\b)", re.IGNORECASE)
_CLOSES = re.compile(r"^[ \t]*(?:ENDIF|ENDWHILE|ENDFOR|ENDTEST)\b", re.IGNORECASE)
_STATEMENT = re.compile(r"^[ \t]*(\w+)[ \t]*(?:;|[ \t\\])", re.MULTILINE)


@dataclass
class _Routine:
    name: str
    file: int
    first: int  # line of PROC
    last: int  # line of ENDPROC
    events: list = field(default_factory=list)  # (line, kind, value): ("switch", (which, off)) or ("call", name)


def _line_of(text: str, offset: int) -> int:
    return text.count("\n", 0, offset) + 1


def routines(sources) -> dict[str, _Routine]:
    """The PROCs of every module, with their switch and call statements in text order."""
    found: dict[str, _Routine] = {}
    for f, doc in enumerate(sources):
        text = re.sub(r"!.*", lambda m: " " * len(m.group()), doc.text)  # comments out, offsets kept
        ends = [_line_of(text, m.start()) for m in _ENDPROC.finditer(text)]
        for m in _PROC.finditer(text):
            first = _line_of(text, m.start())
            last = next((e for e in ends if e > first), first)
            found.setdefault(m.group(1).upper(), _Routine(m.group(1), f, first, last))
        for r in (r for r in found.values() if r.file == f):
            for m in _SWITCH.finditer(text):
                line = _line_of(text, m.start())
                if r.first < line < r.last:
                    r.events.append((line, "switch", (m.group(1).upper(), m.group(2).upper() == "OFF")))
    for f, doc in enumerate(sources):
        text = re.sub(r"!.*", lambda m: " " * len(m.group()), doc.text)
        for m in _STATEMENT.finditer(text):
            line = _line_of(text, m.start())
            callee = m.group(1).upper()
            if callee in found:
                caller = next((r for r in found.values() if r.file == f and r.first < line < r.last), None)
                if caller is not None:
                    caller.events.append((line, "call", callee))
    for r in found.values():
        r.events.sort(key=lambda e: e[0])
    return found


def refuse_conditional_switches(sources) -> None:
    """InputError naming the first ConfL/ConfJ switch that runs only under a condition (inside
    IF / WHILE / FOR / TEST, or as a one-line IF's statement): the posture rule after it is
    decided at run time."""
    for doc in sources:
        depth = 0
        for number, line in enumerate(re.sub(r"!.*", "", doc.text).split("\n"), start=1):
            if _CLOSES.match(line):
                depth = max(depth - 1, 0)
            found = _ANY_SWITCH.search(line)
            if found and (depth > 0 or not _SWITCH.match(line + "\n")):
                raise InputError(f"{doc.path}:{number}:{found.start() + 1}: {found.group(0)} runs only under a condition (IF, loop or TEST): "
                                 "the posture rule of the motions after it is decided at run time; set it outside the block")
            if _OPENS.match(line):
                depth += 1


def switch_states(tp, text_order: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """(N,) True where ``ConfL`` / ``ConfJ`` is off at each target, by the call structure from
    ``main``; ``text_order`` (the module-text answer) where main does not reach a target."""
    refuse_conditional_switches(tp.sources)
    table = routines(tp.sources)
    switched_off = any(kind == "switch" and value[1] for r in table.values() for _, kind, value in r.events)
    if "MAIN" not in table or not switched_off:
        return text_order
    reached: dict[int, dict[str, bool]] = {}
    conflicts: list[tuple[int, str]] = []
    rows_of = {}
    for i, (f, line) in enumerate(zip(tp.file.tolist(), tp.line.tolist())):
        rows_of.setdefault((f, line), []).append(i)

    def walk(name: str, state: dict[str, bool], stack: tuple[str, ...], via: str) -> dict[str, bool]:
        r = table[name]
        lines = sorted({line for (f, line) in rows_of if f == r.file and r.first < line < r.last})
        items = sorted([(line, "motion", None) for line in lines] + r.events, key=lambda e: (e[0], e[1] != "switch"))
        for line, kind, value in items:
            if kind == "switch":
                state = {**state, value[0]: value[1]}
            elif kind == "call" and value not in stack:
                state = walk(value, state, stack + (value,), f"{via} -> {table[value].name} (line {line})")
            elif kind == "motion":
                for i in rows_of[(r.file, line)]:
                    if i in reached and reached[i] != state:
                        conflicts.append((i, via))
                    reached[i] = state
        return state

    walk("MAIN", {"CONFL": False, "CONFJ": False}, ("MAIN",), table["MAIN"].name)
    if conflicts:
        i, via = conflicts[0]
        raise InputError(f"{tp.sources[int(tp.file[i])].path}, line {tp.line[i]}: this motion runs with ConfL/ConfJ both on and off "
                         f"(its routine is called where the switch differs, e.g. {via}); set ConfL/ConfJ in the routine itself before its motions")
    out = {}
    for which, fallback in text_order.items():
        col = fallback.copy()
        for i, state in reached.items():
            col[i] = state[which]
        out[which] = col
    return out
