"""Writing a new robot program from a Toolpath (when the input was another language).

A narrow event protocol, as CAM post-processors use: start, frame, tool, speed, zone,
move_joint / move_linear / move_circular / move_joints, raw line, end. Each dialect that
can write a new program implements it (``Dialect.new_writer``); ``drive`` plays a
Toolpath through one. This module imports no language: the rules of the language a
Toolpath was read in come in as an argument (the dialects' writers import it).
"""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import EmitError
from postproc.robot.frames import quat_wxyz_to_matrix

from ..arcs import arc_rows, geometry
from ..ir import Kind, Toolpath
from .feeds import machine_speeds
from .unknown_axes import refuse_unknown_positions

# A tool pointing straight down (180 degrees about y): the orientation given to targets
# that come without one (3-axis G-code).
TOOL_DOWN = np.array([0.0, 0.0, 1.0, 0.0])


def legal_name(text: str, prefix: str) -> str:
    """``text`` as an identifier (letters, digits, '_', a letter first)."""
    clean = re.sub(r"[^A-Za-z0-9_]", "_", text).strip("_") or prefix
    return clean if clean[0].isalpha() else f"{prefix}_{clean}"


def short_number(v: float, decimals: int = 4) -> str:
    """``v`` rounded to ``decimals``, without trailing zeros (and never '-0')."""
    text = f"{v:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def drive(w, tp: Toolpath, name: str = "converted", loads=None, arc_tol_mm: float | None = None, *, source) -> list[str]:
    """Texts of a new program (the writer's files, e.g. KRL [src, dat]) with every target of tp;
    ``loads`` (emit.load_plan.LoadPlan): the load of each target, given to ``w.load`` after its
    tool and wherever it changes; ``arc_tol_mm``: helical and spiral arcs become straight
    moves within this chord error (refused without it). ``source``: the rules of the language
    ``tp`` was read in (a ``Dialect``; its ``speed_to_mm_per_s`` and ``machine_program`` are
    used), given by the caller so that emit imports no language."""
    w.start(name)
    if hasattr(w, "source"):  # a writer that takes the input's configuration data only in its own language's terms
        w.source = source.name
    refuse_unknown_positions(tp)  # which axis, why, and how to give it
    refuse_unplaced(tp, source.machine_program)
    poses = tp.target_poses()
    no_ori = np.isnan(tp.orientation).any(axis=1)
    if no_ori.any():
        poses[no_ori, :3, :3] = quat_wxyz_to_matrix(TOOL_DOWN[None])[0]
    frame = tool = load = -1
    speed = zone = None
    # G-code feeds are mm/min (the IR keeps speeds as written); the writers take mm/s.
    per_second = source.speed_to_mm_per_s
    # G93 / G95 feeds as the speed the machine moves at (F x length, F x S), or refused with the F word's place.
    speeds = machine_speeds(tp) if source.machine_program else tp.speed
    arcs = circular_moves(tp, poses, arc_tol_mm)
    i = 0
    while i < len(tp):
        if tp.frame[i] != frame:
            frame = int(tp.frame[i])
            w.frame(tp.frame_names[frame], tp.frames[frame])
        if tp.tool[i] != tool:
            tool = int(tp.tool[i])
            w.tool(tp.tool_names[tool], tp.tools[tool])
            load = -2
        if hasattr(w, "load") and (-1 if loads is None else int(loads.index[i])) != load:
            load = -1 if loads is None else int(loads.index[i])
            w.load(None if load < 0 else loads.states[load])
        if speed is None or not np.array_equal(speeds[i], speed, equal_nan=True):
            speed = speeds[i]
            w.speed(float(speed) * per_second)
        if zone is None or not np.array_equal(tp.zone[i], zone, equal_nan=True):
            zone = tp.zone[i]
            w.zone(float(zone))
        kind = int(tp.kind[i])
        if kind == Kind.CIRC_VIA and i + 1 < len(tp):
            w.move_circular(poses[i], poses[i + 1], tp.conf[i + 1])
            i += 2
            continue
        if kind == Kind.ABSJ:
            w.move_joints(tp.joints[i])
        elif kind in (Kind.JOINT, Kind.RAPID):
            w.move_joint(poses[i], tp.conf[i])
        elif kind in (Kind.ARC_CW, Kind.ARC_CCW) and i in arcs:
            for via, end in arcs[i]:  # a G2/G3 as circular moves through the points the controller's arc passes
                if via is None:  # a helix or spiral piece (--arc-tol): a straight move
                    w.move_linear(end, tp.conf[i])
                else:
                    w.move_circular(via, end, tp.conf[i])
        else:
            w.move_linear(poses[i], tp.conf[i])
        i += 1
    return w.end()


