"""RAPID WHILE loops over a routine-local counter, run as the controller runs them.

ABB "Technical reference manual - RAPID Instructions, Functions and Data types"
(3HAC050917-001): WHILE ``WHILE condition DO ... ENDWHILE`` runs the body as long as the
condition is TRUE, evaluated before each pass; Incr / Decr add / subtract 1; ``:=`` assigns.
A ``VAR num`` declared inside a routine is local to it (RAPID overview, "Scope of data"): no
other routine, TRAP or task can change it, except as an argument.

A WHILE in a routine's straight-line code is run pass by pass when its condition reads only
known routine-local nums and literals, and its body changes those only by top-level
``v := <expression of known nums>``, ``Incr v`` or ``Decr v``: the count is worked out first
(without emitting anything), then the body runs that many times with the counters' values.
Anything else (a counter changed inside an IF, passed to a call, an unknown start value, a
label or GOTO in the routine) leaves the loop listed once, as before, with every local num
made unknown.
"""

from __future__ import annotations

import numpy as np
from lark import Token, Tree

from .loops import Loop, evaluate

MAX_PASSES = 100_000
_OPENS = {"if_open", "for_open", "while_open", "test_open"}
_CLOSES = {"endif", "endfor", "endwhile", "endtest"}


def condition(node, env: dict[str, float]) -> bool | None:
    """A comparison (and AND / OR / NOT of them) of known nums; None where it reads anything else."""
    if not isinstance(node, Tree):
        return None
    if node.data == "cmp_expr" and len(node.children) == 3:
        a, op, b = evaluate(node.children[0], env), str(node.children[1]), evaluate(node.children[2], env)
        if np.isnan(a) or np.isnan(b):
            return None
        return {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b, "=": a == b, "<>": a != b}[op]
    if node.data in ("and_expr", "or_expr"):
        parts = [condition(c, env) for c in node.children if isinstance(c, Tree)]
        ops = {str(c).upper() for c in node.children if isinstance(c, Token)}
        if None in parts or ops - {"AND", "OR"} or len(ops) > 1:
            return None
        return all(parts) if ops == {"AND"} else any(parts)
    if node.data == "not_expr":
        inner = condition(node.children[-1], env)
        return None if inner is None else not inner
    return None


def update_of(node, locals_: set[str]) -> tuple[str, object] | None:
    """(counter, how) for a top-level ``v := expr`` / ``Incr v`` / ``Decr v`` of a local v."""
    if node.data == "assign":
        target = node.children[0]
        if isinstance(target, Tree) and len(target.children) == 1 and str(target.children[0]).upper() in locals_:
            return str(target.children[0]).upper(), node.children[1]
    if node.data == "record_field" and str(node.children[0]).upper() in ("INCR", "DECR"):
        arg = node.children[1]
        name = str(arg.children[0]).upper() if isinstance(arg, Tree) and len(arg.children) == 1 else str(arg).upper()
        if name in locals_:
            return name, 1.0 if str(node.children[0]).upper() == "INCR" else -1.0
    return None


def touches(node, locals_: set[str]) -> bool:
    """Whether a statement (with any statement nested in it, a one-line IF's) may change one of
    the local nums: an assignment to it, or a call that gets it as an argument."""
    if not isinstance(node, Tree):
        return False
    for sub in node.iter_subtrees():
        if sub.data == "assign":
            target = sub.children[0]
            if isinstance(target, Tree) and str(target.children[0]).upper() in locals_:
                return True
        elif sub.data in ("record_field", "call"):
            args = {str(t).upper() for c in sub.children[1:] for t in ([c] if isinstance(c, Token) else c.scan_values(lambda v: isinstance(v, Token)))}
            if args & locals_:
                return True
    return False


def plan(loop: Loop, env: dict[str, float], locals_: set[str]) -> tuple[list[int], dict[int, tuple[str, object]]] | None:
    """The counter values' history: None when the loop is not of the shape described above;
    else (number of passes as a one-element list, {body index: update})."""
    updates: dict[int, tuple[str, object]] = {}
    depth = 0
    for k, item in enumerate(loop.body):
        if isinstance(item, Loop):
            if any(touches(n, locals_) for n, _ in _flat(item)):
                return None
            continue
        node = item[0]
        kind = node.data if isinstance(node, Tree) else None
        if kind in _CLOSES:
            depth -= 1
        found = update_of(node, locals_) if depth == 0 and isinstance(node, Tree) else None
        if found is not None:
            updates[k] = found
        elif touches(node, locals_) or kind in ("label", "goto"):
            return None
        if kind in _OPENS:
            depth += 1
    values = dict(env)
    passes = 0
    while True:
        verdict = condition(loop.node.children[1] if len(loop.node.children) > 2 else loop.node.children[0], values)
        if verdict is None or passes > MAX_PASSES:
            return None
        if not verdict:
            return [passes], updates
        for name, how in updates.values():
            values[name] = apply(name, how, values)
        passes += 1


def apply(name: str, how, values: dict[str, float]) -> float:
    return values.get(name, float("nan")) + how if isinstance(how, float) else evaluate(how, values)


def _flat(loop: Loop):
    for item in loop.body:
        if isinstance(item, Loop):
            yield from _flat(item)
        else:
            yield item
