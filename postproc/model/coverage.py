"""The region a model was measured in, and the poses outside it.

A fitted model is a function fitted to poses in one region: its joint ranges and the part
of the workspace its TCP visited. Outside them it extrapolates (a joint-2 harmonic fitted
over -30..28 deg predicted 108 mm at -120 deg), so every model records the region
(``Coverage``), ``evaluate`` reports the poses outside it and ``compensate`` refuses
targets outside it unless the user allows extrapolation.

The Cartesian region is the convex hull of the commanded TCP positions (nominal forward
kinematics of the measured joints with the model's tool, so in the robot's base frame
whatever frame the tracker measured in), stored as its vertices, with the radius and z
ranges for summaries. Distances outside the hull are the largest facet violation: exact
where the nearest part of the hull is a facet, a lower bound near its edges and corners.

A model whose predictor reads the path before each pose (``--gp-features tcp+joints+travel``)
also records the TCP travels it was measured with (``travel_log1p``): the move into each pose
and the two before, as the predictor sees them, log(1 + mm). UR10 Series A has moves of
0-1.7 mm (the probe turned at a grid point) and of 84-1301 mm (to another point), none in
between: a program of 1-50 mm moves asks the predictor about moves it never saw.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from postproc.errors import ModelFileError
from postproc.robot import kinematics as kin

from .path_history import path_travel_mm, previous_targets

# A target this close to the measured region is inside it. The measured poses are samples:
# the hull of N poses scattered through a volume V falls short of the volume sampled by
# about one spacing between poses, (V / N)^(1/3) (250 poses of the KR160 cylinder region:
# 106 mm; 14 of 100 poses drawn from the same region lay up to 69 mm outside the hull), so
# the Cartesian tolerance is that spacing, within these bounds. A joint may go beyond its
# fitted range by a twentieth of that range (at least 1 deg): the model's terms in that
# joint vary over the range, and so change little within 5 % beyond it (a wrist fitted over
# -175..168 deg may take 172 deg; a q2 fitted over -30..28 deg may not take -120 deg).
JOINT_TOLERANCE_DEG = 1.0
JOINT_TOLERANCE_FRACTION = 0.05
HULL_TOLERANCE_MIN_MM = 10.0
HULL_TOLERANCE_MAX_MM = 100.0
# A travel is inside the measured ones where its log(1 + mm) lies this close to one of them:
# a factor of about 1.65 in travel (10 mm is inside where 6-16 mm moves were measured). The
# predictor's travel features are in these units; Series A's two groups of moves lie 3.8
# apart, so the tolerance is well short of bridging its gap.
TRAVEL_TOLERANCE_LOG1P = 0.5
TRAVEL_ROUND_LOG1P = 0.05  # the model file keeps the measured travels to this step: a few hundred numbers whatever the poses

COVERAGE_KEY = "coverage"  # the model file's key (postproc.model.model_io)
_HULL_BLOCK = 4096  # rows per product in Coverage.hull_excess


@dataclass(frozen=True)
class Coverage:
    """Joint ranges and Cartesian region of the poses a model was fitted on."""

    poses: int
    joint_lower_deg: np.ndarray  # (6,)
    joint_upper_deg: np.ndarray  # (6,)
    radius_mm: tuple[float, float]  # distance from the base z axis
    z_mm: tuple[float, float]
    hull_vertices_mm: np.ndarray | None  # (V, 3), None where the poses span no volume
    # Per step back along the path (the move into the pose, the one before, ...): the sorted
    # distinct log(1 + mm) TCP travels measured; None where the model does not read the path.
    travel_log1p: tuple[np.ndarray, ...] | None = None

    @classmethod
    def of(cls, robot, tool_mm, q_deg: np.ndarray) -> "Coverage":
        """The region of measured joints ``q_deg`` (N, 6) with the measured point ``tool_mm``."""
        q = np.asarray(q_deg, dtype=float)
        tcp = kin.fk(robot, q, tool=np.asarray(tool_mm, dtype=float))[:, :3, 3]
        radius = np.hypot(tcp[:, 0], tcp[:, 1])
        return cls(poses=len(q), joint_lower_deg=q.min(axis=0), joint_upper_deg=q.max(axis=0),
                   radius_mm=(float(radius.min()), float(radius.max())), z_mm=(float(tcp[:, 2].min()), float(tcp[:, 2].max())),
                   hull_vertices_mm=_hull_vertices(tcp))

    def describe(self) -> str:
        """One line for summaries: poses, z and radius ranges, joint ranges."""
        joints = ", ".join(f"q{j + 1} {lo:.0f}..{hi:.0f}" for j, (lo, hi) in enumerate(zip(self.joint_lower_deg, self.joint_upper_deg)))
        return (f"{self.poses} poses, z {self.z_mm[0]:.0f}..{self.z_mm[1]:.0f} mm, radius {self.radius_mm[0]:.0f}..{self.radius_mm[1]:.0f} mm, "
                f"joints {joints} deg")

    # ---------------------------------------------------------------- the check

    @property
    def joint_tolerance_deg(self) -> np.ndarray:
        """(6,) how far beyond its fitted range each joint may go (see JOINT_TOLERANCE_*)."""
        return np.maximum(JOINT_TOLERANCE_DEG, JOINT_TOLERANCE_FRACTION * (self.joint_upper_deg - self.joint_lower_deg))

    def joint_excess(self, q_deg: np.ndarray) -> np.ndarray:
        """(N, 6) deg beyond the fitted range per joint (0 inside; NaN rows stay NaN)."""
        q = np.asarray(q_deg, dtype=float)
        return np.maximum(np.maximum(self.joint_lower_deg - q, q - self.joint_upper_deg), 0.0)

    def hull_excess(self, xyz_mm: np.ndarray) -> np.ndarray:
        """(N,) mm outside the measured region (0 inside): the hull, or the radius and z
        ranges where the poses span no volume."""
        xyz = np.asarray(xyz_mm, dtype=float)
        if self.hull_vertices_mm is None:
            radius = np.hypot(xyz[:, 0], xyz[:, 1])
            return np.maximum.reduce([self.radius_mm[0] - radius, radius - self.radius_mm[1],
                                      self.z_mm[0] - xyz[:, 2], xyz[:, 2] - self.z_mm[1], np.zeros(len(xyz))])
        eq = _facets(self.hull_vertices_mm)  # (F, 4): unit normal, offset; inside where n.x + d <= 0
        normals, offsets = np.ascontiguousarray(eq[:, :3].T), eq[:, 3]
        out = np.empty(len(xyz))
        # In blocks of rows: the (rows, facets) products stay in cache (half the time of one
        # product over a 100,000-target chunk: 24 against 50 ms).
        for start in range(0, len(xyz), _HULL_BLOCK):
            block = xyz[start : start + _HULL_BLOCK] @ normals
            block += offsets
            out[start : start + _HULL_BLOCK] = block.max(axis=1)
        return np.maximum(out, 0.0)

    def with_travels(self, travel_mm: np.ndarray) -> "Coverage":
        """This region with the measured TCP travels ``travel_mm`` (N, k) recorded (see travel_log1p)."""
        logs = np.round(np.log1p(np.asarray(travel_mm, dtype=float)) / TRAVEL_ROUND_LOG1P) * TRAVEL_ROUND_LOG1P
        return replace(self, travel_log1p=tuple(np.unique(column) for column in logs.T))

    def travel_excess(self, travel_mm: np.ndarray) -> np.ndarray:
        """(N,) log(1 + mm) from each pose's travels (N, k) to the nearest measured travel, the
        largest over the k steps (0 where the model records no travels)."""
        travel = np.asarray(travel_mm, dtype=float)
        if self.travel_log1p is None:
            return np.zeros(len(travel))
        out = np.zeros(len(travel))
        for column, measured in zip(np.log1p(travel).T, self.travel_log1p):
            at = np.searchsorted(measured, column)  # the measured travel above each, then the one below
            above, below = measured[np.minimum(at, len(measured) - 1)], measured[np.maximum(at - 1, 0)]
            out = np.maximum(out, np.minimum(np.abs(column - above), np.abs(column - below)))
        return out

    def travel_ranges_mm(self) -> str:
        """The measured travels of the move into a pose, as ranges in mm, for messages."""
        measured = self.travel_log1p[0]
        breaks = np.nonzero(np.diff(measured) > TRAVEL_TOLERANCE_LOG1P)[0]
        starts, ends = np.r_[0, breaks + 1], np.r_[breaks, len(measured) - 1]
        spans = [f"{np.expm1(measured[a]):.1f}" + ("" if a == b else f"-{np.expm1(measured[b]):.1f}") for a, b in zip(starts, ends)]
        return ", ".join(spans) + " mm"

    @property
    def hull_tolerance_mm(self) -> float:
        """How far outside the hull a pose may lie and still be inside the sampled region:
        one spacing between the measured poses (see HULL_TOLERANCE_*)."""
        if self.hull_vertices_mm is None:
            return HULL_TOLERANCE_MIN_MM
        spacing = (ConvexHull(self.hull_vertices_mm).volume / self.poses) ** (1.0 / 3.0)
        return float(np.clip(spacing, HULL_TOLERANCE_MIN_MM, HULL_TOLERANCE_MAX_MM))

    def outside(self, q_deg: np.ndarray, xyz_mm: np.ndarray, travel_mm: np.ndarray | None = None) -> "Outside":
        """Which poses lie outside the region beyond the tolerances, and by how much;
        ``travel_mm`` (N, k): their TCP travels along the path, checked where the model
        records travels (see travel_log1p)."""
        joints = self.joint_excess(q_deg)
        joints_known = ~np.isnan(joints).any(axis=1)
        joints = np.nan_to_num(joints)
        cart = self.hull_excess(xyz_mm)
        beyond = joints > self.joint_tolerance_deg
        # The joint named: the furthest beyond its tolerance, else the furthest beyond its range.
        worst_joint = np.where(beyond.any(axis=1), np.argmax(np.where(beyond, joints, -1.0), axis=1), np.argmax(joints, axis=1))
        worst_deg = joints[np.arange(len(joints)), worst_joint]
        tolerance = self.hull_tolerance_mm
        out = (beyond.any(axis=1) & joints_known) | (cart > tolerance)
        travel = None
        if travel_mm is not None and self.travel_log1p is not None:
            travel = np.asarray(travel_mm, dtype=float)
            out |= self.travel_excess(travel) > TRAVEL_TOLERANCE_LOG1P
        return Outside(out, worst_joint, worst_deg, cart, tolerance, self.joint_tolerance_deg, travel)

    # ---------------------------------------------------------------- model file

    def to_document(self) -> dict:
        return {
            "poses": self.poses,
            "joint_lower_deg": np.round(self.joint_lower_deg, 4).tolist(),
            "joint_upper_deg": np.round(self.joint_upper_deg, 4).tolist(),
            "radius_mm": [round(v, 3) for v in self.radius_mm],
            "z_mm": [round(v, 3) for v in self.z_mm],
            "hull_vertices_mm": None if self.hull_vertices_mm is None else np.round(self.hull_vertices_mm, 2).tolist(),
            **({} if self.travel_log1p is None else {"travel_log1p": [np.round(column, 4).tolist() for column in self.travel_log1p]}),
        }

    @classmethod
    def from_document(cls, doc, source: str) -> "Coverage":
        """The model file's ``coverage`` object; errors name the file and the key."""

        def numbers(key: str, shape: tuple) -> np.ndarray:
            try:
                value = np.array(doc.get(key), dtype=float)
            except (TypeError, ValueError):
                value = np.array([])
            if value.shape[1:] != shape[1:] or (shape[0] and value.shape[0] != shape[0]) or not np.isfinite(value).all():
                raise ModelFileError(f"{source}: key '{COVERAGE_KEY}.{key}': must be {' x '.join(str(s or 'N') for s in shape)} finite numbers")
            return value

        if not isinstance(doc, dict):
            raise ModelFileError(f"{source}: key '{COVERAGE_KEY}': must be an object (poses, joint ranges, region)")
        poses = doc.get("poses")
        if not isinstance(poses, int) or isinstance(poses, bool) or poses < 1:
            raise ModelFileError(f"{source}: key '{COVERAGE_KEY}.poses': must be a positive whole number")
        hull = None if doc.get("hull_vertices_mm") is None else numbers("hull_vertices_mm", (0, 3))
        lower, upper = numbers("joint_lower_deg", (6,)), numbers("joint_upper_deg", (6,))
        if (lower > upper).any():
            raise ModelFileError(f"{source}: key '{COVERAGE_KEY}.joint_lower_deg': above joint_upper_deg")
        radius, z = numbers("radius_mm", (2,)), numbers("z_mm", (2,))
        return cls(poses, lower, upper, (float(radius[0]), float(radius[1])), (float(z[0]), float(z[1])), hull, _travels(doc, source))


