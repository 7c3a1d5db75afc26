"""KRL: $BASE and $TOOL followed through calls to the program's subprograms, in execution order.

KUKA System Software 8.x, Operating and Programming Instructions for System Integrators,
"Subprograms and functions": a local subprogram (``DEF NAME() ... END`` after the main DEF of
the same .src) runs when called; system variables such as ``$BASE`` / ``$TOOL`` are global, so
a subprogram runs with the frames in force at its call and the caller continues with the
frames the subprogram leaves. (BAS.SRC itself relies on this: ``BAS(#BASE, n)`` is a call
whose ``BASE(n)`` sets ``$BASE`` for the caller.)

So the state is found by walking the program from its first DEF, as the RAPID side follows
``ConfL`` (rapid/confswitch.py): a routine's statements in text order, a call walks the
callee with the state at the call and continues with the state it leaves. Every executed
copy of a routine gets its own positions ("virtual offsets") in one execution-ordered line,
so the frame replay (state.py) runs unchanged over them. A motion of a routine called from
places with different frames, before it sets its own, gets one frame per call: it cannot
have one frame, and is left unknown with a note. What is not provable from straight-line
execution stays unknown: a call inside a block makes the callee's frame changes unknown
from the block on; a routine reached by no call from the first DEF, one named as an
INTERRUPT or TRIGGER handler (``DO NAME(...)``: it runs at any time) or a recursive call
keeps the old rule (its frame changes make the frame unknown everywhere); a call to a
routine not in the file (another module, a system routine) may change the frames: they are
unknown after it.

Virtual offsets: ``real * SCALE`` for the first DEF; the code of a routine called at real
offset ``c`` of the first DEF lies in ``(c * SCALE, (c + 1) * SCALE)``, so every query of
the first DEF keeps its order against the called code.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace

SCALE = 1 << 24  # executed subprogram text per call of the first DEF (16 MiB) fits between two offsets
MAX_VISITS = 10_000  # executed routine copies followed; a call tree that runs more is not followed (OverflowError)


@dataclass
class Routine:
    name: str
    start: int  # offset of the DEF line
    end: int  # offset just after the END line
    jumps: bool = False  # a GOTO that may change what is in force (jumps.py): its changes are not straight-line


@dataclass
class Call:
    offset: int  # the call statement
    callee: str  # upper case
    where: tuple  # (offset from which a change may apply, straight-line?, in a subprogram?)
    line: int


@dataclass
class Visit:
    """One executed copy of a routine: real segments [start, end) placed at virtual offsets."""

    routine: int
    exact: bool  # every call on the way was straight-line code
    floor: int  # virtual offset from which its changes may apply when not exact
    scale: int = 1  # SCALE for the first DEF, 1 for called code
    segments: list = field(default_factory=list)  # (real start, real end, virtual start)

    def virtual(self, real: int) -> int | None:
        for start, end, base in self.segments:
            if start <= real < end:
                return base + (real - start) * self.scale
        return None


_HANDLER = re.compile(r"\bDO[ \t]+([A-Za-z_$][\w$]*)[ \t]*\(", re.IGNORECASE)


def handlers(text: str) -> set[str]:
    """Routines an INTERRUPT DECL or a TRIGGER names after DO: they run at any time."""
    return {m.group(1).upper() for m in _HANDLER.finditer(re.sub(r";[^\n]*", "", text))}


def walk(routines: list[Routine], calls: list[Call], handler_names: set[str]) -> tuple[list[Visit], set[int]]:
    """Every executed copy of the file's routines, from the first DEF (see the module's
    docstring), and the offsets of the recursive calls (not followed)."""
    recursive: set[int] = set()
    if not routines:
        return [], recursive
    index = {r.name.upper(): i for i, r in enumerate(routines)}
    visits: list[Visit] = []

    def run(i: int, exact: bool, floor: int, base: int, stack: tuple[int, ...]) -> int:
        """Walks routine i (called code: one virtual offset a character); returns where it ends."""
        r, top = routines[i], not stack
        if r.jumps and exact:  # its changes may apply from its start on, in any order
            exact, floor = False, base
        visit = Visit(i, exact, floor, SCALE if top else 1)
        visits.append(visit)
        if len(visits) > MAX_VISITS or len(stack) > 200:  # bounded work, and Python's call depth
            raise OverflowError(r.name)
        position, counter = r.start, base
        for call in sorted((c for c in calls if r.start <= c.offset < r.end), key=lambda c: c.offset):
            callee = index.get(call.callee)
            if callee is not None and (callee == i or callee in stack):
                recursive.add(call.offset)
            if callee is None or callee == i or callee in stack or call.callee in handler_names:
                continue
            visit.segments.append((position, call.offset + 1, counter))
            counter += (call.offset + 1 - position) * visit.scale
            position = call.offset + 1
            block, straight, _ = call.where
            inner_exact = exact and straight
            inner_floor = floor if not exact else (visit.virtual(block) if not straight else 0)
            end = run(callee, inner_exact, inner_floor, visit.virtual(call.offset) + 1, stack + (i,))
            if not top:
                counter = end
        visit.segments.append((position, r.end, counter))
        return counter + (r.end - position)

    run(0, True, 0, routines[0].start * SCALE, ())
    return visits, recursive


def unknown_calls(routines: list[Routine], calls: list[Call], recursive: set[int], handler_names: set[str]) -> list[Call]:
    """Calls whose callee's frame changes are not followed: a routine not in the file, a
    recursive call, a call to a handler routine."""
    names = {r.name.upper() for r in routines}
    return [c for c in calls if c.callee not in names or c.callee in handler_names or c.offset in recursive]


def remap(events, visits: list[Visit], routines: list[Routine], frame_keys, handler_names: set[str]) -> list:
    """The events at virtual offsets: the first DEF's once; a subprogram's frame changes once
    per executed copy (anytime where the routine is not reached); other subprogram events as they were."""
    if not visits:
        return events
    out = []
    by_routine: dict[int, list[Visit]] = {}
    for v in visits:
        by_routine.setdefault(v.routine, []).append(v)
    for ev in events:
        r = routine_of(routines, ev.line_offset)
        copies = by_routine.get(r, []) if r is not None else []
        if r == 0:  # line_offset stays the statement's real offset: its text is read there
            out.append(replace(ev, offset=copies[0].virtual(ev.offset)))
        elif ev.key in frame_keys and copies and routines[r].name.upper() not in handler_names:
            for v in copies:
                if v.exact:
                    out.append(replace(ev, offset=v.virtual(ev.offset), anytime=False))
                else:
                    out.append(replace(ev, offset=v.floor, exact=False, anytime=False))
        else:
            out.append(replace(ev, anytime=True))
    return out


def routine_of(routines: list[Routine], offset: int) -> int | None:
    for i, r in enumerate(routines):
        if r.start <= offset < r.end:
            return i
    return None


def virtual_offsets(visits: list[Visit], routines: list[Routine], offset: int) -> list[int]:
    """Where a statement of the program file runs, once per executed copy of its routine."""
    r = routine_of(routines, offset)
    return [v.virtual(offset) for v in visits if v.routine == r]
