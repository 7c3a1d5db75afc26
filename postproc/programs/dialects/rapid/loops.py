"""RAPID FOR loops as the controller runs them: one IR row per executed motion.

ABB "Technical reference manual - RAPID Instructions, Functions and Data types"
(3HAC050917-001), instruction FOR: ``FOR Loop counter FROM Start value TO End value
[STEP Step value] DO ... ENDFOR``; the counter starts at the start value and the body runs
while it has not passed the end value; "If the step value is not specified, it is
automatically set to 1, or -1 if the start value is larger than the end value"; the loop
counter is a local num that the body may not change.

A FOR whose start, end and step can be computed from literals and the counters of the loops
around it is unrolled: every executed move gives a row, and the rows of one move statement
share the statement's text spans (a shared number that would need two values is refused
on write-back, see emit/splice.py). ``Offs(p, i*10, 0, 0)`` and ``path{i}`` are evaluated
with the counter's value. A count that cannot be computed runs the body once with the
counter unknown: targets that use it are unresolved, the others are listed once and noted.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
from lark import Token, Tree

MAX_ITERATIONS = 100_000  # per loop; more is read as a count not known at post time
MAX_REPLAYED = 200_000  # statements run by the unrolled loops of one module (~30 s); more is refused

_BLOCK_LINE = re.compile(r"^[ \t]*(FOR|ENDFOR|WHILE|ENDWHILE)\b", re.IGNORECASE)


@dataclass
class Loop:
    """A FOR statement whose body is being read (statements kept until its ENDFOR)."""

    node: Tree
    start: int
    body: list = field(default_factory=list)  # (node, start) or a nested Loop
    kind: str = "for"  # or "while" (counters.py)
    inner_whiles: int = 0  # WHILEs open inside a buffered WHILE (kept as plain statements)


def evaluate(node, env: dict[str, float]) -> float:
    """A num expression of literals and bound loop counters; NaN where it reads anything else."""
    if isinstance(node, Token):
        return float(node) if node.type == "NUMBER" else float("nan")
    kind = node.data
    if kind == "number":
        return float(node.children[0])
    if kind == "neg":
        return -evaluate(node.children[0], env)
    if kind == "lvalue" and len(node.children) == 1:
        return env.get(str(node.children[0]).upper(), float("nan"))
    if kind in ("sum_expr", "prod_expr"):
        total = evaluate(node.children[0], env)
        for op, operand in zip(node.children[1::2], node.children[2::2]):
            total = _apply(str(op).upper(), total, evaluate(operand, env))
        return total
    return float("nan")


def _apply(op: str, a: float, b: float) -> float:
    if np.isnan(a) or np.isnan(b):
        return float("nan")
    if op in ("/", "DIV", "MOD") and b == 0:
        return float("nan")  # a run-time error on the controller, not a value
    if op in ("DIV", "MOD") and (a != int(a) or b != int(b)):
        return float("nan")  # DIV and MOD take integers
    if op == "+":
        return a + b
    if op == "-":
        return a - b
    if op == "*":
        return a * b
    if op == "/":
        return a / b
    if op in ("DIV", "MOD"):  # (each operation computed alone: a dict of all of them divided by a zero b of "+")
        quotient = int(a / b)
        return float(quotient) if op == "DIV" else float(int(a) - int(b) * quotient)
    return float("nan")


def for_counter(node: Tree, env: dict[str, float]) -> tuple[str, list[float] | None]:
    """(counter name, its values in order) of a ``for_open`` tree; None when not computable."""
    name = str(next(c for c in node.children if isinstance(c, Token) and c.type == "NAME")).upper()
    exprs = [c for c in node.children if isinstance(c, Tree)]  # start, end [, step]; keywords are tokens
    start, end = evaluate(exprs[0], env), evaluate(exprs[1], env)
    step = evaluate(exprs[2], env) if len(exprs) > 2 else (1.0 if start <= end else -1.0)
    if np.isnan([start, end, step]).any() or step == 0:
        return name, None
    count = int(np.floor((end - start) / step + 1e-9)) + 1
    if count > MAX_ITERATIONS:
        return name, None
    return name, [start + k * step for k in range(max(count, 0))]


def planned_statements(loop: Loop, env: dict[str, float]) -> int:
    """How many statements running ``loop`` replays (inner loops counted with the outer
    counters' first values; a count not known counts one pass)."""
    name, values = for_counter(loop.node, env)
    passes = len(values) if values is not None else 1
    inner_env = {**env, name: values[0] if values else float("nan")}
    per_pass = sum(planned_statements(item, inner_env) if isinstance(item, Loop) else 1 for item in loop.body)
    return passes * per_pass


def loop_body_lines(code: str) -> np.ndarray:
    """(lines,) True for each line inside a FOR ... ENDFOR or WHILE ... ENDWHILE (comments
    already blanked): those lines are read statement by statement, never as bulk one-liners."""
    lines = code.split("\n")
    inside = np.zeros(len(lines), bool)
    depth = 0
    for i, line in enumerate(lines):
        m = _BLOCK_LINE.match(line)
        if m and m.group(1).upper() in ("ENDFOR", "ENDWHILE"):
            depth = max(depth - 1, 0)
        inside[i] = depth > 0
        if m and m.group(1).upper() in ("FOR", "WHILE"):
            depth += 1
    return inside


def element_key(node, env: dict[str, float]) -> str | None:
    """``path{i}`` with i bound -> ``PATH{3}`` (the key array elements are declared under);
    None for any other shape or an index that is not a known whole number."""
    if not (isinstance(node, Tree) and node.data == "lvalue") or len(node.children) != 2:
        return None
    index = node.children[1]
    if isinstance(index, Token):
        return None
    value = evaluate(index, env)
    if np.isnan(value) or value != int(value):
        return None
    return f"{str(node.children[0]).upper()}{{{int(value)}}}"
