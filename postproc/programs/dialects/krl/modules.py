"""KRL: other modules' data lists and functions a program uses (``--data``).

KUKA System Software 8.x, Operating and Programming Instructions for System Integrators:
- "Data lists": a module's data list (``DEFDAT NAME``) is local to its module; a name it
  declares is seen by other modules only when the data list is ``DEFDAT NAME PUBLIC`` and
  the declaration is ``DECL GLOBAL``; $CONFIG.DAT is the global data list (every name in it
  is seen by every program).
- "Global declarations" / "Local and global": a local name hides a global one of the same
  name (the program's own .src and .dat win over another module's GLOBAL points).
- "Subprograms and functions": ``GLOBAL DEF`` / ``GLOBAL DEFFCT`` of another module may be
  called by name (functions: ``modules_fct.py``).

Here a module's .dat is a source of role ``module`` (read for its GLOBAL declarations of a
PUBLIC list only); a module's .src is a source of role ``module_src`` (read for its
functions). Compensation writes a changed point back into the module's .dat.
"""

from __future__ import annotations

import re
from pathlib import Path

from postproc.errors import InputError

from ...ir import SourceDoc

_PUBLIC = re.compile(r"^[ \t]*DEFDAT[ \t]+[\w$]+[^\n;]*\bPUBLIC\b", re.IGNORECASE | re.MULTILINE)
_DECL = re.compile(r"^[ \t]*(?P<g1>GLOBAL[ \t]+)?DECL[ \t]+(?P<g2>GLOBAL[ \t]+)?[\w$]+[ \t]+(?P<names>[^=;\n]+)", re.IGNORECASE | re.MULTILINE)
_BARE = re.compile(r"^[ \t]*(?:E6POS|POS|FRAME|E6AXIS|AXIS)[ \t]+(?P<names>[\w$]+)", re.IGNORECASE | re.MULTILINE)
_NAME = re.compile(r"([A-Za-z_$][\w$]*)")


def module_docs(program: str | Path, paths) -> list[SourceDoc]:
    """The files named by ``--data`` (a folder: every .dat and .src below it), without the
    program's own .src, .dat and $config.dat (read already)."""
    program = Path(program)
    own = {p.resolve() for p in (program, program.with_suffix(".dat"), program.parent / "$config.dat") if str(program) != "-"}
    found: list[Path] = []
    for given in map(Path, paths):
        if given.is_dir():
            found += sorted(p for p in given.rglob("*") if p.suffix.lower() in (".dat", ".src") and p.is_file())
        elif given.is_file():
            found.append(given)
        else:
            raise InputError(f"{given}: --data: no such file or folder")
    docs, seen = [], set(own)
    for path in found:
        if path.resolve() in seen:
            continue
        seen.add(path.resolve())
        role = "module" if path.suffix.lower() == ".dat" else "module_src"
        if path.name.lower() == "$config.dat":  # the robot's global data list kept in another folder (KRC/R1/System)
            role = "config"
        docs.append(SourceDoc.read(path, role))
    return docs


def visibility(text: str) -> tuple[set[str], dict[str, int]]:
    """Names another module sees (GLOBAL in a PUBLIC data list) and {NAME: line} of those
    it does not (declared without GLOBAL, or in a data list that is not PUBLIC)."""
    public = bool(_PUBLIC.search(text))
    seen: set[str] = set()
    hidden: dict[str, int] = {}
    for m in _DECL.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        for name in _declared_names(m.group("names")):
            if public and (m.group("g1") or m.group("g2")):
                seen.add(name)
            else:
                hidden.setdefault(name, line)
    for m in _BARE.finditer(text):  # 'E6POS XP1=...' without DECL: a local declaration
        hidden.setdefault(m.group("names").upper(), text.count("\n", 0, m.start()) + 1)
    return seen, {k: v for k, v in hidden.items() if k not in seen}


def _declared_names(names: str) -> list[str]:
    """'XP1, XP2[10]' -> ['XP1', 'XP2'] (the array's name; brackets dropped)."""
    out = []
    for part in re.sub(r"\[[^\]]*\]", "", names).split(","):
        m = _NAME.match(part.strip())
        if m:
            out.append(m.group(1).upper())
    return out


def base_name(name: str) -> str:
    """XP1 -> XP1, PATH[3] -> PATH (upper case)."""
    return name.split("[")[0].strip().upper()
