"""G2/G3 arcs: their geometry as the controller reads it, and their compensation.

The controller (LinuxCNC's canon, "G2, G3 Arc Feed"; Fanuc and Siemens alike) moves from the
arc's start (the previous target) to its end point around the centre, in the plane G17 (XY),
G18 (ZX) or G19 (YZ) of the program's coordinates: clockwise (G2) or counter-clockwise (G3)
seen from the plane's positive normal axis, the radius going linearly from the start's to
the end's, the normal axis linearly with the angle (a helix). An end point equal to the start
in the plane is a full circle. The centre is I J K (offsets from the start under G91.1,
coordinates under G90.1) or follows from R (R < 0: the arc of more than 180 degrees).

Compensation moves the start and end commands so the robot lands on the intended points; a
circle through the two commands alone has one free parameter left (its centre on their
bisector, both in the plane) and the controller's plane cannot tilt. The new centre is the
one whose commanded arc passes, in the least-squares sense, through the compensated commands
of three intended interior points (1/4, 1/2, 3/4 of the sweep), each solved like a target
(its intended pose, the arc end's posture). A full circle keeps its end on its start and
takes the centre through those three points. The predicted actual arc then passes the
intended one at five points; between them its distance from the intended arc is sampled and
reported (the mid-arc deviation, ``Report.path_mm`` of the arc's row).

Refused, with file:line:column: an arc with no target before it (its start is unknown),
full turns (P other than 1), and a radius-format arc whose compensated centre the written
radius cannot give back (nearly a half circle: R decides the centre ill-conditioned).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from postproc.errors import InputError, OutputCheckError
from postproc.robot.frames import invert_transform
from postproc.robot.posture import interpolate_poses, near_singular

from .emit.splice import TOLERANCE
from .ir import F_ARC, Kind, Toolpath

# In-plane first and second axes and the normal axis of each plane, in program coordinates;
# (first, second, normal) is right-handed, so counter-clockwise in (first, second) is G3.
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
INTERIOR = np.array([0.25, 0.5, 0.75])  # fractions of the sweep whose compensated commands fix the centre
SAMPLES = 16  # interior samples of each arc for the predicted deviation
R_CENTRE_TOL_MM = 2e-3  # largest centre shift a radius written to 5e-4 mm may cause
FULL_TOL_MM = 1e-9  # start and end closer than this in the plane: a full circle
I_, J_, K_, R_ = (F_ARC.start + n for n in range(4))


def arc_rows(tp: Toolpath) -> np.ndarray:
    return np.nonzero(np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW)))[0]


@dataclass(frozen=True)
class Arcs:
    """M arcs of a program, each in its end target's frame (program coordinates, mm)."""

    rows: np.ndarray  # (M,) target index of each arc's end
    axes: np.ndarray  # (M, 3) first, second, normal axis index
    start: np.ndarray  # (M, 3)
    end: np.ndarray  # (M, 3)
    centre: np.ndarray  # (M, 2) in-plane
    ccw: np.ndarray  # (M,) bool: G3
    full: np.ndarray  # (M,) bool: the end is the start in the plane

    def take(self, idx) -> "Arcs":
        return Arcs(self.rows[idx], self.axes[idx], self.start[idx], self.end[idx], self.centre[idx], self.ccw[idx], self.full[idx])

    def in_plane(self, p: np.ndarray) -> np.ndarray:
        """(M, ..., 2) in-plane coordinates of points (M, ..., 3)."""
        idx = self.axes[:, :2].reshape((len(self.rows),) + (1,) * (p.ndim - 2) + (2,))
        return np.take_along_axis(p, idx, axis=-1)

    def normal(self, p: np.ndarray) -> np.ndarray:
        idx = self.axes[:, 2].reshape((len(self.rows),) + (1,) * (p.ndim - 1))
        return np.take_along_axis(p, idx, axis=-1)[..., 0]

    def sweep(self) -> tuple[np.ndarray, np.ndarray]:
        """Start angle and signed sweep (radians, + counter-clockwise) of each arc."""
        s = self.in_plane(self.start) - self.centre
        e = self.in_plane(self.end) - self.centre
        a0 = np.arctan2(s[:, 1], s[:, 0])
        turn = np.arctan2(e[:, 1], e[:, 0]) - a0
        ccw_sweep = np.where(self.full, 2 * np.pi, np.mod(turn, 2 * np.pi))
        cw_sweep = np.where(self.full, 2 * np.pi, np.mod(-turn, 2 * np.pi))
        return a0, np.where(self.ccw, ccw_sweep, -cw_sweep)

    def points(self, fractions: np.ndarray) -> np.ndarray:
        """(M, K, 3) points of the arcs at fractions of their sweep, as the controller
        interpolates them (radius and normal axis linear in the angle)."""
        a0, sweep = self.sweep()
        r0 = np.linalg.norm(self.in_plane(self.start) - self.centre, axis=1)
        r1 = np.linalg.norm(self.in_plane(self.end) - self.centre, axis=1)
        f = np.asarray(fractions)[None, :]
        ang = a0[:, None] + f * sweep[:, None]
        rad = r0[:, None] + f * (r1 - r0)[:, None]
        h = self.normal(self.start)[:, None] + f * (self.normal(self.end) - self.normal(self.start))[:, None]
        coords = (self.centre[:, None, 0] + rad * np.cos(ang), self.centre[:, None, 1] + rad * np.sin(ang), h)
        out = np.zeros((len(self.rows), f.shape[1], 3))
        for c, value in enumerate(coords):
            where = np.broadcast_to(self.axes[:, None, c : c + 1], value.shape + (1,))
            np.put_along_axis(out, where, value[..., None], axis=2)
        return out

    def distance(self, p: np.ndarray) -> np.ndarray:
        """Distance (M, K) of points (M, K, 3) from the arcs: radial and normal-axis error at
        each point's own angle (the arc's fraction there, clipped to the arc)."""
        a0, sweep = self.sweep()
        rel = self.in_plane(p) - self.centre[:, None]
        ang = np.arctan2(rel[..., 1], rel[..., 0]) - a0[:, None]
        ang = np.where(sweep[:, None] >= 0, np.mod(ang, 2 * np.pi), -np.mod(-ang, 2 * np.pi))
        f = np.clip(ang / np.where(sweep == 0, 1.0, sweep)[:, None], 0.0, 1.0)
        r0 = np.linalg.norm(self.in_plane(self.start) - self.centre, axis=1)
        r1 = np.linalg.norm(self.in_plane(self.end) - self.centre, axis=1)
        h0, h1 = self.normal(self.start), self.normal(self.end)
        radial = np.linalg.norm(rel, axis=-1) - (r0[:, None] + f * (r1 - r0)[:, None])
        axial = self.normal(p) - (h0[:, None] + f * (h1 - h0)[:, None])
        return np.hypot(radial, axial)


