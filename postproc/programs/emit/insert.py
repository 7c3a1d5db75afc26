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

from postproc.errors import EmitError

from ..arcs import PLANE_AXES
from ..ir import F_ARC, F_EXT, F_ORI, F_POS, FIELDS, Kind, SourceDoc, Toolpath
from .splice import TOLERANCE, format_like

_WRITTEN = np.r_[np.arange(F_POS.start, F_POS.stop), np.arange(F_ORI.start, F_ORI.stop), np.arange(F_EXT.start, F_EXT.stop)]


@dataclass(frozen=True)
class NewPoint:
    """A target to insert before the motion of ``row``: its numbers as the IR reads them
    (``values`` (FIELDS,), NaN where the row's target has none) and configuration data."""

    row: int  # the target whose motion (and declaration) the point copies
    values: np.ndarray
    conf: np.ndarray
    at: int = -1  # written before the motion of this row (-1: ``row``); a split arc's copies go before its auxiliary point
    replaces: bool = False  # the numbers replace ``row``'s own target (the auxiliary point of a split arc's last piece)

    @property
    def before(self) -> int:
        return self.row if self.at < 0 else self.at


def insert_points(dialect, tp: Toolpath, points: list[NewPoint]) -> tuple[list[SourceDoc], list[str]]:
    """New sources of ``tp`` with ``points`` written in (in list order before each row's
    motion), and the name each new point got ('' for an inline one). A point copying a
    circular motion's auxiliary point comes with the next one, its end point: the two make
    one copied CIRC / MoveC statement. A point that ``replaces`` rewrites its row's target
    in its own statement (a named one gets a new declaration, the old one stays)."""
    edits: list[tuple[int, int, int, str]] = []  # (source, start, end, text): a replacement, or an insertion where start == end
    taken = _words(tp)
    names: list[str] = []
    i = 0
    while i < len(points):
        p = points[i]
        if p.replaces or tp.kind[p.row] in (Kind.CIRC_VIA, Kind.ARC_CW, Kind.ARC_CCW):
            group = _arc_pair(tp, points, i) if tp.kind[p.row] == Kind.CIRC_VIA and not p.replaces else [p]
            motion, decls, new_names = _statement_with(dialect, tp, group, taken)
            start, end = _line_start(tp, p.row), _statement_end(dialect, tp.sources[int(tp.file[p.row])].text, _line_start(tp, p.row))
            if p.replaces:
                edits.append((int(tp.file[p.row]), start, end, motion))
            else:
                edits.append((int(tp.file[p.row]), start, start, dialect.clone_motion(motion, _where(tp, p.row))))
            edits += decls
            names += new_names
            i += len(group)
            continue
        motion, decl, name = _clone(dialect, tp, p, taken)
        edits.append((int(tp.file[p.row]), _line_start(tp, p.row), _line_start(tp, p.row), motion))
        if decl is not None:
            edits.append((decl[0], decl[1], decl[1], decl[2]))
        names.append(name)
        i += 1
    texts = [doc.text for doc in tp.sources]
    # Later offsets first so earlier ones stay valid; at one offset a replacement first, then
    # the insertions in reverse, which leaves them in list order.
    order = sorted(range(len(edits)), key=lambda k: (edits[k][0], -edits[k][1], edits[k][2] == edits[k][1], -k))
    for k in order:
        source, start, end, text = edits[k]
        texts[source] = texts[source][:start] + text + texts[source][end:]
    return [SourceDoc(doc.path, text, doc.role) for doc, text in zip(tp.sources, texts)], names


def _where(tp: Toolpath, r: int) -> str:
    return f"{tp.sources[int(tp.file[r])].path}, line {tp.line[r]}"


def _arc_pair(tp: Toolpath, points: list[NewPoint], i: int) -> list[NewPoint]:
    if i + 1 >= len(points) or points[i + 1].row != points[i].row + 1 or tp.kind[points[i + 1].row] != Kind.CIRC_END:
        raise EmitError(f"{_where(tp, points[i].row)}: a new auxiliary point comes without its end point")
    return [points[i], points[i + 1]]


def _statement_with(dialect, tp: Toolpath, group: list[NewPoint], taken: set[str]):
    """The motion statement of ``group``'s rows (one statement: a CIRC / MoveC's auxiliary
    and end points, or one of them) with each point's numbers and configuration in place
    of its row's: (statement text, declaration insertions, new names)."""
    r = group[0].row
    file = int(tp.file[r])
    text = tp.sources[file].text
    start = _line_start(tp, r)
    region = text[start : _statement_end(dialect, text, start)]
    inline, decls, names = [], [], []
    for p in group:
        fields = _fields(tp, p.row)
        source = int(tp.spans[p.row, fields[0], 0])
        if source == file and all(start <= tp.spans[p.row, f, 1] < start + len(region) for f in fields):
            inline.append((p, fields))
            names.append("")
            continue
        name = tp.target_name[p.row]
        if not name or dialect.point_name_limit <= 0:
            raise EmitError(f"{_where(tp, p.row)}: the target's numbers are not on its motion line and it has no name to copy")
        doc = tp.sources[source].text
        decl_start = doc.rfind("\n", 0, int(tp.spans[p.row, fields, 1].min())) + 1
        decl_end = _statement_end(dialect, doc, int(tp.spans[p.row, fields, 2].max()))
        new = _new_name(dialect, name, taken)
        block = _rename_first(_with_numbers(tp, p, fields, doc, decl_start, decl_end), name, new, dialect, _where(tp, p.row))
        decls.append((source, decl_end, decl_end, _set_conf(dialect, block, p, tp, p.row, decl_start)))
        region = _rename_first(region, name, new, dialect, _where(tp, p.row))
        names.append(new)
    # Inline literals from the back, so the offsets of those before stay valid.
    for p, fields in sorted(inline, key=lambda item: -int(tp.spans[item[0].row, item[1], 1].min())):
        if tp.kind[p.row] in (Kind.ARC_CW, Kind.ARC_CCW):  # a G-code block: its words, and those it lacks added
            return _block_with(dialect, tp, p, fields, text, start, start + len(region)), decls, names
        lit_start, lit_end = _literal_around(region, int(tp.spans[p.row, fields, 1].min()) - start)
        literal = _with_numbers(tp, p, fields, text, start + lit_start, start + lit_end)
        region = region[:lit_start] + _set_conf(dialect, literal, p, tp, p.row, 0) + region[lit_end:]
    return region, decls, names


