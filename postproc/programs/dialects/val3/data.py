"""A VAL3 application's data file (.dtx): its variables and every number's place in the text.

The .dtx is XML (VAL3 reference manual, "Application data"; Stäubli Robotics Suite writes it):
``<Data name="pPick" type="pointRx" size="2">`` holds one ``<Value key="i" .../>`` per
element, each field an attribute: ``x y z rx ry rz`` (mm, degrees), ``shoulder elbow
wrist`` (the point's config), ``fatherId="fTable[0]"`` (the frame or tool it is linked to),
``j1``..``j6`` (jointRx), ``accel vel decel tmax rmax blend leave reach`` (mdesc). The
texts are read with regular expressions, not an XML parser, because every number's offset
in the file is needed to write it back in place (an XML parser gives none).

A data file of a long program holds a <Value> per point: the tags are found in one pass
(their places and keys; a file with comments or a quoted '>' is read tag by tag), their
numbers in one vectorised pass (``NUMERIC``: value and span of each), their words (config,
fatherId) in another; an element's other attributes are read when asked for (``Element.attrs``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from postproc.errors import ParseError

from ...parse.common import LineIndex, scan_numbers

_TAG = re.compile(r"<(Data|Value)\b((?:[^>\"]|\"[^\"]*\")*?)(/?)>|</Data\s*>|<!--.*?-->", re.DOTALL)
_FAST_TAG = re.compile(r"<(Data|Value)\b([^>]*?)(/?)>|</Data\s*>|<!--.*?-->", re.DOTALL)
_ATTR = re.compile(r"([\w:]+)\s*=\s*\"([^\"]*)\"")
_FATHER = re.compile(r"^(\w+)\[([\d\s,]+)\]$")
_INDEX = re.compile(r"\d+(?:\s*,\s*\d+)*$")
_KEY = re.compile(r"\s+key\s*=\s*\"([^\"]*)\"")
#: the numeric fields read in bulk, in this column order (x..rz -> FIELDS 0..5, j1..j6 -> 7..12)
NUMERIC = ("x", "y", "z", "rx", "ry", "rz", "j1", "j2", "j3", "j4", "j5", "j6")
#: the word fields, in the column order of ``Database.word_codes``
WORDS = ("shoulder", "elbow", "wrist", "fatherId")
_DATA_EVENT = re.compile(r"<Data\b([^>]*?)(/?)>|</Data\s*>")
_VALUE_KEY = re.compile(r"<Value\b(\s+key\s*=\s*\"[^\"]*\")?")  # a <Value and the key="" it starts with
# the bytes Python's \s matches in a str pattern (the text is Latin-1 here)
_BLANK = np.zeros(256, bool)
_BLANK[[9, 10, 11, 12, 13, 28, 29, 30, 31, 32, 0x85, 0xA0]] = True


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
    word_codes: np.ndarray  # (T, 4) per tag, its WORDS: an index into word_texts[column], -1 where not written
    word_texts: list[list[str]]  # per WORDS column: the distinct texts written

    def words(self, tag: int) -> dict[str, str]:
        """The config words and fatherId the tag writes."""
        return {w: self.word_texts[c][code] for c, (w, code) in enumerate(zip(WORDS, self.word_codes[tag].tolist())) if code >= 0}

    @cached_property
    def offset_array(self) -> np.ndarray:
        return np.array(self.offsets, np.int64)

    @cached_property
    def point_type(self) -> np.ndarray:
        """Per tag: 1 for a pointRx, 2 for a jointRx, 0 for another type."""
        codes = {"pointRx": 1, "jointRx": 2}
        return np.array([codes.get(t, 0) for t in self.tag_type], np.int8)

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
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    found = _read_tags_fast(path, text, raw, lines) if _plain_tags(text) and "<!--" not in text else None
    types, sizes, index, tag_type, offsets, starts, ends = found or _read_tags(path, text, lines)
    starts_a, ends_a = np.array(starts, np.int64), np.array(ends, np.int64)
    numbers, spans, complete = _numeric_table(text, raw, starts_a, ends_a)
    codes, texts = _word_table(text, raw, starts_a, ends_a)
    return Database(path, text, types, index, tag_type, offsets, starts, ends, lines, sizes, numbers, spans, complete, codes, texts)


def _read_tags(path: str, text: str, lines: LineIndex):
    """The Data and Value tags one by one (a file with comments or a quoted '>')."""
    types: dict[str, str] = {}
    sizes: dict[str, str] = {}
    index: dict[tuple[str, str], int] = {}  # (name, key) -> tag
    tag_type: list[str] = []
    offsets: list[int] = []  # where each <Value starts
    starts: list[int] = []
    ends: list[int] = []
    current: tuple[str, str] | None = None
    # A tag ends at its first '>' unless a quoted value holds one (then the careful pattern).
    pattern = _FAST_TAG if _plain_tags(text) else _TAG
    for m in pattern.finditer(text):
        tag = m.group(1)
        if tag is None:  # </Data> or a comment
            if m.group(0).startswith("</"):
                current = None
            continue
        if tag == "Data":
            current = _data_tag(path, lines, m.start(), m.group(2), bool(m.group(3)), types, sizes)
            continue
        if current is None:
            raise lines.error(path, m.start(), "a <Value> outside a <Data> element")
        key_match = _KEY.match(text, m.start(2))
        index[(current[0], _key(key_match.group(1) if key_match else _other_key(m.group(2))))] = len(starts)
        tag_type.append(current[1])
        offsets.append(m.start())
        starts.append(m.start(2))
        ends.append(m.end(2))
    return types, sizes, index, tag_type, offsets, starts, ends


def _data_tag(path: str, lines: LineIndex, at: int, attributes: str, closed: bool, types: dict, sizes: dict) -> tuple[str, str] | None:
    """Records a <Data> tag's name, type and size; (name, type) of the Values that follow,
    None where it closes itself."""
    attrs = dict(_ATTR.findall(attributes))
    if "name" not in attrs:
        raise lines.error(path, at, "a <Data> without a name")
    types[attrs["name"]] = attrs.get("type", "")
    sizes[attrs["name"]] = attrs.get("size", "1").strip()
    return None if closed else (attrs["name"], attrs.get("type", ""))


def _key(key_text: str) -> str:
    """An array's index as the code writes it ("3", "1,2"), or a collection's key, any text (VAL3 s7 collections)."""
    return key_text if key_text.isdigit() else index_text(key_text) if _INDEX.match(key_text.strip()) else key_text


def _other_key(attributes: str) -> str:
    return dict(_ATTR.findall(attributes)).get("key", "0")


def _read_tags_fast(path: str, text: str, raw: np.ndarray, lines: LineIndex):
    """The tags of a file without comments and quoted '>': the few Data tags one by one, the
    <Value> tags (one per point) in one pass each for their places and keys. None where a
    tag lies inside another (the file is then read tag by tag)."""
    events = list(_DATA_EVENT.finditer(text))
    value_at = np.fromiter((m.start() for m in _VALUE_KEY.finditer(text)), np.int64)
    close = np.flatnonzero(raw == ord(">"))
    slot = np.searchsorted(close, value_at)
    if (slot >= len(close)).any():
        return None
    tag_end = close[slot]
    event_at = np.array([m.start() for m in events], np.int64)
    event_end = np.array([m.end() for m in events], np.int64)
    if _overlap(np.concatenate([value_at, event_at]), np.concatenate([tag_end + 1, event_end])):
        return None
    owner = np.searchsorted(event_at, value_at) - 1  # the Data event each Value follows
    opens = np.array([m.group(1) is not None and not m.group(2) for m in events] + [False], bool)
    outside = np.flatnonzero(~opens[owner])  # after a </Data>, a <Data/> or before any Data
    first_outside = int(value_at[outside[0]]) if len(outside) else len(text)
    types, sizes, current = _data_events(path, lines, events, first_outside)
    starts = value_at + len("<Value")
    ends = tag_end - (raw[tag_end - 1] == ord("/"))
    keys = [_key(k[k.index('"') + 1:-1]) if k else _other_key(text[a:b]) for k, a, b in zip(_VALUE_KEY.findall(text), starts.tolist(), ends.tolist())]
    owners = [current[o] for o in owner.tolist()]
    index = dict(zip(zip([o[0] for o in owners], keys), range(len(keys))))
    return types, sizes, index, [o[1] for o in owners], value_at.tolist(), starts.tolist(), ends.tolist()


def _overlap(starts: np.ndarray, ends: np.ndarray) -> bool:
    """Whether any of the spans starts inside the one before it."""
    order = np.argsort(starts, kind="stable")
    return bool((starts[order][1:] < ends[order][:-1]).any())


def _data_events(path: str, lines: LineIndex, events: list, first_outside: int):
    """types, sizes and, per event, the (name, type) of the Values after it (None after a
    </Data>). The first error in the text is raised, as the tag-by-tag reading does: a Data
    without a name, or a Value outside any Data (at ``first_outside``) before it."""
    types: dict[str, str] = {}
    sizes: dict[str, str] = {}
    current: list[tuple[str, str] | None] = []
    for m in events:
        if m.start() > first_outside:
            break
        if m.group(1) is None:  # </Data>
            current.append(None)
            continue
        current.append(_data_tag(path, lines, m.start(), m.group(1), bool(m.group(2)), types, sizes))
    if first_outside < len(lines.text):
        raise lines.error(path, first_outside, "a <Value> outside a <Data> element")
    return types, sizes, current


def _plain_tags(text: str) -> bool:
    """True where no quoted attribute value holds a '>' (so a tag ends at its first '>')."""
    return re.search(r'=\s*"[^"]*>', text) is None


def _owner(positions: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The tag each position lies in (-1: in none)."""
    tag = np.searchsorted(starts, positions, side="right") - 1
    inside = (tag >= 0) & (positions < ends[np.maximum(tag, 0)])
    return np.where(inside, tag, -1)