def geometry(tp: Toolpath, base_positions: np.ndarray | None = None, words: np.ndarray | None = None) -> Arcs:
    """The arcs of a program (every G2/G3 target with a target before it), from its words;
    ``base_positions`` (N, 3) replaces the targets' positions, ``words`` (N, 4) the I J K R values."""
    rows = arc_rows(tp)
    rows = rows[rows > 0]
    if tp.arc is None or not len(rows):
        z = np.zeros((0, 3))
        return Arcs(rows[:0], np.zeros((0, 3), int), z, z, np.zeros((0, 2)), np.zeros(0, bool), np.zeros(0, bool))
    base = tp.base_positions() if base_positions is None else base_positions
    words = tp.values[:, F_ARC] if words is None else words
    start = _local(tp, rows, base[rows - 1])
    end = _local(tp, rows, base[rows])
    axes = np.array([PLANE_AXES[int(p)] for p in tp.arc[rows, 0]], dtype=int).reshape(-1, 3)
    ccw = tp.kind[rows] == Kind.ARC_CCW
    arcs = Arcs(rows, axes, start, end, np.zeros((len(rows), 2)), ccw, np.zeros(len(rows), bool))
    s2, e2 = arcs.in_plane(start), arcs.in_plane(end)
    full = np.linalg.norm(e2 - s2, axis=1) < FULL_TOL_MM
    ijk = np.nan_to_num(words[rows, :3])  # a centre word left out reads as 0
    centre = np.take_along_axis(ijk, axes[:, :2], axis=1)
    centre = np.where(tp.arc[rows, 1:2] == 1.0, centre, s2 + centre)
    radius = words[rows, 3]
    by_r = ~np.isnan(radius)
    if by_r.any():
        centre[by_r] = centre_from_radius(s2[by_r], e2[by_r], radius[by_r], ccw[by_r])
    return Arcs(rows, axes, start, end, centre, ccw, full)


