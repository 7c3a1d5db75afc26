"""RAPID robtargets changed by constant assignments in straight-line code, followed as the
controller runs them.

``p1.trans.z := 305;`` or ``p1.trans := [100, 50, 0];`` between two ``MoveL p1`` of one
routine is deterministic: RAPID runs a routine's statements in order (RAPID kernel reference,
"Statements"), so the move before the assignment goes to the declared point and the one after
to the changed one. Followed when every assignment of the robtarget in the program is such a
literal update in straight-line code of one routine (no block open; or the body of FOR loops
whose passes are all known, compared in execution order, see ``Update.runs_at``), the routine
has no GOTO,
and every move that uses the robtarget is a plain ``Move... p1`` of that routine; the changed
numbers are the assignment's own (write-back splices them there). Literal updates: the whole
robtarget (``p1 := [[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[e1,...,e6]];``, its
configuration data too), ``trans`` / ``rot`` / ``extax`` or one of ``trans``'s x, y, z; a work
object's ``uframe`` / ``oframe`` ``trans`` / ``rot`` (the moves in it after the update use the
new frame); a tool's ``tframe`` ``trans`` / ``rot`` (likewise the moves with it). A changed
frame's numbers are not compensated (only targets are), so their place in the text does not
matter. Anything else keeps every target that uses the name unresolved, as before
(``parse._runtime_changes``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from postproc.robot.frames import make_transform, quat_wxyz_to_matrix

_COMPONENT = {"X": 0, "Y": 1, "Z": 2}
_OFRAME = 10  # update fields of a work object's oframe (its uframe's are 0-6, x y z q1..q4)
_NO_AXIS_ABOVE = 8.9e9  # an external axis written 9E9: none (parse.NO_AXIS_ABOVE)
# A whole robtarget's 17 numbers: IR fields x y z o1..o4, configuration data (negative: -1 ->
# cf1 ... -4 -> cfx, as parse._RT_FIELDS), external axes e1..e6.
_ROBTARGET = (0, 1, 2, 3, 4, 5, 6, -1, -2, -3, -4, 13, 14, 15, 16, 17, 18)


@dataclass
class Update:
    line: int
    file: int
    routine: tuple[int, int]  # (file, line of the PROC) it is in
    fields: dict[int, tuple[float, tuple[int, int, int]]]  # IR field (negative: configuration data) -> (value, span)
    runs_at: tuple[int, int] = (0, 0)  # (line, tick): when it runs (parse.RapidParser._run_at)


@dataclass
class Updates:
    """Constant updates of robtargets by name (upper case); ``spoiled``: names also changed otherwise."""

    by_name: dict[str, list[Update]] = field(default_factory=dict)
    spoiled: set[str] = field(default_factory=set)
    wobj_parts: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)  # NAME -> uframe, oframe (x y z q1..q4)
    tool_parts: dict[str, np.ndarray] = field(default_factory=dict)  # NAME -> tframe (x y z q1..q4) of a robot-held tool

    def add(self, name: str, update: Update) -> None:
        self.by_name.setdefault(name.upper(), []).append(update)


_FRAMES_OF = {"robtarget": (), "wobjdata": ("UFRAME", "OFRAME"), "tooldata": ("TFRAME",)}


def update_fields(path: list[str], numbers: list[tuple[float, tuple[int, int, int]]], kind: str = "robtarget") -> dict | None:
    """IR fields an lvalue path (after the name of a ``kind``: robtarget, wobjdata, tooldata)
    sets from literal numbers, or None where the assignment is not such an update (``trans`` :=
    [x, y, z]; ``trans.x`` := v; ``rot`` := [q1, q2, q3, q4]; ``extax`` := [e1, ..., e6]; the
    whole robtarget; a work object's or tool's frame's ``trans`` / ``rot``)."""
    path = [p.upper() for p in path]
    if kind != "robtarget" and path[:1] and path[0] not in _FRAMES_OF[kind]:
        return None  # another component of the work object / tool (or none it has): not followed
    if path[:1] in (["UFRAME"], ["OFRAME"], ["TFRAME"]) and path[0] in _FRAMES_OF[kind]:  # fields 0-6 of uframe / tframe, 10-16 of oframe
        shift = _OFRAME if path[0] == "OFRAME" else 0
        inner = update_fields(path[1:], numbers) if path[1:2] in (["TRANS"], ["ROT"]) else None
        return None if inner is None else {f + shift: v for f, v in inner.items()}
    if kind != "robtarget":
        return None
    if not path and len(numbers) == len(_ROBTARGET):
        return {f: numbers[k] for k, f in enumerate(_ROBTARGET)}
    if path == ["TRANS"] and len(numbers) == 3:
        return {k: numbers[k] for k in range(3)}
    if path == ["ROT"] and len(numbers) == 4:
        return {3 + k: numbers[k] for k in range(4)}
    if path == ["EXTAX"] and len(numbers) == 6:
        return {13 + k: numbers[k] for k in range(6)}
    if len(path) == 2 and path[0] == "TRANS" and path[1] in _COMPONENT and len(numbers) == 1:
        return {_COMPONENT[path[1]]: numbers[0]}
    return None


def apply(blocks: list[dict], updates: Updates, routine_of, goto_routines: set[tuple[int, int]], frame_index, tool_index) -> set[str]:
    """Rows of the builder's blocks that move to an updated robtarget (or in an updated work
    object, or with an updated tool) take its value where they run; returns the names followed
    (the others stay for ``_runtime_changes`` to flag). ``routine_of(file, line)``: the (file,
    PROC line) a row is in; ``frame_index(name, transform)`` / ``tool_index``: the builder's
    index of a (new) frame / tool."""
    followed = set()
    for name, ups in updates.by_name.items():
        if name in updates.spoiled or len({u.routine for u in ups}) != 1 or ups[0].routine in goto_routines:
            continue
        if name in updates.wobj_parts:
            if _apply_wobj(blocks, name, sorted(ups, key=lambda u: u.line), updates.wobj_parts[name], routine_of, frame_index):
                followed.add(name)
            continue
        if name in updates.tool_parts:
            if _apply_frames(blocks, "tool", name, sorted(ups, key=lambda u: u.line), [updates.tool_parts[name]], routine_of, tool_index):
                followed.add(name)
            continue
        rows = [(b, i) for b in blocks for i in _uses(b, name)]
        if any(str(b["name"][i]).upper().replace(" ", "") != name for b, i in rows):
            continue  # used inside an expression (Offs(p1, ...)): not followed
        if any(routine_of(int(_at(b, "file", i)), int(_at(b, "line", i))) != ups[0].routine for b, i in rows):
            continue  # used in another routine: its order against the updates is not read here
        ups = sorted(ups, key=lambda u: u.runs_at)
        for b, i in rows:
            runs_at = _runs_at(b, i)
            for u in ups:
                if u.runs_at < runs_at:
                    _set(b, i, u.fields)
        followed.add(name)
    return followed


def _set(block: dict, i: int, fields: dict) -> None:
    """Row ``i`` of ``block`` takes an update's numbers (and their places in the text)."""
    for f, (value, span) in fields.items():
        if f < 0:  # configuration data: no IR field, no span (conf is never compensated)
            block["conf"][i, -f - 1] = value
        elif f >= 13 and abs(value) >= _NO_AXIS_ABOVE:  # 9E9: no such external axis
            block["values"][i, f], block["spans"][i, f] = np.nan, -1
        else:
            block["values"][i, f], block["spans"][i, f] = value, span


def _apply_wobj(blocks, name: str, ups: list[Update], parts, routine_of, frame_index) -> bool:
    """Moves in work object ``name`` after its frame's updates take the updated frame (a new
    frame of the builder, 'NAME@line'); False where a move in it is in another routine."""
    return _apply_frames(blocks, "frame", name, ups, list(parts), routine_of, frame_index)


def _apply_frames(blocks, key: str, name: str, ups: list[Update], parts: list[np.ndarray], routine_of, register) -> bool:
    """Rows whose ``key`` ("frame": work object, "tool") is ``name`` take, after each update,
    the product of its updated ``parts`` (uframe @ oframe, or tframe) as a new entry of the
    builder, 'NAME@line'; False where such a row is in another routine than the updates."""
    index = register(name, None)
    rows = [(b, i) for b in blocks if key in b for i in np.nonzero(np.atleast_1d(np.asarray(b[key])) == index)[0].tolist()]
    if index < 0 or any(routine_of(int(_at(b, "file", i)), int(_at(b, "line", i))) != ups[0].routine for b, i in rows):
        return False
    parts = [p.copy() for p in parts]
    entries = []  # (when it runs, builder index) after each update
    seen: dict[int, list[np.ndarray]] = {}  # line -> the distinct frames its update gave
    for u in sorted(ups, key=lambda u: u.runs_at):
        for f, (value, _) in u.fields.items():
            parts[f // _OFRAME][f % _OFRAME] = value
        transform = np.eye(4)
        for p in parts:
            transform = transform @ make_transform(quat_wxyz_to_matrix(p[3:7][None])[0], p[:3])
        # one name per value: an update in a loop may give another frame on a later pass
        made = seen.setdefault(u.line, [])
        k = next((k for k, t in enumerate(made) if np.allclose(t, transform, rtol=0, atol=0)), len(made))
        if k == len(made):
            made.append(transform)
        entries.append((u.runs_at, register(f"{name}@{u.line}" + (f" ({k + 1})" if k else ""), transform)))
    for b, i in rows:
        runs_at = _runs_at(b, i)
        later = [k for at, k in entries if at < runs_at]
        if later:
            b[key] = np.array(np.atleast_1d(b[key]), copy=True)
            b[key][i] = later[-1]
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


def _runs_at(block: dict, i: int) -> tuple[int, int]:
    """When row ``i`` runs: (line, tick) where the parser recorded it (moves of the grammar),
    else (line, 0) (bulk moves: straight-line code)."""
    if "run_line" in block:
        return int(_at(block, "run_line", i)), int(_at(block, "run_tick", i))
    return int(_at(block, "line", i)), 0


def _at(block: dict, key: str, i: int):
    value = block[key]
    return value[i] if np.ndim(value) else value