@dataclass(frozen=True)
class Outside:
    """Per pose: outside the region, the joint furthest beyond its range and by how much
    (deg), and how far outside the Cartesian region (mm)."""

    mask: np.ndarray
    joint: np.ndarray
    joint_deg: np.ndarray
    cartesian_mm: np.ndarray
    tolerance_mm: float  # Cartesian: a pose this close to the hull is inside
    tolerance_deg: np.ndarray  # (6,) per joint: this far beyond the fitted range is inside
    travel_mm: np.ndarray | None = None  # (N, k) the poses' TCP travels, where they were checked

    def reason(self, i: int, coverage: Coverage) -> str:
        """Why pose ``i`` is outside, in words."""
        parts = []
        j = int(self.joint[i])
        if self.joint_deg[i] > self.tolerance_deg[j]:
            parts.append(f"q{j + 1} is {self.joint_deg[i]:.1f} deg beyond the fitted range "
                         f"[{coverage.joint_lower_deg[j]:.1f}, {coverage.joint_upper_deg[j]:.1f}] (tolerance {self.tolerance_deg[j]:.1f} deg)")
        if self.cartesian_mm[i] > self.tolerance_mm:
            parts.append(f"the TCP is {self.cartesian_mm[i]:.0f} mm outside the measured region (tolerance {self.tolerance_mm:.0f} mm)")
        if self.travel_mm is not None and coverage.travel_excess(self.travel_mm[i : i + 1])[0] > TRAVEL_TOLERANCE_LOG1P:
            moves = ", ".join(f"{v:.1f}" for v in self.travel_mm[i])
            parts.append(f"its TCP travels along the path ({moves} mm: the move into it, then the ones before) are unlike the moves "
                         f"the model's predictor was measured with (into a pose: {coverage.travel_ranges_mm()})")
        return "outside the region the model was measured in: " + " and ".join(parts)

    def summary(self) -> dict:
        """Count and worst distances, for --json."""
        return {"count": int(self.mask.sum()), "worst_joint_deg": float(self.joint_deg.max(initial=0.0)),
                "worst_mm": float(self.cartesian_mm.max(initial=0.0)), "tolerance_deg": self.tolerance_deg.round(3).tolist(), "tolerance_mm": self.tolerance_mm}


