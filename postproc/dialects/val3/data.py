"""A VAL3 application's data file (.dtx): its variables and every number's place in the text.

The .dtx is XML (VAL3 reference manual, "Application data"; Stäubli Robotics Suite writes it):
``<Data name="pPick" type="pointRx" size="2">`` holds one ``<Value key="i" .../>`` per
element, each field an attribute: ``x y z rx ry rz`` (mm, degrees), ``shoulder elbow
wrist`` (the point's config), ``fatherId="fTable[0]"`` (the frame or tool it is linked to),
``j1``..``j6`` (jointRx), ``accel vel decel tmax rmax blend leave reach`` (mdesc). The
texts are read with regular expressions, not an XML parser, because every number's offset
in the file is needed to write it back in place (an XML parser gives none).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ...errors import ParseError
from ...parse.common import LineIndex

_TAG = re.compile(r"<(Data|Value)\b((?:[^>\"]|\"[^\"]*\")*?)(/?)>|</Data\s*>|<!--.*?-->", re.DOTALL)
_ATTR = re.compile(r"([\w:]+)\s*=\s*\"([^\"]*)\"")
_FATHER = re.compile(r"^(\w+)\[([\d\s,]+)\]$")
_INDEX = re.compile(r"\d+(?:\s*,\s*\d+)*$")


def index_text(text: str) -> str:
    """An element index as the data file's keys write it: "3", "1,2"."""
    return ",".join(part.strip() for part in text.split(","))


@dataclass
class Element:
    """One element of a data array: its attributes as (text, start, end) in the file."""

    datum: str  # the variable's name
    type: str  # pointRx, jointRx, frame, tool, mdesc, ...
    key: str  # "3", or "1,2" in a two-dimensional array
    attrs: dict[str, tuple[str, int, int]]
    offset: int  # where the <Value tag starts

    @property
    def name(self) -> str:
        return f"{self.datum}[{self.key}]"

    def father(self) -> tuple[str, str] | None:
        """(name, index) the element is linked to ("" as index where the text is not
        name[index]), None where it states none."""
        if "fatherId" not in self.attrs:
            return None
        text = self.attrs["fatherId"][0].strip()
        m = _FATHER.match(text)
        return (m.group(1), index_text(m.group(2))) if m else (text, "")


@dataclass
class Database:
    """Every element of the .dtx by (name, key), and each variable's type."""

    path: str
    text: str
    types: dict[str, str]
    elements: dict[tuple[str, str], Element]
    lines: LineIndex
    sizes: dict[str, str]

    def element(self, name: str, key: str) -> Element | None:
        """The element ``name[key]``; one the file declares (``size``) but writes no <Value>
        for has every field at its default (Stäubli Robotics Suite writes
        ``<Data name="jHome" type="jointRx" size="1"></Data>`` for a jointRx of zeros);
        None where the variable or the index does not exist."""
        found = self.elements.get((name, key))
        size = self.sizes.get(name, "1")
        if found is None and name in self.types and key.isdigit() and size.isdigit() and int(key) < int(size):
            return Element(name, self.types[name], key, {}, -1)
        return found

    def error(self, offset: int, message: str) -> ParseError:
        return self.lines.error(self.path, offset, message)


def read_database(path: str, text: str) -> Database:
    """The variables of a .dtx; a Value outside a Data is a ParseError at its place."""
    lines = LineIndex(text)
    types: dict[str, str] = {}
    sizes: dict[str, str] = {}
    elements: dict[tuple[str, str], Element] = {}
    current: tuple[str, str] | None = None
    for m in _TAG.finditer(text):
        tag = m.group(1)
        if tag is None:  # </Data> or a comment
            if m.group(0).startswith("</"):
                current = None
            continue
        attrs = {a.group(1): (a.group(2), m.start(2) + a.start(2), m.start(2) + a.end(2)) for a in _ATTR.finditer(m.group(2))}
        if tag == "Data":
            if "name" not in attrs:
                raise lines.error(path, m.start(), "a <Data> without a name")
            name, kind = attrs["name"][0], attrs.get("type", ("", 0, 0))[0]
            types[name] = kind
            sizes[name] = attrs.get("size", ("1", 0, 0))[0].strip()
            current = None if m.group(3) else (name, kind)
            continue
        if current is None:
            raise lines.error(path, m.start(), "a <Value> outside a <Data> element")
        key_text = attrs.get("key", ("0", 0, 0))[0]
        # an array's index ("3", "1,2"), or a collection's key, any text (VAL3 s7 collections)
        key = index_text(key_text) if _INDEX.match(key_text.strip()) else key_text
        elements[(current[0], key)] = Element(current[0], current[1], key, attrs, m.start())
    return Database(path, text, types, elements, lines, sizes)
