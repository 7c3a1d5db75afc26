"""What every dialect's parser shares: number spans found in one vectorised pass, line and
column lookup for error messages, and the builder that assembles a Toolpath."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ParseError
from ..ir import FIELDS, NF, Kind, SourceDoc, Toolpath

_DIGIT = np.zeros(256, dtype=bool)
_DIGIT[ord("0") : ord("9") + 1] = True
_WORD = np.zeros(256, dtype=bool)  # characters that make a number part of an identifier
for _c in range(256):
    ch = chr(_c)
    if ch.isalnum() or ch in "_$.":
        _WORD[_c] = True


@dataclass(frozen=True)
class Numbers:
    """All free-standing numbers of a text: start, end offsets and values, in text order."""

    start: np.ndarray
    end: np.ndarray
    value: np.ndarray

    def between(self, lo: int, hi: int) -> slice:
        return slice(int(np.searchsorted(self.start, lo)), int(np.searchsorted(self.start, hi)))


def scan_numbers(text: str, letter_prefix: bool = False) -> Numbers:
    """Every decimal number in ``text`` that is not part of an identifier, with its sign.

    ``letter_prefix``: a number right after a letter counts (G-code words like X-10.5);
    otherwise digits glued to a letter belong to a name (p10, tool0, E1).
    """
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    n = len(raw)
    if n == 0:
        empty = np.zeros(0, dtype=np.int64)
        return Numbers(empty, empty, np.zeros(0))
    digit = _DIGIT[raw]
    numchar = digit | (raw == ord("."))
    # Exponents (1e5, 9E-3) are rare: look only at the e/E that follow a digit or dot.
    cand = np.nonzero(((raw == ord("e")) | (raw == ord("E")))[1:-1] & numchar[:-2])[0] + 1
    if len(cand):
        nxt = raw[cand + 1]
        nxt2 = raw[np.minimum(cand + 2, n - 1)]
        signed = ((nxt == ord("+")) | (nxt == ord("-"))) & _DIGIT[nxt2] & (cand + 2 < n)
        ok = _DIGIT[nxt] | signed
        numchar[cand[ok]] = True
        numchar[cand[ok & signed] + 1] = True
    start_mask = numchar.copy()
    start_mask[1:] &= ~numchar[:-1]
    end_mask = numchar.copy()
    end_mask[:-1] &= ~numchar[1:]
    starts = np.nonzero(start_mask)[0]
    ends = np.nonzero(end_mask)[0] + 1
    del start_mask, end_mask
    # A run must contain a digit and may not be glued to a name.
    digits_before = np.concatenate([[0], np.cumsum(digit, dtype=np.int32)])
    has_digit = digits_before[ends] > digits_before[starts]
    del digits_before, digit
    before = np.where(starts > 0, raw[np.maximum(starts - 1, 0)], 32)
    glued = _WORD[before] & (starts > 0)
    if letter_prefix:
        glued = glued & ~(((before | 32) >= ord("a")) & ((before | 32) <= ord("z")))
    keep = has_digit & ~glued
    starts, ends = starts[keep], ends[keep]
    # A sign right before the number belongs to it when it is not a binary operator.
    sign_pos = starts - 1
    has_sign = (sign_pos >= 0) & np.isin(raw[np.maximum(sign_pos, 0)], (ord("-"), ord("+")))
    before_sign = np.where(sign_pos > 0, raw[np.maximum(sign_pos - 1, 0)], 32)
    binary = _WORD[before_sign] & ~(letter_prefix & (((before_sign | 32) >= ord("a")) & ((before_sign | 32) <= ord("z"))))
    binary |= before_sign == ord(")")
    binary &= sign_pos > 0
    starts = np.where(has_sign & ~binary, starts - 1, starts)
    # Blank everything but the numbers and let NumPy's C parser read them in one call.
    # Runs are maximal, so no run starts where another ends: plain assignment is exact.
    edge = np.zeros(n + 1, dtype=np.int8)
    edge[starts] = 1
    edge[ends] = -1
    inside = np.cumsum(edge[:-1], dtype=np.int8).view(bool)
    buf = np.where(inside, raw, np.uint8(32))
    values = _read_floats(buf.tobytes(), len(starts))
    return Numbers(starts.astype(np.int64), ends.astype(np.int64), values)


def _read_floats(buf: bytes, count: int) -> np.ndarray:
    """Space-separated numbers -> array; a malformed run ('1e5e3', '.e1') becomes NaN."""
    if count == 0:
        return np.zeros(0)
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            values = np.fromstring(buf, dtype=float, sep=" ")
    except ValueError:  # NumPy 2.4 raises where older versions warned and stopped
        values = np.zeros(0)
    if len(values) == count:
        return values
    return np.array([_to_float(t) for t in buf.split()], dtype=float)


def _to_float(token: bytes) -> float:
    try:
        return float(token)
    except ValueError:
        return float("nan")


def _ranges(starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Concatenated np.arange(s, e) for all pairs, without a Python loop."""
    lengths = ends - starts
    if len(lengths) == 0:
        return np.zeros(0, dtype=np.int64)
    offsets = np.repeat(starts - np.concatenate([[0], np.cumsum(lengths)[:-1]]), lengths)
    return np.arange(lengths.sum()) + offsets


