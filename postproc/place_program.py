"""A program as a placement problem, and the program written back with its new workpiece frame.

The program's Cartesian targets must all lie in one workpiece frame (RAPID work object,
KRL $BASE). Writing replaces only that frame's numbers: the RAPID wobjdata uframe (the
oframe is kept, uframe = best . inv(oframe)) or the KRL ``$BASE = {X .., C ..}`` literal;
the written text is parsed again and must place every target where the new frame puts it,
else nothing is written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import compliance as comp
from . import dialects
from .errors import EmitError, InputError
from .forces import CUTTING_KINDS, CutParams, forces_along
from .ir import Kind, Toolpath
from .placement import PlacementProblem
from .robots import RobotModel


def workpiece_frame_index(tp: Toolpath) -> tuple[int, np.ndarray]:
    """The one frame every Cartesian target uses, and the rows of those targets."""
    rows = np.nonzero(tp.kind != Kind.ABSJ)[0]
    if not len(rows):
        raise InputError(f"{tp.sources[0].path}: no Cartesian target to place")
    bad = rows[np.isnan(tp.position[rows]).any(axis=1) | np.isnan(tp.orientation[rows]).any(axis=1)]
    if len(bad):
        raise InputError(f"{tp.sources[0].path}, line {tp.line[bad[0]]}: target without a position or orientation in its frame")
    used = np.unique(tp.frame[rows])
    if len(used) != 1:
        names = ", ".join(tp.frame_names[i] for i in used)
        line = tp.line[rows][np.nonzero(tp.frame[rows] != tp.frame[rows[0]])[0][0]]
        raise InputError(f"{tp.sources[0].path}, line {line}: targets in several frames ({names}); placement moves one workpiece frame")
    unresolved = rows[~tp.resolved[rows]]
    if len(unresolved):
        raise InputError(f"{tp.sources[0].path}, line {tp.line[unresolved[0]]}: target or tool cannot be evaluated from the program")
    tools_unknown = tp.tool_known is not None and not tp.tool_known[tp.tool[rows]].all()
    if tools_unknown:
        i = rows[~tp.tool_known[tp.tool[rows]]][0]
        raise InputError(f"{tp.sources[0].path}, line {tp.line[i]}: tool '{tp.tool_names[tp.tool[i]]}' is not defined in the program")
    return int(used[0]), rows


def problem_from_program(tp: Toolpath, robot: RobotModel, *, force_tool=None, params: CutParams | None = None,
                         engagement=None, model=None, singular_deg: float = 5.0) -> PlacementProblem:
    """Placement problem of a program: targets in its workpiece frame, forces from a constant
    tool-frame force or the mechanistic model, joint compliance from the robot file or a fitted model."""
    if robot.opw is None:
        raise InputError(f"robot '{robot.name}' has no analytic IK: placement needs an ortho-parallel arm")
    _, rows = workpiece_frame_index(tp)
    local = tp.target_poses()[rows]
    cutting = np.isin(tp.kind[rows], CUTTING_KINDS)
    eng = None if engagement is None else np.asarray(engagement, dtype=float)[rows]
    force, normal = forces_along(local, cutting, params=params, force_tool=force_tool, engagement=eng)
    weights = comp.step_weights(local[:, :3, 3], cutting)
    return PlacementProblem(
        robot=robot, local_tcp=local, flange_T_tcp=tp.tools[tp.tool[rows]], force_local=force, normal_local=normal,
        weights=weights, conf=tp.conf[rows], dialect=tp.dialect, conf_applies=dialects.of(tp).conf_applies(tp)[rows],
        compliance=comp.joint_compliance(robot, model),
        line=tp.line[rows], singular_deg=singular_deg,
    )


def current_frame(tp: Toolpath) -> np.ndarray | None:
    """base_T_wobj as the program defines it, None where the program leaves it undefined."""
    k, _ = workpiece_frame_index(tp)
    if tp.frame_known is not None and not tp.frame_known[k]:
        return None
    return tp.frames[k]


def frame_xy_theta(frame: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, theta about z, z) of a frame, theta from its x axis in the base xy plane."""
    return float(frame[0, 3]), float(frame[1, 3]), float(np.degrees(np.arctan2(frame[1, 0], frame[0, 0]))), float(frame[2, 3])


# ------------------------------------------------------------------ writing


def placed_texts(tp: Toolpath, new_frame: np.ndarray) -> list[str]:
    """Every source text of the program with its workpiece frame set to ``new_frame``."""
    k, _ = workpiece_frame_index(tp)
    texts = [doc.text for doc in tp.sources]
    texts[0] = dialects.of(tp).place_workpiece(texts[0], tp.frame_names[k], new_frame, tp.sources[0].path)
    return texts


def check_placed(tp: Toolpath, texts: list[str], new_frame: np.ndarray, tol_mm: float = 1e-3) -> None:
    """Parse the new text back: every Cartesian target must sit at new_frame . local, else EmitError."""
    from .programs import parse_program

    _, rows = workpiece_frame_index(tp)
    data = texts[0].encode("latin-1")
    new_tp = parse_program(tp.sources[0].path, tp.dialect, data) if len(tp.sources) == 1 else None
    if new_tp is None:
        return _check_multi(tp, texts, new_frame, rows, tol_mm)
    expected = (new_frame @ tp.target_poses()[rows])[:, :3, 3]
    got = new_tp.base_positions()[rows]
    worst = float(np.nanmax(np.abs(got - expected))) if len(rows) else 0.0
    if not np.isfinite(worst) or worst > tol_mm:
        raise EmitError(f"{tp.sources[0].path}: the written frame does not reproduce the placement (off by {worst:.4g} mm); nothing written")


def _check_multi(tp, texts, new_frame, rows, tol_mm):
    import tempfile

    from .programs import parse_program

    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for doc, text in zip(tp.sources, texts):
            p = Path(tmp) / Path(doc.path).name
            p.write_bytes(text.encode("latin-1"))
            paths.append(p)
        new_tp = parse_program(paths[0], tp.dialect)
    expected = (new_frame @ tp.target_poses()[rows])[:, :3, 3]
    worst = float(np.nanmax(np.abs(new_tp.base_positions()[rows] - expected)))
    if not np.isfinite(worst) or worst > tol_mm:
        raise EmitError(f"{tp.sources[0].path}: the written frame does not reproduce the placement (off by {worst:.4g} mm); nothing written")

