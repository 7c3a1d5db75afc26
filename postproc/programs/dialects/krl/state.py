"""KRL runtime state in program order: points, $BASE and $TOOL as the controller changes them.

The parser records every statement of the program (.src) that changes a point or a frame
as an ``Event``; ``replay`` runs them in program order. A change in straight-line code (the
first DEF, outside any IF/FOR/WHILE/LOOP/REPEAT/SWITCH, no GOTO in the file) is applied
exactly when its value can be computed from literals and known points; any other change
(inside a block, in another DEF or after a jump, an expression of unknown values, a
system routine whose effect is not read) makes the value unknown from the point where the
controller may first have run it: the targets that use it are then unresolved (points) or
in an unknown frame (frames), and refused for compensation. A declared value is never used
after the program may have changed it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import chain, count

import numpy as np
from lark import Token, Tree

from postproc.robot.frames import abc_to_matrix, make_transform, matrix_to_abc

from ...ir import NF

FRAME_KEYS = ("$BASE", "$TOOL")
_XYZABC = {"X": 0, "Y": 1, "Z": 2, "A": 3, "B": 4, "C": 5}


@dataclass
class Event:
    offset: int  # from where the change may apply (a block's start when not straight-line)
    line_offset: int  # the statement itself
    key: str  # "$BASE", "$TOOL" or a point's key (XP1, PATH[3]); "PATH[" for a whole array
    exact: bool  # straight-line code
    field: str = ""  # component assigned (X, A1, ...), "" for the whole value
    rhs: object = None  # the value's parse tree; None: unknown
    text: str = ""  # the statement's text (names the frame)
    line: int = 0
    anytime: bool = False  # in a subprogram or in a program with GOTO: may run before any line
    env: dict | None = None  # the FOR counter's value in the pass it is replayed for (passes.py)


@dataclass
class Point:
    values: np.ndarray
    spans: np.ndarray
    conf: np.ndarray
    insert: np.ndarray
    known: bool = True

    @staticmethod
    def unknown() -> "Point":
        return Point(np.full(NF, np.nan), np.full((NF, 3), -1, np.int64), np.full(4, np.nan), np.array([-1, -1]), False)

    def copy(self) -> "Point":
        return Point(self.values.copy(), self.spans.copy(), self.conf.copy(), self.insert.copy(), self.known)


@dataclass
class Frame:
    name: str
    pose: np.ndarray | None  # X Y Z A B C (mm, degrees); None: unknown

    def transform(self) -> np.ndarray:
        v = self.pose
        return make_transform(abc_to_matrix(v[3:6][None])[0], v[:3])


def pose_of(transform: np.ndarray) -> np.ndarray:
    return np.concatenate([transform[:3, 3], matrix_to_abc(transform[None, :3, :3])[0]])


@dataclass
class Timeline:
    """What the replay found: for each key, (offset, state) in program order."""

    points: dict[str, list[tuple[int, Point]]] = field(default_factory=dict)
    arrays: dict[str, int] = field(default_factory=dict)  # array prefix -> offset from which every element is unknown
    frames: dict[str, list[tuple[int, Frame]]] = field(default_factory=lambda: {k: [] for k in FRAME_KEYS})

    def point_at(self, key: str, offset: int) -> Point | None:
        """The point's state at ``offset``; None where the program has not changed it."""
        prefix = key.split("[")[0] + "[" if "[" in key else None
        if prefix in self.arrays and offset >= self.arrays[prefix]:
            return Point.unknown()
        history = self.points.get(key)
        if not history:
            return None
        at = np.searchsorted([o for o, _ in history], offset, side="right") - 1
        return history[at][1] if at >= 0 else None


