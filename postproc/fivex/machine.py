"""Five-axis machine data: the immutable ``Machine`` and ``load_machine`` with schema checks.

A machine file (``machines/*.toml``, package data ``postproc.machine_files``) lists the
linear axes with their limits and the rotary axes in chain order: table axes from the bed
outward (the first carries the second), head axes from the ram to the spindle. Each rotary
axis has a unit direction and a point on it (mm, machine frame, all axes at zero); a
positive angle turns its carrier (table or head) right-handed about the direction.
The workpiece frame is the machine frame with every rotary axis at zero; the tool axis
(tip -> spindle) at zero is ``tool_axis``. Head axes' points are given relative to a
gauge point on the spindle (e.g. the pivot), ``gauge_to_tip`` mm above the tool tip.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .errors import MachineFileError, UnknownMachineError

KINDS = {"table-table": ("table", "table"), "head-table": ("head", "table"), "head-head": ("head", "head")}
_TOP_KEYS = {"machine", "units", "sources", "linear", "rotary", "linuxcnc", "calibration", "heidenhain"}
# [heidenhain]: the TNC's machine parameters a Klartext program's meaning depends on (docs/languages/heidenhain.md)
_HEIDENHAIN_KEYS = {"cycle19_angles": ("spatial", "axis")}


@dataclass(frozen=True)
class RotaryAxis:
    name: str
    carrier: str  # "table" or "head"
    direction: np.ndarray  # (3,) unit
    point: np.ndarray  # (3,) mm
    limits: np.ndarray  # (2,) deg

    @property
    def periodic(self) -> bool:
        """A continuous rotary axis (range over a turn): angles are equivalent modulo 360."""
        return self.limits[1] - self.limits[0] > 360.0


@dataclass(frozen=True)
class Machine:
    name: str
    description: str
    source_path: str
    kind: str
    axes: tuple[str, ...]  # e.g. ("X", "Y", "Z", "A", "C"): the program's axis letters
    tool_axis: np.ndarray
    linear_limits: np.ndarray  # (3, 2) mm
    rotary: tuple[RotaryAxis, RotaryAxis]
    sources: dict[str, str] = field(default_factory=dict)
    linuxcnc: dict[str, str] = field(default_factory=dict)
    calibration: dict[str, Any] = field(default_factory=dict)
    gauge_to_tip: float = 0.0  # head machines: from the point the head axes' points are given from to the tool tip, mm
    heidenhain: dict[str, str] = field(default_factory=dict)  # [heidenhain] machine parameters (_HEIDENHAIN_KEYS)

    @property
    def rotary_names(self) -> tuple[str, str]:
        return self.rotary[0].name, self.rotary[1].name

    def with_axes(self, updates: dict[str, tuple[np.ndarray, np.ndarray]], calibration: dict | None = None) -> "Machine":
        """A copy with new (direction, point) for the named rotary axes (a calibrated machine)."""
        axes = []
        for ax in self.rotary:
            if ax.name in updates:
                d, p = (np.asarray(v, dtype=float) for v in updates[ax.name])
                ax = replace(ax, direction=d / np.linalg.norm(d), point=p)
            axes.append(ax)
        return replace(self, rotary=tuple(axes), calibration=dict(calibration or self.calibration))


def available_machines() -> list[str]:
    root = resources.files("postproc.machine_files")
    return sorted(p.name[: -len(".toml")] for p in root.iterdir() if p.name.endswith(".toml"))


def load_machine(name_or_path: str | Path) -> Machine:
    """A bundled machine by name (``xyzac-trt``) or a machine TOML file by path."""
    candidate = Path(name_or_path)
    if candidate.suffix == ".toml" or candidate.exists():
        if not candidate.is_file():
            raise UnknownMachineError(f"{candidate}: machine file not found")
        return parse_machine_toml(candidate.read_text(encoding="utf-8"), str(candidate))
    resource = resources.files("postproc.machine_files") / f"{name_or_path}.toml"
    if not resource.is_file():
        raise UnknownMachineError(f"unknown machine '{name_or_path}': not a bundled machine ({', '.join(available_machines())}) nor an existing file")
    return parse_machine_toml(resource.read_text(encoding="utf-8"), f"machines/{name_or_path}.toml")


class _Reader:
    def __init__(self, path: str):
        self.path = path

    def fail(self, key: str, message: str) -> MachineFileError:
        return MachineFileError(self.path, key, message)

    def table(self, data: dict, key: str, required: bool = True) -> dict:
        value = data.get(key)
        if value is None and not required:
            return {}
        if not isinstance(value, dict):
            raise self.fail(key, "missing section" if value is None else "must be a table")
        return value

    def string(self, data: dict, key: str, where: str) -> str:
        value = data.get(key)
        if not isinstance(value, str) or not value.strip():
            raise self.fail(where, "must be a non-empty string")
        return value

    def numbers(self, data: dict, key: str, where: str, length: int) -> np.ndarray:
        value = data.get(key)
        if not isinstance(value, list) or len(value) != length:
            raise self.fail(where, f"must be a list of {length} numbers")
        for i, item in enumerate(value):
            if isinstance(item, bool) or not isinstance(item, (int, float)) or not math.isfinite(item):
                raise self.fail(f"{where}[{i}]", f"must be a finite number, got {item!r}")
        return np.array(value, dtype=float)

    def limits(self, data: dict, key: str, where: str) -> np.ndarray:
        lim = self.numbers(data, key, where, 2)
        if not lim[0] < lim[1]:
            raise self.fail(where, f"lower limit {lim[0]} must be below upper limit {lim[1]}")
        return lim

    def unit_vector(self, data: dict, key: str, where: str) -> np.ndarray:
        v = self.numbers(data, key, where, 3)
        norm = np.linalg.norm(v)
        if abs(norm - 1.0) > 1e-6:
            raise self.fail(where, f"must be a unit vector (length {norm:.9g})")
        return v / norm


def parse_machine_toml(text: str, path: str) -> Machine:
    """Validate and build a Machine; every error names ``path`` and the key."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MachineFileError(path, "<syntax>", str(exc)) from None
    r = _Reader(path)
    for key in data:
        if key not in _TOP_KEYS:
            raise r.fail(key, f"unknown key (allowed: {', '.join(sorted(_TOP_KEYS))})")
    head = r.table(data, "machine")
    units = r.table(data, "units")
    for quantity, unit in (("length", "mm"), ("angle", "deg")):
        if units.get(quantity) != unit:
            raise r.fail(f"units.{quantity}", f"must be '{unit}' (conventions.md), got {units.get(quantity)!r}")
    kind = r.string(head, "kind", "machine.kind")
    if kind not in KINDS:
        raise r.fail("machine.kind", f"'{kind}' is not one of {', '.join(KINDS)}")
    linear = r.table(data, "linear")
    linear_limits = np.stack([r.limits(linear, ax, f"linear.{ax}") for ax in "XYZ"])
    rotary = _rotary_axes(r, data, kind)
    axes = head.get("axes")
    expected = ["X", "Y", "Z", rotary[0].name, rotary[1].name]
    if axes != expected:
        raise r.fail("machine.axes", f"must be {expected} (linear axes, then the rotary axes in chain order), got {axes!r}")
    name = r.string(head, "name", "machine.name")
    if path.startswith("machines/") and Path(path).stem != name:  # bundled files: name = file name
        raise r.fail("machine.name", f"'{name}' does not match the file name '{Path(path).stem}'")
    gauge = head.get("gauge_to_tip", 0.0)
    if isinstance(gauge, bool) or not isinstance(gauge, (int, float)) or not math.isfinite(gauge) or gauge < 0:
        raise r.fail("machine.gauge_to_tip", f"must be a finite number >= 0 (mm), got {gauge!r}")
    for key in head:
        if key not in ("name", "description", "kind", "axes", "tool_axis", "gauge_to_tip"):
            raise r.fail(f"machine.{key}", "unknown key (allowed: axes, description, gauge_to_tip, kind, name, tool_axis)")
    sources = r.table(data, "sources")
    if "geometry" not in sources:
        raise r.fail("sources.geometry", "missing: cite where the axis geometry comes from")
    return Machine(
        name=name,
        description=r.string(head, "description", "machine.description"),
        source_path=path,
        kind=kind,
        axes=tuple(expected),
        tool_axis=r.unit_vector(head, "tool_axis", "machine.tool_axis"),
        linear_limits=linear_limits,
        rotary=rotary,
        sources={k: str(v) for k, v in sources.items()},
        linuxcnc={k: str(v) for k, v in r.table(data, "linuxcnc", required=False).items()},
        calibration=dict(r.table(data, "calibration", required=False)),
        gauge_to_tip=float(gauge),
        heidenhain=_heidenhain(r, data),
    )


