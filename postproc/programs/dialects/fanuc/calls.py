"""The file set of a TP program: the programs it calls (``CALL NAME`` without arguments),
found as NAME.ls in the program's folder, and the programs those call (R-30iB Operator's
Manual, "Program call instruction": the called program runs, then the caller goes on after
the CALL). A called program that is not there is left out: the caller's flow is then read
in text order with a note (``flow.py``)."""

from __future__ import annotations

import re
from pathlib import Path

from ...ir import SourceDoc
from ..base import read_bytes

_CALLS = re.compile(r"^[ \t]*\d*[ \t]*:[ \t]*CALL[ \t]+(\w+)[ \t]*;", re.MULTILINE | re.IGNORECASE)
ROLE = "called"


def called_programs(program: Path, text: str) -> list[SourceDoc]:
    """The programs ``text`` (the listing at ``program``) calls, directly or not, that are in
    its folder, each once, in the order first called."""
    if _CALLS.search(text) is None:
        return []  # (most programs: the folder is not listed)
    folder = program.parent
    listings = {p.stem.upper(): p for p in sorted(folder.iterdir()) if p.suffix.lower() == ".ls" and p.is_file()} if folder.is_dir() else {}
    seen = {program.stem.upper()}
    out: list[SourceDoc] = []
    pending = [text]
    while pending:
        for name in (m.group(1).upper() for m in _CALLS.finditer(pending.pop(0))):
            if name in seen or name not in listings:
                continue
            seen.add(name)
            doc = SourceDoc(str(listings[name]), read_bytes(listings[name]).decode("latin-1"), ROLE)
            out.append(doc)
            pending.append(doc.text)
    return out
