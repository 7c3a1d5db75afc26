"""Candidate poses: generated within reach, joint limits, a workspace region and a laser
tracker's range and line of sight, or read from a CSV of joint values the user can reach;
and the CSV of the chosen poses (the measurement schema's ``id`` and ``q1..q6`` columns,
other columns carried along as written).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from postproc.errors import InputError, MeasurementError
from postproc.model.measurements import APPROACH, FORCES, JOINTS
from postproc.model.sim import sample_poses
from postproc.robot import kinematics as kin
from postproc.robot.robots import RobotModel

# The robot programs that visit the poses write joint values with 4 decimals
# (postproc.programs.emit.writer.short_number): candidates are rounded to them, so the CSV, the
# design and the program hold the very numbers the controller executes.
JOINT_DECIMALS = 4
_NUMERIC_OPTIONAL = FORCES + APPROACH + ("temp", "t")
# How many poses to generate when the user gives no --n-candidates: CANDIDATES_PER_POSE per chosen
# pose, within [MIN_CANDIDATES, MAX_CANDIDATES]. The design gains over random selection by choosing,
# and with a fixed count the choice per pose shrinks as N grows: on the simulated machining pass
# (benchmarks/suggest_sim.py candidates, 3 seeds) 4x the candidates cut the poses the design needs by
# 2.1-2.8 points of random's at N = 32-100 (random, drawn from the same distribution, does not change).
# The search's time grows with candidates x N (suggest_poses at N = 100: 1.3 s on 1,500, 5.0 s on 6,000),
# hence the cap.
MIN_CANDIDATES = 2000
CANDIDATES_PER_POSE = 60
MAX_CANDIDATES = 12000


def default_count(n: int) -> int:
    """Candidates to generate for a design of n poses: 60 per pose, at least 2,000, at most 12,000."""
    return int(min(MAX_CANDIDATES, max(MIN_CANDIDATES, CANDIDATES_PER_POSE * n)))


@dataclass(frozen=True)
class Candidates:
    """Poses the design may choose from; ``columns``/``cells`` carry the file's other columns as written."""

    q_deg: np.ndarray  # (C, 6)
    ids: tuple[str, ...]
    source: str
    columns: tuple[str, ...] = ()
    cells: tuple[tuple[str, ...], ...] = ()  # per row, the text of ``columns``
    numeric: dict[str, np.ndarray] = field(default_factory=dict)  # force/approach/temp/t columns, when present
    rounded_deg: float = 0.0  # the largest change rounding to JOINT_DECIMALS made

    def __len__(self) -> int:
        return len(self.q_deg)

    def group(self, names: tuple[str, ...]) -> np.ndarray | None:
        """(C, len(names)) of an optional column group, None when the file lacks it."""
        if names[0] not in self.numeric:
            return None
        return np.column_stack([self.numeric[c] for c in names])


@dataclass(frozen=True)
class Tracker:
    """A laser tracker in the robot's base frame: where the beam can reach the measured point."""

    position_mm: np.ndarray  # (3,) robot base frame
    range_mm: tuple[float, float] = (1000.0, 15000.0)  # e.g. Leica AT960: 0.8-20 m; keep a margin
    cone_deg: float | None = None  # reflector acceptance half-angle about the tool z axis (None: not checked)
    link_radius_mm: float = 75.0  # links as capsules of this radius about the lines between joint origins


def visible(robot: RobotModel, tool_mm, q_deg: np.ndarray, tracker: Tracker) -> np.ndarray:
    """(C,) True where the tracker reaches the measured point: within its range, inside the
    reflector's acceptance cone, and the beam clears the links (an approximation: capsules
    about the lines joining the DH frame origins; the last 2 radii before the point are not
    checked, where the beam meets the tool itself)."""
    tcp = kin.fk(robot, q_deg, tool=np.asarray(tool_mm, dtype=float))
    point = tcp[:, :3, 3]
    beam = point - tracker.position_mm
    length = np.linalg.norm(beam, axis=1)
    ok = (length >= tracker.range_mm[0]) & (length <= tracker.range_mm[1])
    if tracker.cone_deg is not None:
        towards = -beam / np.maximum(length, 1e-9)[:, None]
        ok &= np.einsum("ci,ci->c", tcp[:, :3, 2], towards) >= np.cos(np.deg2rad(tracker.cone_deg))
    _, origins = kin.joint_frames(robot, q_deg)  # (C, 7, 3)
    # Sample the beam from the tracker to 2 link radii short of the point.
    stop = np.clip(1.0 - 2 * tracker.link_radius_mm / np.maximum(length, 1e-9), 0.0, 1.0)
    s = np.linspace(0.0, 1.0, 48)[None, :] * stop[:, None]  # (C, S)
    samples = tracker.position_mm + s[:, :, None] * beam[:, None, :]  # (C, S, 3)
    a, b = origins[:, :-1], origins[:, 1:]  # link segments (C, L, 3)
    ab = b - a
    ap = samples[:, :, None, :] - a[:, None, :, :]  # (C, S, L, 3)
    t = np.clip(np.einsum("csli,cli->csl", ap, ab) / np.maximum(np.einsum("cli,cli->cl", ab, ab), 1e-9)[:, None, :], 0.0, 1.0)
    dist = np.linalg.norm(ap - t[..., None] * ab[:, None, :, :], axis=-1)
    return ok & (dist.min(axis=(1, 2)) > tracker.link_radius_mm)


