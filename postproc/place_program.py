"""A program as a placement problem, and the program written back with its new workpiece frame.

The program's Cartesian targets must all lie in one workpiece frame (RAPID work object,
KRL $BASE). Writing replaces only that frame's numbers: the RAPID wobjdata uframe (the
oframe is kept, uframe = best . inv(oframe)) or the KRL ``$BASE = {X .., C ..}`` literal;
the written text is parsed again and must place every target where the new frame puts it,
else nothing is written.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from . import compliance as comp
from .errors import EmitError, InputError
from .forces import CUTTING_KINDS, CutParams, forces_along
from .frames import matrix_to_abc, matrix_to_quat_wxyz, quat_wxyz_to_matrix
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
        weights=weights, conf=tp.conf[rows], dialect=tp.dialect, compliance=comp.joint_compliance(robot, model),
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


_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def _fmt(v: float, decimals: int) -> str:
    text = f"{v:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _rapid_wobj(text: str, name: str, new_frame: np.ndarray, path: str) -> str:
    decl = re.compile(rf"wobjdata\s+{re.escape(name)}\s*:=\s*\[", re.IGNORECASE)
    found = list(decl.finditer(text))
    if len(found) != 1:
        raise EmitError(f"{path}: work object '{name}' is declared {len(found)} times; cannot place it")
    start = found[0].end()
    end = text.find(";", start)
    body = text[start:end]
    after_string = body.find('"', body.find('"') + 1) + 1  # past the ufmec string
    nums = [m for m in re.finditer(_NUM, body[after_string:])]
    if after_string <= 0 or len(nums) != 14:
        raise EmitError(f"{path}: work object '{name}' is not a literal wobjdata (14 numbers); cannot place it")
    values = np.array([float(m.group()) for m in nums])
    oframe = np.eye(4)
    oframe[:3, :3] = quat_wxyz_to_matrix(values[10:14][None])[0]
    oframe[:3, 3] = values[7:10]
    uframe = new_frame @ np.linalg.inv(oframe)
    new = list(uframe[:3, 3]) + list(matrix_to_quat_wxyz(uframe[None, :3, :3])[0])
    digits = [4, 4, 4, 8, 8, 8, 8]
    out = text
    for m, value, dec in sorted(zip(nums[:7], new, digits), key=lambda t: -t[0].start()):
        s, e = start + after_string + m.start(), start + after_string + m.end()
        out = out[:s] + _fmt(value, dec) + out[e:]
    return out


def _krl_base(text: str, new_frame: np.ndarray, path: str) -> str:
    pattern = re.compile(r"\$BASE\s*=\s*\{([^}]*)\}", re.IGNORECASE)
    found = list(pattern.finditer(text))
    if len(found) != 1:
        raise EmitError(f"{path}: the program sets $BASE {len(found)} times (need exactly one inline {{X .., C ..}} literal)")
    abc = matrix_to_abc(new_frame[None, :3, :3])[0]
    values = dict(zip("XYZABC", [*new_frame[:3, 3], *abc]))
    # 6 decimals of a degree: 2e-5 mm at 1 m from the frame's origin
    literal = "{" + ", ".join(f"{k} {_fmt(v, 4 if k in 'XYZ' else 6)}" for k, v in values.items()) + "}"
    m = found[0]
    return text[: m.start(1) - 1] + literal + text[m.end(1) + 1 :]


def placed_texts(tp: Toolpath, new_frame: np.ndarray) -> list[str]:
    """Every source text of the program with its workpiece frame set to ``new_frame``."""
    k, rows = workpiece_frame_index(tp)
    path = tp.sources[0].path
    texts = [doc.text for doc in tp.sources]
    if tp.dialect == "rapid":
        name = tp.frame_names[k]
        if name.upper() == "WOBJ0":
            raise EmitError(f"{path}: the targets are in wobj0 (the base frame); declare a work object to place the workpiece")
        texts[0] = _rapid_wobj(texts[0], name, new_frame, path)
    elif tp.dialect == "krl":
        texts[0] = _krl_base(texts[0], new_frame, path)
    else:
        raise EmitError(f"{path}: writing a placed {tp.dialect} program is not supported (RAPID work objects and KRL $BASE are)")
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

