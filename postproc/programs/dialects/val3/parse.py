"""A VAL3 application's program as a Toolpath: the motions of the code (postproc.programs.dialects.val3.code)
at the points, frames, tools and motion descriptors of the data file (.dtx).

Every number a target takes from the data has its span in the .dtx; a field the data
leaves out is 0 (Stäubli Robotics Suite writes no attribute whose value is 0, e.g.
``<Value key="0" j3="90" j5="90" />``) and can be added there (``insert_at``). A point is
placed in its frame through its ``fatherId`` chain up to ``world`` (the robot's world frame,
the base of the robot files), a tool through its chain up to ``flange`` (VAL3 reference
manual, "frame" and "tool" types: each is defined relative to the one it is linked to).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from postproc.errors import ParseError

from ...ir import NF, Kind, SourceDoc, Toolpath
from ...parse.common import Builder, LineIndex
from .code import CodeReader, Motion, PlainMotions, PointArg, find_programs
from .data import WORDS, Database, Element, parse_father, read_database
from .rotation import matrix_to_rxyz, rxyz_to_matrix, rxyz_to_quat_wxyz, trsf_matrix

POSE_ATTRS = ("x", "y", "z", "rx", "ry", "rz")  # -> FIELDS x y z o1 o2 o3
JOINT_ATTRS = ("j1", "j2", "j3", "j4", "j5", "j6")  # -> FIELDS j1..j6
# config words (VAL3 reference manual, "config" type) -> the code kept in Toolpath.conf
CONFIG = {
    "shoulder": {"righty": 1.0, "lefty": -1.0, "ssame": 0.0, "sfree": 2.0},
    "elbow": {"epositive": 1.0, "enegative": -1.0, "esame": 0.0, "efree": 2.0},
    "wrist": {"wpositive": 1.0, "wnegative": -1.0, "wsame": 0.0, "wfree": 2.0},
}
# mdesc defaults (VAL3 reference manual, "mdesc": accel 100, vel 100, decel 100, tvel 99999,
# rvel 9999, blend off, leave 50, reach 50); Stäubli Robotics Suite writes no field at its default.
MDESC_LEAVE = 50.0
ROOTS = {"world": "frame", "flange": "tool"}  # the roots of the frame and tool trees
MAX_CHAIN = 64


def parse_application(sources: list[SourceDoc]) -> Toolpath:
    """sources: the program's .pgx first, then the data file (role "data") and the other
    programs it calls (role "program"), any project file (role "project")."""
    data_at = [i for i, s in enumerate(sources) if s.role == "data"]
    if not data_at:
        raise ParseError(sources[0].path, 1, 1, "no data file (.dtx) found beside this program: the points it moves to are there")
    db = read_database(sources[data_at[0]].path, sources[data_at[0]].text)
    pgx = [(i, s.text) for i, s in enumerate(sources) if s.role == "program"]
    programs = find_programs(pgx)
    entry = _program_name(sources[0])
    reader = CodeReader([s.path for s in sources], [s.text for s in sources], programs, db.types)
    motions = reader.run(entry)
    return _Assembler(sources, data_at[0], db).toolpath(motions)


def _program_name(doc: SourceDoc) -> str:
    names = find_programs([(0, doc.text)]).code
    if not names and "<programList" in doc.text:
        raise ParseError(doc.path, 1, 1, "a VAL3 s6 program file (<programList>, CS8 controllers before VAL3 s7): postproc reads the s7 and later format (<Programs>); open it in Stäubli Robotics Suite 2013 or later to convert it")
    stem = Path(doc.path).stem
    if stem in names:
        return stem
    if len(names) == 1:
        return next(iter(names))
    raise ParseError(doc.path, 1, 1, "no <Program> with <Code><![CDATA[...]]> in this file" if not names else f"several programs in this file ({', '.join(names)}) and none is named after it")


class _Assembler:
    """Rows of targets from the motions, frames and tools resolved through the data."""

    def __init__(self, sources: list[SourceDoc], data_index: int, db: Database):
        self.sources, self.data_index, self.db = sources, data_index, db
        self.builder = Builder("val3", "rxyz", list(sources))
        self.builder.frame_names[0], self.builder.tool_names[0] = "world[0]", "flange[0]"
        self.notes: list[str] = []
        self._frames: dict[tuple[str, str] | None, int] = {}  # fatherId -> frame index
        self._tools: dict[tuple[str, str], int] = {}
        self._tool_of_ref: dict = {}  # Ref -> tool index
        self._mdesc_of_ref: dict = {}  # Ref -> (speed, zone)
        self._configs: dict[tuple, tuple[float, float, float]] = {}  # the words written -> codes
        self._fathers: dict[str | None, tuple[str, str] | None] = {}  # fatherId text -> (name, index)
        self._mdescs: dict[tuple[str, str], tuple[float, float]] = {}

    def toolpath(self, motions: list[Motion | PlainMotions]) -> Toolpath:
        cols = _Rows(sum(len(m) if isinstance(m, PlainMotions) else len(m.points) for m in motions))
        r = 0
        for item in motions:
            if isinstance(item, PlainMotions):
                self._plain_rows(cols, r, item)
                r += len(item)
                continue
            for k, point in zip(KINDS[item.word], item.points):
                if not self._bulk_row(cols, r, item, point, k):
                    self._element_row(cols, r, item, point, k)
                r += 1
        return self._build(cols)

    def _plain_rows(self, cols: "_Rows", r: int, block: PlainMotions) -> None:
        """Rows r.. of a run of plain motion lines: those whose point the bulk tables hold are
        set as arrays, the others (declared without a <Value>, not read whole, another type:
        their errors) one by one, in program order."""
        index = self.db.index
        tags = np.array([index.get(pair, -1) for pair in zip(block.point_name, block.point_key)], np.int64)
        kind = np.append(self.db.point_type, 0)[tags]  # tag -1 (no such element): the 0 appended
        fast = np.append(self.db.complete, False)[tags] & ((kind == 1) | (kind == 2) & block.movej)
        bounds = [0] + (np.flatnonzero(fast[1:] != fast[:-1]) + 1).tolist() + [len(block)]
        for a, b in zip(bounds[:-1], bounds[1:]):
            if fast[a]:
                self._fast_rows(cols, r, block, a, b, tags[a:b], kind[a:b] == 2)
                continue
            for i in range(a, b):
                motion = block.motion(i)
                self._element_row(cols, r + i, motion, motion.points[0], KINDS[motion.word][0])

    def _fast_rows(self, cols: "_Rows", r: int, block: PlainMotions, a: int, b: int, tags: np.ndarray, joint: np.ndarray) -> None:
        """Rows r+a..r+b of block[a:b], every point in the bulk tables: the row by row reading
        (``_bulk_row``) as arrays. Configs, frames, tools and descriptors are resolved once
        each, in the order the row by row reading meets them (its errors, its frame and tool
        numbers); the notes on movej without a fixed posture follow in row order."""
        rows, movej = np.arange(r + a, r + b), block.movej[a:b]
        cols.kind[rows] = np.where(joint, Kind.ABSJ, np.where(movej, Kind.JOINT, Kind.LINEAR))
        cols.file[rows], cols.offset[rows] = block.file, block.offset[a:b]
        cols.name[rows] = [f"{n}[{k}]" for n, k in zip(block.point_name[a:b], block.point_key[a:b])]
        cols.insert[rows] = self.db.offset_array[tags] + len("<Value")
        cols.bulk_blocks.append((rows, tags, joint))
        conf, frame, tool, mdesc = self._resolve_once(block, a, b, tags, joint)
        cart = ~joint
        cols.conf[rows[cart]], cols.frame[rows[cart]] = conf[cart], frame[cart]
        cols.tool[rows], cols.speed[rows], cols.zone[rows] = tool, mdesc[:, 0], mdesc[:, 1]
        unfixed = np.flatnonzero(movej & cart & ~_fixed_postures(conf))
        cols.resolved[rows[unfixed]] = False
        for i in unfixed.tolist():
            motion = block.motion(a + i)
            self._unfixed(motion, motion.points[0], self.db.element(motion.points[0].ref.name, motion.points[0].ref.key))

    def _resolve_once(self, block: PlainMotions, a: int, b: int, tags: np.ndarray, joint: np.ndarray):
        """(conf (M, 3), frame (M,), tool (M,), speed and zone (M, 2)) of block[a:b]'s rows."""
        words = self.db.word_codes[tags] + 1  # 0: not written
        base = np.array([len(t) + 1 for t in self.db.word_texts[:3]], np.int64)
        combo = np.where(joint, -1, (words[:, 0] * base[1] + words[:, 1]) * base[2] + words[:, 2])
        father = np.where(joint, -1, words[:, 3])
        keys = [(combo, 0), (father, 1), (block.tool_code[a:b], 2), (block.mdesc_code[a:b], 3)]
        found = [np.unique(k, return_index=True, return_inverse=True) for k, _ in keys]
        # (first row, what) of each distinct value, resolved in that order
        todo = sorted((int(row), what, int(value)) for (k, what), (values, first, _) in zip(keys, found) for value, row in zip(values.tolist(), first.tolist()) if value >= 0)
        table = {(what, value): self._resolve(what, int(tags[row]), block, a + row) for row, what, value in todo}
        columns = []
        for what, (values, _, inverse) in enumerate(found):
            resolved = [table.get((what, v), (np.nan,) * 3 if what == 0 else 0) for v in values.tolist()]
            columns.append(np.array(resolved, dtype=float if what in (0, 3) else np.int64)[inverse.reshape(-1)])
        return columns

    def _resolve(self, what: int, tag: int, block: PlainMotions, i: int):
        """A row's config (what 0), frame (1), tool (2) or speed and zone (3), as ``_bulk_row`` finds it."""
        if what == 0:
            return self._config_words(tag)
        if what == 1:
            return self._frame_of(tag)
        motion = block.motion(i)
        if what == 2:
            return self._tool_of_ref[motion.tool] if motion.tool in self._tool_of_ref else self._tool(motion)
        return self._mdesc_of_ref[motion.mdesc] if motion.mdesc in self._mdesc_of_ref else self._mdesc(motion)

    def _bulk_row(self, cols: "_Rows", r: int, motion: Motion, point: PointArg, k: int) -> bool:
        """The bulk of a program: a data point read whole, nothing composed with it (its numbers
        come from the data's tables in ``_build``). False where the row needs ``_element_row``."""
        tag = self.db.index.get((point.ref.name, point.ref.key))
        if tag is None or not self.db.complete[tag] or point.approach is not None:
            return False
        joint = self.db.tag_type[tag] == "jointRx"
        if not (joint and motion.word == "movej" or self.db.tag_type[tag] == "pointRx"):
            return False
        cols.kind[r] = Kind.ABSJ if joint else k
        cols.file[r], cols.offset[r], cols.name[r], cols.insert[r] = motion.file, motion.offset, point.ref.label, self.db.offsets[tag] + len("<Value")
        cols.bulk.append((r, tag, joint))
        if not joint:
            cols.conf[r], cols.frame[r] = self._config_words(tag), self._frame_of(tag)
        cols.tool[r] = self._tool_of_ref[motion.tool] if motion.tool in self._tool_of_ref else self._tool(motion)
        cols.speed[r], cols.zone[r] = self._mdesc_of_ref[motion.mdesc] if motion.mdesc in self._mdesc_of_ref else self._mdesc(motion)
        if motion.word == "movej" and not joint and not _fixed_posture(cols.conf[r]):
            self._unfixed(motion, point, self.db.element(point.ref.name, point.ref.key))
            cols.resolved[r] = False
        return True

    def _element_row(self, cols: "_Rows", r: int, motion: Motion, point: PointArg, k: int) -> None:
        """A row through its element: a declared element without a <Value>, an appro(), or one
        whose numbers the bulk pass did not read whole (their errors are raised here)."""
        element = self._element(motion.file, point.ref, ("pointRx", "jointRx") if motion.word == "movej" else ("pointRx",))
        cols.kind[r] = Kind.ABSJ if element.type == "jointRx" else k
        cols.file[r], cols.offset[r], cols.name[r] = motion.file, motion.offset, point.ref.label
        if element.offset >= 0:  # a field left out can be added to the element's <Value>
            cols.insert[r] = element.offset + len("<Value")
        if element.tag >= 0 and self.db.complete[element.tag]:
            cols.bulk.append((r, element.tag, element.type == "jointRx"))
        else:
            first = 7 if element.type == "jointRx" else 0
            for c, attr in enumerate(JOINT_ATTRS if element.type == "jointRx" else POSE_ATTRS):
                text = element.attrs.get(attr)
                if text is not None:
                    cols.cells.append((r, first + c, self._number(text), text[1], text[2]))
        if element.type == "pointRx":
            cols.conf[r], cols.frame[r] = self._config(element), self._frame(element)
            if point.approach is not None:
                cols.approach[r] = point.approach
        cols.tool[r] = self._tool(motion)
        cols.speed[r], cols.zone[r] = self._mdesc(motion)
        if motion.word == "movej" and element.type == "pointRx" and not _fixed_posture(cols.conf[r]):
            cols.resolved[r] = False
            self._unfixed(motion, point, element)

    def _build(self, cols: "_Rows") -> Toolpath:
        """The Toolpath of the rows: numbers and spans, poses in their frames, appro() applied."""
        n = len(cols.kind)
        values, spans = np.full((n, NF), np.nan), np.full((n, NF, 3), -1, np.int64)
        if cols.cells:
            r_, c_, v_, s_, e_ = (np.array(col) for col in zip(*cols.cells))
            values[r_, c_] = v_
            spans[r_, c_] = np.column_stack([np.full(len(r_), self.data_index), s_, e_])
        if cols.bulk:
            rows, tags, joint = (np.array(col) for col in zip(*cols.bulk))
            cols.bulk_blocks.append((rows, tags, joint.astype(bool)))
        for rows, tags, joint in cols.bulk_blocks:
            self._gather(rows, tags, joint, values, spans)
        kind, file = cols.kind, cols.file
        cart = kind != Kind.ABSJ
        pose = np.nan_to_num(values[:, :6])  # an attribute left out is 0
        position, rotation = pose[:, :3].copy(), pose[:, 3:6]
        joints = np.where(cart[:, None], np.nan, np.nan_to_num(values[:, 7:13]))
        orientation = np.full((n, 4), np.nan)
        if cart.any():
            orientation[cart] = rxyz_to_quat_wxyz(rotation[cart])
        offset = np.zeros((n, NF))
        if cols.approach:
            trsf = np.full((n, 6), np.nan)
            trsf[list(cols.approach)] = list(cols.approach.values())
            position, orientation, offset = _approach(position, rotation, trsf, ~np.isnan(trsf).any(axis=1), offset)
        position[~cart], orientation[~cart] = np.nan, np.nan
        conf = np.full((n, 4), np.nan)
        conf[:, :3] = cols.conf
        insert = cols.insert
        insert_at = np.column_stack([np.where(insert >= 0, self.data_index, -1), insert]).reshape(n, 2)
        self.builder.notes.extend(self.notes)
        self.builder.add_block(np.arange(n), kind=kind, line=self._lines(file, cols.offset), file=file, values=values, spans=spans,
                               conf=conf, speed=cols.speed, zone=cols.zone, tool=cols.tool,
                               frame=cols.frame, resolved=cols.resolved, name=cols.name,
                               insert_at=insert_at, offset=offset)
        tp = self.builder.build(orientation=False)
        return replace(tp, position=position, orientation=orientation, joints=joints)

    def _unfixed(self, motion: Motion, point: PointArg, element: Element) -> None:
        self.notes.append(f"{self.where(motion)}: movej to {point.ref.label} with config {_config_text(element)}: the arm configuration the controller takes is not fixed by the point (VAL3 reference manual, 'config': free lets the controller choose, same keeps the current value), give shoulder, elbow and wrist, or ssame, esame and wsame")

    def _config_words(self, tag: int) -> tuple[float, float, float]:
        given = self.db.words(tag)
        written = (given.get("shoulder"), given.get("elbow"), given.get("wrist"))
        if written not in self._configs:
            self._configs[written] = self._config_of(self.db.element_at(tag), given)
        return self._configs[written]

    def _frame_of(self, tag: int) -> int:
        text = self.db.words(tag).get("fatherId")
        if text not in self._fathers:
            self._fathers[text] = None if text is None else parse_father(text)
        father = self._fathers[text]
        if father not in self._frames:
            self._frames[father] = self._new_frame(self.db.element_at(tag), father)
        return self._frames[father]

    def _gather(self, rows: np.ndarray, tags: np.ndarray, joint: np.ndarray, values: np.ndarray, spans: np.ndarray) -> None:
        """Numbers and spans of the rows' elements from the data file's bulk tables."""
        for sel, fields, table in ((~joint, slice(0, 6), slice(0, 6)), (joint, slice(7, 13), slice(6, 12))):
            if sel.any():
                r, t = rows[sel], tags[sel]
                values[r, fields] = self.db.numbers[t, table]
                found = self.db.spans[t, table]
                spans[r, fields, 0] = np.where(found[..., 0] >= 0, self.data_index, -1)
                spans[r, fields, 1:] = found

    def _lines(self, file: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """1-based line of each motion statement in its own file."""
        lines = np.zeros(len(file), np.int32)
        for f in np.unique(file).tolist():
            mine = file == f
            lines[mine] = LineIndex(self.sources[f].text).line(offsets[mine])
        return lines

    # ------------------------------------------------------------- lookups
    def reader_line(self, motion: Motion) -> int:
        text = self.sources[motion.file].text
        return text.count("\n", 0, motion.offset) + 1

    def where(self, motion: Motion) -> str:
        """file:line:column of a motion statement."""
        text = self.sources[motion.file].text
        column = motion.offset - text.rfind("\n", 0, motion.offset)
        return f"{self.sources[motion.file].path}:{self.reader_line(motion)}:{column}"

    def _code_error(self, file: int, offset: int, message: str) -> ParseError:
        return LineIndex(self.sources[file].text).error(self.sources[file].path, offset, message)

    def _element(self, file: int, ref, types: tuple[str, ...]) -> Element:
        element = self.db.element(ref.name, ref.key)
        if element is None:
            what = "has no such element" if ref.name in self.db.types else "has no such variable"
            raise self._code_error(file, ref.offset, f"{ref.label}: the data file {self.db.path} {what} (local variables and parameters are set at run time)")
        if element.type not in types:
            raise self._code_error(file, ref.offset, f"{ref.label} is a {element.type}, not a {' or '.join(types)}")
        return element

    def _number(self, text: tuple[str, int, int]) -> float:
        try:
            return float(text[0])
        except ValueError:
            raise self.db.error(text[1], f"'{text[0]}' is not a number") from None

    def _config(self, element: Element) -> tuple[float, float, float]:
        given = self.db.words(element.tag) if element.tag >= 0 else {}
        written = (given.get("shoulder"), given.get("elbow"), given.get("wrist"))
        if written not in self._configs:
            self._configs[written] = self._config_of(element, given)
        return self._configs[written]

    def _config_of(self, element: Element, given: dict[str, str]) -> tuple[float, float, float]:
        out = [np.nan, np.nan, np.nan]
        for i, (attr, words) in enumerate(CONFIG.items()):
            if attr in given:
                if given[attr] not in words:
                    text = element.attrs[attr]
                    raise self.db.error(text[1], f"{attr}='{text[0]}' is not one of {', '.join(words)}")
                out[i] = words[given[attr]]
        return tuple(out)

    def _pose(self, element: Element) -> np.ndarray:
        return trsf_matrix(np.array([self._number(element.attrs[a]) if a in element.attrs else 0.0 for a in POSE_ATTRS]))[0]

    def _chain(self, element: Element, root: str) -> np.ndarray | None:
        """root_T_element through the fatherId links; None where a link is not in the data."""
        transform, seen = np.eye(4), 0
        while True:
            father = element.father()
            if father is None or not father[1]:
                return None
            if father[0] == root:
                return transform if father[1] == "0" else None
            parent = self.db.element(*father)
            seen += 1
            if parent is None or parent.type != ROOTS[root] or seen > MAX_CHAIN:
                return None
            transform = self._pose(parent) @ transform
            element = parent

    def _frame(self, point: Element) -> int:
        text = None if point.tag < 0 else self.db.words(point.tag).get("fatherId")
        if text not in self._fathers:
            self._fathers[text] = None if text is None else parse_father(text)
        father = self._fathers[text]
        if father not in self._frames:
            self._frames[father] = self._new_frame(point, father)
        return self._frames[father]

    def _new_frame(self, point: Element, father) -> int:
        name = "<no fatherId>" if father is None else f"{father[0]}[{father[1]}]"
        if father == ("world", "0"):
            return 0
        return self.builder.frame_index(name, self._chain(point, "world"))

    def _tool(self, motion: Motion) -> int:
        key = (motion.tool.name, motion.tool.key)
        if key not in self._tools:
            self._tools[key] = self._new_tool(motion)
        self._tool_of_ref[motion.tool] = self._tools[key]
        return self._tools[key]

    def _new_tool(self, motion: Motion) -> int:
        ref = motion.tool
        if ref.name == "flange" and ref.key == "0":
            return 0
        element = self._element(motion.file, ref, ("tool",))
        chain = self._chain(element, "flange")
        return self.builder.tool_index(ref.label, None if chain is None else chain @ self._pose(element))

    def _mdesc(self, motion: Motion) -> tuple[float, float]:
        key = (motion.mdesc.name, motion.mdesc.key)
        if key not in self._mdescs:
            self._mdescs[key] = self._new_mdesc(motion)
        self._mdesc_of_ref[motion.mdesc] = self._mdescs[key]
        return self._mdescs[key]

    def _new_mdesc(self, motion: Motion) -> tuple[float, float]:
        """(speed: the descriptor's tmax in mm/s, NaN where it is left at its default 99999, no
        limit; zone: 0 with blend off, the default; the leave distance, default 50 mm, with
        blend joint or Cartesian)."""
        element = self._element(motion.file, motion.mdesc, ("mdesc",))
        speed = self._number(element.attrs["tmax"]) if "tmax" in element.attrs else np.nan
        blend = element.attrs.get("blend", ("off",))
        if blend[0] not in ("off", "joint", "Cartesian"):
            raise self.db.error(blend[1], f"blend='{blend[0]}' is not off, joint or Cartesian")
        if blend[0] == "off":
            return speed, 0.0
        return speed, self._number(element.attrs["leave"]) if "leave" in element.attrs else MDESC_LEAVE


def _fixed_postures(conf: np.ndarray) -> np.ndarray:
    """``_fixed_posture`` of each row of an (M, 3) array."""
    return (np.abs(conf) == 1.0).all(axis=1) | (conf == 0.0).all(axis=1)


def _fixed_posture(conf: tuple[float, float, float]) -> bool:
    """True where a movej's posture follows from the point's config: all three named (the
    controller takes them) or all three 'same' (the arm keeps the one it is in)."""
    return all(abs(v) == 1.0 for v in conf) or all(v == 0.0 for v in conf)


def _object_array(items: list) -> np.ndarray:
    out = np.empty(len(items), dtype=object)
    out[:] = items
    return out


class _Rows:
    """The rows' columns, filled row by row (slow path) or by blocks of rows (plain motions)."""

    def __init__(self, n: int):
        self.kind, self.file, self.offset, self.name = np.zeros(n, np.int8), np.zeros(n, np.int16), np.zeros(n, np.int64), _object_array([""] * n)
        self.frame, self.tool, self.speed, self.zone = np.zeros(n, np.int32), np.zeros(n, np.int32), np.full(n, np.nan), np.full(n, np.nan)
        self.insert, self.conf, self.resolved = np.full(n, -1, np.int64), np.full((n, 3), np.nan), np.ones(n, bool)
        self.approach: dict[int, tuple[float, ...]] = {}  # row -> appro()'s trsf
        self.cells: list[tuple[int, int, float, int, int]] = []  # (row, column, value, start, end)
        self.bulk: list[tuple[int, int, bool]] = []  # (row, data tag, jointRx)
        self.bulk_blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (rows, data tags, jointRx) of plain motions


KINDS = {"movej": (Kind.JOINT,), "movel": (Kind.LINEAR,), "movec": (Kind.CIRC_VIA, Kind.CIRC_END)}


def _config_text(element: Element) -> str:
    return "{" + ", ".join(element.attrs[a][0] if a in element.attrs else f"({a} not written)" for a in CONFIG) + "}"


def _approach(position, rotation, approach, rows, offset):
    """appro(p, t) = p . t (VAL3 reference manual, "appro": t is expressed in the point's
    own axes): the position is p's plus R_p t's translation, a constant added to p's numbers
    (``offset``); the orientation is R_p R_t."""
    position, offset = position.copy(), offset.copy()
    r_point = rxyz_to_matrix(rotation[rows])
    shift = np.einsum("nij,nj->ni", r_point, approach[rows, :3])
    position[rows] += shift
    offset[np.nonzero(rows)[0], 0:3] = shift
    orientation = np.full((len(position), 4), np.nan)
    orientation[~rows] = rxyz_to_quat_wxyz(rotation[~rows])
    orientation[rows] = rxyz_to_quat_wxyz(matrix_to_rxyz(r_point @ rxyz_to_matrix(approach[rows, 3:6])))
    return position, orientation, offset


__all__ = ["parse_application", "PointArg"]
