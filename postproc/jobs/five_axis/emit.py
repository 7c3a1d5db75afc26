"""Five-axis G-code emitters: LinuxCNC TCP, Fanuc G43.4, Siemens TRAORI, and machine axes.

Every mode solves the machine's inverse kinematics (both branches, continuity, limits,
the pole held): the RTCP modes write the tool tip (workpiece frame) with the rotary angles
the controller will turn to; ``none`` writes the machine axes themselves, from the
machine file given (a calibrated one makes the calibration count on a controller without
RTCP). Feeds: RTCP modes keep the tool-tip feed (G94, mm/min); machine-axis moves that
turn a rotary axis use inverse time (G93, F = 1 / minutes) so the tip keeps its feed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from postproc.fivex.errors import UnreachableError
from postproc.fivex.given_angles import keep_given
from postproc.fivex.kinematics import POLE_TOL_DEG, fk, ik
from postproc.fivex.machine import Machine

from .program import FivePath

MODES = ("linuxcnc", "fanuc", "siemens", "none")
DECIMALS = 6  # 1e-6 mm / deg: a robot -> G-code -> robot round trip stays within 1e-6 mm


@dataclass(frozen=True)
class Emitted:
    text: str
    axes: np.ndarray  # (N, 5) machine axes of every target
    held: np.ndarray  # (N,) rotary angle held at the pole
    chord_error_mm: float  # largest tip deviation at the middle of a machine-axis move (mode none)
    notes: tuple[str, ...]
    path: FivePath  # the targets written (with the intermediate ones of mode none)


def _num(v: float) -> str:
    text = f"{v:.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "", "-") else text


def solve(machine: Machine, path: FivePath, tool_length: float = 0.0):
    """IK of every target; unreachable targets stop the job naming their lines."""
    start = (0.0, 0.0) if path.angles is None else tuple(path.angles[0])
    result = ik(machine, path.tip, path.axis, start_deg=start, tool_length=tool_length)
    result = keep_given(machine, path.tip, path.axis, path.angles, result, tool_length)  # the input's own rotary positions (given_angles.py)
    if not result.reachable.all():
        bad = np.nonzero(~result.reachable)[0]
        lines = ", ".join(str(int(path.line[i])) for i in bad[:20]) + (" ..." if len(bad) > 20 else "")
        raise UnreachableError(f"{path.source}: {len(bad)} target(s) outside machine {machine.name}'s limits (lines {lines}); nothing was written")
    return result


def _header(mode: str, machine: Machine, path: FivePath) -> list[str]:
    c = ";" if mode == "siemens" else None
    kins = machine.linuxcnc.get("kinematics", "its kinematics module")
    switch = f"{kins}{' (M428 in the trt sim configs)' if kins.endswith('trt-kins') else ''}"
    what = {"linuxcnc": f"LinuxCNC TCP kinematics (tool tip + rotary angles); run with {switch}",
            "fanuc": "Fanuc tool centre point control G43.4 (tool tip + rotary angles)",
            "siemens": "Siemens TRAORI (tool tip + rotary angles)",
            "none": "machine axes (no RTCP), from the machine file's kinematics"}[mode]
    # file names only: the program must not depend on where it was made
    texts = [f"postproc: {what}", f"machine {machine.name} ({Path(machine.source_path).name}); from {Path(path.source).name}"]
    if machine.calibration:
        texts.append("machine axes calibrated: " + ", ".join(f"{k} {v}" for k, v in machine.calibration.items()))
    return [f"; {t}" if c else f"({t.replace('(', '[').replace(')', ']')})" for t in texts]


def subdivide(machine: Machine, path: FivePath, max_deviation_mm: float, tool_length: float = 0.0, rounds: int = 8) -> FivePath:
    """Machine-axis moves split until the tip, with the axes interpolated linearly as the
    controller does, stays within ``max_deviation_mm`` of the straight tip path at every
    move's middle (the chord error falls with the square of the number of pieces)."""
    for _ in range(rounds):
        axes = solve(machine, path, tool_length).axes
        dev = np.zeros(len(axes))
        if len(axes) > 1:
            mid, _ = fk(machine, 0.5 * (axes[1:] + axes[:-1]), tool_length)
            dev[1:] = np.linalg.norm(mid - 0.5 * (path.tip[1:] + path.tip[:-1]), axis=1)
        dev[path.rapid] = 0.0
        if dev.max() <= max_deviation_mm:
            return path
        pieces = np.maximum(1, np.ceil(np.sqrt(dev / max_deviation_mm) * 1.2)).astype(int)
        path = _split(path, pieces)
    return path


def _split(path: FivePath, pieces: np.ndarray) -> FivePath:
    """Each move i cut into pieces[i] equal steps of the tip (and the normalised tool axis)."""
    owner = np.repeat(np.arange(len(pieces)), pieces)
    step = np.arange(len(owner)) - np.repeat(np.cumsum(pieces) - pieces, pieces) + 1
    frac = (step / pieces[owner])[:, None]
    prev = np.maximum(owner - 1, 0)
    tip = path.tip[prev] + frac * (path.tip[owner] - path.tip[prev])
    axis = path.axis[prev] + frac * (path.axis[owner] - path.axis[prev])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    return FivePath(tip, axis, path.rapid[owner], path.feed[owner], path.time_min[owner] / pieces[owner], path.line[owner],
                    None if path.angles is None else path.angles[owner], path.source, path.notes, path.tool_length)