def parse_statement(parser, text: str, lines: "LineIndex", path: str, start: int, what: str):
    """Parse one statement with a lark parser; any failure is a ParseError at its file position.

    ``start`` is the statement's offset in the file, so lark's position inside the
    statement becomes the file's line and column."""
    from lark.exceptions import LarkError, UnexpectedCharacters, UnexpectedInput

    try:
        return parser.parse(text)
    except UnexpectedInput as exc:
        pos = getattr(exc, "pos_in_stream", None)
        if pos is None:
            pos = (getattr(exc, "column", 1) or 1) - 1
        kind = "unexpected character" if isinstance(exc, UnexpectedCharacters) else "unexpected token"
        raise lines.error(path, start + pos, f"{kind}: cannot parse this {what}") from None
    except LarkError as exc:
        raise lines.error(path, start, f"cannot parse this {what} ({exc})") from None


class LineIndex:
    """Offsets <-> 1-based line and column numbers."""

    def __init__(self, text: str):
        raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
        self.starts = np.concatenate([[0], np.nonzero(raw == 10)[0] + 1]).astype(np.int64)
        self.text = text

    def line(self, offset) -> np.ndarray | int:
        return np.searchsorted(self.starts, offset, side="right")

    def error(self, path: str, offset: int, message: str) -> ParseError:
        line = int(self.line(offset))
        start = int(self.starts[line - 1])
        end = self.text.find("\n", start)
        excerpt = self.text[start : end if end >= 0 else len(self.text)].rstrip("\r")
        return ParseError(path, line, offset - start + 1, message, excerpt[:200])