def _travels(doc: dict, source: str) -> tuple[np.ndarray, ...] | None:
    """The model file's ``coverage.travel_log1p`` (absent in files of models that do not read the path)."""
    if doc.get("travel_log1p") is None:
        return None
    try:
        columns = tuple(np.array(column, dtype=float) for column in doc["travel_log1p"])
    except (TypeError, ValueError):
        columns = ()
    if not columns or any(c.ndim != 1 or not len(c) or not np.isfinite(c).all() or (np.diff(c) < 0).any() for c in columns):
        raise ModelFileError(f"{source}: key '{COVERAGE_KEY}.travel_log1p': must be lists of increasing finite numbers, one per step along the path")
    return columns


def _hull_vertices(points: np.ndarray) -> np.ndarray | None:
    """The convex hull's vertices, or None where the points span no volume (a plane, a line)."""
    if len(points) < 4:
        return None
    try:
        hull = ConvexHull(points)
    except QhullError:
        return None
    return points[hull.vertices]


def _facets(vertices: np.ndarray) -> np.ndarray:
    """Facet equations (F, 4) of the hull of ``vertices`` (unit outward normals, offsets)."""
    return ConvexHull(vertices).equations


def outside_poses(model, q_deg: np.ndarray, previous_q_deg: np.ndarray | None = None) -> Outside | None:
    """Which measured poses (joints ``q_deg``, the model's tool) lie outside the region the
    model was fitted on; None where the model records none. Where it records travels, the
    poses' path is ``previous_q_deg`` (N, k, 6), else their rows' order (the measured order)."""
    if model.coverage is None:
        return None
    q = np.asarray(q_deg, dtype=float)
    tcp = kin.fk(model.robot, q, tool=model.tool_mm)[:, :3, 3]
    travel = None
    if model.coverage.travel_log1p is not None:
        history = previous_targets(q) if previous_q_deg is None else previous_q_deg
        travel = path_travel_mm(model.robot, model.tool_mm, q, history)
    return model.coverage.outside(q, tcp, travel)


def describe_outside(outside: Outside | None, poses: int) -> str:
    """evaluate's line about the poses outside the fitted region."""
    if outside is None:
        return "region the model was fitted on: unknown (the model file records none); poses outside it cannot be found"
    s = outside.summary()
    if not s["count"]:
        return f"all {poses} poses lie within the joint ranges and region the model was fitted on"
    worst_joint = int(outside.joint[int(np.argmax(outside.joint_deg))])
    what = "joint ranges or region" if outside.travel_mm is None else "joint ranges, region or moves"
    return (f"{s['count']} of {poses} poses lie outside the {what} the model was fitted on (the model extrapolates there): "
            f"worst q{worst_joint + 1} {s['worst_joint_deg']:.1f} deg beyond its fitted range, TCP up to {s['worst_mm']:.0f} mm outside the measured region")
