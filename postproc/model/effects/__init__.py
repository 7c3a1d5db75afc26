"""The catalog of physical error effects and the effect-spec parser.

Every module of this package except ``base`` defines one ``Effect`` subclass; the
catalog discovers them, so adding an effect is adding one file. Names are fixed by
spec/cli.md (more may be added). Effects written outside the package (against
``postproc.model.effects.api``) join the catalog through ``register``, called by
``postproc.plugins.load_plugins``.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

from .backlash import Backlash
from .base import DH, KINDS, Context, Effect, EffectSpecError, EffectSum, Param
from .base_frame import BaseFrame
from .external_load import ExternalLoad
from .geometric import Geometric
from .joint_compliance import JointCompliance
from .joint_harmonics import JointHarmonics
from .thermal import Thermal
from .tool_offset import ToolOffset


def _discover() -> dict[str, type[Effect]]:
    """name -> class of every Effect subclass defined in a module of this package."""
    found: dict[str, type[Effect]] = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_") or info.name == "base":
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if issubclass(cls, Effect) and cls.__module__ == module.__name__ and cls.name:
                if cls.name in found:
                    raise RuntimeError(f"two effects named '{cls.name}' ({found[cls.name].__module__}, {module.__name__})")
                if cls.kind not in KINDS:
                    raise RuntimeError(f"effect '{cls.name}' has kind '{cls.kind}', not one of {KINDS}")
                found[cls.name] = cls
    return found


def _check_class(cls: type[Effect], where: str) -> None:
    if not (isinstance(cls, type) and issubclass(cls, Effect) and cls.name):
        raise EffectSpecError(f"{where}: not an Effect subclass with a name")
    if cls.kind not in KINDS:
        raise EffectSpecError(f"effect '{cls.name}' ({where}) has kind '{cls.kind}', not one of {', '.join(KINDS)}")


# The catalog is a module-level table on purpose: model files, toolpath-independent
# workers (Dask, forked stream workers) and diagnose resolve effect names through it.
# Built-ins are fixed at import; plugins are added only by ``register`` (called by
# postproc.plugins.load_plugins, explicitly), which is idempotent for the same class.
CATALOG: dict[str, type[Effect]] = _discover()
BUILTIN: frozenset[str] = frozenset(CATALOG)


def register(cls: type[Effect], where: str) -> None:
    """Add a plugin effect class to the catalog (``where``: its file, for messages).

    Registering a class under its own name again (the same plugin loaded twice, or
    reloaded from a changed file) replaces it; a built-in name or a name another
    plugin holds is refused."""
    _check_class(cls, where)
    if cls.name in BUILTIN:
        raise EffectSpecError(f"{where}: effect '{cls.name}' is a built-in effect's name; choose another")
    held = CATALOG.get(cls.name)
    if held is not None and held is not cls and getattr(held, "__module__", None) != cls.__module__:
        raise EffectSpecError(f"{where}: effect '{cls.name}' is already defined by {held.__module__}")
    CATALOG[cls.name] = cls


def catalog_of_kind(kind: str) -> list[type[Effect]]:
    """Catalog classes contributing in one way (e.g. the 'base' effect that re-registers a frame)."""
    return [cls for cls in CATALOG.values() if cls.kind == kind]


def consumers_of(group: str) -> list[str]:
    """Names of the catalog effects that consume a compensation input (force, temp)."""
    return [name for name, cls in CATALOG.items() if group in cls.consumes]


def _split_top_level(text: str) -> list[str]:
    parts, depth, current = [], 0, []
    for ch in text:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
            if depth < 0:
                raise EffectSpecError(f"unbalanced ']' in effects '{text}'")
        if ch == "," and depth == 0:
            parts.append("".join(current))
            current = []
        else:
            current.append(ch)
    if depth:
        raise EffectSpecError(f"unbalanced '[' in effects '{text}'")
    parts.append("".join(current))
    return [p.strip() for p in parts if p.strip()]


def parse_effect(item: str) -> Effect:
    name, _, rest = item.partition("[")
    name = name.strip()
    if name not in CATALOG:
        raise EffectSpecError(f"unknown effect '{name}' (known: {', '.join(CATALOG)}; "
                              "an effect of your own: load its file with --plugins PATH or POSTPROC_PLUGINS)")
    opts: dict[str, str] = {}
    if rest:
        if not rest.endswith("]"):
            raise EffectSpecError(f"effect '{item}': options must end with ']'")
        for pair in rest[:-1].split(";"):
            if not pair.strip():
                continue
            key, eq, value = pair.partition("=")
            if not eq:
                raise EffectSpecError(f"effect '{item}': option '{pair}' is not key=value")
            opts[key.strip()] = value.strip()
    return CATALOG[name].from_options(opts)


def parse_effects(text: str) -> EffectSum:
    """'geometric,joint_harmonics[joints=2,3;orders=3,4]' -> EffectSum; 'none' or '' -> empty."""
    if text.strip() in ("", "none"):
        return EffectSum()
    total = EffectSum()
    for item in _split_top_level(text):
        total = total + parse_effect(item)
    return total


__all__ = [
    "BUILTIN",
    "CATALOG",
    "DH",
    "Backlash",
    "BaseFrame",
    "Context",
    "Effect",
    "EffectSpecError",
    "EffectSum",
    "ExternalLoad",
    "Geometric",
    "JointCompliance",
    "JointHarmonics",
    "Param",
    "Thermal",
    "ToolOffset",
    "catalog_of_kind",
    "consumers_of",
    "parse_effects",
    "register",
]
