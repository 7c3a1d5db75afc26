"""A VAL3 application's data file (.dtx): its variables and every number's place in the text.

The .dtx is XML (VAL3 reference manual, "Application data"; Stäubli Robotics Suite writes it):
``<Data name="pPick" type="pointRx" size="2">`` holds one ``<Value key="i" .../>`` per
element, each field an attribute: ``x y z rx ry rz`` (mm, degrees), ``shoulder elbow
wrist`` (the point's config), ``fatherId="fTable[0]"`` (the frame or tool it is linked to),
``j1``..``j6`` (jointRx), ``accel vel decel tmax rmax blend leave reach`` (mdesc). The
texts are read with regular expressions, not an XML parser, because every number's offset
in the file is needed to write it back in place (an XML parser gives none).

A data file of a long program holds a <Value> per point: their numbers are read in one
vectorised pass (``NUMERIC``: value and span of each), their words (config, fatherId) in
another; an element's other attributes are read when asked for (``Element.attrs``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ...errors import ParseError
from ...parse.common import LineIndex, scan_numbers

_TAG = re.compile(r"<(Data|Value)\b((?:[^>\"]|\"[^\"]*\")*?)(/?)>|</Data\s*>|<!--.*?-->", re.DOTALL)
_FAST_TAG = re.compile(r"<(Data|Value)\b([^>]*?)(/?)>|</Data\s*>|<!--.*?-->", re.DOTALL)
_ATTR = re.compile(r"([\w:]+)\s*=\s*\"([^\"]*)\"")
_FATHER = re.compile(r"^(\w+)\[([\d\s,]+)\]$")
_INDEX = re.compile(r"\d+(?:\s*,\s*\d+)*$")
_KEY = re.compile(r"\s+key\s*=\s*\"([^\"]*)\"")
#: the numeric fields read in bulk, in this column order (x..rz -> FIELDS 0..5, j1..j6 -> 7..12)
NUMERIC = ("x", "y", "z", "rx", "ry", "rz", "j1", "j2", "j3", "j4", "j5", "j6")
_NUMERIC_ATTR = re.compile(r"\s(x|y|z|rx|ry|rz|j[1-6])=\"")
_WORD_ATTR = re.compile(r"\s(shoulder|elbow|wrist|fatherId)=\"([^\"]*)\"")


def index_text(text: str) -> str:
    """An element index as the data file's keys write it: "3", "1,2"."""
    return ",".join(part.strip() for part in text.split(","))


@dataclass
class Element:
    """One element of a data array. ``attrs``: its attributes as (text, start, end) in the file."""

    datum: str  # the variable's name
    type: str  # pointRx, jointRx, frame, tool, mdesc, ...
    key: str  # "3", or "1,2" in a two-dimensional array
    offset: int  # where the <Value tag starts (-1: declared without a <Value>, all defaults)
    source: str = field(default="", repr=False)  # the file's text
    inner: tuple[int, int] = (0, 0)  # the tag's attributes: text[inner[0]:inner[1]]
    tag: int = -1  # index into the database's bulk tables

    @property
    def name(self) -> str:
        return f"{self.datum}[{self.key}]"

    @cached_property
    def attrs(self) -> dict[str, tuple[str, int, int]]:
        start, end = self.inner  # (match offsets are the file's: finditer is given pos, endpos)
        return {a.group(1): (a.group(2), a.start(2), a.end(2)) for a in _ATTR.finditer(self.source, start, end)}

    def father(self) -> tuple[str, str] | None:
        """(name, index) the element is linked to ("" as index where the text is not
        name[index]), None where it states none."""
        if "fatherId" not in self.attrs:
            return None
        return parse_father(self.attrs["fatherId"][0])


def parse_father(text: str) -> tuple[str, str]:
    m = _FATHER.match(text.strip())
    return (m.group(1), index_text(m.group(2))) if m else (text.strip(), "")


@dataclass
class Database:
    """Every <Value> of the .dtx (a tag) by (name, key), each variable's type and size, and
    the bulk tables of the tags (row = ``Element.tag``)."""

    path: str
    text: str
    types: dict[str, str]
    index: dict[tuple[str, str], int]  # (name, key) -> tag
    tag_type: list[str]  # per tag: the type of its variable
    offsets: list[int]  # per tag: where its <Value starts
    starts: list[int]  # per tag: where its attributes start
    ends: list[int]  # and end
    lines: LineIndex
    sizes: dict[str, str]
    numbers: np.ndarray  # (T, 12) NUMERIC fields, NaN where the tag has none
    spans: np.ndarray  # (T, 12, 2) their start, end; -1 where none
    complete: np.ndarray  # (T,) every NUMERIC attribute of the tag was read as a number
    words: list[dict[str, str]]  # per tag: its config words and fatherId

    def element(self, name: str, key: str) -> Element | None:
        """The element ``name[key]``; one the file declares (``size``) but writes no <Value>
        for has every field at its default (Stäubli Robotics Suite writes
        ``<Data name="jHome" type="jointRx" size="1"></Data>`` for a jointRx of zeros);
        None where the variable or the index does not exist."""
        tag = self.index.get((name, key))
        if tag is not None:
            return Element(name, self.tag_type[tag], key, self.offsets[tag], self.text, (self.starts[tag], self.ends[tag]), tag)
        size = self.sizes.get(name, "1")
        if name in self.types and key.isdigit() and size.isdigit() and int(key) < int(size):
            return Element(name, self.types[name], key, -1)
        return None

    def element_at(self, tag: int) -> Element:
        name, key = self._names[tag]
        return Element(name, self.tag_type[tag], key, self.offsets[tag], self.text, (self.starts[tag], self.ends[tag]), tag)

    @cached_property
    def _names(self) -> dict[int, tuple[str, str]]:
        return {tag: name_key for name_key, tag in self.index.items()}

    def error(self, offset: int, message: str) -> ParseError:
        return self.lines.error(self.path, offset, message)