def emit(machine: Machine, path: FivePath, mode: str, tool: int = 1, tool_length: float = 0.0, max_deviation_mm: float | None = 0.01) -> Emitted:
    """The program text for ``mode`` and the machine axes it commands (``path`` of the
    result: the targets written, after subdivision in mode none)."""
    if mode == "none" and max_deviation_mm is not None:
        before = len(path.tip)
        path = subdivide(machine, path, max_deviation_mm, tool_length)
        if len(path.tip) > before:
            path = _with_note(path, f"{len(path.tip) - before} intermediate target(s) added so that the tip stays within {max_deviation_mm} mm of the straight path between targets")
    result = solve(machine, path, tool_length)
    axes = result.axes
    letters = machine.axes
    lines = _header(mode, machine, path)
    lines += {"linuxcnc": ["G21 G90 G94 G17 G40"], "fanuc": ["G21 G90 G94 G17 G40", f"G43.4 H{tool}"],
              "siemens": ["G71 G90 G94 G17 G40", "TRAORI"], "none": ["G21 G90 G94 G17 G40"]}[mode]
    pos = axes[:, :3] if mode == "none" else path.tip
    words = np.c_[pos, axes[:, 3:5]]
    # RTCP modes keep the tip feed, and an input block's own inverse time (a pure
    # reorientation has no tip feed); machine axes get inverse time wherever a rotary turns.
    g93 = _inverse_time(machine, path, axes) if mode == "none" else np.where(path.rapid, np.nan, 1.0 / path.time_min)
    feed_mode = "G94"
    for i in range(len(pos)):  # text assembly only; every number was computed above, vectorised
        parts = ["G0" if path.rapid[i] else "G1"]
        if not path.rapid[i] and np.isfinite(g93[i]) and feed_mode != "G93":
            parts.insert(0, "G93")
            feed_mode = "G93"
        elif not path.rapid[i] and not np.isfinite(g93[i]) and feed_mode != "G94":
            parts.insert(0, "G94")
            feed_mode = "G94"
        parts += [f"{ax}{_num(v)}" for ax, v in zip(letters, words[i])]
        if not path.rapid[i]:
            parts.append(f"F{_num(g93[i] if np.isfinite(g93[i]) else path.feed[i])}")
        lines.append(" ".join(parts))
    lines += {"linuxcnc": ["G94", "M2"], "fanuc": ["G94", "G49", "M30"], "siemens": ["G94", "TRAFOOF", "M30"], "none": ["G94", "M2"]}[mode]
    notes = list(path.notes)
    if result.held.any():
        worst = float(np.degrees(np.nanmax(result.axis_error_rad[result.held])))
        notes.append(f"{int(result.held.sum())} target(s) within {POLE_TOL_DEG} deg of the singular pole (tool axis along a rotary axis): that axis was held "
                     f"(at its previous angle; at the program start, at the angle the first tilted target needs); tool axis off by at most {worst:.4f} deg there")
    chord = _chord_error(machine, path, axes) if mode == "none" else 0.0
    return Emitted("\n".join(lines) + "\n", axes, result.held, chord, tuple(notes), path)


def _with_note(path: FivePath, note: str) -> FivePath:
    return replace(path, notes=path.notes + (note,))


def _inverse_time(machine: Machine, path: FivePath, axes: np.ndarray) -> np.ndarray:
    """(N,) G93 F words (1/min) for feed moves that turn a rotary axis, NaN for the others.
    Time: the input's own G93 time, else tip distance / tip feed; a move with a fixed tip
    takes the machine's linear distance, or the rotary angle (deg as mm) when that is zero."""
    prev = np.vstack([axes[:1], axes[:-1]])
    turns = np.abs(axes[:, 3:5] - prev[:, 3:5]).max(axis=1) > 1e-9
    tip_prev = np.vstack([path.tip[:1], path.tip[:-1]])
    length = np.linalg.norm(path.tip - tip_prev, axis=1)
    linear = np.linalg.norm(axes[:, :3] - prev[:, :3], axis=1)
    angular = np.abs(axes[:, 3:5] - prev[:, 3:5]).max(axis=1)
    length = np.where(length > 1e-9, length, np.where(linear > 1e-9, linear, angular))
    with np.errstate(divide="ignore", invalid="ignore"):  # no-motion blocks: not turning, NaN below
        minutes = np.where(np.isfinite(path.time_min), path.time_min, length / path.feed)
        return np.where(turns & ~path.rapid & (minutes > 0), 1.0 / minutes, np.nan)


def _chord_error(machine: Machine, path: FivePath, axes: np.ndarray) -> float:
    """Largest distance between the tip at the middle of each machine-axis move (axes
    interpolated linearly, as the controller does) and the middle of the straight tip path."""
    if len(axes) < 2:
        return 0.0
    mid_axes = 0.5 * (axes[1:] + axes[:-1])
    tip_mid, _ = fk(machine, mid_axes, path.tool_length)
    want = 0.5 * (path.tip[1:] + path.tip[:-1])
    feed = ~path.rapid[1:]
    return float(np.linalg.norm(tip_mid - want, axis=1)[feed].max()) if feed.any() else 0.0