def centre_from_radius(s: np.ndarray, e: np.ndarray, radius: np.ndarray, ccw: np.ndarray) -> np.ndarray:
    """In-plane centres (M, 2) of radius-format arcs: on the bisector of start and end, on the
    side that makes the arc at most 180 degrees for R > 0 and more for R < 0."""
    chord = e - s
    d = np.linalg.norm(chord, axis=1)
    h = np.sqrt(np.maximum(radius**2 - d**2 / 4.0, 0.0))
    left = np.stack([-chord[:, 1], chord[:, 0]], axis=1) / np.maximum(d, 1e-300)[:, None]
    # Counter-clockwise and short (R > 0): the centre lies to the left of start -> end.
    side = np.where(ccw == (radius > 0), 1.0, -1.0)
    return (s + e) / 2.0 + (side * h)[:, None] * left


def _local(tp: Toolpath, rows: np.ndarray, base: np.ndarray) -> np.ndarray:
    """Base-frame points (M, 3) in the frames of targets ``rows``."""
    inv = invert_transform(tp.frames[tp.frame[rows]])
    return np.einsum("mij,mj->mi", inv[:, :3, :3], base) + inv[:, :3, 3]


def _to_base(tp: Toolpath, rows: np.ndarray, local: np.ndarray) -> np.ndarray:
    frames = tp.frames[tp.frame[rows]]
    shape = local.shape
    pts = local.reshape(len(rows), -1, 3)
    return (np.einsum("mij,mkj->mki", frames[:, :3, :3], pts) + frames[:, None, :3, 3]).reshape(shape)


# ---------------------------------------------------------------- refusals

def refuse_uncompensable(tp: Toolpath) -> None:
    """Arcs compensation cannot rewrite: InputError naming file:line:column."""
    rows = arc_rows(tp)
    if not len(rows):
        return
    if tp.arc is None:  # both G-code readers give every G2/G3 its words; a Toolpath built without them has no centres
        raise InputError(_where(tp, int(rows[0]), I_) + "this arc has no centre words in the toolpath; it cannot be compensated")
    if rows[0] == 0:
        raise InputError(_where(tp, 0, I_) + "the program starts with an arc: its start is where the machine stands, unknown to the "
                         "post-processor (move to the start first)")
    turns = tp.arc[rows, 2]
    bad = rows[~(turns == 1.0)]
    if len(bad):
        raise InputError(_where(tp, int(bad[0]), I_) + "an arc of several turns (P) is not compensated; write one arc per turn")
    # a centre or radius the reader worked out (SINUMERIK AR= opening angle, CIP intermediate point): no number to rewrite
    worked_out = ~np.isnan(tp.values[rows, F_ARC]).all(axis=1) & (tp.spans[rows, F_ARC, 1] < 0).all(axis=1)
    if worked_out.any():
        raise InputError(_where(tp, int(rows[worked_out][0]), I_) + "this arc's centre or radius is not a number in the text "
                         "(an opening angle AR= or an intermediate point CIP): it cannot be rewritten; "
                         "write the arc with CR= or I J K to compensate it")
    prev_absj = rows[tp.kind[rows - 1] == Kind.ABSJ]
    if len(prev_absj):
        raise InputError(_where(tp, int(prev_absj[0]), I_) + "an arc after a joint target is not compensated")


