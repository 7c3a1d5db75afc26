"""The bulk of a long URScript program, read without a Python step per line.

CAM and offline-programming output is mostly one line shape repeated: ``movel(p[x, y, z,
rx, ry, rz], a=..., v=..., r=...)`` with literal numbers. Such a line changes nothing but
the robot's position, so every one of them takes the state (TCP, posture) the statements
before it left; the parser (parse.py) walks only the other statements and hands each run of
bulk lines between two of them to ``rows`` with that state. The lines are found by shape
(postproc.programs.parse.line_shapes: one regular-expression match per distinct shape) and their
numbers by the compiled number scan, so the cost per line is a few array operations.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ...ir import F_POS, NF, Kind
from ...parse.common import scan_numbers
from ...parse.line_shapes import LineShapes
from .poses import M_TO_MM

_NUM = r"-?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"  # digit runs only through \d+ / \d* (line_shapes)
_SEP = r"[ \t]*,[ \t]*"
BULK_LINE = re.compile(
    rf"[ \t]*(?P<function>movel|movep)[ \t]*\([ \t]*p[ \t]*\[[ \t]*"
    + _SEP.join(f"(?P<n{k}>{_NUM})" for k in range(6))
    + rf"[ \t]*\](?:{_SEP}a[ \t]*=[ \t]*(?P<a>{_NUM}))?(?:{_SEP}v[ \t]*=[ \t]*(?P<v>{_NUM}))?"
    rf"(?:{_SEP}r[ \t]*=[ \t]*(?P<r>{_NUM}))?[ \t]*\)[ \t]*\r?"
)
DEFAULT = {"a": 1.2, "v": 0.25, "r": 0.0}  # movel / movep defaults (URScript manual, "movel", "movep")


@dataclass(frozen=True)
class BulkLines:
    """The bulk lines of one text, in text order: where they start (file offset), their line
    number (1-based), and per line its six pose numbers' spans and values and a, v, r."""

    start: np.ndarray  # (B,)
    line: np.ndarray  # (B,)
    spans: np.ndarray  # (B, 6, 2)
    numbers: np.ndarray  # (B, 6) as written
    accel: np.ndarray
    speed: np.ndarray
    blend: np.ndarray
    process: np.ndarray  # movep

    def __len__(self) -> int:
        return len(self.start)

    def between(self, lo: int, hi: int) -> slice:
        return slice(int(np.searchsorted(self.start, lo)), int(np.searchsorted(self.start, hi)))


def find(mask: str, line_starts: np.ndarray) -> BulkLines:
    raw = np.frombuffer(mask.encode("latin-1"), dtype=np.uint8)
    found = LineShapes(mask, raw, line_starts).match(BULK_LINE)
    numbers = scan_numbers(mask, raw=raw)
    spans = np.stack([np.stack(found.span(f"n{k}"), axis=1) for k in range(6)], axis=1) if len(found) else np.zeros((0, 6, 2), np.int64)
    values = _values(mask, numbers, spans.reshape(-1, 2)).reshape(-1, 6)
    options = {}
    for key in ("a", "v", "r"):
        s, e = found.span(key) if len(found) else (np.zeros(0, np.int64), np.zeros(0, np.int64))
        given = s >= 0
        column = np.full(len(found), DEFAULT[key])
        column[given] = _values(mask, numbers, np.stack([s[given], e[given]], axis=1))
        options[key] = column
    function = found.factorize("function") if len(found) else (np.zeros(0, np.int64), [])
    process = np.array([name.lower() == "movep" for name in function[1]], dtype=bool)[function[0]] if len(found) else np.zeros(0, bool)
    return BulkLines(found.start, found.line + 1, spans, values, options["a"], options["v"], options["r"], process)


def _values(mask: str, numbers, spans: np.ndarray) -> np.ndarray:
    """The values of the numbers at ``spans`` (M, 2), from the number scan (Python's float where
    the scan saw the number otherwise)."""
    at = np.searchsorted(numbers.start, spans[:, 0])
    at = np.minimum(at, max(len(numbers.start) - 1, 0))
    same = (len(numbers.start) > 0) & (numbers.start[at] == spans[:, 0]) & (numbers.end[at] == spans[:, 1]) if len(spans) else np.zeros(0, bool)
    out = np.where(same, numbers.value[at] if len(numbers.start) else np.nan, np.nan)
    for i in np.nonzero(~same)[0].tolist():
        out[i] = float(mask[spans[i, 0] : spans[i, 1]])
    return out


def rows(bulk: BulkLines, sel: slice, tool: int, resolved: bool) -> dict:
    """Builder block columns of the bulk lines ``sel`` under the TCP ``tool``."""
    n = sel.stop - sel.start
    values = np.full((n, NF), np.nan)
    values[:, F_POS] = bulk.numbers[sel, :3] * M_TO_MM
    values[:, 3:6] = bulk.numbers[sel, 3:]
    scale = np.ones((n, NF))
    scale[:, F_POS] = M_TO_MM
    spans = np.full((n, NF, 3), -1, dtype=np.int64)
    spans[:, :6, 0] = 0
    spans[:, :6, 1:] = bulk.spans[sel]
    return {"order": bulk.start[sel] * 2, "kind": np.full(n, Kind.LINEAR, np.int8), "line": bulk.line[sel].astype(np.int32), "values": values,
            "spans": spans, "scale": scale, "speed": bulk.speed[sel], "zone": bulk.blend[sel] * M_TO_MM, "tool": np.full(n, tool, np.int32),
            "resolved": np.full(n, resolved), "urscript.accel": bulk.accel[sel], "urscript.blend_m": bulk.blend[sel],
            "urscript.time_s": np.zeros(n), "urscript.process_move": bulk.process[sel]}
