"""New motion targets written into a program's text, the language's way.

A new point subdivides the segment into an existing target (row ``r``): it is written as a
copy of that target's own motion statement (same instruction, speed, zone, tool, frame),
inserted just before it, with new numbers. Where the target is a named point, the copy of
its declaration (KRL ``DECL E6POS`` in the .dat or $config.dat, RAPID ``CONST robtarget``)
gets a new legal, unused name and is declared right after the original; the copied motion
statement names it. Inline targets (``LIN {X ...}``, ``MoveL [[...]]``, a G1 block) are
copied with their numbers replaced. What differs between languages is asked of the dialect
(``Dialect.point_name_limit``, ``statement_end``, ``clone_motion``, ``set_conf_text``).

Every number of the copy is written where the original has its number (``Toolpath.spans``),
in the original's style; the caller re-parses the new text and checks each new point.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import EmitError
from ..ir import F_EXT, F_ORI, F_POS, SourceDoc, Toolpath
from .splice import TOLERANCE, format_like

_WRITTEN = np.r_[np.arange(F_POS.start, F_POS.stop), np.arange(F_ORI.start, F_ORI.stop), np.arange(F_EXT.start, F_EXT.stop)]


@dataclass(frozen=True)
class NewPoint:
    """A target to insert before the motion of ``row``: its numbers as the IR reads them
    (``values`` (FIELDS,), NaN where the row's target has none) and configuration data."""

    row: int
    values: np.ndarray
    conf: np.ndarray


def insert_points(dialect, tp: Toolpath, points: list[NewPoint]) -> tuple[list[SourceDoc], list[str]]:
    """New sources of ``tp`` with ``points`` written in (in list order before each row's
    motion), and the name each new point got ('' for an inline one)."""
    edits: list[tuple[int, int, str]] = []  # (source, offset, text) insertions
    taken = _words(tp)
    names = []
    for p in points:
        motion, decl, name = _clone(dialect, tp, p, taken)
        edits.append((int(tp.file[p.row]), _line_start(tp, p.row), motion))
        if decl is not None:
            edits.append(decl)
        names.append(name)
    texts = [doc.text for doc in tp.sources]
    # Later offsets first so earlier ones stay valid; at one offset keep the list order.
    order = sorted(range(len(edits)), key=lambda k: (edits[k][0], -edits[k][1], -k))
    for k in order:
        source, offset, text = edits[k]
        texts[source] = texts[source][:offset] + text + texts[source][offset:]
    return [SourceDoc(doc.path, text, doc.role) for doc, text in zip(tp.sources, texts)], names


def _clone(dialect, tp: Toolpath, p: NewPoint, taken: set[str]):
    """(motion text, declaration insertion or None, new name) of one new point."""
    r = p.row
    where = f"{tp.sources[int(tp.file[r])].path}, line {tp.line[r]}"
    spans = tp.spans[r]
    fields = [f for f in _WRITTEN if spans[f, 0] >= 0]
    if not fields or spans[F_POS, 0].max() < 0:
        raise EmitError(f"{where}: the target writes no coordinate: a point before it cannot be written as a copy")
    # A coordinate the target leaves out keeps its value from the previous target (G-code
    # modal axes, a KRL aggregate without Y): so does the copy, on the same line between them.
    if tp.offset_span is not None and (tp.offset_span[r, :, 0] >= 0).any():
        raise EmitError(f"{where}: the target is an expression on another point (Offs, RelTool, ...): a point before it cannot be written as a copy")
    if tp.relative[r]:
        raise EmitError(f"{where}: the target is written in increments (G91): a point before it cannot be written as a copy")
    source = int(spans[fields[0], 0])
    if any(int(spans[f, 0]) != source for f in fields):
        raise EmitError(f"{where}: the target's numbers are spread over several files")
    motion_start, motion_end = _line_start(tp, r), _statement_end(dialect, tp.sources[int(tp.file[r])].text, _line_start(tp, r))
    inline = source == int(tp.file[r]) and all(motion_start <= spans[f, 1] < motion_end for f in fields)
    if inline:
        text = _with_numbers(tp, p, fields, tp.sources[source].text, motion_start, motion_end)
        return dialect.clone_motion(_set_conf(dialect, text, p, tp, r, motion_start), where), None, ""
    name = tp.target_name[r]
    if not name or dialect.point_name_limit <= 0:
        raise EmitError(f"{where}: the target's numbers are not on its motion line and it has no name to copy")
    doc = tp.sources[source].text
    start = doc.rfind("\n", 0, int(spans[fields].min(axis=0)[1])) + 1
    end = _statement_end(dialect, doc, int(spans[fields, 2].max()))
    new = _new_name(dialect, name, taken)
    block = _with_numbers(tp, p, fields, doc, start, end)
    block = _rename_first(block, name, new, dialect, where)
    block = _set_conf(dialect, block, p, tp, r, start)
    motion = tp.sources[int(tp.file[r])].text[motion_start:motion_end]
    motion = _rename_all(motion, name, new, dialect, where)
    return dialect.clone_motion(motion, where), (source, end, block), new


def _with_numbers(tp: Toolpath, p: NewPoint, fields, text: str, start: int, end: int) -> str:
    """text[start:end] with the numbers of ``fields`` replaced by the new point's values."""
    r = p.row
    pieces, at = [], start
    for f in sorted(fields, key=lambda f: tp.spans[r, f, 1]):
        s, e = int(tp.spans[r, f, 1]), int(tp.spans[r, f, 2])
        scale = tp.scale[r, f] if tp.scale[r, f] != 0 else 1.0
        offset = 0.0 if tp.offset is None or np.isnan(tp.offset[r, f]) else tp.offset[r, f]
        value = (p.values[f] - offset) / scale
        pieces += [text[at:s], format_like(text[s:e], float(value), float(TOLERANCE[f] / abs(scale)))]
        at = e
    pieces.append(text[at:end])
    return "".join(pieces)


def _set_conf(dialect, text: str, p: NewPoint, tp: Toolpath, r: int, start: int) -> str:
    if np.isnan(p.conf).all():
        return text
    return dialect.set_conf_text(text, p.conf)


def _line_start(tp: Toolpath, r: int) -> int:
    """Offset of the first character of target ``r``'s motion line."""
    return int(_line_starts(tp.sources[int(tp.file[r])].text)[int(tp.line[r]) - 1])


@lru_cache(maxsize=8)
def _line_starts(text: str) -> np.ndarray:
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    return np.concatenate([[0], np.nonzero(raw == 10)[0] + 1])


def _statement_end(dialect, text: str, at: int) -> int:
    """Offset just past the statement holding ``at`` (and its line end)."""
    end = text.find(dialect.statement_end, at) if dialect.statement_end != "\n" else at
    end = text.find("\n", max(end, at))
    return len(text) if end < 0 else end + 1


def _words(tp: Toolpath) -> set[str]:
    return {w.upper() for doc in tp.sources for w in re.findall(r"[A-Za-z_$][\w$]*", doc.text)}


def _new_name(dialect, name: str, taken: set[str]) -> str:
    """``name`` with a suffix _S1, _S2, ... (shortened to the language's limit), not in ``taken``."""
    limit = dialect.point_name_limit
    for k in range(1, 1_000_000):
        suffix = f"_S{k}"
        new = name[: limit - len(suffix)] + suffix
        if new.upper() not in taken:
            taken.add(new.upper())
            return new
    raise EmitError(f"no free name for a new point after {name}")


def _word(name: str) -> re.Pattern:
    return re.compile(rf"(?<![\w$]){re.escape(name)}(?![\w$])", re.IGNORECASE)


def _rename_first(text: str, old: str, new: str, dialect, where: str) -> str:
    out, n = _word(old).subn(new, text, count=1)
    if n != 1:
        raise EmitError(f"{where}: the declaration of {old} does not name it")
    return out


def _rename_all(text: str, old: str, new: str, dialect, where: str) -> str:
    out, n = _word(old).subn(new, text)
    if n < 1:
        raise EmitError(f"{where}: the motion does not name {old}")
    return out
