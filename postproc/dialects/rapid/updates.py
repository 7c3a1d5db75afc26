"""RAPID robtargets changed by constant assignments in straight-line code, followed as the
controller runs them.

``p1.trans.z := 305;`` or ``p1.trans := [100, 50, 0];`` between two ``MoveL p1`` of one
routine is deterministic: RAPID runs a routine's statements in order (RAPID kernel reference,
"Statements"), so the move before the assignment goes to the declared point and the one after
to the changed one. Followed when every assignment of the robtarget in the program is such a
literal update of ``trans`` (or one of its x, y, z) in straight-line code of one routine
(no block open), the routine has no GOTO, and every move that uses the robtarget is a plain
``Move... p1`` of that routine; the changed numbers are the assignment's own (write-back
splices them there). Anything else keeps every target that uses the name unresolved, as
before (``parse._runtime_changes``), and so do work objects and tools changed at run time.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ...frames import make_transform, quat_wxyz_to_matrix

_COMPONENT = {"X": 0, "Y": 1, "Z": 2}
_OFRAME = 10  # update fields of a work object's oframe (its uframe's are 0-2)


@dataclass
class Update:
    line: int
    file: int
    routine: tuple[int, int]  # (file, line of the PROC) it is in
    fields: dict[int, tuple[float, tuple[int, int, int]]]  # IR field -> (value, span)


@dataclass
class Updates:
    """Constant updates of robtargets by name (upper case); ``spoiled``: names also changed otherwise."""

    by_name: dict[str, list[Update]] = field(default_factory=dict)
    spoiled: set[str] = field(default_factory=set)
    wobj_parts: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)  # NAME -> uframe, oframe (x y z q1..q4)

    def add(self, name: str, update: Update) -> None:
        self.by_name.setdefault(name.upper(), []).append(update)


def update_fields(path: list[str], numbers: list[tuple[float, tuple[int, int, int]]]) -> dict | None:
    """IR fields an lvalue path (after the robtarget's name) sets from literal numbers, or None
    where the assignment is not such an update (``trans`` := [x, y, z]; ``trans.x`` := v)."""
    path = [p.upper() for p in path]
    if path[:1] in (["UFRAME"], ["OFRAME"]):  # a work object's frame: fields 0-2 of uframe, 10-12 of oframe
        shift = 0 if path[0] == "UFRAME" else _OFRAME
        inner = update_fields(path[1:], numbers)
        return None if inner is None else {f + shift: v for f, v in inner.items()}
    if path == ["TRANS"] and len(numbers) == 3:
        return {k: numbers[k] for k in range(3)}
    if len(path) == 2 and path[0] == "TRANS" and path[1] in _COMPONENT and len(numbers) == 1:
        return {_COMPONENT[path[1]]: numbers[0]}
    return None


def apply(blocks: list[dict], updates: Updates, routine_of, goto_routines: set[tuple[int, int]], frame_index) -> set[str]:
    """Rows of the builder's blocks that move to an updated robtarget (or in an updated work
    object) take its value where they run; returns the names followed (the others stay for
    ``_runtime_changes`` to flag). ``routine_of(file, line)``: the (file, PROC line) a row is
    in; ``frame_index(name, transform)``: the builder's index of a (new) frame."""
    followed = set()
    for name, ups in updates.by_name.items():
        if name in updates.spoiled or len({u.routine for u in ups}) != 1 or ups[0].routine in goto_routines:
            continue
        if name in updates.wobj_parts:
            if _apply_wobj(blocks, name, sorted(ups, key=lambda u: u.line), updates.wobj_parts[name], routine_of, frame_index):
                followed.add(name)
            continue
        rows = [(b, i) for b in blocks for i in _uses(b, name)]
        if any(str(b["name"][i]).upper().replace(" ", "") != name for b, i in rows):
            continue  # used inside an expression (Offs(p1, ...)): not followed
        if any(routine_of(int(_at(b, "file", i)), int(_at(b, "line", i))) != ups[0].routine for b, i in rows):
            continue  # used in another routine: its order against the updates is not read here
        ups = sorted(ups, key=lambda u: u.line)
        for b, i in rows:
            line = int(_at(b, "line", i))
            for u in ups:
                if u.line < line:
                    for f, (value, span) in u.fields.items():
                        b["values"][i, f] = value
                        b["spans"][i, f] = span
        followed.add(name)
    return followed


def _apply_wobj(blocks, name: str, ups: list[Update], parts, routine_of, frame_index) -> bool:
    """Moves in work object ``name`` after its frame's updates take the updated frame (a new
    frame of the builder, 'NAME@line'); False where a move in it is in another routine."""
    index = frame_index(name, None)
    rows = [(b, i) for b in blocks if "frame" in b for i in np.nonzero(np.atleast_1d(np.asarray(b["frame"])) == index)[0].tolist()]
    if any(routine_of(int(_at(b, "file", i)), int(_at(b, "line", i))) != ups[0].routine for b, i in rows):
        return False
    uframe, oframe = parts[0].copy(), parts[1].copy()
    frames = []  # (line, builder index) after each update
    for u in ups:
        for f, (value, _) in u.fields.items():
            (uframe if f < _OFRAME else oframe)[f % _OFRAME] = value
        transform = make_transform(quat_wxyz_to_matrix(uframe[3:7][None])[0], uframe[:3]) @ make_transform(quat_wxyz_to_matrix(oframe[3:7][None])[0], oframe[:3])
        frames.append((u.line, frame_index(f"{name}@{u.line}", transform)))
    for b, i in rows:
        line = int(_at(b, "line", i))
        later = [k for at, k in frames if at < line]
        if later:
            b["frame"] = np.array(np.atleast_1d(b["frame"]), copy=True)
            b["frame"][i] = later[-1]
    return True


def _uses(block: dict, name: str) -> list[int]:
    """Rows of ``block`` whose target text names ``name`` (as a whole word)."""
    names = block.get("name")
    if names is None or not len(names):
        return []
    texts, codes = np.unique(np.asarray(names, dtype=object).astype(str), return_inverse=True)
    pattern = re.compile(rf"(?<![A-Za-z0-9_]){re.escape(name)}(?![A-Za-z0-9_])", re.IGNORECASE)
    hit = np.array([bool(pattern.search(t)) for t in texts])
    return np.nonzero(hit[codes])[0].tolist()


def _at(block: dict, key: str, i: int):
    value = block[key]
    return value[i] if np.ndim(value) else value
