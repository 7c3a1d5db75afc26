"""``while`` loops whose number of passes the text fixes (URScript manual, "Flow of control":
``while`` runs its body while the condition holds).

The one form counted: an integer counter set to a literal before the loop, the condition
``counter < N`` or ``counter <= N`` (N a literal integer, brackets allowed), and in the body
exactly one ``counter = counter + 1`` at its own level, no other assignment to the counter
anywhere in it, and no ``break``, ``continue``, ``return`` or ``halt``. The parser then runs
the body pass by pass (one IR row per executed motion, the passes sharing the text's
spans); any other loop is listed once with a note.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

_CONDITION = re.compile(r"[ \t]*while[ \t]*\(?[ \t]*([A-Za-z_]\w*)[ \t]*(<=|<)[ \t]*(\d+)[ \t]*\)?[ \t]*:[ \t]*\r?\Z")
_OPENS = re.compile(r"[ \t]*(?:def|thread|if|while)\b")
_ENDS = re.compile(r"[ \t]*end\b")
_LEAVES = re.compile(r"\b(?:break|continue|return|halt)\b")
INT_LITERAL = re.compile(r"[ \t]*(\d+)[ \t]*\r?\Z")


@dataclass(frozen=True)
class CountedLoop:
    counter: str
    passes: int
    end_index: int  # index (among the parser's statements) of the loop's 'end'
    first: int  # the counter's value at the first pass
    limit: str  # the condition, for notes


def counted(mask: str, starts: np.ndarray, ends: np.ndarray, index: int, scalars: dict) -> CountedLoop | None:
    """The loop whose ``while`` is statement ``index`` (of ``starts``/``ends``), if its passes
    are fixed by the text (see the module's docstring), else None."""
    head = _CONDITION.match(mask, int(starts[index]), int(ends[index]))
    if head is None or type(scalars.get(head.group(1))) is not int:  # (a truth value is no counter)
        return None
    counter, first, limit = head.group(1), scalars[head.group(1)], int(head.group(3))
    increment = re.compile(rf"[ \t]*{re.escape(counter)}[ \t]*=[ \t]*{re.escape(counter)}[ \t]*\+[ \t]*1[ \t]*\r?\Z")
    assigns = re.compile(rf"[ \t]*(?:(?:global|local)[ \t]+)?{re.escape(counter)}[ \t]*=(?!=)")
    depth, increments = 1, 0
    for i in range(index + 1, len(starts)):
        s, e = int(starts[i]), int(ends[i])
        if _LEAVES.search(mask, s, e):
            return None
        if _ENDS.match(mask, s, e):
            depth -= 1
            if depth == 0:
                passes = max(limit - first + (head.group(2) == "<="), 0)
                return CountedLoop(counter, passes, i, first, f"{counter} {head.group(2)} {limit}") if increments == 1 and passes > 0 else None
            continue
        if _OPENS.match(mask, s, e):
            depth += 1
            continue
        if increment.match(mask, s, e):
            if depth != 1:
                return None
            increments += 1
        elif assigns.match(mask, s, e):
            return None
    return None
