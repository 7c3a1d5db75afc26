"""Subdividing straight segments whose predicted path strays from the intended line.

Compensation makes every target exact under the model, but between two targets the
controller interpolates the commands while the robot's error changes: the predicted path
bows away from the intended line (``compensate.Report.path_mm``). Where that exceeds the
tolerance (``--max-deviation``, 0.02 mm by default with ``--subdivide``), the segment gets
new targets on the intended line, evenly spaced, written as copies of the segment's own
motion (same instruction, speed, zone, tool, frame; named points declared the language's
way, see ``postproc.programs.emit.insert``); then the whole program is compensated again, so new and
old targets are compensated together. The error's departure from its chord grows with the
square of the segment's length, so k pieces bring a deviation d to about d / k^2; rounds
repeat until every straight segment is within the tolerance (or refuse with the lines).

Arcs over the tolerance are split into arcs of the same circle (``arc_points``: KRL CIRC /
SCIRC, RAPID MoveC; ``gcode_arc_points``: G2 / G3, whose plane cannot follow an error across
it): copies of the statement before it, the statement itself keeping its end point.

The new text is re-parsed and every new point must read back where it was meant to be,
every old one unchanged (a split arc's own auxiliary point and centre words excepted: they
must read back as the last piece's); the caller re-parses the compensated output as for any program.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postproc.compensation.request import CompensationRequest
from postproc.compensation.segments import arc_at
from postproc.errors import EmitError, OutputCheckError
from postproc.programs import arcs, rotation_forms
from postproc.programs.emit.insert import NewPoint
from postproc.programs.ir import F_ARC, F_EXT, Kind, Toolpath
from postproc.programs.program_io import language_of
from postproc.robot import kinematics as kin
from postproc.robot.frames import invert_transform, make_transform
from postproc.robot.posture import interpolate_poses

from .compensate import (
    RUN_OPTIONS,
    ProcessForces,
    Report,
    compensate,
    process_forces,
    request_for,
)

DEFAULT_TOLERANCE_MM = 0.02
MAX_ROUNDS = 4
ARC_KINDS = (Kind.CIRC_END, Kind.ARC_CW, Kind.ARC_CCW)
MAX_PIECES = 64  # per segment and round: more means the model, not the segment, is the problem


@dataclass(frozen=True)
class Subdivided:
    """The program with its new targets (as written, uncompensated), compensated, and the report."""

    program: Toolpath
    compensated: Toolpath
    report: Report
    added: tuple[tuple[int, str], ...]  # (line in the new program's file, name or '') of each new target


def subdivide_request(request: CompensationRequest, tp: Toolpath, language, *, forces: ProcessForces | None = None,
                      **run) -> Subdivided:
    """Compensate ``tp`` as ``request`` asks, subdividing every straight segment and arc whose
    predicted path strays more than ``request.max_deviation_mm`` (default
    ``DEFAULT_TOLERANCE_MM``) from the intended one, and compensating again. ``language``:
    the program's language (its ``insert_points``, ``parse_sources``, configuration rules);
    ``run``: ``progress``, ``detail`` (``compensate``)."""
    forces = process_forces(request, tp) if forces is None else forces
    options = {**request.solver_options(), "force_per_target": forces.per_target, **run}
    options.pop("max_deviation_mm")
    return _subdivided(tp, request.machine.model, request.max_deviation_mm or DEFAULT_TOLERANCE_MM, language, options)


def compensate_subdivided(tp: Toolpath, model, tolerance_mm: float = DEFAULT_TOLERANCE_MM, *, language=None, **options) -> Subdivided:
    """``subdivide_request`` in keyword form (``options`` as ``compensate``'s; ``language``
    default: the one ``tp`` was read in)."""
    run = {key: options.pop(key) for key in RUN_OPTIONS if key in options}
    request = request_for(model, max_deviation_mm=tolerance_mm, **options)
    return subdivide_request(request, tp, language_of(tp) if language is None else language, **run)


def _subdivided(tp: Toolpath, model, tolerance_mm: float, lang, options: dict) -> Subdivided:
    added_rows: list[int] = []
    for round_ in range(MAX_ROUNDS + 1):
        new, report = compensate(tp, model, max_deviation_mm=tolerance_mm, controller=lang.controller, **options)
        over, arcs_over = _segments_over(tp, report, tolerance_mm), _arcs_over(tp, report, tolerance_mm)
        others = report.failed & ~np.isin(np.arange(len(tp)), np.r_[over, arcs_over])
        if not (len(over) or len(arcs_over)) or others.any() or round_ == MAX_ROUNDS:
            break
        placed = tp.with_frames(options.get("frames"), options.get("tools")) if options.get("frames") or options.get("tools") else tp
        circ = arcs_over[tp.kind[arcs_over] == Kind.CIRC_END]
        g2g3 = arcs_over[tp.kind[arcs_over] != Kind.CIRC_END]
        points = (new_points(placed, model.robot, over, pieces(report.path_mm[over], tolerance_mm), language=lang)
                  + arc_points(placed, model.robot, circ, pieces(report.path_mm[circ], tolerance_mm), language=lang)
                  + gcode_arc_points(placed, g2g3, pieces(report.path_mm[g2g3], tolerance_mm)))
        sources, _ = lang.insert_points(tp, points)
        longer = lang.parse_sources(sources)
        new_index = check_inserted(tp, longer, placed, points, options)
        options = _options_for_longer(options, tp, points, new_index)
        added_rows = [int(new_index[r]) for r in added_rows] + [int(i) for i in _inserted_rows(tp, points, new_index)]
        tp = longer
    added = tuple((int(tp.line[r]), tp.target_name[r]) for r in sorted(added_rows))
    return Subdivided(tp, new, report, added)


def _options_for_longer(options: dict, tp: Toolpath, points: list[NewPoint], new_index: np.ndarray) -> dict:
    """Per-target options (a force per motion block) for the longer program: a new target
    gets the value of the motion it was copied from."""
    per_target = options.get("force_per_target")
    if per_target is None:
        return options
    per_target = np.asarray(per_target)
    inserted = [points[i] for i in _inserted_order(points)]
    out = np.zeros((len(tp) + len(inserted),) + per_target.shape[1:])
    out[new_index] = per_target
    out[_inserted_rows(tp, points, new_index)] = per_target[[p.row for p in inserted]]
    return {**options, "force_per_target": out}


def _segments_over(tp: Toolpath, report: Report, tolerance_mm: float) -> np.ndarray:
    path = np.nan_to_num(report.path_mm, nan=0.0)
    return np.nonzero((path > tolerance_mm) & (tp.kind == Kind.LINEAR))[0]


def _arcs_over(tp: Toolpath, report: Report, tolerance_mm: float) -> np.ndarray:
    """End rows of the circular motions (CIRC / SCIRC / MoveC) whose predicted arc strays too far."""
    path = np.nan_to_num(report.path_mm, nan=0.0)
    return np.nonzero((path > tolerance_mm) & np.isin(tp.kind, ARC_KINDS))[0]


def pieces(deviation_mm: np.ndarray, tolerance_mm: float) -> np.ndarray:
    """Pieces per segment so that deviation / pieces^2 is 0.7 of the tolerance (at least 2)."""
    k = np.ceil(np.sqrt(np.asarray(deviation_mm) / (0.7 * tolerance_mm)))
    return np.clip(k, 2, MAX_PIECES).astype(int)


def new_points(tp: Toolpath, robot, rows: np.ndarray, count: np.ndarray, *, language=None) -> list[NewPoint]:
    """Targets evenly spaced on the intended straight segments into ``rows`` (``count[i]``
    pieces each), with orientation interpolated as the controller does, in each end
    target's frame and notation. ``language``: the program's (default: the one ``tp`` was read in)."""
    lang = language_of(tp) if language is None else language
    base = tp.base_poses()
    points = []
    repeated = _runs_more_than_once(tp)
    for r, k in zip(rows.tolist(), count.tolist()):
        if repeated[r]:
            raise EmitError(f"{tp.sources[int(tp.file[r])].path}, line {tp.line[r]}: the block runs more than once (a loop or "
                            "subprogram body): a point inserted before it would run every time")
        t = np.arange(1, k) / k
        poses = interpolate_poses(base[r - 1 : r], base[r : r + 1], t)[0]
        values = _values_at(tp, r, poses, t, r - 1)
        conf = _conf(lang, robot, tp, r, poses)
        points += [NewPoint(r, values[j], conf[j]) for j in range(k - 1)]
    return points


def gcode_arc_points(tp: Toolpath, rows: np.ndarray, count: np.ndarray) -> list[NewPoint]:
    """A G2 / G3 into each row of ``rows`` split into ``count[i]`` arcs of the same circle (or
    helix): copies of its block before it, each ending at the next piece's start with the
    centre words (I J K or R, in the block's own form) of its piece, and the block itself
    given the last piece's centre words (and end-point words where a full circle had none).
    A planar arc cannot follow an error across its plane; each piece's ends are compensated,
    so what is left shrinks with the square of the piece."""
    geometry = arcs.geometry(tp)
    base = tp.base_poses()
    repeated = _runs_more_than_once(tp)
    points = []
    for r, k in zip(rows.tolist(), count.tolist()):
        if repeated[r]:
            raise EmitError(f"{tp.sources[int(tp.file[r])].path}, line {tp.line[r]}: the block runs more than once (a loop or "
                            "subprogram body): an arc inserted before it would run every time")
        one = geometry.take(np.nonzero(geometry.rows == r)[0][:1])
        t = np.arange(k + 1) / k
        local = one.points(t)[0]
        piece = arcs.Arcs(np.full(k, r), np.repeat(one.axes, k, axis=0), local[:-1], local[1:], np.repeat(one.centre, k, axis=0),
                          np.repeat(one.ccw, k), np.zeros(k, dtype=bool))
        words = arcs.centre_words(tp, piece)
        frame = tp.frames[tp.frame[r]]
        poses = interpolate_poses(base[r - 1][None], base[r][None], t[1:])[0]
        poses[:, :3, 3] = local[1:] @ frame[:3, :3].T + frame[:3, 3]
        values = _values_at(tp, r, poses, t[1:], r - 1, every_axis=True)
        values[:, F_ARC] = np.where(np.isnan(words), tp.values[r, F_ARC], words)
        points += [NewPoint(r, values[j], np.full(4, np.nan)) for j in range(k - 1)]
        points.append(NewPoint(r, values[k - 1], np.full(4, np.nan), replaces=True))
    return points


def _values_at(tp: Toolpath, r: int, poses: np.ndarray, t: np.ndarray, start: int, every_axis: bool = False) -> np.ndarray:
    """Numbers (K, FIELDS) of copies of target ``r`` at ``poses`` (base frame), in its frame and
    notation; external axes interpolated at fractions ``t`` from target ``start``. An
    auxiliary point's orientation is left as written (the controller ignores it)."""
    local = invert_transform(tp.frames[tp.frame[r]]) @ poses
    values = np.repeat(tp.values[r][None], len(poses), axis=0)
    values[:, 0:3] = local[:, :3, 3] if every_axis else np.where(np.isnan(values[:, 0:3]), np.nan, local[:, :3, 3])
    via = tp.kind[r] == Kind.CIRC_VIA
    if not every_axis:  # (a G2 / G3 piece gets every axis word it needs written)
        _require_inherited(tp, r, local, orientation=not via)
    if not via or not np.isnan(tp.values[r, 3:6]).all():
        values[:, 3:7] = _orientation_values(tp, r, local[:, :3, :3], values[:, 3:7])
    ext_start, ext_end = tp.values[start, F_EXT], tp.values[r, F_EXT]
    both = ~np.isnan(ext_start) & ~np.isnan(ext_end)
    values[:, F_EXT] = np.where(both, ext_start + t[:, None] * (ext_end - ext_start), values[:, F_EXT])
    return values


def arc_points(tp: Toolpath, robot, rows: np.ndarray, count: np.ndarray, *, language=None) -> list[NewPoint]:
    """A circular motion into each end row of ``rows`` split into ``count[i]`` arcs of the
    same circle: copies of its statement (auxiliary point in the middle of each piece, end
    point at its end) written before it, and its own auxiliary point moved to the middle of
    the last piece (a named one declared anew). Orientation runs from start to end as the
    controller interpolates it. ``language``: the program's (default: the one ``tp`` was read in)."""
    lang = language_of(tp) if language is None else language
    base = tp.base_poses()
    repeated = _runs_more_than_once(tp)
    points = []
    for r, k in zip(rows.tolist(), count.tolist()):
        via, start = r - 1, r - 2
        if repeated[r]:
            raise EmitError(f"{tp.sources[int(tp.file[r])].path}, line {tp.line[r]}: the block runs more than once (a loop or "
                            "subprogram body): an arc inserted before it would run every time")
        t_end, t_via = np.arange(1, k) / k, (np.arange(k) + 0.5) / k
        ends = arc_at(base[start][None], base[via][None], base[r][None], t_end)[0]
        vias = arc_at(base[start][None], base[via][None], base[r][None], t_via)[0]
        end_values, via_values = _values_at(tp, r, ends, t_end, start), _values_at(tp, via, vias, t_via, start)
        end_conf, via_conf = _conf(lang, robot, tp, r, ends), _conf(lang, robot, tp, via, vias)
        for j in range(k - 1):
            points += [NewPoint(via, via_values[j], via_conf[j], at=via), NewPoint(r, end_values[j], end_conf[j], at=via)]
        points.append(NewPoint(via, via_values[k - 1], via_conf[k - 1], replaces=True))
    return points


def _runs_more_than_once(tp: Toolpath) -> np.ndarray:
    """(N,) True where the target's text is executed by several rows (G-code loops and subs
    are unrolled into one row per execution, sharing the text's spans)."""
    spans = np.where(tp.spans[:, :, 0] >= 0, tp.spans[:, :, 1], np.iinfo(np.int64).max).min(axis=1)
    keys = np.stack([tp.file.astype(np.int64), tp.line.astype(np.int64), spans], axis=1)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    return counts[inverse.ravel()] > 1


def _require_inherited(tp: Toolpath, r: int, local: np.ndarray, orientation: bool = True) -> None:
    """A coordinate or orientation the target leaves out (it keeps the previous value) must
    not change along the segment, or a copy that leaves it out too would be elsewhere."""
    missing = np.isnan(tp.values[r, 0:3])
    moves = np.abs(local[:, :3, 3][:, missing] - tp.position[r, missing]).max(initial=0.0) > 1e-6
    turns = orientation and np.isnan(tp.values[r, 3:6]).all() and np.abs(local[:, :3, :3] - tp.target_poses()[r, :3, :3]).max() > 1e-9
    if moves or turns:
        raise EmitError(f"{tp.sources[int(tp.file[r])].path}, line {tp.line[r]}: the target leaves out a coordinate that changes "
                        "along the segment into it: a point before it cannot be written as a copy")


def _orientation_values(tp: Toolpath, r: int, rot: np.ndarray, like: np.ndarray) -> np.ndarray:
    """Orientation numbers (K, 4) in the program's notation, each close to the end target's."""
    out = like.copy()
    notation = rotation_forms.form(tp.orientation_kind)
    if notation.width:
        near = np.repeat(tp.values[r, 3:3 + notation.width][None], len(rot), axis=0)
        out[:, :notation.width] = notation.numbers_from_matrix(rot, near)
    return np.where(np.isnan(like), np.nan, out)


def _conf(lang, robot, tp: Toolpath, r: int, poses: np.ndarray) -> np.ndarray:
    """Configuration data of the new points: the joints on the end target's branch, in the
    language's notation; NaN (copy the end target's) where it gives none or the branch has no solution."""
    k = len(poses)
    conf = np.full((k, 4), np.nan)
    if np.isnan(tp.conf[r]).all():
        return conf
    inv_tool = np.linalg.inv(tp.tools[tp.tool[r]])
    end_flange = (tp.base_poses()[r] @ inv_tool)[None]
    q_end, branch = lang.controller.branch_from_conf(robot, kin.ik(robot, end_flange), tp.conf[r][None])
    if branch[0] < 0:
        return conf
    q, b = kin.select_branch(robot, kin.ik(robot, poses @ inv_tool), np.repeat(branch, k), np.repeat(q_end, k, axis=0))
    ok = b >= 0
    if ok.any():
        conf[ok] = lang.conf_of_joints(robot, q[ok])
    return conf


def _inserted_order(points: list[NewPoint]) -> list[int]:
    """Indices of the points that become new rows, in the longer program's order."""
    return sorted((i for i, p in enumerate(points) if not p.replaces), key=lambda i: points[i].before)


def _new_index(tp: Toolpath, points: list[NewPoint]) -> np.ndarray:
    """Index in the longer program of every old row (new points go just before their row)."""
    before = np.bincount([p.before for p in points if not p.replaces], minlength=len(tp))
    return np.arange(len(tp)) + np.cumsum(before)


def _inserted_rows(tp: Toolpath, points: list[NewPoint], new_index: np.ndarray) -> list[int]:
    out = []
    inserted = [points[i] for i in _inserted_order(points)]
    for r in sorted({p.before for p in inserted}):
        k = sum(p.before == r for p in inserted)
        out += list(range(int(new_index[r]) - k, int(new_index[r])))
    return out


def check_inserted(tp: Toolpath, longer: Toolpath, placed: Toolpath, points: list[NewPoint], options: dict) -> np.ndarray:
    """The re-parsed program must hold every old target unchanged and every new one where it
    was meant (position 1e-3 mm, orientation 1e-6), of its segment's kind; else an OutputCheckError.
    Returns the new index of every old row."""
    where = tp.sources[0].path
    order = _inserted_order(points)
    if len(longer) != len(tp) + len(order):
        raise OutputCheckError(f"{where}: with {len(order)} new targets the program reads back with {len(longer)} targets, not {len(tp) + len(order)}")
    new_index = _new_index(tp, points)
    frames, tools = options.get("frames"), options.get("tools")
    longer_placed = longer.with_frames(frames, tools) if frames or tools else longer
    got, want = longer_placed.base_poses(), placed.base_poses().copy()
    for p in points:
        if p.replaces:  # a split arc's own auxiliary point, moved
            want[p.row] = _pose_from_values(placed, p)
    inserted = np.array(_inserted_rows(tp, points, new_index), dtype=int)
    intended = np.stack([_pose_from_values(placed, points[i]) for i in order])
    checks = [(new_index, want, "a target", tp.kind), (inserted, intended, "a new target", tp.kind[[points[i].row for i in order]])]
    for rows, poses, what, kinds in checks:
        same_unknown = np.isnan(got[rows]) & np.isnan(poses)  # an old target unknown before stays so
        diff = np.where(same_unknown, 0.0, np.abs(got[rows] - poses))
        bad = ~(diff[:, :3, 3].max(axis=1) <= 1e-3)  # NaN (unknown where it was known): bad
        bad |= ~(diff[:, :3, :3].max(axis=(1, 2)) <= 1e-5) & (kinds != Kind.CIRC_VIA)  # an auxiliary point's orientation is not used
        bad |= longer.kind[rows] != kinds
        if bad.any():
            i = int(rows[np.nonzero(bad)[0][0]])
            raise OutputCheckError(f"{longer.sources[int(longer.file[i])].path}, line {longer.line[i]}: {what} reads back wrong after subdividing; nothing was written")
    _check_split_arcs(placed, longer_placed, points, new_index, inserted, order)
    return new_index


def _check_split_arcs(placed: Toolpath, longer_placed: Toolpath, points: list[NewPoint], new_index, inserted, order) -> None:
    """Every piece of a split G2 / G3, as its words read back, lies on the arc it came from
    (its centre words are not targets, so the pose check above does not see them)."""
    split = sorted({p.row for p in points if p.replaces and placed.kind[p.row] in (Kind.ARC_CW, Kind.ARC_CCW)})
    if not split:
        return
    before, after = arcs.geometry(placed), arcs.geometry(longer_placed)
    for r in split:
        rows = [int(inserted[i]) for i, k in enumerate(order) if points[k].row == r] + [int(new_index[r])]
        one = before.take(np.nonzero(before.rows == r)[0][:1])
        pieces = after.take(np.searchsorted(after.rows, rows))
        off = one.distance(pieces.points(np.linspace(0.0, 1.0, 9)).reshape(1, -1, 3))
        if not (off.max() <= 2e-3):
            i = rows[int(np.argmax(off.reshape(len(rows), -1).max(axis=1)))]
            raise OutputCheckError(f"{longer_placed.sources[int(longer_placed.file[i])].path}, line {longer_placed.line[i]}: a piece of the split arc "
                                   f"reads back {off.max():.4f} mm off the arc; nothing was written")


def _pose_from_values(placed: Toolpath, p: NewPoint) -> np.ndarray:
    v = p.values  # as the parser reads the numbers (postproc.programs.parse.common)
    notation = rotation_forms.form(placed.orientation_kind)
    numbers = v[3:3 + notation.width]
    if notation.to_matrix is not None and not np.isnan(numbers).any():
        rot = notation.to_matrix(numbers[None])[0]
    else:
        rot = placed.target_poses()[p.row][:3, :3]
    position = np.where(np.isnan(v[0:3]), placed.position[p.row], v[0:3])  # left out: kept from before
    return placed.frames[placed.frame[p.row]] @ make_transform(rot[None], position[None])[0]