@dataclass
class Builder:
    """Collects targets row by row (slow path) or in blocks (fast path), then freezes them."""

    dialect: str
    orientation_kind: str
    sources: list[SourceDoc]
    tool_names: list[str] = field(default_factory=lambda: ["<flange>"])
    tools: list[np.ndarray] = field(default_factory=lambda: [np.eye(4)])
    frame_names: list[str] = field(default_factory=lambda: ["<base>"])
    frames: list[np.ndarray] = field(default_factory=lambda: [np.eye(4)])
    blocks: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    tool_known: list[bool] = field(default_factory=lambda: [True])
    frame_known: list[bool] = field(default_factory=lambda: [True])

    @staticmethod
    def _register(names, values, known, name, transform, is_known):
        """Index of a named frame/tool; a None transform is unknown (identity stands in, flagged)."""
        is_known = transform is not None if is_known is None else is_known
        if name in names:
            i = names.index(name)
            if transform is not None:
                values[i] = transform
                known[i] = is_known
            return i
        names.append(name)
        values.append(np.eye(4) if transform is None else transform)
        known.append(is_known)
        return len(names) - 1

    def tool_index(self, name: str, transform: np.ndarray | None, known: bool | None = None) -> int:
        return self._register(self.tool_names, self.tools, self.tool_known, name, transform, known)

    def frame_index(self, name: str, transform: np.ndarray | None, known: bool | None = None) -> int:
        return self._register(self.frame_names, self.frames, self.frame_known, name, transform, known)

    def add_block(self, order: np.ndarray, **arrays) -> None:
        """Targets whose program order is given by ``order`` (their statement offsets)."""
        self.blocks.append({"order": np.asarray(order, dtype=np.int64), **arrays})

    def add(self, order: int, **values) -> None:
        self.add_block(np.array([order]), **{k: np.asarray(v)[None] for k, v in values.items()})

    def build(self) -> Toolpath:
        defaults = {
            "file": (np.int16, 0),
            "kind": (np.int8, 0),
            "line": (np.int32, 0),
            "values": (float, np.nan),
            "spans": (np.int64, -1),
            "scale": (float, 1.0),
            "relative": (bool, False),
            "conf": (float, np.nan),
            "speed": (float, np.nan),
            "zone": (float, np.nan),
            "tool": (np.int32, 0),
            "frame": (np.int32, 0),
            "resolved": (bool, True),
            "name": (object, ""),
            "insert_at": (np.int64, -1),
            "offset": (float, 0.0),
            "offset_span": (np.int64, -1),
        }
        shapes = {"values": (NF,), "spans": (NF, 3), "scale": (NF,), "conf": (4,), "insert_at": (2,), "offset": (NF,), "offset_span": (NF, 3)}
        total = sum(len(b["order"]) for b in self.blocks)
        order = np.concatenate([b["order"] for b in self.blocks]) if self.blocks else np.zeros(0, np.int64)
        # Program order is statement order; most programs arrive sorted and need no copy.
        perm = None if total < 2 or bool(np.all(order[1:] >= order[:-1])) else np.argsort(order, kind="stable")
        cols = {}
        for key, (dtype, fill) in defaults.items():
            shape = shapes.get(key, ())
            parts = [np.asarray(b[key], dtype=dtype) if key in b else np.broadcast_to(np.array(fill, dtype=dtype), (len(b["order"]),) + shape) for b in self.blocks]
            if not parts:
                col = np.full((0,) + shape, fill, dtype=dtype)
            elif len(parts) == 1:
                col = parts[0]
            else:
                col = np.concatenate(parts)
            cols[key] = col if perm is None else col[perm]
        values = cols["values"]
        from ..frames import abc_to_matrix, matrix_to_quat_wxyz

        position = values[:, 0:3].copy()
        if self.orientation_kind == "quat":
            orientation = values[:, 3:7].copy()
            norm = np.linalg.norm(orientation, axis=1, keepdims=True)
            orientation = np.where(norm > 0, orientation / np.where(norm > 0, norm, 1), np.nan)
        elif self.orientation_kind == "abc":
            orientation = np.full((total, 4), np.nan)
            ok = ~np.isnan(values[:, 3:6]).any(axis=1)
            if ok.any():
                orientation[ok] = matrix_to_quat_wxyz(abc_to_matrix(values[ok, 3:6]))
        else:
            orientation = np.full((total, 4), np.nan)
        return Toolpath(
            dialect=self.dialect,
            sources=tuple(self.sources),
            kind=cols["kind"],
            line=cols["line"],
            file=cols["file"],
            position=position,
            orientation=orientation,
            orientation_kind=self.orientation_kind,
            joints=values[:, 7:13].copy(),
            ext=values[:, 13:19].copy(),
            conf=cols["conf"],
            speed=cols["speed"],
            zone=cols["zone"],
            tool=cols["tool"],
            frame=cols["frame"],
            tools=np.array(self.tools, dtype=float).reshape(-1, 4, 4),
            tool_names=tuple(self.tool_names),
            frames=np.array(self.frames, dtype=float).reshape(-1, 4, 4),
            frame_names=tuple(self.frame_names),
            resolved=cols["resolved"],
            target_name=tuple(cols["name"].tolist()),
            spans=cols["spans"],
            scale=cols["scale"],
            relative=cols["relative"],
            values=values,
            insert_at=cols["insert_at"],
            frame_known=np.array(self.frame_known, dtype=bool),
            tool_known=np.array(self.tool_known, dtype=bool),
            offset=cols["offset"],
            offset_span=cols["offset_span"],
            notes=tuple(self.notes),
        )


__all__ = ["FIELDS", "Builder", "Kind", "LineIndex", "Numbers", "scan_numbers"]
