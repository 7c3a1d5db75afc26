"""A VAL3 application's program as a Toolpath: the motions of the code (postproc.dialects.val3.code)
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

import numpy as np

from ...errors import ParseError
from ...ir import NF, Kind, SourceDoc, Toolpath
from ...parse.common import Builder
from .code import CodeReader, Motion, PointArg, find_programs
from .data import Database, Element, read_database
from .rotation import rxyz_to_quat_wxyz, trsf_matrix

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
    from pathlib import Path

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

    def toolpath(self, motions: list[Motion]) -> Toolpath:
        rows = [(m, p, k) for m in motions for k, p in zip(_kinds(m), m.points)]
        n = len(rows)
        values, spans = np.full((n, NF), np.nan), np.full((n, NF, 3), -1, np.int64)
        position, rotation = np.zeros((n, 3)), np.zeros((n, 3))
        offset = np.zeros((n, NF))
        conf, speed, zone = np.full((n, 4), np.nan), np.full(n, np.nan), np.full(n, np.nan)
        kind, line, file = np.zeros(n, np.int8), np.zeros(n, np.int32), np.zeros(n, np.int16)
        frame, tool, resolved = np.zeros(n, np.int32), np.zeros(n, np.int32), np.ones(n, bool)
        insert_at, names = np.full((n, 2), -1, np.int64), []
        approach = np.full((n, 6), np.nan)
        for r, (motion, point, k) in enumerate(rows):
            element = self._element(motion.file, point.ref, ("pointRx", "jointRx") if motion.word == "movej" else ("pointRx",))
            kind[r] = Kind.ABSJ if element.type == "jointRx" else k
            line[r] = int(self.reader_line(motion))
            file[r], names = motion.file, names + [point.ref.label]
            if element.offset >= 0:  # a field left out can be added to the element's <Value>
                insert_at[r] = (self.data_index, element.offset + len("<Value"))
            attrs, columns = (JOINT_ATTRS, range(7, 13)) if element.type == "jointRx" else (POSE_ATTRS, range(0, 6))
            for attr, col in zip(attrs, columns):
                text = element.attrs.get(attr)
                if text is not None:
                    values[r, col] = self._number(text)
                    spans[r, col] = (self.data_index, text[1], text[2])
            if element.type == "pointRx":
                pose = np.nan_to_num(values[r, :6])  # an attribute left out is 0
                position[r], rotation[r] = pose[:3], pose[3:6]
                conf[r, :3] = self._config(element)
                frame[r] = self._frame(element)
                if point.approach is not None:
                    approach[r] = point.approach
            tool[r] = self._tool(motion)
            speed[r], zone[r] = self._mdesc(motion)
            if motion.word == "movej" and element.type == "pointRx" and not _definite(conf[r]):
                resolved[r] = False
                self.notes.append(f"{self.where(motion)}: movej to {point.ref.label} with config {_config_text(element)}: the arm configuration the controller takes is not fixed by the point (VAL3 reference manual, 'config': same/free follow the current position), give shoulder, elbow and wrist")
        joints = values[:, 7:13].copy()
        cart = kind != Kind.ABSJ
        orientation = np.full((n, 4), np.nan)
        if cart.any():
            orientation[cart] = rxyz_to_quat_wxyz(rotation[cart])
        approached = ~np.isnan(approach).any(axis=1)
        if approached.any():
            position, orientation, offset = _approach(position, rotation, approach, approached, offset)
        position[~cart], orientation[~cart] = np.nan, np.nan
        joints[~cart] = np.where(np.isnan(joints[~cart]), 0.0, joints[~cart])
        self.builder.notes.extend(self.notes)
        self.builder.add_block(np.arange(n), kind=kind, line=line, file=file, values=values, spans=spans, conf=conf, speed=speed, zone=zone,
                               tool=tool, frame=frame, resolved=resolved, name=np.array(names + [""], dtype=object)[:n], insert_at=insert_at, offset=offset)
        tp = self.builder.build(orientation=False)
        return replace(tp, position=position, orientation=orientation, joints=joints)

    # ------------------------------------------------------------- lookups
    def reader_line(self, motion: Motion) -> int:
        text = self.sources[motion.file].text
        return text.count("\n", 0, motion.offset) + 1

    def where(self, motion: Motion) -> str:
        return f"{self.sources[motion.file].path}:{self.reader_line(motion)}"

    def _code_error(self, file: int, offset: int, message: str) -> ParseError:
        from ...parse.common import LineIndex

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

    def _config(self, element: Element) -> np.ndarray:
        out = np.full(3, np.nan)
        for i, (attr, words) in enumerate(CONFIG.items()):
            text = element.attrs.get(attr)
            if text is not None:
                if text[0] not in words:
                    raise self.db.error(text[1], f"{attr}='{text[0]}' is not one of {', '.join(words)}")
                out[i] = words[text[0]]
        return out

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
        father = point.father()
        name = "<no fatherId>" if father is None else f"{father[0]}[{father[1]}]"
        if father == ("world", "0"):
            return 0
        return self.builder.frame_index(name, self._chain(point, "world"))

    def _tool(self, motion: Motion) -> int:
        ref = motion.tool
        if ref.name == "flange" and ref.key == "0":
            return 0
        element = self._element(motion.file, ref, ("tool",))
        chain = self._chain(element, "flange")
        return self.builder.tool_index(ref.label, None if chain is None else chain @ self._pose(element))

    def _mdesc(self, motion: Motion) -> tuple[float, float]:
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


def _kinds(motion: Motion) -> tuple[int, ...]:
    return {"movej": (Kind.JOINT,), "movel": (Kind.LINEAR,), "movec": (Kind.CIRC_VIA, Kind.CIRC_END)}[motion.word]


def _definite(conf: np.ndarray) -> bool:
    return bool(np.all(np.abs(conf[:3]) == 1.0))


def _config_text(element: Element) -> str:
    return "{" + ", ".join(element.attrs[a][0] if a in element.attrs else f"({a} not written)" for a in CONFIG) + "}"


def _approach(position, rotation, approach, rows, offset):
    """appro(p, t) = p . t (VAL3 reference manual, "appro": t is expressed in the point's
    own axes): the position is p's plus R_p t's translation, a constant added to p's numbers
    (``offset``); the orientation is R_p R_t."""
    from .rotation import matrix_to_rxyz, rxyz_to_matrix

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