def _attribute_names(raw: np.ndarray, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Where each of ``names`` is given a value (``\\sNAME="``, as a regular expression would
    find it): the offsets of the value's first character and the name's index in ``names``."""
    quote = np.flatnonzero((raw[:-1] == ord("=")) & (raw[1:] == ord('"')))
    width = max(len(n) for n in names) + 1
    padded = np.concatenate([np.zeros(width, np.uint8), raw])  # names at the file's start look at zeros
    before = [padded[quote + width - k] for k in range(width + 1)]  # before[k]: the byte k before each '=' (one gather each)
    at, column = [], []
    for c, name in enumerate(names):
        ok = _BLANK[before[len(name) + 1]]
        for k, ch in enumerate(reversed(name.encode("latin-1")), 1):
            ok &= before[k] == ch
        at.append(quote[ok] + 2)
        column.append(np.full(int(ok.sum()), c, np.int64))
    at, column = np.concatenate(at), np.concatenate(column)
    order = np.argsort(at, kind="stable")
    return at[order], column[order]


def _numeric_table(text: str, raw: np.ndarray, starts: np.ndarray, ends: np.ndarray):
    """(T, 12) values and (T, 12, 2) spans of every tag's NUMERIC attributes, and (T,) True
    where each NUMERIC attribute the tag writes was read whole as a number."""
    t = len(starts)
    numbers, spans = np.full((t, len(NUMERIC)), np.nan), np.full((t, len(NUMERIC), 2), -1, np.int64)
    at, names = _attribute_names(raw, NUMERIC)
    if not len(at) or not t:
        return numbers, spans, np.ones(t, bool)
    owner = _owner(at, starts, ends)
    written = np.bincount(owner[owner >= 0], minlength=t)
    found = scan_numbers(text, raw=raw)
    # a number that is an attribute's whole value: it starts right after '="' and ends at '"'
    slot = np.searchsorted(found.start, at)
    ok = (owner >= 0) & (slot < len(found.start))
    slot = np.minimum(slot, max(len(found.start) - 1, 0))
    ok &= (found.start[slot] == at) & (raw[np.minimum(found.end[slot], len(raw) - 1)] == ord('"')) & ~np.isnan(found.value[slot])
    rows, cols = owner[ok], names[ok]
    numbers[rows, cols] = found.value[slot[ok]]
    spans[rows, cols, 0], spans[rows, cols, 1] = found.start[slot[ok]], found.end[slot[ok]]
    return numbers, spans, np.bincount(rows, minlength=t) == written


def _word_table(text: str, raw: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, list[list[str]]]:
    """Per tag, its config words and fatherId: (T, 4) codes into the distinct texts of each word."""
    codes = np.full((len(starts), len(WORDS)), -1, np.int64)
    texts: list[list[str]] = [[] for _ in WORDS]
    at, column = _attribute_names(raw, WORDS)
    quotes = np.flatnonzero(raw == ord('"'))
    close = quotes[np.minimum(np.searchsorted(quotes, at), len(quotes) - 1)] if len(quotes) else at
    # a value runs to its closing quote: a '="' there (a value ending in '=') starts no attribute
    keep = (close >= at) & (raw[np.minimum(close, len(raw) - 1)] == ord('"')) if len(at) else np.zeros(0, bool)
    if len(at) > 1:
        keep[1:] &= at[1:] - 2 >= close[:-1]
    owner = _owner(at, starts, ends) if len(starts) else np.full(len(at), -1)
    keep &= owner >= 0
    for c in range(len(WORDS)):
        mine = keep & (column == c)
        values = [text[a:b] for a, b in zip(at[mine].tolist(), close[mine].tolist())]
        distinct: dict[str, int] = {}
        codes[owner[mine], c] = [distinct.setdefault(v, len(distinct)) for v in values]
        texts[c] = list(distinct)
    return codes, texts
