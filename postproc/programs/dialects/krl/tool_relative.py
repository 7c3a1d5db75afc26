"""LIN_REL / PTP_REL ... #TOOL targets on write-back.

Their increments are in the tool frame at the previous target (KSS 8.3 'LIN_REL'), while
the splice emitter writes increments per base axis. So the splice runs with those targets
held where they were, and their X Y Z are written here afterwards: the new increment is the
step from where the previous target is written to the compensated target, seen in the
previous target's tool frame, ``R_prev^T (p - p_prev)`` (compensation moves positions only,
so the orientations and the A B C increments stay as written). A component the text leaves
out is added to the aggregate where it is needed. A base-frame relative target right after a
step is written again from the step's new place. The written program is read back and
checked against the compensated targets by the caller (``programs.check_texts``).
"""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import EmitError
from postproc.robot.frames import quat_wxyz_to_matrix

from ...emit.splice import TOLERANCE, format_like
from ...ir import SourceDoc, Toolpath

_TOOL_WORD = re.compile(r"#TOOL\b", re.IGNORECASE)


def tool_steps(tp: Toolpath) -> np.ndarray:
    """(N,) True at LIN_REL / PTP_REL ... #TOOL targets."""
    out = np.zeros(len(tp), bool)
    lines = {}
    for r in np.nonzero(tp.relative)[0].tolist():
        doc = tp.sources[int(tp.file[r])]
        text = lines.setdefault(doc.path, doc.text.split("\n"))[int(tp.line[r]) - 1]
        out[r] = _TOOL_WORD.search(text.split(";")[0]) is not None
    return out


def held_and_moved(original: Toolpath, modified: Toolpath) -> tuple[Toolpath, np.ndarray]:
    """``modified`` with the moved #TOOL steps held where they were, and those steps' rows
    (True: a #TOOL step to write in the tool frame)."""
    steps = tool_steps(original)
    moved = ~np.isclose(modified.position, original.position, rtol=0, atol=1e-9, equal_nan=True).all(axis=1)
    todo = steps & (moved | np.concatenate([[False], moved[:-1]]))
    if not todo.any():
        return modified, todo
    if todo[0]:  # a step from where the robot happens to be (or a streamed chunk's first target)
        raise EmitError(f"{original.sources[int(original.file[0])].path}:{int(original.line[0])}:1: a #TOOL step before any target of the "
                        "program starts from a place the text does not give; it cannot be written back compensated")
    position = modified.position.copy()
    position[todo] = original.position[todo]
    return modified.with_positions(position), todo


def write_steps(texts: list[str], original: Toolpath, modified: Toolpath, todo: np.ndarray, reread, insert_field) -> list[str]:
    """``texts`` (spliced with the steps held) with the steps' X Y Z increments written.
    ``reread(sources)``: the program's IR from texts (to find the numbers where they are now)."""
    now = reread([SourceDoc(doc.path, text, doc.role) for doc, text in zip(original.sources, texts)])
    edits: dict[int, list[tuple[int, int, str]]] = {}
    # a base-frame relative target right after a step was spliced from the held place: its
    # increments are written again from the step's new place (the ones after it are right)
    after = np.concatenate([[False], todo[:-1] & original.relative[1:] & ~todo[1:]])
    # Where each target is once the steps are rewritten: a relative target the splice wrote
    # keeps its step as read back, from where the one before it really is (the held steps'
    # splice-written numbers put the read-back chain elsewhere until they are rewritten).
    rewrite = todo | after
    true = now.position.copy()
    first = int(np.argmax(rewrite))
    for r in range(first, len(true)):
        if not rewrite[r]:
            if original.relative[r]:
                true[r] = true[r - 1] + (now.position[r] - now.position[r - 1])
            continue
        prev = true[r - 1]  # from where the previous target is written: no rounding adds up
        turn = quat_wxyz_to_matrix(modified.orientation[r - 1][None])[0] if todo[r] else np.eye(3)
        step = turn.T @ (modified.position[r] - prev)
        put = np.zeros(3)
        for f in range(3):
            file, start, end = (int(v) for v in now.spans[r, f])
            if end >= 0:
                text = format_like(texts[file][start:end], float(step[f]), float(TOLERANCE[f]))
                edits.setdefault(file, []).append((start, end, text))
            elif abs(step[f]) > TOLERANCE[f]:
                file, offset = (int(v) for v in now.insert_at[r])
                if offset < 0:
                    raise EmitError(f"{original.sources[file].path}:{int(original.line[r])}:1: the #TOOL step has no {'XYZ'[f]} and none can be added")
                text = format_like("0.000", float(step[f]), float(TOLERANCE[f]))
                edits.setdefault(file, []).append((offset, offset, insert_field(file, "XYZ"[f], text)))
            else:
                continue
            put[f] = float(text)
        true[r] = prev + turn @ put
    out = list(texts)
    for file, pieces in edits.items():
        text = out[file]
        for start, end, piece in sorted(pieces, reverse=True):
            text = text[:start] + piece + text[end:]
        out[file] = text
    return out

