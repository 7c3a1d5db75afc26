"""``if`` / ``elif`` / ``else`` whose branch the text fixes (URScript manual, "Flow of
control": the first branch whose condition holds runs, else the ``else``).

A condition is fixed where it is ``True`` or ``False``, ``not`` of a fixed condition, or one
comparison (``<``, ``<=``, ``>``, ``>=``, ``==``, ``!=``) of number literals and of variables
the text sets to an integer or a truth value in straight-line code (``scalars``: the parser's
record, None once a block that may or may not run, or a function, sets the variable). The
parser then reads only the branch that runs: its motions are straight-line, the others' are
not executed and give no target. Any other condition leaves the block as before (its motions
listed, the posture after it unknown)."""

from __future__ import annotations

import operator
import re

_TEST = re.compile(r"[ \t]*(?:if|elif)\b(.*):[ \t]*\r?\Z", re.DOTALL)
_NOT = re.compile(r"[ \t]*not\b(.*)\Z", re.DOTALL)
_COMPARE = re.compile(r"(.+?)(<=|>=|==|!=|<|>)(.+)\Z", re.DOTALL)
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\Z")
_NAME = re.compile(r"[A-Za-z_]\w*\Z")
_OPERATORS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge, "==": operator.eq, "!=": operator.ne}
_BLOCK_OPENS = re.compile(r"[ \t]*(?:def|thread|if|while)\b")
_BLOCK_ENDS = re.compile(r"[ \t]*end\b")
_OTHER_BRANCH = re.compile(r"[ \t]*(?:elif\b|else[ \t]*:)")
TRUTH = {"True": True, "False": False}


def condition(mask: str, start: int, end: int, scalars: dict) -> bool | None:
    """The truth of the ``if`` / ``elif`` statement mask[start:end]'s condition where the text
    fixes it, else None."""
    head = _TEST.match(mask, start, end)
    return None if head is None else _truth(head.group(1), scalars)


def _truth(text: str, scalars: dict) -> bool | None:
    text = _unbracket(text.strip())
    negated = _NOT.match(text)
    if negated:
        inner = _truth(negated.group(1), scalars)
        return None if inner is None else not inner
    compared = _COMPARE.match(text)
    if compared:
        left, right = _operand(compared.group(1), scalars), _operand(compared.group(3), scalars)
        return None if left is None or right is None else bool(_OPERATORS[compared.group(2)](left, right))
    value = _operand(text, scalars)
    return value if isinstance(value, bool) else None


def _operand(text: str, scalars: dict) -> float | bool | None:
    text = _unbracket(text.strip())
    if text in TRUTH:
        return TRUTH[text]
    if _NUMBER.match(text):
        return float(text)
    return scalars.get(text) if _NAME.match(text) else None


def _unbracket(text: str) -> str:
    """``text`` without brackets around all of it."""
    while text.startswith("(") and text.endswith(")") and _balanced(text[1:-1]):
        text = text[1:-1].strip()
    return text


def _balanced(text: str) -> bool:
    depth = 0
    for ch in text:
        depth += (ch == "(") - (ch == ")")
        if depth < 0:
            return False
    return depth == 0


def next_branch(mask: str, starts, ends, index: int, to_end: bool) -> int:
    """Index of the statement after ``index`` that ends its branch: the next ``elif`` / ``else``
    of the same block or its ``end`` (``to_end``: only its ``end``); len(starts) where none."""
    depth = 0
    for i in range(index + 1, len(starts)):
        s, e = int(starts[i]), int(ends[i])
        if _BLOCK_ENDS.match(mask, s, e):
            if depth == 0:
                return i
            depth -= 1
        elif _BLOCK_OPENS.match(mask, s, e):
            depth += 1
        elif depth == 0 and not to_end and _OTHER_BRANCH.match(mask, s, e):
            return i
    return len(starts)
