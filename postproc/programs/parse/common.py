"""What every dialect's parser shares: number spans found in one vectorised pass, line and
column lookup for error messages, and the builder that assembles a Toolpath."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from lark.exceptions import LarkError, UnexpectedCharacters, UnexpectedInput

from postproc.errors import ParseError

from .. import rotation_forms
from ..ir import FIELDS, NF, Kind, SourceDoc, Toolpath
from . import scan_kernel


@dataclass(frozen=True)
class Numbers:
    """All free-standing numbers of a text: start, end offsets and values, in text order."""

    start: np.ndarray
    end: np.ndarray
    value: np.ndarray

    def between(self, lo: int, hi: int) -> slice:
        return slice(int(np.searchsorted(self.start, lo)), int(np.searchsorted(self.start, hi)))


def scan_numbers(text: str, letter_prefix: bool = False, raw: np.ndarray | None = None) -> Numbers:
    """Every decimal number in ``text`` that is not part of an identifier, with its sign.

    ``letter_prefix``: a number right after a letter counts (G-code words like X-10.5);
    otherwise digits glued to a letter belong to a name (p10, tool0, E1). A run that is
    not a valid number ('1e5e3', '1.2.3') has the value NaN. ``raw``: the text's Latin-1
    bytes where the caller has them already (a 100 MB text is not encoded twice).
    """
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8) if raw is None else raw
    starts, ends, values, status = scan_kernel.scan(raw, letter_prefix)
    for i in np.nonzero(status == scan_kernel.SLOW)[0].tolist():
        values[i] = float(text[starts[i] : ends[i]])  # beyond the exact fast path: Python rounds
    return Numbers(starts, ends, values)


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

    def position(self, offset: int) -> tuple[int, int]:
        """(line, column), both 1-based, of one offset."""
        line = int(self.line(offset))
        return line, offset - int(self.starts[line - 1]) + 1

    def error(self, path: str, offset: int, message: str) -> ParseError:
        line, column = self.position(offset)
        start = int(self.starts[line - 1])
        end = self.text.find("\n", start)
        excerpt = self.text[start : end if end >= 0 else len(self.text)].rstrip("\r")
        return ParseError(path, line, column, message, excerpt[:200])


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
    # A language's own per-target columns (Toolpath.extras): name -> (dtype, fill, shape of one
    # row); a block gives one under its name, a block that does not gets the fill.
    extra_columns: dict[str, tuple] = field(default_factory=dict)
    # Extras left out of the Toolpath where no block gives them (the program never states them)
    optional_extras: set[str] = field(default_factory=set)

    def declare_extra(self, name: str, dtype, fill, shape: tuple = (), optional: bool = False) -> None:
        """A per-target column only this language (or family: ``"nc."``) has (``"<dialect>.<what>"``),
        kept in Toolpath.extras; ``optional``: left out where no block of the program gives it."""
        self.extra_columns[name] = (dtype, fill, tuple(shape))
        if optional:
            self.optional_extras.add(name)

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

    def build(self, orientation: bool = True) -> Toolpath:
        """The Toolpath; ``orientation=False`` leaves orientations NaN for a caller that
        computes them itself (KRL fills partial aggregates first)."""
        cols = self._columns()
        values = cols["values"]
        return Toolpath(
            dialect=self.dialect,
            sources=tuple(self.sources),
            kind=cols["kind"],
            line=cols["line"],
            file=cols["file"],
            position=values[:, 0:3].copy(),
            orientation=self._orientations(values) if orientation else np.full((len(values), 4), np.nan),
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
            extras={name: cols[name] for name in self.extra_columns if cols[name] is not None},
        )

    def _columns(self) -> dict[str, np.ndarray | None]:
        """Every per-target column, joined over the blocks in program order (defaults where a block has none)."""
        total = sum(len(b["order"]) for b in self.blocks)
        order = np.concatenate([b["order"] for b in self.blocks]) if self.blocks else np.zeros(0, np.int64)
        # Program order is statement order; most programs arrive sorted and need no copy.
        perm = None if total < 2 or bool(np.all(order[1:] >= order[:-1])) else np.argsort(order, kind="stable")
        cols = {}
        columns = {key: (dtype, fill, _COLUMN_SHAPES.get(key, ())) for key, (dtype, fill) in _COLUMN_DEFAULTS.items()}
        for key, (dtype, fill, shape) in {**columns, **self.extra_columns}.items():
            if (key in ("offset", "offset_span") or key in self.optional_extras) and not any(key in b for b in self.blocks):
                cols[key] = None  # no Offs in this program: 600 bytes a target saved
                continue
            parts = [np.asarray(b[key], dtype=dtype) if key in b else np.broadcast_to(np.array(fill, dtype=dtype), (len(b["order"]),) + shape) for b in self.blocks]
            if not parts:
                col = np.full((0,) + shape, fill, dtype=dtype)
            elif len(parts) == 1:
                col = parts[0]
            else:
                col = np.concatenate(parts)
            cols[key] = col if perm is None else col[perm]
        return cols

    def _orientations(self, values: np.ndarray) -> np.ndarray:
        """(N, 4) unit quaternions from the orientation numbers in the dialect's notation (NaN where none)."""
        return rotation_forms.form(self.orientation_kind).quaternions(values[:, 3:])


# Per-target columns of the builder: dtype and the value a block that gives none gets.
_COLUMN_DEFAULTS = {
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
_COLUMN_SHAPES = {"values": (NF,), "spans": (NF, 3), "scale": (NF,), "conf": (4,), "insert_at": (2,), "offset": (NF,), "offset_span": (NF, 3)}


__all__ = ["FIELDS", "Builder", "Kind", "LineIndex", "Numbers", "scan_numbers"]