def generate(robot: RobotModel, tool_mm, n: int, region, rng: np.random.Generator, tracker: Tracker | None = None,
             id_prefix: str = "s") -> Candidates:
    """n candidate poses in ``region`` (postproc.model.sim regions) inside the joint limits, visible
    to the tracker, with ids ``{id_prefix}1``, ``{id_prefix}2``, ..."""
    if n < 1:
        raise InputError("--n-candidates must be at least 1")
    kept = np.empty((0, 6))
    for _ in range(50):
        q = np.round(sample_poses(robot, tool_mm, 2 * n, region, rng), JOINT_DECIMALS)
        q = q[kin.within_limits(robot, q)]
        if tracker is not None:
            q = q[visible(robot, tool_mm, q, tracker)]
        kept = np.concatenate([kept, q])
        if len(kept) >= n:
            break
    if len(kept) < n:
        raise InputError(f"only {len(kept)} of {n} candidate poses in the workspace region are within the tracker's range and line of sight; "
                         "move the tracker (--tracker) or widen the region")
    return Candidates(q_deg=kept[:n], ids=tuple(f"{id_prefix}{i + 1}" for i in range(n)), source="<generated>")


def read_candidates(path: str | Path, robot: RobotModel) -> Candidates:
    """A CSV with ``q1..q6`` (degrees; ``id`` optional; other columns carried along).
    Problems name the file, line and column; joints beyond the robot's limits are refused."""
    source = str(path)
    try:
        text = Path(path).read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise MeasurementError(source, None, None, f"cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise MeasurementError(source, None, None, "not UTF-8 text") from None
    rows = [(i + 1, r) for i, r in enumerate(csv.reader(io.StringIO(text))) if any(c.strip() for c in r)]
    if not rows:
        raise MeasurementError(source, 1, None, "empty file: expected a header row with q1..q6")
    header = [h.strip() for h in rows[0][1]]
    missing = [c for c in JOINTS if c not in header]
    if missing:
        raise MeasurementError(source, rows[0][0], missing[0], f"required column missing (missing: {', '.join(missing)})")
    dup = [c for c in header if header.count(c) > 1]
    if dup:
        raise MeasurementError(source, rows[0][0], dup[0], "column appears twice")
    body = rows[1:]
    if not body:
        raise MeasurementError(source, 2, None, "no data rows")
    col = {c: i for i, c in enumerate(header)}
    numeric_names = list(JOINTS) + [c for c in _NUMERIC_OPTIONAL if c in col]
    values = np.empty((len(body), len(numeric_names)))
    ids: list[str] = []
    first_line: dict[str, int] = {}
    for r, (line, row) in enumerate(body):
        if len(row) != len(header):
            raise MeasurementError(source, line, None, f"{len(row)} cells, the header has {len(header)}")
        for k, name in enumerate(numeric_names):
            cell = row[col[name]].strip()
            try:
                values[r, k] = float(cell)
            except ValueError:
                raise MeasurementError(source, line, name, f"not a number: '{cell}'") from None
            if not math.isfinite(values[r, k]):
                raise MeasurementError(source, line, name, f"not a finite number: '{cell}'")
        ident = row[col["id"]].strip() if "id" in col else str(r + 1)
        if ident == "":
            raise MeasurementError(source, line, "id", "empty id")
        if ident in first_line:
            raise MeasurementError(source, line, "id", f"duplicate id '{ident}' (first on line {first_line[ident]})")
        first_line[ident] = line
        ids.append(ident)
    q = values[:, :6]
    _check_limits(source, [line for line, _ in body], q, robot)
    rounded = np.round(q, JOINT_DECIMALS)
    carried = tuple(c for c in header if c not in JOINTS and c != "id")
    return Candidates(
        q_deg=rounded, ids=tuple(ids), source=source, columns=carried,
        cells=tuple(tuple(row[col[c]] for c in carried) for _, row in body),
        numeric={name: values[:, k] for k, name in enumerate(numeric_names) if name not in JOINTS},
        rounded_deg=float(np.abs(rounded - q).max()),
    )


def _check_limits(source: str, lines: list[int], q: np.ndarray, robot: RobotModel) -> None:
    outside = (q < robot.lower_deg - 1e-9) | (q > robot.upper_deg + 1e-9)
    if outside.any() and not robot.estimates.get("limits", False):
        r = int(np.argmax(outside.any(axis=1)))
        j = int(np.argmax(outside[r]))
        raise MeasurementError(source, lines[r], JOINTS[j], f"{q[r, j]:g} deg is outside {robot.name}'s limits "
                               f"[{robot.lower_deg[j]:g}, {robot.upper_deg[j]:g}] ({int(outside.any(axis=1).sum())} row(s) in all)")


def chosen_csv(cands: Candidates, order: np.ndarray) -> str:
    """The chosen rows in measuring order: id, q1..q6 (as the program writes them), then the carried columns."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["id", *JOINTS, *cands.columns])
    for i in order:
        joints = [f"{v:.{JOINT_DECIMALS}f}" for v in cands.q_deg[i]]
        writer.writerow([cands.ids[i], *joints, *(cands.cells[i] if cands.cells else ())])
    return buf.getvalue()


def measuring_order(q_deg: np.ndarray, start_deg: np.ndarray | None = None) -> np.ndarray:
    """A short tour through the poses: from the one nearest ``start_deg`` (default: the
    first), always to the nearest not yet visited, the distance being the largest joint
    move (joints move together, so that one sets the time of a joint move)."""
    n = len(q_deg)
    if n == 0:
        return np.zeros(0, dtype=int)
    left = np.ones(n, dtype=bool)
    here = 0 if start_deg is None else int(np.argmin(np.abs(q_deg - start_deg).max(axis=1)))
    order = [here]
    left[here] = False
    for _ in range(n - 1):
        dist = np.where(left, np.abs(q_deg - q_deg[here]).max(axis=1), np.inf)
        here = int(np.argmin(dist))
        order.append(here)
        left[here] = False
    return np.array(order, dtype=int)


def load_state_order(q_deg: np.ndarray, force_n: np.ndarray | None, start_deg: np.ndarray | None = None) -> np.ndarray:
    """``measuring_order`` within each load state (rows of equal force), the states one after
    another from the smallest force: the load is changed once per state, not between poses."""
    if force_n is None:
        return measuring_order(q_deg, start_deg)
    states, state_of = np.unique(force_n, axis=0, return_inverse=True)
    state_of = state_of.reshape(-1)
    order = []
    for s in np.argsort(np.linalg.norm(states, axis=1), kind="stable"):
        rows = np.nonzero(state_of == s)[0]
        tour = rows[measuring_order(q_deg[rows], start_deg)]
        order.extend(tour.tolist())
        start_deg = q_deg[tour[-1]]
    return np.array(order, dtype=int)


def with_load_states(cands: Candidates, states_n: np.ndarray) -> Candidates:
    """Every candidate pose under each load state (forces on the TCP, base frame, N: rows of
    ``states_n``), as columns fx, fy, fz; ids ``<id>-L<k>`` (k from 1, in the states' order).
    Loads make the TCP force vary independently of the pose, which separates the joints'
    compliance (``joint_compliance``, ``external_load``) from the geometry."""
    states_n = np.asarray(states_n, dtype=float).reshape(-1, 3)
    if not np.isfinite(states_n).all():
        raise InputError("--load-states: forces must be finite numbers (N)")
    if cands.group(FORCES) is not None:
        raise InputError(f"{cands.source}: the candidates have force columns fx,fy,fz already; give either them or --load-states")
    k = len(states_n)
    force = np.repeat(states_n[None], len(cands), axis=0).reshape(-1, 3)  # pose-major: pose 1 in every state, then pose 2
    text = [tuple(f"{v:g}" for v in f) for f in states_n]
    return Candidates(
        q_deg=np.repeat(cands.q_deg, k, axis=0),
        ids=tuple(f"{ident}-L{j + 1}" for ident in cands.ids for j in range(k)),
        source=cands.source,
        columns=(*cands.columns, *FORCES),
        cells=tuple((*(cands.cells[i] if cands.cells else ()), *text[j]) for i in range(len(cands)) for j in range(k)),
        numeric={**{name: np.repeat(v, k) for name, v in cands.numeric.items()}, **{c: force[:, i] for i, c in enumerate(FORCES)}},
        rounded_deg=cands.rounded_deg,
    )
