"""The languages postproc reads and writes: one package per dialect, and the registry.

``REGISTRY`` maps a dialect's name (the ``--dialect`` / ``--to`` option value and
``Toolpath.dialect``) to its ``Dialect`` object. Adding a language is one new package
here with a ``Dialect`` subclass, plus its entry in ``REGISTRY`` below.
"""

from __future__ import annotations

from pathlib import Path

from postproc.errors import InputError

from ..ir import Toolpath
from .base import Dialect, read_head
from .fanuc import FANUC
from .gcode import GCODE
from .heidenhain import HEIDENHAIN
from .inform import INFORM
from .krl import KRL
from .rapid import RAPID
from .sinumerik import SINUMERIK
from .urscript import URSCRIPT
from .val3 import VAL3

# A module-level table on purpose: a toolpath names its dialect (Toolpath.dialect) and
# every stage, forked workers included, resolves it here. Built-ins are fixed at import;
# plugin dialects are added only by ``register`` (postproc.plugins.load_plugins), idempotently.
REGISTRY: dict[str, Dialect] = {d.name: d for d in (RAPID, VAL3, URSCRIPT, KRL, FANUC, INFORM, SINUMERIK, HEIDENHAIN, GCODE)}  # sniffing tries them in this order (VAL3 before URScript: its code calls movej( too; Klartext's BEGIN PGM before G-code's M3)
BUILTIN: frozenset[str] = frozenset(REGISTRY)


def register(dialect: Dialect, where: str) -> None:
    """Add a plugin dialect (an instance of a Dialect subclass); the same name from the
    same module again replaces it, a built-in name or another plugin's is refused."""
    if not (isinstance(dialect, Dialect) and dialect.name):
        raise InputError(f"{where}: not a Dialect instance with a name")
    if dialect.name in BUILTIN:
        raise InputError(f"{where}: dialect '{dialect.name}' is a built-in dialect's name; choose another")
    held = REGISTRY.get(dialect.name)
    if held is not None and type(held).__module__ != type(dialect).__module__:
        raise InputError(f"{where}: dialect '{dialect.name}' is already defined by {type(held).__module__}")
    REGISTRY[dialect.name] = dialect


def names() -> tuple[str, ...]:
    return tuple(REGISTRY)


def get(name: str, option: str = "--dialect") -> Dialect:
    """The dialect called ``name``; an unknown name is an InputError naming the known ones."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise InputError(f"{option}: '{name}' is not one of {', '.join(REGISTRY)}") from None


def of(tp: Toolpath) -> Dialect:
    """The dialect a toolpath was read in."""
    return REGISTRY[tp.dialect]


def sniff(path: str | Path, data: bytes | None = None) -> Dialect:
    """The dialect of a program from its extension, or from its content when that is unknown."""
    suffix = Path(str(path)).suffix.lower()
    by_extension = [d for d in REGISTRY.values() if suffix in d.extensions]
    if by_extension and suffix != ".txt":  # .txt is anything: look inside
        return by_extension[0]
    if data is None:
        data = read_head(path)
    head = data[:4096].decode("latin-1").upper()
    for dialect in REGISTRY.values():
        if dialect.sniff(head):
            return dialect
    raise InputError(f"{path}: cannot tell the dialect (give --dialect {', '.join(REGISTRY)})")


__all__ = ["BUILTIN", "REGISTRY", "Dialect", "get", "names", "of", "register", "sniff"]