def _where(tp: Toolpath, row: int, field: int) -> str:
    """``file:line:column: `` of a target's word (its first arc word, else the block)."""
    spans = tp.spans[row, F_ARC]
    have = np.nonzero(spans[:, 1] >= 0)[0]
    f = F_ARC.start + int(have[0]) if field in range(F_ARC.start, F_ARC.stop) and len(have) else field
    source, start = int(tp.spans[row, f, 0]), int(tp.spans[row, f, 1])
    doc = tp.sources[int(tp.file[row])] if source < 0 else tp.sources[source]
    if start < 0:
        return f"{doc.path}:{tp.line[row]}:1: "
    col = start - (doc.text.rfind("\n", 0, start) + 1) + 1
    return f"{doc.path}:{tp.line[row]}:{col}: "


# ---------------------------------------------------------------- compensation

@dataclass
class ArcFit:
    """The compensated arcs of one program: new words, and their predicted deviation."""

    rows: np.ndarray  # (M,) target rows of the arcs
    words: np.ndarray  # (M, 4) new I J K R (NaN where the arc does not use the word)
    deviation_mm: np.ndarray  # (M,) largest predicted distance of the robot from the intended arc

    def put_deviation(self, path_mm: np.ndarray, problem_rows: np.ndarray) -> None:
        """Into the per-Cartesian-target path deviations (indexed like ``problem_rows``)."""
        at = np.searchsorted(problem_rows, self.rows)
        path_mm[at] = self.deviation_mm

    def apply(self, tp: Toolpath) -> Toolpath:
        """``tp`` with the new arc words (only the words the arc uses)."""
        if not len(self.rows):
            return tp

        values = tp.values.copy()
        values[self.rows, F_ARC] = self.words
        return replace(tp, values=values)


CHUNK = 20_000  # arcs compensated at once (their interior points and samples): memory bounded


def fit(problem, sol, tol_mm: float, max_iter: int, solve, progress=lambda msg: None) -> ArcFit:
    """Compensate the arcs of ``problem`` (compensate._Problem) given the solved targets
    ``sol`` (its cmd of full-circle ends is set to their start): new centres and words."""
    tp, rows_all = problem.tp, problem.rows
    arcs = geometry(tp)
    words, deviation = np.zeros((len(arcs.rows), 4)), np.zeros(len(arcs.rows))
    for lo in range(0, len(arcs.rows), CHUNK):
        part = arcs.take(slice(lo, lo + CHUNK))
        progress(f"compensating arcs {lo + 1}-{lo + len(part.rows)} of {len(arcs.rows)}")
        at = np.searchsorted(rows_all, part.rows)  # the arcs' ends among the Cartesian targets (their starts are at - 1)
        _close_full_circles(tp, part, at, sol.cmd)
        interior = _solve_interior(problem, part, at, tol_mm, max_iter, solve)
        commanded = Arcs(part.rows, part.axes, _local(tp, part.rows, sol.cmd[at - 1]), _local(tp, part.rows, sol.cmd[at]), part.centre, part.ccw, part.full)
        centre = _centre_through(commanded, np.stack([_local(tp, part.rows, interior[:, k]) for k in range(interior.shape[1])], axis=1))
        commanded = Arcs(commanded.rows, commanded.axes, commanded.start, commanded.end, centre, commanded.ccw, commanded.full)
        words[lo : lo + CHUNK] = _words(tp, commanded)
        deviation[lo : lo + CHUNK] = _deviation(problem, sol, part, commanded, at)
    return ArcFit(arcs.rows, words, deviation)