def refuse_unplaced(tp: Toolpath, machine_program: bool) -> None:
    """A new program states every target in the robot's base: a target whose position the
    input does not determine (flagged when read: an unknown parameter, a Z after a tool
    length change, cutter compensation), or whose frame or tool the input does not define
    (a work offset G54 never set by G10, a G43 H1 length in the tool table), would be
    written with a stand-in (the identity). Refused with file:line:column of its block
    (``frames``/``tools`` given by name, ``Toolpath.with_frames``, place them); so are
    G-code rotary axis words, which a robot program has no place for (``machine_program``:
    ``tp`` was read in a language that drives machine axes, ``Dialect.machine_program``)."""
    cart = tp.kind != Kind.ABSJ
    frame_ok = np.ones(len(tp), bool) if tp.frame_known is None else tp.frame_known[tp.frame]
    tool_ok = np.ones(len(tp), bool) if tp.tool_known is None else tp.tool_known[tp.tool]
    # (a five-axis program read with --machine has its rotary axes turned into orientations: carried)
    rotary = ~np.isnan(tp.ext[:, :3]).all(axis=1) & np.isnan(tp.orientation).any(axis=1) if machine_program else np.zeros(len(tp), bool)
    for rows, why in ((cart & ~tp.resolved, lambda r: "the target's position depends on what the program text does not determine (see the notes "
                                                       "of `postproc inspect`); it cannot be written"),
                      (cart & ~frame_ok, lambda r: f"the target is in frame {tp.frame_names[tp.frame[r]]}, which the program does not define (a work offset "
                                                   "is set on the controller, e.g. by G10 L2): give it with --frame "
                                                   f"{_base_name(tp.frame_names[tp.frame[r]])}=X,Y,Z,A,B,C (the robot base -> the frame, mm, deg)"),
                      (cart & ~tool_ok, lambda r: f"the target is for tool {tp.tool_names[tp.tool[r]]}, which the program does not define (a tool length is in "
                                                  f"the controller's tool table): give it with --tool {tp.tool_names[tp.tool[r]]}=X,Y,Z[,A,B,C] "
                                                  "(the flange -> the tool tip, mm, deg)"),
                      (rotary, lambda r: "rotary axis words (A B C) move a five-axis machine, not a robot: convert with --machine "
                                         "(a five-axis machine file) and --input-axes")):
        if rows.any():
            r = int(np.argmax(rows))
            raise EmitError(f"{where(tp, r)}: {why(r)}")


def _base_name(frame_name: str) -> str:
    """The name --frame takes for a frame composed on an undefined one (G54+G92@line4 -> G54)."""
    return frame_name.split("+")[0]


def where(tp: Toolpath, row: int) -> str:
    """``file:line:column`` of a target's block (the column of its first word read, else 1)."""
    doc = tp.sources[int(tp.file[row])]
    spans = tp.spans[row]
    mine = (spans[:, 1] >= 0) & ((spans[:, 0] == int(tp.file[row])) | (spans[:, 0] < 0))
    column = 1
    if mine.any():
        start = int(spans[mine, 1].min())
        column = start - (doc.text.rfind("\n", 0, start) + 1) + 1
    return f"{doc.path}:{tp.line[row]}:{column}"


ARC_RADIUS_TOL_MM = 2e-3  # start and end radius may differ this much (LinuxCNC accepts such arcs) for one circle


def circular_moves(tp: Toolpath, poses: np.ndarray, arc_tol_mm: float | None = None) -> dict[int, list[tuple[np.ndarray | None, np.ndarray]]]:
    """Target row of each G2/G3 -> its (via, end) poses for circular moves (a full circle: two
    halves), on the arc as the controller runs it, with the end target's orientation. An arc
    no circle through three points can hold (a helix, a spiral) is refused with its place
    (writing its chord would cut a different path), or with ``arc_tol_mm`` written as
    straight moves (via None) whose chord error is at most that."""

    rows = arc_rows(tp)
    if not len(rows):
        return {}
    geo = geometry(tp)  # in each end target's frame, like the poses written
    if len(geo.rows) < len(rows):
        first = int(np.setdiff1d(rows, geo.rows)[0])
        raise EmitError(f"line {tp.line[first]}: an arc whose start is not known here (the program's first move) cannot be written "
                        "as a circular move")
    r0 = np.linalg.norm(geo.in_plane(geo.start) - geo.centre, axis=1)
    r1 = np.linalg.norm(geo.in_plane(geo.end) - geo.centre, axis=1)
    helix = np.abs(geo.normal(geo.end) - geo.normal(geo.start)) > 1e-6
    spiral = np.abs(r1 - r0) > ARC_RADIUS_TOL_MM
    if (helix | spiral).any() and arc_tol_mm is None:
        m = int(np.argmax(helix | spiral))
        bad = int(geo.rows[m])
        raise EmitError(f"{where(tp, bad)}: a {'helical' if helix[m] else 'spiral'} arc is no circle: the target language's circular "
                        "move cannot write it; give --arc-tol MM to write it as straight moves within that chord error (as the FreeCAD post "
                        "does), or split it into plane arcs first")
    # The arcs' points at 1/4, 1/2, 3/4 of the sweep, as poses with the end target's orientation.
    via = np.repeat(poses[geo.rows][:, None], 3, axis=1)
    via[:, :, :3, 3] = geo.points(np.array([0.25, 0.5, 0.75]))
    out = {}
    for m, r in enumerate(geo.rows.tolist()):
        if helix[m] or spiral[m]:
            out[r] = [(None, p) for p in _straight_pieces(geo, m, poses[r], max(r0[m], r1[m]), arc_tol_mm)]
            continue
        out[r] = [(via[m, 0], via[m, 1]), (via[m, 2], poses[r])] if geo.full[m] else [(via[m, 1], poses[r])]
    return out


def _straight_pieces(geo, m: int, end_pose: np.ndarray, radius: float, tol_mm: float) -> list[np.ndarray]:
    """End poses of the fewest straight moves along arc ``m`` of ``geo`` (a helix or a spiral,
    as the controller interpolates it) whose chord error in the plane is at most ``tol_mm``;
    the last is the arc's own end target (the angle whose chord has sagitta tol: 2 acos(1 - tol/r))."""
    _, sweep = geo.sweep()
    step = 2 * np.arccos(max(1.0 - tol_mm / max(radius, 1e-9), -1.0))
    n = max(int(np.ceil(abs(float(sweep[m])) / step)), 1)
    points = geo.points(np.arange(1, n) / n)[m] if n > 1 else np.zeros((0, 3))
    pieces = [end_pose.copy() for _ in range(n - 1)]
    for pose, point in zip(pieces, points):
        pose[:3, 3] = point
    return pieces + [end_pose]