def _block_with(dialect, tp: Toolpath, p: NewPoint, fields: list[int], text: str, start: int, end: int) -> str:
    """A G2 / G3 block text[start:end] with the point's axis and arc words; a word the block
    leaves out but the point needs (an end point of a full circle, a J read as 0) is added
    where the block's words end (``Toolpath.insert_at``)."""
    lacking = [f for f in (*range(F_POS.start, F_POS.stop), *range(F_ARC.start, F_ARC.stop))
               if f not in fields and not np.isnan(p.values[f]) and (f < F_ARC.start or p.values[f] != 0.0)]
    # The axis normal to the plane, where the arc does not move it (Z of a planar G17 arc),
    # stays modal, as in the block.

    r = p.row
    normal = PLANE_AXES[int(tp.arc[r, 0])][2] if tp.arc is not None and int(tp.arc[r, 0]) in PLANE_AXES else -1
    lacking = [f for f in lacking if not (f == normal and r > 0 and abs(p.values[f] - tp.position[r, f]) <= 1e-9
                                          and abs(tp.position[r - 1, f] - tp.position[r, f]) <= 1e-9)]
    file, at = (int(v) for v in tp.insert_at[p.row]) if tp.insert_at is not None else (-1, -1)
    if lacking and not (file == int(tp.file[p.row]) and start <= at <= end):
        raise EmitError(f"{_where(tp, p.row)}: the block has no place to add the words {' '.join(FIELDS[f].upper() for f in lacking)} a piece of the arc needs")
    offset = np.zeros(len(FIELDS)) if tp.offset is None else np.nan_to_num(tp.offset[p.row])
    scale = np.where(tp.scale[p.row] != 0, tp.scale[p.row], 1.0)
    added = "".join(dialect.insert_field(file, FIELDS[f], format_like("0.0000", float((p.values[f] - offset[f]) / scale[f]), float(TOLERANCE[f] / abs(scale[f]))))
                    for f in lacking)
    if not lacking:
        return _with_numbers(tp, p, fields, text, start, end)
    head = [f for f in fields if tp.spans[p.row, f, 1] < at]
    tail = [f for f in fields if tp.spans[p.row, f, 1] >= at]
    return _with_numbers(tp, p, head, text, start, at) + added + _with_numbers(tp, p, tail, text, at, end)


def _fields(tp: Toolpath, r: int) -> list[int]:
    """The written fields of target ``r`` (a G2 / G3's arc words too); an EmitError where its
    numbers cannot be copied."""
    spans = tp.spans[r]
    written = np.r_[_WRITTEN, np.arange(F_ARC.start, F_ARC.stop)] if tp.kind[r] in (Kind.ARC_CW, Kind.ARC_CCW) else _WRITTEN
    fields = [f for f in written if spans[f, 0] >= 0]
    if tp.kind[r] in (Kind.ARC_CW, Kind.ARC_CCW) and spans[F_POS, 0].max() < 0:
        return fields  # a full circle: its end-point words are added
    if not fields or spans[F_POS, 0].max() < 0:
        raise EmitError(f"{_where(tp, r)}: the target writes no coordinate: a point before it cannot be written as a copy")
    if tp.offset_span is not None and (tp.offset_span[r, :, 0] >= 0).any():
        raise EmitError(f"{_where(tp, r)}: the target is an expression on another point (Offs, RelTool, ...): it cannot be written as a copy")
    if tp.relative[r]:
        raise EmitError(f"{_where(tp, r)}: the target is written in increments (G91): it cannot be written as a copy")
    if any(int(spans[f, 0]) != int(spans[fields[0], 0]) for f in fields):
        raise EmitError(f"{_where(tp, r)}: the target's numbers are spread over several files")
    return fields


def _literal_around(text: str, at: int) -> tuple[int, int]:
    """(start, end) of the outermost bracketed literal ({...} or [...]) of ``text`` holding offset ``at``."""
    depth, start = 0, -1
    for i, ch in enumerate(text):
        if ch in "[{":
            if depth == 0:
                start = i
            depth += 1
        elif ch in "]}":
            depth -= 1
            if depth == 0 and start <= at < i:
                return start, i + 1
    raise EmitError(f"no literal around offset {at} of '{text.strip()[:80]}'")


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