def _heidenhain(r: _Reader, data: dict) -> dict[str, str]:
    table = r.table(data, "heidenhain", required=False)
    for key, value in table.items():
        if key not in _HEIDENHAIN_KEYS:
            raise r.fail(f"heidenhain.{key}", f"unknown key (allowed: {', '.join(sorted(_HEIDENHAIN_KEYS))})")
        if value not in _HEIDENHAIN_KEYS[key]:
            raise r.fail(f"heidenhain.{key}", f"must be one of {', '.join(_HEIDENHAIN_KEYS[key])}, got {value!r}")
    return dict(table)


def _rotary_axes(r: _Reader, data: dict, kind: str) -> tuple[RotaryAxis, RotaryAxis]:
    items = data.get("rotary")
    if not isinstance(items, list) or len(items) != 2:
        raise r.fail("rotary", "must be exactly two [[rotary]] tables (chain order)")
    axes = []
    allowed = {"name", "carrier", "direction", "point", "limits"}
    for i, item in enumerate(items):
        where = f"rotary[{i}]"
        for key in item:
            if key not in allowed:
                raise r.fail(f"{where}.{key}", f"unknown key (allowed: {', '.join(sorted(allowed))})")
        name = r.string(item, "name", f"{where}.name")
        if name not in ("A", "B", "C"):
            raise r.fail(f"{where}.name", f"must be A, B or C, got '{name}'")
        carrier = r.string(item, "carrier", f"{where}.carrier")
        if carrier != KINDS[kind][i]:
            raise r.fail(f"{where}.carrier", f"a {kind} machine has a {KINDS[kind][i]} axis here (chain order: head axes first, table axes from the bed), got '{carrier}'")
        axes.append(RotaryAxis(name, carrier, r.unit_vector(item, "direction", f"{where}.direction"), r.numbers(item, "point", f"{where}.point", 3), r.limits(item, "limits", f"{where}.limits")))
    if axes[0].name == axes[1].name:
        raise r.fail("rotary[1].name", f"both rotary axes are named '{axes[0].name}'")
    if abs(float(axes[0].direction @ axes[1].direction)) > 1.0 - 1e-6:
        raise r.fail("rotary[1].direction", "the two rotary axes are parallel: the tool axis cannot be reached")
    return axes[0], axes[1]