def number(node, lookup, call=None) -> float:
    """The value of a numeric expression of literals and known components; NaN otherwise.
    ``lookup(text)`` gives a component such as ``XP1.X`` or ``$BASE.Z``; ``call(node,
    lookup)`` the value of a function call (functions.py), NaN without it."""
    if isinstance(node, Token) or node is None:
        return float("nan")
    kind = node.data
    if kind == "number":
        return float(node.children[0])
    if kind == "neg":
        return -number(node.children[0], lookup, call)
    if kind in ("sum_expr", "prod_expr"):
        total = number(node.children[0], lookup, call)
        for op, operand in zip(node.children[1::2], node.children[2::2]):
            v = number(operand, lookup, call)
            total = {"+": total + v, "-": total - v, "*": total * v, "/": total / v if v else float("nan")}.get(str(op), float("nan"))
        return total
    if kind == "lvalue":
        return lookup(_lvalue_text(node))
    if kind == "unary":  # unary plus keeps its tree when lark cannot inline it
        return number(node.children[-1], lookup, call)
    if kind == "funcall" and call is not None:
        return call(node, lookup)
    return float("nan")


def _lvalue_text(node: Tree, env: dict | None = None) -> str | None:
    """NAME.FIELD or NAME[3].FIELD of an lvalue tree, upper case; None for other shapes.
    ``env``: FOR counters' values (NAME[I] in a pass with I = 3 is NAME[3])."""
    parts = [str(node.children[0]).upper()]
    for acc in node.children[1:]:
        child = acc.children[0] if len(acc.children) == 1 else None
        if isinstance(child, Token) and child.type == "NAME":
            parts.append("." + str(child).upper())
        elif isinstance(child, Tree) and child.data == "number":
            parts.append(f"[{int(float(child.children[0]))}]")
        elif env and isinstance(child, Tree) and child.data == "lvalue" and len(child.children) == 1 and str(child.children[0]).upper() in env:
            parts.append(f"[{env[str(child.children[0]).upper()]}]")
        else:
            return None
    return "".join(parts)


# BAS(#...) commands of KUKA's BAS.SRC that set velocities or accelerations only; every
# other one (#INITMOV: "initialization of velocities, accelerations, $BASE, $TOOL, etc.",
# #PTP_PARAMS / #CP_PARAMS / #FRAMES: $TOOL and $BASE from FDAT_ACT) may set the frames.
BAS_KEEPS_FRAMES = {"VEL_PTP", "ACC_PTP", "VEL_CP", "ACC_CP"}


