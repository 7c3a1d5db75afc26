"""KRL FOR loops as the controller runs them: one IR row per executed motion.

KUKA System Software 8.x, Operating and Programming Instructions for System Integrators,
"FOR ... TO ... ENDFOR": ``FOR Counter = Start TO End [STEP Increment]``; the counter (INT)
starts at Start, the body runs while it has not passed End, then the counter changes by
Increment (an integer constant, +1 when STEP is left out; a loop whose Start is already past
End runs no pass).

The parser reads each motion once, in text order (state.py gives each its point and frames
at its line). A FOR in the program file whose Start, End and Increment are literal
(expressions of literals) is unrolled here: the rows of its body are repeated once per
pass, in execution order, and share their text spans (a number that would need two values
is refused on write-back: emit/splice.py). A target ``NAME[I]`` indexed by the counter takes
the element of the pass when the program never changes that array. A loop whose count is
not known at post time (LOOP, WHILE, REPEAT, a FOR over variables) keeps its body once; a
note names it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from ...ir import Toolpath

MAX_ROWS = 1_000_000  # executed motions after unrolling; more is refused (memory is bounded)


@dataclass
class ForLoop:
    first_line: int  # the FOR line
    last_line: int  # its ENDFOR
    counter: str
    values: list[int] | None  # None: count not known at post time
    update: tuple[int, int] | None = None  # WHILE/REPEAT (counters.py): (line of I = I + k, k); later rows see the new value


def for_values(start: float, end: float, step: float) -> list[int] | None:
    if np.isnan([start, end, step]).any() or step == 0 or any(v != int(v) for v in (start, end, step)):
        return None
    count = int((end - start) // step) + 1
    if count > MAX_ROWS:
        return None
    return [int(start + k * step) for k in range(max(count, 0))]


def _sequence(rows: np.ndarray, lines: np.ndarray, loops: list[ForLoop], env: dict, out: list, envs: list) -> None:
    """Append, in execution order, the rows of ``rows`` (indices into lines) with the loops among them run."""
    outer = [lp for lp in loops if not any(o is not lp and o.first_line < lp.first_line and lp.last_line < o.last_line for o in loops)]
    position = 0
    for lp in sorted(outer, key=lambda lp: lp.first_line):
        before = rows[position:][lines[rows[position:]] < lp.first_line]
        out.extend(before.tolist())
        envs.extend([env] * len(before))
        position += len(before)
        body = rows[position:][lines[rows[position:]] < lp.last_line]
        position += len(body)
        inner = [o for o in loops if lp.first_line < o.first_line and o.last_line < lp.last_line]
        if not inner and lp.update is None and lp.values is not None:  # a plain body: its rows once per pass
            if len(out) + len(body) * len(lp.values) > MAX_ROWS:
                raise OverflowError(lp.first_line)
            body_rows = body.tolist()
            for value in lp.values:
                out.extend(body_rows)
                envs.extend([{**env, lp.counter: value}] * len(body_rows))
            continue
        for value in lp.values if lp.values is not None else [None]:
            first = len(out)
            _sequence(body, lines, inner, {**env, lp.counter: value}, out, envs)
            if lp.update is not None:  # rows after the counter's update see its new value
                for k in range(first, len(out)):
                    if lines[out[k]] > lp.update[0]:
                        envs[k] = {**envs[k], lp.counter: value + lp.update[1]}
            if len(out) > MAX_ROWS:
                raise OverflowError(lp.first_line)
    rest = rows[position:]
    out.extend(rest.tolist())
    envs.extend([env] * len(rest))


def executed_rows(tp: Toolpath, loops: list[ForLoop], lines: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """Rows of ``tp`` in execution order with every known-count FOR run, and the counters'
    values of each; ``lines``: the line that places each row against the loops (default
    its own: a subprogram's copy is placed by the line of its call, calls.py)."""
    known = [lp for lp in loops if lp.values is not None]
    if not known:
        return np.arange(len(tp)), [{}] * len(tp)
    program = np.nonzero(tp.file == 0)[0]
    others = np.nonzero(tp.file != 0)[0]
    out: list[int] = []
    envs: list[dict] = []
    _sequence(program, tp.line if lines is None else lines, known, {}, out, envs)
    return np.array(out + others.tolist(), dtype=np.int64), envs + [{}] * len(others)


def unroll(tp: Toolpath, loops: list[ForLoop], symbols, changed_arrays: set[str]) -> Toolpath:
    """``tp`` with every known-count FOR of the program file run (see the module's docstring).
    ``symbols``: the declared points (``rows(names)`` and ``table()``)."""
    rows, envs = executed_rows(tp, loops)
    return indexed_by_counter(tp.take(rows), envs, symbols, changed_arrays)


def indexed_by_counter(tp: Toolpath, envs: list[dict], symbols, changed_arrays: set[str]) -> Toolpath:
    """Targets ``NAME[I]`` with I a counter of the pass: the element of that pass (``symbols``:
    the parser's point table, looked up once for every pass together)."""
    index = re.compile(r"^([A-Za-z_$][\w$]*)\[\s*([A-Za-z_]\w*)\s*\]$")
    shapes = {name: index.match(name or "") for name in set(tp.target_name)}  # a few names, many passes
    hits = [(r, m) for r, name in enumerate(tp.target_name) if envs[r] and (m := shapes[name])]
    wanted = [(r, f"{m.group(1).upper()}[{envs[r].get(m.group(2).upper())}]") for r, m in hits
              if envs[r].get(m.group(2).upper()) is not None and m.group(1).upper() + "[" not in changed_arrays]
    if not wanted:
        return tp
    rows = np.array([r for r, _ in wanted], np.int64)
    found = symbols.rows([name for _, name in wanted])
    table_values, table_spans, table_conf, table_insert = symbols.table()  # its last row: not declared (NaN)
    # an element not declared, or partial: stays unresolved (no values)
    ok = ~np.isnan(table_values[found][:, :6]).any(axis=1)
    rows, found = rows[ok], found[ok]
    values, spans, conf = tp.values.copy(), tp.spans.copy(), tp.conf.copy()
    values[rows], spans[rows], conf[rows] = table_values[found], table_spans[found], table_conf[found]
    insert = tp.insert_at.copy() if tp.insert_at is not None else None
    if insert is not None:
        insert[rows] = table_insert[found]
    return replace(tp, values=values, spans=spans, conf=conf, insert_at=insert)  # poses and 'resolved' follow from the values
