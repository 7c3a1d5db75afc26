"""A program as a placement problem, and the program written back with its new workpiece frame.

The program's Cartesian targets must all lie in one workpiece frame (RAPID work object,
KRL $BASE). Writing replaces only that frame's numbers: the RAPID wobjdata uframe (the
oframe is kept, uframe = best . inv(oframe)) or the KRL ``$BASE = {X .., C ..}`` literal;
the written text is parsed again and must place every target where the new frame puts it,
else nothing is written.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from postproc.errors import EmitError, InputError
from postproc.programs import dialects
from postproc.programs.ir import Toolpath
from postproc.programs.program_io import parse_program
from postproc.programs.workpiece import workpiece_frame_index
from postproc.robot.robots import RobotModel

from . import compliance as comp
from .forces import CUTTING_KINDS, CutParams, forces_along
from .placement import PlacementProblem, placement_joints


def problem_from_program(tp: Toolpath, robot: RobotModel, *, force_tool=None, params: CutParams | None = None,
                         engagement=None, model=None, singular_deg: float = 5.0, conf_mode: str = "rederive") -> PlacementProblem:
    """Placement problem of a program: targets in its workpiece frame, forces from a constant
    tool-frame force or the mechanistic model, joint compliance from the robot file or a fitted
    model; its configuration data re-derived for each placement or kept (``placement_branch``)."""
    if robot.opw is None:
        raise InputError(f"robot '{robot.name}' has no analytic IK: placement needs an ortho-parallel arm")
    _, rows = workpiece_frame_index(tp)
    local = tp.target_poses()[rows]
    cutting = np.isin(tp.kind[rows], CUTTING_KINDS)
    eng = None if engagement is None else np.asarray(engagement, dtype=float)[rows]
    force, normal = forces_along(local, cutting, params=params, force_tool=force_tool, engagement=eng)
    weights = comp.step_weights(local[:, :3, 3], cutting)
    applies = dialects.of(tp).controller.conf_applies(tp)[rows]
    return PlacementProblem(
        robot=robot, local_tcp=local, flange_T_tcp=tp.tools[tp.tool[rows]], force_local=force, normal_local=normal,
        weights=weights, conf=tp.conf[rows], language=dialects.of(tp), conf_applies=applies,
        compliance=comp.joint_compliance(robot, model),
        line=tp.line[rows], arm=_arm_configuration(tp, rows, applies), singular_deg=singular_deg, conf_mode=conf_mode,
    )


def _arm_configuration(tp: Toolpath, rows: np.ndarray, applies: np.ndarray) -> np.ndarray:
    """(P,) the arm configuration (ABB cfx, KUKA Status) the program states where its data apply, -1 else."""
    column = dialects.of(tp).arm_conf_column
    arm = np.full(len(rows), -1)
    if column is not None:
        stated = applies & np.isfinite(tp.conf[rows, column])
        arm[stated] = tp.conf[rows[stated], column].astype(int)
    return arm


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


def placed_texts(tp: Toolpath, new_frame: np.ndarray, new_conf: np.ndarray | None = None) -> list[str]:
    """Every source text of the program with its workpiece frame set to ``new_frame`` and,
    where ``new_conf`` (P, 4) over the placed targets is finite, their configuration data."""
    k, rows = workpiece_frame_index(tp)
    texts = [doc.text for doc in tp.sources]
    if new_conf is not None:  # first: the targets' spans are offsets into the texts as read
        texts = _with_conf(tp, texts, rows, np.asarray(new_conf, dtype=float))
    texts[0] = dialects.of(tp).place_workpiece(texts[0], tp.frame_names[k], new_frame, tp.sources[0].path)
    return texts


def _with_conf(tp: Toolpath, texts: list[str], rows: np.ndarray, conf: np.ndarray) -> list[str]:
    """texts with the configuration data of the targets ``rows`` set to ``conf`` (NaN rows kept).
    A named point used by several targets must get the same data from each."""
    lang = dialects.of(tp)
    edits: dict[tuple[int, int], tuple[int, np.ndarray, int]] = {}  # (source, literal start) -> (end, conf, line)
    for r, c in zip(rows, conf):
        if np.isnan(c).all():
            continue
        source, first = int(tp.spans[r, 0, 0]), int(tp.spans[r, 0, 1])
        if source < 0:
            raise EmitError(f"{tp.sources[0].path}, line {tp.line[r]}: target without a literal to write its configuration data into")
        start, end = lang.target_literal(texts[source], first)
        seen = edits.get((source, start))
        if seen is not None and not np.array_equal(seen[1], c, equal_nan=True):
            raise EmitError(f"{tp.sources[0].path}, lines {seen[2]} and {tp.line[r]}: one point needs two sets of configuration data "
                            "at the new placement; nothing written (give --keep-conf, or give the targets their own points)")
        edits[(source, start)] = (end, c, int(tp.line[r]))
    for (source, start), (end, c, _) in sorted(edits.items(), key=lambda kv: -kv[0][1]):
        text = texts[source]
        texts[source] = text[:start] + lang.set_conf_text(text[start:end], c) + text[end:]
    return texts


def placed_conf(problem: PlacementProblem, frame: np.ndarray) -> np.ndarray:
    """(P, 4) the configuration data a re-post writes for the workpiece at ``frame``: those of
    the joints the robot takes, at the targets whose data apply (NaN elsewhere)."""
    q, reason = placement_joints(problem, frame)
    conf = np.full((len(q), 4), np.nan)
    has = problem.conf_applies & (reason == 0)
    if has.any():
        conf[has] = problem.language.conf_of_joints(problem.robot, q[has])
    return conf


def check_placed(tp: Toolpath, texts: list[str], new_frame: np.ndarray, new_conf: np.ndarray | None = None, tol_mm: float = 1e-3) -> None:
    """Parse the new text back: every Cartesian target must sit at new_frame . local and carry
    ``new_conf`` where that is finite, else EmitError (nothing is written)."""
    _, rows = workpiece_frame_index(tp)
    new_tp = _parse_texts(tp, texts)
    expected = (new_frame @ tp.target_poses()[rows])[:, :3, 3]
    got = new_tp.base_positions()[rows] if len(new_tp) == len(tp) else np.full_like(expected, np.nan)
    worst = float(np.nanmax(np.abs(got - expected))) if len(rows) else 0.0
    if not np.isfinite(worst) or worst > tol_mm:
        raise EmitError(f"{tp.sources[0].path}: the written frame does not reproduce the placement (off by {worst:.4g} mm); nothing written")
    if new_conf is not None:
        want = np.asarray(new_conf, dtype=float)
        differs = np.isfinite(want) & (new_tp.conf[rows] != want)
        if differs.any():
            r = rows[np.nonzero(differs.any(axis=1))[0][0]]
            raise EmitError(f"{tp.sources[0].path}, line {tp.line[r]}: the written configuration data do not read back; nothing written")


def _parse_texts(tp: Toolpath, texts: list[str]) -> Toolpath:
    """The program of ``texts`` parsed as ``tp`` was (its files side by side in a scratch folder)."""
    if len(tp.sources) == 1:
        return parse_program(tp.sources[0].path, tp.dialect, texts[0].encode("latin-1"))
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for doc, text in zip(tp.sources, texts):
            p = Path(tmp) / Path(doc.path).name
            p.write_bytes(text.encode("latin-1"))
            paths.append(p)
        return parse_program(paths[0], tp.dialect)