def machine_toml(machine: Machine, header: str = "") -> str:
    """The machine as TOML text (the calibrated machine file): same schema, axes updated."""
    def vec(v):
        return "[" + ", ".join(f"{float(x):.9f}" for x in v) + "]"

    def s(text):
        return '"' + str(text).replace("\\", "\\\\").replace('"', '\\"') + '"'

    lines = [f"# {h}" for h in header.splitlines()] + [
        "[machine]", f"name = {s(machine.name)}", f"description = {s(machine.description)}", f"kind = {s(machine.kind)}",
        "axes = [" + ", ".join(s(a) for a in machine.axes) + "]", f"tool_axis = {vec(machine.tool_axis)}",
        *([f"gauge_to_tip = {machine.gauge_to_tip:.9f}"] if machine.gauge_to_tip else []), "",
        "[units]", 'length = "mm"', 'angle = "deg"', "", "[sources]"]
    lines += [f"{k} = {s(v)}" for k, v in machine.sources.items()]
    lines += ["", "[linear]"] + [f"{ax} = {vec(lim)}" for ax, lim in zip("XYZ", machine.linear_limits)]
    for ax in machine.rotary:
        lines += ["", "[[rotary]]", f"name = {s(ax.name)}", f"carrier = {s(ax.carrier)}", f"direction = {vec(ax.direction)}",
                  f"point = {vec(ax.point)}", f"limits = {vec(ax.limits)}"]
    if machine.linuxcnc:
        lines += ["", "[linuxcnc]"] + [f"{k} = {s(v)}" for k, v in machine.linuxcnc.items()]
    if machine.heidenhain:
        lines += ["", "[heidenhain]"] + [f"{k} = {s(v)}" for k, v in machine.heidenhain.items()]
    if machine.calibration:
        lines += ["", "[calibration]"] + [f"{k} = {s(v)}" for k, v in machine.calibration.items()]
    return "\n".join(lines) + "\n"