def _close_full_circles(tp: Toolpath, arcs: Arcs, at: np.ndarray, cmd: np.ndarray) -> None:
    """A full circle's end command is its start command in the plane (it stays a full circle)."""
    if not arcs.full.any():
        return
    f = np.nonzero(arcs.full)[0]
    start = _local(tp, arcs.rows[f], cmd[at[f] - 1])
    end = _local(tp, arcs.rows[f], cmd[at[f]])
    m = np.arange(len(f))[:, None]
    end[m, arcs.axes[f, :2]] = start[m, arcs.axes[f, :2]]
    cmd[at[f]] = _to_base(tp, arcs.rows[f], end)


class _Interior:
    """Intended interior points of the arcs as targets to compensate (compensate._Problem's
    interface for the solvers): posture and tool of each arc's end."""

    def __init__(self, problem, goal_poses: np.ndarray, arc_at: np.ndarray):
        self.plant, self.order_q = problem.plant, problem.order_q
        self.rows = np.repeat(problem.rows[arc_at], goal_poses.shape[0] // len(arc_at))
        self.target = goal_poses
        self.goal = goal_poses[:, :3, 3]
        k = goal_poses.shape[0] // len(arc_at)
        self.q_ref = np.repeat(problem.q_ref[arc_at], k, axis=0)
        self.branch_ref = np.repeat(problem.branch_ref[arc_at], k)

    def evaluate(self, commands: np.ndarray, active: np.ndarray):
        poses = self.target[active].copy()
        poses[:, :3, 3] = commands
        q, b = self.plant.joints(poses, self.rows[active], self.q_ref[active], self.branch_ref[active])
        return self.plant.actual(q, self.rows[active], self.order_q) - self.goal[active], q, b


def _interior_poses(problem, arcs: Arcs, at: np.ndarray, positions_base: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    """(M * K, 4, 4) poses at interior points: positions given (base frame), orientation
    interpolated from the arc's start to its end as the controller does."""

    poses = interpolate_poses(problem.target[at - 1], problem.target[at], fractions)
    poses[..., :3, 3] = positions_base
    return poses.reshape(-1, 4, 4)


def _solve_interior(problem, arcs: Arcs, at: np.ndarray, tol_mm: float, max_iter: int, solve) -> np.ndarray:
    """Compensated commands (M, K, 3), base frame, of the arcs' intended interior points."""
    tp = problem.tp
    goal = _to_base(tp, arcs.rows, arcs.points(INTERIOR))
    interior = _Interior(problem, _interior_poses(problem, arcs, at, goal, INTERIOR), at)
    before, _, _ = interior.evaluate(interior.goal, np.ones(len(interior.goal), bool))
    solved = solve(interior, before, tol_mm, max_iter, lambda msg: None)
    bad = ~(solved.converged & solved.within)
    if bad.any():
        row = int(interior.rows[np.nonzero(bad)[0][0]])
        raise InputError(_where(tp, row, I_) + "a point inside this arc cannot be compensated on the robot's posture "
                         "(out of reach, the joint limits, or no convergence)")
    return solved.cmd.reshape(len(arcs.rows), len(INTERIOR), 3)


def _centre_through(arcs: Arcs, interior_local: np.ndarray) -> np.ndarray:
    """In-plane centres (M, 2): on the bisector of start and end (exactly through both) and
    nearest, in least squares, to passing the interior points; a full circle's through its
    start and the interior points. |q - c|^2 = |s - c|^2 is linear in c: 2 c.(q - s) = |q|^2 - |s|^2."""
    s = arcs.in_plane(arcs.start)
    e = arcs.in_plane(arcs.end) - s
    q = arcs.in_plane(interior_local) - s[:, None]
    rhs = np.einsum("mkj,mkj->mk", q, q)
    centre = np.zeros_like(s)
    part = ~arcs.full
    if part.any():
        perp = np.stack([-e[part, 1], e[part, 0]], axis=1)
        a = 2.0 * np.einsum("mkj,mj->mk", q[part], perp)
        b = rhs[part] - np.einsum("mkj,mj->mk", q[part], e[part])
        t = np.einsum("mk,mk->m", a, b) / np.einsum("mk,mk->m", a, a)
        centre[part] = e[part] / 2.0 + t[:, None] * perp
    if arcs.full.any():
        a = 2.0 * q[arcs.full]
        centre[arcs.full] = np.linalg.solve(np.einsum("mki,mkj->mij", a, a), np.einsum("mki,mk->mi", a, rhs[arcs.full])[..., None])[..., 0]
    return s + centre


def centre_words(tp: Toolpath, arcs: Arcs) -> np.ndarray:
    """I J K R (M, 4) of arcs (``rows`` naming the block whose form each follows), as ``_words``."""
    return _words(tp, arcs)


def _words(tp: Toolpath, arcs: Arcs) -> np.ndarray:
    """New I J K R (M, 4) of arcs with these commanded starts, ends and centres, in the words
    each arc uses; a radius-format arc whose written radius would not give the centre back
    is refused."""
    rows = arcs.rows
    old = tp.values[rows, F_ARC]
    words = np.full((len(rows), 4), np.nan)
    s2 = arcs.in_plane(arcs.start)
    by_r = ~np.isnan(old[:, 3])
    absolute = tp.arc[rows, 1] == 1.0
    offset = np.where(absolute[:, None], arcs.centre, arcs.centre - s2)
    m = np.nonzero(~by_r)[0]
    words[m[:, None], arcs.axes[m, :2]] = offset[m]
    if by_r.any():
        words[by_r, 3] = _radius_words(tp, arcs, by_r)
    # A word the block gives outside the plane is refused by the parser; the others stay as they were.
    return words


def _radius_words(tp: Toolpath, arcs: Arcs, by_r: np.ndarray) -> np.ndarray:
    """R of the radius-format arcs (sign: negative beyond 180 degrees), checked to give the
    centre back within R_CENTRE_TOL_MM when written to the output's precision (5e-4 mm)."""
    s2, e2, c = arcs.in_plane(arcs.start)[by_r], arcs.in_plane(arcs.end)[by_r], arcs.centre[by_r]
    _, sweep = Arcs(arcs.rows[by_r], arcs.axes[by_r], arcs.start[by_r], arcs.end[by_r], c, arcs.ccw[by_r], arcs.full[by_r]).sweep()
    radius = np.linalg.norm(s2 - c, axis=1) * np.where(np.abs(sweep) > np.pi, -1.0, 1.0)
    worst = np.zeros(len(radius))
    for dr in (-5e-4, 5e-4):
        back = centre_from_radius(s2, e2, radius + np.sign(radius) * dr, arcs.ccw[by_r])
        worst = np.maximum(worst, np.linalg.norm(back - c, axis=1))
    bad = ~(worst <= R_CENTRE_TOL_MM)
    if bad.any():
        i = int(np.nonzero(bad)[0][0])
        row = int(arcs.rows[by_r][i])
        raise InputError(_where(tp, row, R_) + f"radius-format arc of {np.degrees(abs(sweep[i])):.3f} deg: after compensation no "
                         f"radius written to 0.0005 mm puts its centre within {R_CENTRE_TOL_MM} mm of the one the robot needs "
                         f"(it moves by {worst[i]:.4f} mm); write this arc with I J K")
    return radius


def _refuse_singular_arcs(tp: Toolpath, rows: np.ndarray, q: np.ndarray, robot) -> None:
    """The controller's arc may not pass near a wrist, elbow or shoulder singularity on the
    posture it is driven in (postproc.robot.posture.near_singular at its samples)."""

    finite = ~np.isnan(q).any(axis=2)
    near = np.zeros(finite.shape, bool)
    near[finite] = near_singular(robot, q[finite])
    if near.any():
        row = int(rows[np.nonzero(near.any(axis=1))[0][0]])
        raise InputError(_where(tp, row, I_) + "the controller's arc passes near a singularity on the robot's posture")


def _deviation(problem, sol, intended: Arcs, commanded: Arcs, at: np.ndarray) -> np.ndarray:
    """(M,) largest predicted distance of the robot from the intended arc along the
    controller's commanded arc (SAMPLES interior points, on the arc end's posture)."""
    tp = problem.tp
    fractions = np.linspace(0.0, 1.0, SAMPLES + 2)[1:-1]
    base = _to_base(tp, commanded.rows, commanded.points(fractions))
    interior = _Interior(problem, _interior_poses(problem, commanded, at, base, fractions), at)
    interior.q_ref = np.repeat(sol.q[at], len(fractions), axis=0)
    interior.branch_ref = np.repeat(sol.branch[at], len(fractions))
    err, q, _ = interior.evaluate(interior.goal, np.ones(len(interior.goal), bool))
    actual = _local(tp, interior.rows, interior.goal + err).reshape(len(at), len(fractions), 3)
    dist = intended.distance(actual)
    _refuse_singular_arcs(tp, intended.rows, q.reshape(len(at), len(fractions), 6), robot=problem.plant.robot)
    lost = np.isnan(dist).any(axis=1)
    if lost.any():
        row = int(intended.rows[np.nonzero(lost)[0][0]])
        raise InputError(_where(tp, row, I_) + "the controller's arc to the compensated end leaves the robot's reach or posture "
                         "(no IK solution on the branch somewhere along it)")
    return dist.max(axis=1)


# ---------------------------------------------------------------- output

def check_words(original: Toolpath, modified: Toolpath, back: Toolpath, rows: np.ndarray) -> None:
    """The re-parsed output ``back`` gives every compensated arc of ``rows`` the centre words
    the compensation wrote (an omitted word reads as 0), within the writing tolerance."""

    if modified.arc is None or not len(rows):
        return
    want, got = modified.values[rows][:, F_ARC], back.values[rows][:, F_ARC]
    bad = ~np.isnan(want) & ~(np.abs(np.nan_to_num(got) - np.nan_to_num(want)) <= TOLERANCE[F_ARC] * (1 + 1e-6))
    if bad.any():
        i, k = (int(v[0]) for v in np.nonzero(bad))
        r = int(rows[i])
        raise OutputCheckError(f"{original.sources[int(original.file[r])].path}, line {original.line[r]}: the arc's "
                               f"{'IJKR'[k]} reads back as {got[i, k]:.4f}, not the compensated {want[i, k]:.4f}; nothing was written")


def summary(tp: Toolpath, path_mm: np.ndarray | None) -> dict | None:
    """The circular motions' predicted largest distance from the intended arc (CIRC / MoveC
    end points and G2/G3 targets; the report's ``path_mm`` of their rows), and where."""
    circular = np.isin(tp.kind, (Kind.CIRC_END, Kind.ARC_CW, Kind.ARC_CCW))
    if path_mm is None or not (circular & np.isfinite(path_mm)).any():
        return None
    dev = np.where(circular, path_mm, np.nan)
    i = int(np.nanargmax(dev))
    return {"arcs": int((circular & np.isfinite(path_mm)).sum()), "max_mm": float(dev[i]), "line": int(tp.line[i])}


def describe(tp: Toolpath) -> dict[int, dict]:
    """Per G2/G3 target row: plane, direction, centre (robot base / machine frame, at the
    start's height along the plane's normal), radius at the start, full circle, turns."""
    geo = geometry(tp)
    if not len(geo.rows):
        return {}
    centre = geo.start.copy()
    m = np.arange(len(geo.rows))[:, None]
    centre[m, geo.axes[:, :2]] = geo.centre
    base = _to_base(tp, geo.rows, centre)
    radius = np.linalg.norm(geo.in_plane(geo.start) - geo.centre, axis=1)
    def num(v):
        return round(float(v), 6) if np.isfinite(v) else None  # an axis the program has not given yet

    return {int(r): {"plane": f"G{int(tp.arc[r, 0])}", "direction": "ccw" if ccw else "cw", "centre": [num(v) for v in c],
                     "radius": num(rad), "full_circle": bool(full), "turns": num(tp.arc[r, 2])}
            for r, ccw, c, rad, full in zip(geo.rows, geo.ccw, base, radius, geo.full)}
