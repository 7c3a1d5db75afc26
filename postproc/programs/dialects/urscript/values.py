"""What a URScript expression evaluates to, where postproc can evaluate it: a pose or a joint
list of constants (with the spans of the numbers a compensated program rewrites), or the
reason it cannot be known from the text.

Evaluated (URScript manual, "Data types", "pose_trans", "pose_add", "get_inverse_kin"):
``p[x, y, z, rx, ry, rz]`` and ``[q1, ..., q6]`` of number literals, a variable holding one,
``pose_trans(F, X)`` with F constant (X is then read in the frame F), ``pose_add(C, X)`` /
``pose_add(X, C)`` where the constant C has no rotation (then it is a translation of X), and
``get_inverse_kin(X)`` / ``get_inverse_kin(X, qnear=Q)`` inside ``movej``. Anything else
(arithmetic, variables set at run time, other functions) is Unknown with its reason.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ..base import NUMBER
from .lexer import matching, split_arguments, strip
from .poses import pose_add_frame, pose_to_transform, pose_trans

_NUMBER = re.compile(rf"{NUMBER}\Z")
_NAME = re.compile(r"[A-Za-z_]\w*\Z")
_CALL = re.compile(r"([A-Za-z_]\w*)\s*\(")


@dataclass(frozen=True)
class Value:
    """A pose (``is_pose``: m, rad) or joint list (rad) of six numbers as the text writes them."""

    is_pose: bool
    numbers: np.ndarray  # (6,) as written
    spans: np.ndarray  # (6, 2) file offsets of each number, -1 where it is not a literal's
    frame: np.ndarray = field(default_factory=lambda: np.eye(4))  # base_T_frame (mm) the pose is read in
    frame_name: str = "<base>"
    name: str = ""  # the variable it was read from ('' for a literal)
    qnear: np.ndarray | None = None  # get_inverse_kin's qnear (rad), where given

    def transform(self) -> np.ndarray:
        """(4, 4) base_T_pose in mm (a pose only)."""
        return self.frame @ pose_to_transform(self.numbers)[0]


@dataclass(frozen=True)
class Scalar:
    """A variable holding one number literal (``global z_safe = 0.25``): a pose or joint list
    that names it takes the number and its span (write-back rewrites the assignment)."""

    number: float
    span: tuple[int, int]


@dataclass(frozen=True)
class Unknown:
    reason: str


class Evaluator:
    """Evaluates expressions of one masked text against the variables set so far."""

    def __init__(self, mask: str, where):
        self.mask = mask
        self.where = where  # offset -> 'line L, column C' for reasons

    def evaluate(self, start: int, end: int, env: dict, scalar: bool = False) -> Value | Scalar | Unknown:
        """The value of mask[start:end]; a number literal is a Scalar only where ``scalar``
        (the right side of an assignment), elsewhere a pose or joint list is wanted."""
        start, end = strip(self.mask, start, end)
        text = self.mask[start:end]
        if scalar and start < end and _NUMBER.match(self.mask, start, end):
            return Scalar(float(text), (start, end))
        if text.startswith("p[") or text.startswith("p ["):
            opener = self.mask.index("[", start)
            return self._literal(opener, end, env, is_pose=True)
        if text.startswith("["):
            return self._literal(start, end, env, is_pose=False)
        if _NAME.match(text):
            held = env.get(text)
            if held is None:
                return Unknown(f"'{text}' is not set to a constant before {self.where(start)}")
            if isinstance(held, Value):
                return Value(held.is_pose, held.numbers, held.spans, held.frame, held.frame_name, text, held.qnear)
            if isinstance(held, Scalar):
                return Unknown(f"'{text}' at {self.where(start)} is a number, not a pose or joint list")
            return held
        call = _CALL.match(text)
        if call and matching(self.mask, start + call.end() - 1) == end - 1:
            return self._call(call.group(1), start + call.end(), end - 1, env, start)
        return Unknown(f"'{_short(text)}' at {self.where(start)} is an expression postproc does not evaluate")

    def _literal(self, opener: int, end: int, env: dict, is_pose: bool) -> Value | Unknown:
        close = matching(self.mask, opener)
        if close != end - 1:
            return Unknown(f"'{_short(self.mask[opener:end])}' at {self.where(opener)} is not one list literal")
        items = split_arguments(self.mask, opener + 1, close)
        if len(items) != 6:
            return Unknown(f"a {'pose' if is_pose else 'joint list'} at {self.where(opener)} has {len(items)} values, not 6")
        numbers, spans = np.full(6, np.nan), np.full((6, 2), -1, dtype=np.int64)
        for k, (s, e) in enumerate(items):
            s, e = strip(self.mask, s, e)
            held = env.get(self.mask[s:e]) if _NAME.match(self.mask, s, e) else None
            if isinstance(held, Scalar):  # a variable holding a number literal: its number, its span
                numbers[k], spans[k] = held.number, held.span
                continue
            if s == e or not _NUMBER.match(self.mask, s, e):
                return Unknown(f"value {k + 1} of the {'pose' if is_pose else 'joint list'} at {self.where(s)} ('{_short(self.mask[s:e])}') is not a number")
            numbers[k] = float(self.mask[s:e])
            spans[k] = (s, e)
        return Value(is_pose, numbers, spans)

    def _call(self, function: str, start: int, end: int, env: dict, at: int) -> Value | Unknown:
        args = split_arguments(self.mask, start, end)
        positional = [a for a in args if not re.match(r"\s*\w+\s*=[^=]", self.mask[a[0] : a[1]])]
        named = {m.group(1): (a[0] + m.end(), a[1]) for a in args if (m := re.match(r"\s*(\w+)\s*=(?!=)", self.mask[a[0] : a[1]]))}
        if function == "pose_trans" and len(args) == 2 and not named:
            return self._pose_trans(*[self.evaluate(s, e, env) for s, e in args], at)
        if function == "pose_add" and len(args) == 2 and not named:
            return self._pose_add(*[self.evaluate(s, e, env) for s, e in args], at)
        if function == "get_inverse_kin" and len(positional) == 1 and set(named) <= {"qnear"}:
            return self._inverse_kin(positional[0], named.get("qnear"), env, at)
        return Unknown(f"{function}(...) at {self.where(at)} is not evaluated by postproc (only pose_trans, pose_add and get_inverse_kin of constants are)")

    def _pose_trans(self, frame: Value | Unknown, pose: Value | Unknown, at: int) -> Value | Unknown:
        for value in (frame, pose):
            if isinstance(value, Unknown):
                return value
            if not value.is_pose:
                return Unknown(f"pose_trans at {self.where(at)} is given a joint list, not a pose")
        name = frame.name or f"pose_trans@{self.where(at)}"
        return Value(True, pose.numbers, pose.spans, pose_trans(frame.transform(), pose.frame), name if pose.frame_name == "<base>" else f"{name}+{pose.frame_name}", pose.name)

    def _pose_add(self, first: Value | Unknown, second: Value | Unknown, at: int) -> Value | Unknown:
        for value in (first, second):
            if isinstance(value, Unknown):
                return value
            if not value.is_pose:
                return Unknown(f"pose_add at {self.where(at)} is given a joint list, not a pose")
        # The constant is the operand whose numbers postproc does not rewrite: a variable
        # (a frame the program names) where the other is a literal, else the first.
        target, constant = (first, second) if (second.name and not first.name) else (second, first)
        shift = pose_add_frame(constant.transform())
        if shift is None:
            return Unknown(f"pose_add at {self.where(at)}: neither pose is a pure translation, so the result is no frame of the other (position p1+p2, rotation R1.R2)")
        name = (constant.name or f"pose_add@{self.where(at)}")
        return Value(True, target.numbers, target.spans, shift @ target.frame, name if target.frame_name == "<base>" else f"{name}+{target.frame_name}", target.name)

    def _inverse_kin(self, pose_span, qnear_span, env: dict, at: int) -> Value | Unknown:
        pose = self.evaluate(*pose_span, env)
        if isinstance(pose, Unknown) or not pose.is_pose:
            return pose if isinstance(pose, Unknown) else Unknown(f"get_inverse_kin at {self.where(at)} is given a joint list, not a pose")
        if qnear_span is None:
            return pose
        qnear = self.evaluate(*qnear_span, env)
        if isinstance(qnear, Unknown) or qnear.is_pose:
            return qnear if isinstance(qnear, Unknown) else Unknown(f"get_inverse_kin's qnear at {self.where(at)} is a pose, not a joint list")
        return Value(True, pose.numbers, pose.spans, pose.frame, pose.frame_name, pose.name, qnear.numbers)


def _short(text: str, width: int = 40) -> str:
    text = " ".join(text.split())
    return text if len(text) <= width else text[: width - 3] + "..."