def read_database(path: str, text: str) -> Database:
    """The variables of a .dtx; a Value outside a Data is a ParseError at its place."""
    lines = LineIndex(text)
    types: dict[str, str] = {}
    sizes: dict[str, str] = {}
    index: dict[tuple[str, str], int] = {}  # (name, key) -> tag
    tag_type: list[str] = []
    offsets: list[int] = []  # where each <Value starts
    starts: list[int] = []
    ends: list[int] = []
    current: tuple[str, str] | None = None
    # The bulk of a data file is <Value .../> tags with no '>' inside their quotes: those are
    # found by a plain pattern; a file with any other (a quoted '>') is read tag by tag.
    pattern = _FAST_TAG if _plain_tags(text) else _TAG
    for m in pattern.finditer(text):
        tag = m.group(1)
        if tag is None:  # </Data> or a comment
            if m.group(0).startswith("</"):
                current = None
            continue
        if tag == "Data":
            attrs = dict(_ATTR.findall(m.group(2)))
            if "name" not in attrs:
                raise lines.error(path, m.start(), "a <Data> without a name")
            types[attrs["name"]] = attrs.get("type", "")
            sizes[attrs["name"]] = attrs.get("size", "1").strip()
            current = None if m.group(3) else (attrs["name"], attrs.get("type", ""))
            continue
        if current is None:
            raise lines.error(path, m.start(), "a <Value> outside a <Data> element")
        key_match = _KEY.match(text, m.start(2))
        key_text = key_match.group(1) if key_match else dict(_ATTR.findall(m.group(2))).get("key", "0")
        # an array's index ("3", "1,2"), or a collection's key, any text (VAL3 s7 collections)
        key = key_text if key_text.isdigit() else index_text(key_text) if _INDEX.match(key_text.strip()) else key_text
        index[(current[0], key)] = len(starts)
        tag_type.append(current[1])
        offsets.append(m.start())
        starts.append(m.start(2))
        ends.append(m.end(2))
    numbers, spans, complete = _numeric_table(text, np.array(starts, np.int64), np.array(ends, np.int64))
    words = _word_table(text, np.array(starts, np.int64), np.array(ends, np.int64))
    return Database(path, text, types, index, tag_type, offsets, starts, ends, lines, sizes, numbers, spans, complete, words)


def _plain_tags(text: str) -> bool:
    """True where no quoted attribute value holds a '>' (so a tag ends at its first '>')."""
    return re.search(r'=\s*"[^"]*>', text) is None


def _owner(positions: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The tag each position lies in (-1: in none)."""
    tag = np.searchsorted(starts, positions, side="right") - 1
    inside = (tag >= 0) & (positions < ends[np.maximum(tag, 0)])
    return np.where(inside, tag, -1)


def _numeric_table(text: str, starts: np.ndarray, ends: np.ndarray):
    """(T, 12) values and (T, 12, 2) spans of every tag's NUMERIC attributes, and (T,) True
    where each NUMERIC attribute the tag writes was read whole as a number."""
    t = len(starts)
    numbers, spans = np.full((t, len(NUMERIC)), np.nan), np.full((t, len(NUMERIC), 2), -1, np.int64)
    column = {name: i for i, name in enumerate(NUMERIC)}
    written = np.zeros(t, np.int64)
    names, at = [], []
    for m in _NUMERIC_ATTR.finditer(text):
        names.append(column[m.group(1)])
        at.append(m.end())  # where the value starts
    if not at or not t:
        return numbers, spans, np.ones(t, bool)
    at, names = np.array(at, np.int64), np.array(names, np.int64)
    owner = _owner(at, starts, ends)
    np.add.at(written, owner[owner >= 0], 1)
    found = scan_numbers(text)
    # a number that is an attribute's whole value: it starts right after '="' and ends at '"'
    slot = np.searchsorted(found.start, at)
    ok = (owner >= 0) & (slot < len(found.start))
    slot = np.minimum(slot, max(len(found.start) - 1, 0))
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    ok &= (found.start[slot] == at) & (raw[np.minimum(found.end[slot], len(raw) - 1)] == ord('"')) & ~np.isnan(found.value[slot])
    rows, cols = owner[ok], names[ok]
    numbers[rows, cols] = found.value[slot[ok]]
    spans[rows, cols, 0], spans[rows, cols, 1] = found.start[slot[ok]], found.end[slot[ok]]
    read = np.zeros(t, np.int64)
    np.add.at(read, rows, 1)
    return numbers, spans, read == written


def _word_table(text: str, starts: np.ndarray, ends: np.ndarray) -> list[dict[str, str]]:
    """Per tag, its config words and fatherId."""
    words: list[dict[str, str]] = [{} for _ in range(len(starts))]
    matches = [(m.start(), m.group(1), m.group(2)) for m in _WORD_ATTR.finditer(text)]
    if matches and len(starts):
        owner = _owner(np.array([p for p, _, _ in matches], np.int64), starts, ends)
        for tag, (_, name, value) in zip(owner.tolist(), matches):
            if tag >= 0:
                words[tag][name] = value
    return words
