"""The catalog of physical error effects (names fixed by spec/cli.md) and the effect-spec parser."""

from __future__ import annotations

from .backlash import Backlash
from .base import Context, Effect, EffectSpecError, EffectSum, Param
from .base_frame import BaseFrame
from .external_load import ExternalLoad
from .geometric import Geometric
from .joint_compliance import JointCompliance
from .joint_harmonics import JointHarmonics
from .thermal import Thermal
from .tool_offset import ToolOffset

CATALOG: dict[str, type[Effect]] = {
    "geometric": Geometric,
    "base_frame": BaseFrame,
    "tool_offset": ToolOffset,
    "joint_compliance": JointCompliance,
    "external_load": ExternalLoad,
    "joint_harmonics": JointHarmonics,
    "backlash": Backlash,
    "thermal": Thermal,
}


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
        raise EffectSpecError(f"unknown effect '{name}' (known: {', '.join(CATALOG)})")
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
    cls = CATALOG[name]
    if hasattr(cls, "from_options"):
        return cls.from_options(opts)
    if opts:
        raise EffectSpecError(f"effect '{name}' takes no options, got '{rest[:-1]}'")
    return cls()


def parse_effects(text: str) -> EffectSum:
    """'geometric,joint_harmonics[joints=2,3;orders=3,4]' -> EffectSum; 'none' or '' -> empty."""
    if text.strip() in ("", "none"):
        return EffectSum()
    total = EffectSum()
    for item in _split_top_level(text):
        total = total + parse_effect(item)
    return total


__all__ = [
    "CATALOG",
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
    "parse_effects",
]
