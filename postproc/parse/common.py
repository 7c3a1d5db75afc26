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
    dot = raw == ord(".")
    body = digit | dot
    # Exponents: e/E followed by digits (optionally signed) right after a body run.
    e_mark = ((raw == ord("e")) | (raw == ord("E")))
    prev_body = np.concatenate([[False], body[:-1]])
    nxt = np.concatenate([raw[1:], [0]])
    nxt2 = np.concatenate([raw[2:], [0, 0]])
    exp_start = e_mark & prev_body & (_DIGIT[nxt] | (((nxt == ord("+")) | (nxt == ord("-"))) & _DIGIT[nxt2]))
    exp_sign = np.concatenate([[False], exp_start[:-1]]) & ((raw == ord("+")) | (raw == ord("-")))
    numchar = body | exp_start | exp_sign
    # Exponent digits continue the run naturally (they are digits).
    start_mask = numchar & ~np.concatenate([[False], numchar[:-1]])
    end_mask = numchar & ~np.concatenate([numchar[1:], [False]])
    starts = np.nonzero(start_mask)[0]
    ends = np.nonzero(end_mask)[0] + 1
    # A run must contain a digit and may not be a lone dot or glued to a name.
    has_digit = np.add.reduceat(digit.astype(np.int32), starts) > 0 if len(starts) else np.zeros(0, bool)
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
    signed = has_sign & ~binary
    starts = np.where(signed, starts - 1, starts)
    buf = np.full(n, ord(" "), dtype=np.uint8)
    idx = _ranges(starts, ends)
    buf[idx] = raw[idx]
    tokens = buf.tobytes().split()
    try:
        values = np.array(tokens, dtype=float) if len(starts) else np.zeros(0)
    except ValueError:
        # A malformed run such as '1e5e3' or '.e1' is no number: NaN (the grammar rejects it).
        values = np.array([_to_float(t) for t in tokens], dtype=float)
    return Numbers(starts.astype(np.int64), ends.astype(np.int64), values)


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

    def tool_index(self, name: str, transform: np.ndarray | None) -> int:
        key = name
        if key in self.tool_names:
            i = self.tool_names.index(key)
            if transform is not None:
                self.tools[i] = transform
            return i
        self.tool_names.append(key)
        self.tools.append(np.eye(4) if transform is None else transform)
        return len(self.tool_names) - 1

    def frame_index(self, name: str, transform: np.ndarray | None) -> int:
        if name in self.frame_names:
            i = self.frame_names.index(name)
            if transform is not None:
                self.frames[i] = transform
            return i
        self.frame_names.append(name)
        self.frames.append(np.eye(4) if transform is None else transform)
        return len(self.frame_names) - 1

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
        cols = {}
        for key, (dtype, fill) in defaults.items():
            cols[key] = np.full((total,) + shapes.get(key, ()), fill, dtype=dtype)
        order = np.zeros(total, dtype=np.int64)
        file_key = np.zeros(total, dtype=np.int64)
        pos = 0
        for b in self.blocks:
            n = len(b["order"])
            order[pos : pos + n] = b["order"]
            for key, arr in b.items():
                if key == "order":
                    continue
                cols[key][pos : pos + n] = arr
            file_key[pos : pos + n] = cols["file"][pos : pos + n]
            pos += n
        # Program order: the main program's statements by offset (targets of the main file).
        perm = np.lexsort((order, np.zeros(total)))
        cols = {k: v[perm] for k, v in cols.items()}
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
            offset=cols["offset"],
            offset_span=cols["offset_span"],
            notes=tuple(self.notes),
        )


__all__ = ["FIELDS", "Builder", "Kind", "LineIndex", "Numbers", "scan_numbers"]