class Replay:
    """Runs the events in program order (see the module's docstring).

    ``declared(key)`` is a point's declared state (None if it has no value), ``read_agg(event)``
    the Point an aggregate right-hand side gives, ``frame_value(event, current)`` the
    (name, transform or None) of any other frame expression."""

    def __init__(self, declared, read_agg, frame_value, call=None):
        self.declared, self.read_agg, self.frame_value = declared, read_agg, frame_value
        self.call = call  # function calls in expressions (functions.Caller), or None: not evaluated
        self.env: dict | None = None  # the counter of the FOR pass being replayed
        self.points: dict[str, Point] = {}
        self.frames = {"$BASE": Frame("<base>", np.zeros(6)), "$TOOL": Frame("<flange>", np.zeros(6))}
        self._seen: dict[str, np.ndarray | None] = {"<base>": np.zeros(6), "<flange>": np.zeros(6)}

    def current(self, key: str) -> Point | None:
        if key in self.points:
            return self.points[key]
        found = self.declared(key)
        return found

    def lookup(self, text: str | None) -> float:
        """A component (XP1.X, $BASE.Z) as it is now; NaN if unknown."""
        if text and self.env and text in self.env:  # the FOR counter of the pass (passes.py)
            return float(self.env[text])
        if not text or "." not in text:
            return float("nan")
        root, comp = text.rsplit(".", 1)
        if root in self.frames:
            pose = self.frames[root].pose
            return float(pose[_XYZABC[comp]]) if pose is not None and comp in _XYZABC else float("nan")
        point, code = self.current(root), FIELD_CODE.get(comp)
        return float(point.values[code]) if point is not None and point.known and code is not None else float("nan")

    def run(self, events: list[Event], exact_allowed: bool) -> Timeline:
        tl = Timeline()
        anytime = {ev.key for ev in events if ev.anytime or not exact_allowed}
        for key in anytime:  # unknown everywhere: no later line makes it known for sure
            if key in self.frames:
                tl.frames[key].append((0, Frame(f"{key} as changed at any time (subprogram or GOTO)", None)))
            elif key.endswith("["):
                tl.arrays[key] = 0
            else:
                tl.points[key] = [(0, Point.unknown())]
        for ev in sorted(events, key=lambda e: (e.offset, e.line_offset)):
            if ev.key in anytime:
                continue
            exact = ev.exact and ev.rhs is not None
            if self.call is not None:
                self.call.where = ev.line
            self.env = ev.env
            if ev.key in self.frames:
                self.frames[ev.key] = self._unique(self._frame(ev, exact), ev)
                tl.frames[ev.key].append((ev.offset, self.frames[ev.key]))
            elif ev.key.endswith("["):
                tl.arrays[ev.key] = min(tl.arrays.get(ev.key, ev.offset), ev.offset)
            else:
                self.points[ev.key] = self._point(ev, exact)
                tl.points.setdefault(ev.key, []).append((ev.offset, self.points[ev.key]))
        return tl

    def _unique(self, frame: Frame, ev: Event) -> Frame:
        """One name, one value: a name met again with another value (BASE_DATA[1] changed
        in between) gets the line, so the IR's frame table keeps both."""
        suffix = "".join(f", {k} = {v}" for k, v in (ev.env or {}).items())  # a FOR pass (passes.py)
        names = [frame.name, f"{frame.name} as on line {ev.line}{suffix}"]
        for name in chain(names, (f"{names[1]} ({k})" for k in count(2))):  # the first name free or holding this value
            seen = self._seen.setdefault(name, frame.pose)
            if (seen is None and frame.pose is None) or (seen is not None and frame.pose is not None and np.allclose(seen, frame.pose, rtol=0, atol=0)):
                return frame if name == frame.name else Frame(name, frame.pose)
        raise AssertionError("unreachable: count() does not end")

    def _point(self, ev: Event, exact: bool) -> Point:
        if not exact:
            return Point.unknown()
        now = self.current(ev.key)
        now = Point(np.full(NF, np.nan), np.full((NF, 3), -1, np.int64), np.full(4, np.nan), np.array([-1, -1])) if now is None else now.copy()
        if not now.known:
            return Point.unknown()
        if ev.field:
            value, code = number(ev.rhs, self.lookup, self.call), FIELD_CODE.get(ev.field)
            if code is None or np.isnan(value):
                return Point.unknown()
            now.values[code], now.spans[code] = value, -1  # no longer a number of the text
            return now
        if isinstance(ev.rhs, Tree) and ev.rhs.data == "aggregate":
            agg = self.read_agg(ev)
            given = ~np.isnan(agg.values)
            if (~given & ~np.isnan(now.values)).any():
                return Point.unknown()  # a component left out: not read here as kept or cleared
            now.values[given], now.spans[given] = agg.values[given], agg.spans[given]
            now.conf = np.where(np.isnan(agg.conf), now.conf, agg.conf)
            now.insert = agg.insert
            return now
        other = self.current(_lvalue_text(ev.rhs, ev.env) or "") if isinstance(ev.rhs, Tree) and ev.rhs.data == "lvalue" else None
        return other.copy() if other is not None else Point.unknown()

    def _frame(self, ev: Event, exact: bool) -> Frame:
        unknown = Frame(f"{ev.key} as changed on line {ev.line}", None)
        pose = self.frames[ev.key].pose
        if not exact:
            return unknown
        if ev.field:
            value = number(ev.rhs, self.lookup, self.call)
            if pose is None or ev.field not in _XYZABC or np.isnan(value):
                return unknown
            pose = pose.copy()
            pose[_XYZABC[ev.field]] = value
            return Frame(f"{ev.key} as set on line {ev.line}", pose)
        if isinstance(ev.rhs, Tree) and ev.rhs.data == "aggregate":
            given = self.read_agg(ev).values[:6]
            if np.isnan(given).any():
                return unknown  # a component left out: not read here as kept or cleared
            return Frame(ev.text, given)
        name, transform = self.frame_value(ev, self.current)  # BASE_DATA[1]: the name --frame may define
        return Frame(name, None if transform is None else pose_of(transform))


FIELD_CODE = {"X": 0, "Y": 1, "Z": 2, "A": 3, "B": 4, "C": 5, **{f"A{i}": 6 + i for i in range(1, 7)}, **{f"E{i}": 12 + i for i in range(1, 7)}}
