"""Probing CSV (spec/probing.md): sphere centres, or touches that are fitted to centres."""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import ProbeFileError
from .fitting import fit_spheres

_KNOWN = {"id", "axis", "angle", "x", "y", "z", "touch"}


@dataclass(frozen=True)
class Centres:
    """Sphere centres, one per rotary-axis position, in file order."""

    ids: tuple[str, ...]
    axis: tuple[str, ...]  # "A", "B" or "C" per row
    angle: np.ndarray  # (N,) deg, NaN where the file gives none
    xyz: np.ndarray  # (N, 3) mm
    rows: tuple[int, ...]  # 1-based data row of each centre (its first touch)
    sphere_rms: np.ndarray  # (N,) RMS of the touches about the fitted sphere (NaN: given as centres)
    radius: np.ndarray  # (N,) fitted or given probe-centre-to-sphere-centre distance (NaN: given as centres)


def _rows(path: Path) -> tuple[list[str], list[tuple[int, int, list[str]]]]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProbeFileError(path, None, None, f"cannot read ({getattr(exc, 'strerror', None) or exc})") from None
    lines = [(i + 1, line) for i, line in enumerate(text.splitlines()) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise ProbeFileError(path, None, None, "no header row")
    reader = csv.reader(io.StringIO("\n".join(line for _, line in lines)))
    parsed = list(reader)
    header = [h.strip().lower() for h in parsed[0]]
    data = [(k, lines[k][0], row) for k, row in enumerate(parsed[1:], start=1)]
    return header, data


def read_probes(path: str | Path, axis: str | None = None, sphere_radius: float | None = None, tip_radius: float = 0.0) -> Centres:
    """Read a probing CSV; touches are fitted to sphere centres (vectorised over spheres)."""
    path = Path(path)
    header, data = _rows(path)
    for name in header:
        if name not in _KNOWN:
            raise ProbeFileError(path, None, name, f"unknown column (known: {', '.join(sorted(_KNOWN))})")
    for name in ("x", "y", "z"):
        if name not in header:
            raise ProbeFileError(path, None, name, "required column missing")
    if "axis" in header and axis is not None:
        raise ProbeFileError(path, 1, "axis", "the file has an axis column: --axis is for files without one; leave it out")
    if "axis" not in header and axis is None:
        raise ProbeFileError(path, None, "axis", "no axis column: give --axis A, B or C")
    if not data:
        raise ProbeFileError(path, None, None, "no data rows")
    col = {name: header.index(name) for name in header}
    n = len(data)
    xyz = np.empty((n, 3))
    angle = np.full(n, np.nan)
    ids, axes = [], []
    for k, line, row in data:
        if len(row) != len(header):
            raise ProbeFileError(path, k, None, f"{len(row)} fields, the header has {len(header)} (file line {line})")
        for j, name in enumerate("xyz"):
            xyz[k - 1, j] = _number(path, k, name, row[col[name]])
        if "angle" in col and row[col["angle"]].strip():
            angle[k - 1] = _number(path, k, "angle", row[col["angle"]])
        ax = row[col["axis"]].strip().upper() if "axis" in col else str(axis).upper()
        if ax not in ("A", "B", "C"):
            raise ProbeFileError(path, k, "axis", f"'{ax}' is not A, B or C")
        axes.append(ax)
        ids.append(row[col["id"]].strip() if "id" in col and row[col["id"]].strip() else str(k))
    if "touch" not in col:
        if sphere_radius is not None:
            raise ProbeFileError(path, 1, "touch", "a sphere radius is for touch probing; these rows are sphere centres (no touch column): leave it out")
        return Centres(tuple(ids), tuple(axes), angle, xyz, tuple(range(1, n + 1)), np.full(n, np.nan), np.full(n, np.nan))
    return _touch_centres(path, ids, axes, angle, xyz, sphere_radius, tip_radius)


def _number(path: Path, row: int, column: str, text: str, error=ProbeFileError) -> float:
    try:
        value = float(text.strip())
    except ValueError:
        raise error(path, row, column, f"'{text.strip()}' is not a number ('.' is the decimal mark)") from None
    if not math.isfinite(value):
        raise error(path, row, column, f"'{text.strip()}' is not a finite number")
    return value


def _touch_centres(path, ids, axes, angle, xyz, sphere_radius, tip_radius) -> Centres:
    """Group touches by (axis, angle) (by id where angles are absent) and fit one sphere each."""
    keys = [(a, "" if np.isnan(g) else repr(float(g)), "" if not np.isnan(g) else i) for a, g, i in zip(axes, angle, ids)]
    order: dict = {}
    group = np.array([order.setdefault(key, len(order)) for key in keys])
    first = np.array([np.nonzero(group == g)[0][0] for g in range(len(order))])
    counts = np.bincount(group)
    for g in np.nonzero(counts < 4)[0]:
        raise ProbeFileError(path, int(first[g]) + 1, "touch", f"sphere '{ids[first[g]]}' has {counts[g]} touches; at least 4 are needed")
    for g in range(len(order)):
        named = {ids[i] for i in np.nonzero(group == g)[0]}
        if len(named) != 1:
            raise ProbeFileError(path, int(np.nonzero(group == g)[0][0]) + 1, "id", f"touches of one sphere position carry different ids: {sorted(named)}")
    radius = None if sphere_radius is None else sphere_radius + tip_radius
    spread = np.array([np.linalg.svd(xyz[group == g] - xyz[group == g].mean(axis=0), compute_uv=False)[-1] for g in range(len(order))])
    if (spread < 1e-6).any():  # one small SVD per sphere: a few dozen spheres at most
        bad = int(np.nonzero(spread < 1e-6)[0][0])
        raise ProbeFileError(path, int(first[bad]) + 1, "touch", f"the touches of sphere '{ids[first[bad]]}' lie in one plane: they do not determine a sphere")
    centre, rad, rms = fit_spheres(xyz, group, len(order), radius)
    if not np.all(np.isfinite(centre)):
        bad = int(np.nonzero(~np.isfinite(centre).all(axis=1))[0][0])
        raise ProbeFileError(path, int(first[bad]) + 1, "touch", f"the touches of sphere '{ids[first[bad]]}' do not determine a sphere (coplanar?)")
    return Centres(tuple(ids[i] for i in first), tuple(axes[i] for i in first), angle[first], centre, tuple(int(i) + 1 for i in first), rms, rad)
