"""The tool load a converted program states where the input stated it (``convert``).

A program that states its load (RAPID tooldata's tload and ``GripLoad``, KRL ``$LOAD`` /
``LOAD_DATA[n]`` / ``BAS(#TOOL, n)``) gets the same load in the new program, at the same
targets: each language's parser writes its statements into the IR (``Toolpath.facts``, and the
one in force at each target as an ``extras`` column, found with ``in_force``), and its
controller turns them into a ``LoadPlan`` (``Controller.stated_loads``), one ``LoadState``
per target. ``--tool-load`` may be given as well only where it is the load the program
states (otherwise one of the two is wrong, and which is not ours to guess).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from postproc.errors import InputError

from .tool_load import ToolLoad, combined
from .writer import where


@dataclass(frozen=True)
class LoadState:
    """The load on the flange at a target: ``tool`` (RAPID: the tooldata's tload, KUKA: the
    whole $LOAD) and ``grip`` (RAPID GripLoad's payload on top of it), each with the
    ``file:line:column`` of the statement that set it (None: nothing in the program set it,
    e.g. tool0's empty load). A load with a NaN component (KRL ``$LOAD.M = 5``: the rest is the
    controller's) is ``partial``."""

    tool: ToolLoad | None
    grip: ToolLoad | None = None
    tool_at: str | None = None
    grip_at: str | None = None

    @property
    def total(self) -> ToolLoad | None:
        return None if self.tool is None else combined(self.tool, self.grip)

    @property
    def stated_at(self) -> str | None:
        return self.grip_at or self.tool_at

    @property
    def partial(self) -> bool:
        return any(part is not None and not np.isfinite([part.mass_kg, *part.cog_mm, *part.inertia_kgm2, *part.aom_wxyz]).all()
                   for part in (self.tool, self.grip))


@dataclass(frozen=True)
class LoadPlan:
    states: list[LoadState]
    index: np.ndarray  # (N,) int: the state of each target, -1 where no load is known


@dataclass(frozen=True)
class Statement:
    """A statement that changes the load from where it stands on (KRL $LOAD =, RAPID GripLoad)."""

    file: int
    line: int
    at: str  # file:line:column
    load: ToolLoad | None  # None: back to none (GripLoad load0)
    offset: int = -1  # where it starts in its file's text (-1: not given; its lines are then read from the file's start)


def in_force(tp, statements: list[Statement]) -> np.ndarray:
    """(N,) the index in ``statements`` of the one in force at each target (-1: none): the last
    one above it in its file. Only sound
    where the targets run in the order they are written: a program whose targets go back up
    (a loop, a called routine) while statements change the load is refused, and so is a
    statement in a file without targets (a routine elsewhere whose calls cannot be placed)."""
    out = np.full(len(tp), -1, dtype=int)
    if not statements:
        return out
    with_rows = set(np.unique(tp.file).tolist())
    for s in statements:
        if s.file not in with_rows:
            raise InputError(f"{s.at}: the load is set in a file without motions (a routine called from elsewhere): where it applies is not "
                             "carried into the new program; give the load with --tool-load and move the statement next to the motions")
    rows_of = {f: np.sort(tp.line[tp.file == f]) for f in {s.file for s in statements}}
    for s in statements:
        near = _Lines(tp.sources[s.file].text, s.line, s.offset) if s.offset >= 0 else _Lines(tp.sources[s.file].text, 1, 0)
        if not _motions_in_routine(near, s.line, rows_of[s.file]):
            raise InputError(f"{s.at}: the load is set in a routine without motions (called from elsewhere): where it applies is not "
                             "carried into the new program; give the load with --tool-load and move the statement next to the motions")
    order = np.lexsort((tp.line, tp.file))
    if len(tp) and not (np.diff(order) > 0).all():
        row = int(np.nonzero(np.diff(order) <= 0)[0][0])
        raise InputError(f"{where(tp, int(order[row + 1]))}: the targets do not run in the order they are written (a loop or a routine "
                         f"called twice) and the program changes its load ({statements[0].at}): which load each target carries is not carried")
    for f in with_rows:
        mine = np.array(sorted((k for k, s in enumerate(statements) if s.file == f), key=lambda k: statements[k].line) + [-1], dtype=int)
        rows = np.nonzero(tp.file == f)[0]
        at = np.searchsorted([statements[k].line for k in mine[:-1]], tp.line[rows], side="left") - 1
        out[rows] = mine[at]  # (at = -1 picks the trailing -1: none)
    return out


_START = re.compile(r"^[ \t]*(?:(?:LOCAL|GLOBAL)[ \t]+)?(?:PROC|TRAP|FUNC|DEF|DEFFCT)\b", re.IGNORECASE)
_END = re.compile(r"^[ \t]*(?:ENDPROC|ENDTRAP|ENDFUNC|END|ENDFCT)\b", re.IGNORECASE)


class _Lines:
    """The lines of one text by number (1-based, counted by newline as ``Toolpath.line`` is),
    read outward from one known line: a parser asks this of every program, and a long one's
    text is not split for the few lines around a statement."""

    def __init__(self, text: str, line: int, offset: int):
        self.text = text
        self.starts = {line: text.rfind("\n", 0, offset) + 1}  # line -> offset of its first character
        self.low = self.high = line

    def __call__(self, line: int) -> str | None:
        """The text of ``line`` (without its newline), None where the text has no such line."""
        text = self.text
        while line < self.low and self.starts[self.low] > 0:
            self.low -= 1
            self.starts[self.low] = text.rfind("\n", 0, self.starts[self.low + 1] - 1) + 1
        while line > self.high and (end := text.find("\n", self.starts[self.high])) >= 0:
            self.high += 1
            self.starts[self.high] = end + 1
        if line not in self.starts or line < 1:
            return None
        end = text.find("\n", self.starts[line])
        return text[self.starts[line] : end if end >= 0 else len(text)]


def _motions_in_routine(line_of, line: int, rows: np.ndarray) -> bool:
    """True where a target's line (``rows``: sorted) lies inside the routine (RAPID PROC/TRAP/FUNC,
    KRL DEF/DEFFCT) around ``line``: after its first line and before its last. Its bounds are
    looked for only between the statement and its nearest targets (``line_of``: a line's text
    by number, None past the text), not over the whole file."""
    above = int(np.searchsorted(rows, line, side="left"))  # rows[:above] are the targets above the statement
    if above and not any(_is(_START, line_of, i) for i in range(line, int(rows[above - 1]) - 1, -1)):
        return True  # the nearest target above, with no routine start between it and the statement
    first_below = int(np.searchsorted(rows, line, side="right" if _is(_START, line_of, line) else "left"))  # a target on the routine's first line is outside it
    return first_below < len(rows) and not any(_is(_END, line_of, i) for i in range(line, int(rows[first_below]) + 1))


def _is(pattern: re.Pattern, line_of, line: int) -> bool:
    text = line_of(line)
    return text is not None and pattern.match(text) is not None


def plan_from_index(candidates: list[LoadState | None], index: np.ndarray) -> LoadPlan | None:
    """A LoadPlan from each target's index in ``candidates`` (-1 or a None candidate: no load
    known); None where no target's load is stated in the program."""
    states = list(dict.fromkeys(s for s in candidates if s is not None))
    lookup = {s: k for k, s in enumerate(states)}
    remap = np.array([-1 if s is None else lookup[s] for s in candidates] + [-1], dtype=int)
    plan = LoadPlan(states, remap[index])
    used = np.unique(plan.index[plan.index >= 0])
    return plan if any(states[k].stated_at for k in used) else None


def _agrees(given: ToolLoad, stated: ToolLoad) -> bool:
    """``stated`` is ``given`` in every component the program states (a partial one: its mass)."""
    if not np.isfinite([*stated.cog_mm, *stated.inertia_kgm2, *stated.aom_wxyz]).all():
        return abs(given.mass_kg - stated.mass_kg) <= 1e-6 if np.isfinite(stated.mass_kg) else True
    return given.same_as(stated)


def carried_loads(tp, given: ToolLoad | None, plan: LoadPlan | None) -> LoadPlan | None:
    """The load of each target of the new program: the program's own (``plan``, what its
    language reads from it: ``Controller.stated_loads``, given by the caller so that emit
    imports no language) or ``given`` (``--tool-load``) on every tool; both: they must be
    the same load (else an InputError naming both); a partial load the program states needs
    ``given``."""
    if plan is not None:
        for state in plan.states:
            if not state.stated_at:
                continue
            if state.partial and given is None:
                raise InputError(f"{state.stated_at}: the program sets only part of the load ({_text(state)}; the rest is the controller's): "
                                 "give the whole load with --tool-load MASS,CX,CY,CZ[,IX,IY,IZ]")
            if given is not None and not (_agrees(given, _partial_part(state)) if state.partial else given.same_as(state.total)):
                raise InputError(f"{state.stated_at}: the program states the tool load {_text(state)}; --tool-load gives {given.text()}: "
                                 "they differ; drop --tool-load to carry the program's load, or correct the program")
        if given is None:
            return plan
    if given is None:
        return None
    return LoadPlan([LoadState(given, None, "--tool-load")], np.zeros(len(tp), dtype=int))


def _partial_part(state: LoadState) -> ToolLoad:
    return next(p for p in (state.tool, state.grip) if p is not None and not np.isfinite([p.mass_kg, *p.cog_mm, *p.inertia_kgm2]).all())


def _text(state: LoadState) -> str:
    if state.partial:
        part = _partial_part(state)
        return f"{part.mass_kg:g} kg" if np.isfinite(part.mass_kg) else "of unknown mass"
    total = state.total
    if state.tool is not None and state.grip is not None and state.tool.mass_kg and state.grip.mass_kg:
        return f"{total.text()} (tool {state.tool.mass_kg:g} kg + gripped {state.grip.mass_kg:g} kg)"
    return total.text()


def with_grip(state: LoadState, grip: Statement | None) -> LoadState:
    return state if grip is None or grip.load is None else replace(state, grip=grip.load, grip_at=grip.at)
