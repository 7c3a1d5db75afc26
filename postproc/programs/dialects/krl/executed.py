"""KRL: one IR row per executed motion of a subprogram, once per call.

KUKA System Software 8.x, Operating and Programming Instructions for System Integrators,
"Subprograms and functions": a subprogram runs every time it is called, with the frames
in force at that call. So a motion of a subprogram the first DEF calls three times is
three executed motions: each gets its own IR row at the place of its call (calls.py gives
each executed copy of a routine its virtual offsets), with the frame and the points in
force there. They share their text spans: a number that would need two values is refused
on write-back (emit/splice.py, SharedNumberError).

A subprogram reached by no call from the first DEF (an INTERRUPT/TRIGGER handler, a
routine only another module calls) keeps its motions once, after the others, with an
unknown frame (virtual offset -1).
"""

from __future__ import annotations

import numpy as np

from . import calls as call_walk


def per_call(offsets: np.ndarray, visits: list, routines: list, loop_spans: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray]:
    """(rows, virtual offsets): every row of ``offsets`` (real offsets of the program file, in
    execution order within each routine) once per executed copy of its routine, ordered as
    the controller runs them. Rows inside ``loop_spans`` (real (start, end) of a subprogram's
    FOR already run pass by pass) keep their pass order: they sort by the loop's start."""
    main = routines[0]
    in_main = (offsets >= main.start) & (offsets < main.end)
    rows = [np.nonzero(in_main)[0]]
    virtual = [offsets[in_main] * call_walk.SCALE]
    group = [virtual[0]]
    by_routine: dict[int, list] = {}
    for v in visits:
        by_routine.setdefault(v.routine, []).append(v)
    unreached = []
    for i in np.nonzero(~in_main)[0].tolist():
        o = int(offsets[i])
        r = call_walk.routine_of(routines, o)
        copies = by_routine.get(r, []) if r not in (None, 0) else []
        if not copies:
            unreached.append(i)
            continue
        anchor = next((s for s, e in loop_spans if s <= o < e), o)
        rows.append(np.full(len(copies), i))
        virtual.append(np.array([c.virtual(o) for c in copies], dtype=np.int64))
        group.append(np.array([c.virtual(anchor) for c in copies], dtype=np.int64))
    rows_all, virtual_all, group_all = (np.concatenate(x) if x else np.zeros(0, np.int64) for x in (rows, virtual, group))
    order = np.lexsort((rows_all, group_all))  # within a loop's group, rows are already in pass order
    out_rows = np.concatenate([rows_all[order], np.array(unreached, dtype=np.int64)])
    out_virtual = np.concatenate([virtual_all[order], np.full(len(unreached), -1, np.int64)])
    return out_rows.astype(np.int64), out_virtual


def anchor_offsets(virtual: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """The first DEF's statement each executed row runs under (itself, or the call that
    started its copy): places the row against the first DEF's loops."""
    return np.where(virtual >= 0, virtual // call_walk.SCALE, offsets)
