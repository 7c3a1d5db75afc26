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
_FATHER = re.compile(r"^(\w+)\[(\d+)\]$")


@dataclass
class Element:
    """One element of a data array: its attributes as (text, start, end) in the file."""

    datum: str  # the variable's name
    type: str  # pointRx, jointRx, frame, tool, mdesc, ...
    key: int
    attrs: dict[str, tuple[str, int, int]]
    offset: int  # where the <Value tag starts

    @property
    def name(self) -> str:
        return f"{self.datum}[{self.key}]"

    def father(self) -> tuple[str, int] | None:
        """(name, index) the element is linked to, None where it states none."""
        if "fatherId" not in self.attrs:
            return None
        text = self.attrs["fatherId"][0].strip()
        m = _FATHER.match(text)
        return (m.group(1), int(m.group(2))) if m else (text, -1)


@dataclass
class Database:
    """Every element of the .dtx by (name, key), and each variable's type."""

    path: str
    text: str
    types: dict[str, str]
    elements: dict[tuple[str, int], Element]
    lines: LineIndex

    def error(self, offset: int, message: str) -> ParseError:
        return self.lines.error(self.path, offset, message)


def read_database(path: str, text: str) -> Database:
    """The variables of a .dtx; a Value outside a Data, or a key that is not a whole number,
    is a ParseError at its place."""
    lines = LineIndex(text)
    types: dict[str, str] = {}
    elements: dict[tuple[str, int], Element] = {}
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
            current = None if m.group(3) else (name, kind)
            continue
        if current is None:
            raise lines.error(path, m.start(), "a <Value> outside a <Data> element")
        key_text = attrs.get("key", ("0", 0, 0))[0]
        if not key_text.isdigit():
            raise lines.error(path, attrs["key"][1] if "key" in attrs else m.start(), f"key '{key_text}' is not an element index")
        elements[(current[0], int(key_text))] = Element(current[0], current[1], int(key_text), attrs, m.start())
    return Database(path, text, types, elements, lines)
