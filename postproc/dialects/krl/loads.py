"""KRL: the payload a program states ($LOAD), for checking it against the model's."""

from __future__ import annotations

import re

from ..base import NUMBER

_LOAD_M = re.compile(rf"^[ \t]*\$LOAD\.M[ \t]*=[ \t]*({NUMBER})", re.IGNORECASE | re.MULTILINE)
_LOAD_AGG = re.compile(rf"^[ \t]*\$LOAD[ \t]*=[ \t]*\{{[^}}]*?\bM[ \t]+({NUMBER})", re.IGNORECASE | re.MULTILINE)
_LOAD_REF = re.compile(r"^[ \t]*\$LOAD[ \t]*=[ \t]*LOAD_DATA\[[ \t]*(\d+)[ \t]*\]", re.IGNORECASE | re.MULTILINE)
_BAS_TOOL = re.compile(r"^[ \t]*BAS[ \t]*\([ \t]*#TOOL[ \t]*,[ \t]*(\d+)", re.IGNORECASE | re.MULTILINE)
_LOAD_DATA = re.compile(rf"LOAD_DATA\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*\{{[^}}]*?\bM[ \t]+({NUMBER})", re.IGNORECASE)


def load_masses(tp) -> list[tuple[float, str]]:
    """(mass kg, 'FILE, line N') of every payload the program's files state."""
    table = {int(m.group(1)): float(m.group(2)) for doc in tp.sources for m in _LOAD_DATA.finditer(doc.text)}
    out = []
    for doc in tp.sources:
        if doc.role == "config":
            continue  # LOAD_DATA declarations: only those the program selects count

        def where(m):
            return f"{doc.path}, line {doc.text.count(chr(10), 0, m.start()) + 1}"

        for pattern in (_LOAD_M, _LOAD_AGG):
            out += [(float(m.group(1)), where(m)) for m in pattern.finditer(doc.text)]
        for pattern in (_LOAD_REF, _BAS_TOOL):
            out += [(table[int(m.group(1))], where(m) + f" (LOAD_DATA[{m.group(1)}])") for m in pattern.finditer(doc.text) if int(m.group(1)) in table]
    return out
