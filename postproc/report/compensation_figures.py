"""Figures of ``compensate --report PAGE.html``: the path, its error, its margins, and the
region the model was measured in against the program's."""

from __future__ import annotations

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.spatial import ConvexHull, QhullError  # noqa: E402

from .figures import AFTER, BEFORE  # noqa: E402

PROGRAMMED = "#222222"
OUTSIDE = "#d62728"
REGION = "#9ecae1"


def path_gain(goal: np.ndarray, before: np.ndarray) -> float:
    """How much to magnify errors so that the largest is a twentieth of the path's extent
    (a round number; 1 where the errors are already visible)."""
    extent = np.nanmax(np.nanmax(goal, axis=0) - np.nanmin(goal, axis=0))
    largest = np.nanmax(np.linalg.norm(before, axis=1))
    if not np.isfinite(largest) or largest <= 0 or not np.isfinite(extent):
        return 1.0
    raw = max(extent / 20.0 / largest, 1.0)
    return float(10 ** np.floor(np.log10(raw)) * (5 if raw / 10 ** np.floor(np.log10(raw)) >= 5 else 1))


def path_3d(goal: np.ndarray, before: np.ndarray, after: np.ndarray, gain: float):
    """The programmed path and the robot's predicted paths without and with compensation,
    errors magnified by ``gain`` so they can be seen."""
    fig = plt.figure(figsize=(9, 7), constrained_layout=True)
    ax = fig.add_subplot(projection="3d")
    ax.plot(*goal.T, color=PROGRAMMED, lw=1.6, label="programmed")
    ax.plot(*(goal + gain * before).T, color=BEFORE, lw=1.2, label=f"predicted, as written (error x{gain:g})")
    ax.plot(*(goal + gain * after).T, color=AFTER, lw=1.2, ls="--", label=f"predicted, compensated (error x{gain:g})")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    spans = np.nanmax(goal, axis=0) - np.nanmin(goal, axis=0)
    ax.set_box_aspect(np.maximum(spans, spans.max() / 4))  # a flat path keeps a readable z axis
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(matplotlib.ticker.MaxNLocator(5))
    ax.set_title(f"Path in the robot base frame (errors drawn {gain:g} times their size)")
    ax.legend(loc="upper left")
    return fig


def errors_along(distance: np.ndarray, before: np.ndarray, after: np.ndarray, between: np.ndarray | None):
    """Predicted 3-D error at the targets, as written and compensated, and the largest
    predicted distance from the intended path between targets, along the path."""
    fig, ax = plt.subplots(figsize=(10, 4.5), constrained_layout=True)
    ax.plot(distance, before, "-", color=BEFORE, lw=1.5, label="at the targets, as written")
    ax.plot(distance, after, "-", color=AFTER, lw=1.5, label="at the targets, compensated")
    if between is not None and np.isfinite(between).any():
        ax.plot(distance, between, ".", color="#2ca02c", ms=4, label="between targets, compensated (largest on the segment into it)")
    ax.set_yscale("log")
    ax.set_xlabel("distance along the path (mm)")
    ax.set_ylabel("predicted 3-D error (mm, log scale)")
    ax.set_title("Predicted error along the path")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="best", fontsize=9)
    return fig


def margins_along(distance: np.ndarray, wrist: np.ndarray, elbow: np.ndarray, limit: np.ndarray, shoulder: np.ndarray,
                  singular_deg: float, shoulder_mm: float):
    """Distances from the singularities and the joint limits at the compensated targets."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, constrained_layout=True)
    top.plot(distance, wrist, color="#1f77b4", label="wrist singularity (axis 5 straight)")
    top.plot(distance, elbow, color="#ff7f0e", label="elbow singularity (arm stretched: edge of reach)")
    top.plot(distance, limit, color="#9467bd", label="nearest joint limit")
    top.axhline(singular_deg, color=OUTSIDE, ls="--", lw=1, label=f"refused below {singular_deg:g} deg (singularities)")
    top.set_ylabel("margin (deg)")
    top.set_ylim(bottom=0)
    top.set_title("Reach, singularity and joint-limit margins along the path (compensated targets)")
    top.legend(loc="upper right", fontsize=8)
    top.grid(alpha=0.3)
    bottom.plot(distance, shoulder, color="#8c564b", label="shoulder singularity (wrist centre from axis 1)")
    bottom.axhline(shoulder_mm, color=OUTSIDE, ls="--", lw=1, label=f"refused below {shoulder_mm:g} mm")
    bottom.set_xlabel("distance along the path (mm)")
    bottom.set_ylabel("margin (mm)")
    bottom.set_ylim(bottom=0)
    bottom.legend(loc="upper right", fontsize=8)
    bottom.grid(alpha=0.3)
    return fig


def region_views(coverage, goal: np.ndarray, outside: np.ndarray):
    """The region the model was measured in (its hull seen from above and from the side,
    radius against z) with the program's targets; those outside it in red."""
    fig, (top, side) = plt.subplots(1, 2, figsize=(12, 5.2), constrained_layout=True)
    radius = np.hypot(goal[:, 0], goal[:, 1])
    views = ((top, goal[:, :2], "x (mm)", "y (mm)", "seen from above"), (side, np.column_stack([radius, goal[:, 2]]), "radius from axis 1 (mm)", "z (mm)", "seen from the side"))
    for ax, points, xlabel, ylabel, title in views:
        if coverage is not None and coverage.hull_vertices_mm is not None:
            v = coverage.hull_vertices_mm
            projected = v[:, :2] if ax is top else np.column_stack([np.hypot(v[:, 0], v[:, 1]), v[:, 2]])
            _filled_hull(ax, projected, f"measured region ({coverage.poses} poses)")
        if coverage is not None and ax is side:
            (r0, r1), (z0, z1) = coverage.radius_mm, coverage.z_mm
            ax.plot([r0, r1, r1, r0, r0], [z0, z0, z1, z1, z0], color="#3182bd", ls=":", lw=1, label="measured radius and z ranges")
        ax.plot(points[~outside, 0], points[~outside, 1], ".", color=PROGRAMMED, ms=3, label="program targets")
        if outside.any():
            ax.plot(points[outside, 0], points[outside, 1], "x", color=OUTSIDE, ms=5, label=f"outside the measured region ({int(outside.sum())})")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"Measured region and program, {title}")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    if coverage is None:
        fig.suptitle("the model file records no measured region (fitted before it was recorded)")
    return fig


def joint_ranges(coverage, lower: np.ndarray, upper: np.ndarray, q_program: np.ndarray):
    """Per joint: the robot's limits, the range the model was fitted on and the program's."""
    fig, ax = plt.subplots(figsize=(10, 4.6), layout="constrained")
    y = np.arange(6)[::-1]
    ax.barh(y, upper - lower, left=lower, height=0.7, color="#eeeeee", edgecolor="#999999", label="robot's joint limits")
    if coverage is not None:
        ax.barh(y, coverage.joint_upper_deg - coverage.joint_lower_deg, left=coverage.joint_lower_deg, height=0.45, color=REGION,
                edgecolor="#3182bd", label="fitted range (measured poses)")
    known = ~np.isnan(q_program).any(axis=1)
    if known.any():
        lo, hi = q_program[known].min(axis=0), q_program[known].max(axis=0)
        width = np.maximum(hi - lo, 2.0)  # a joint the program holds still shows as a 2-deg mark
        ax.barh(y, width, left=(lo + hi - width) / 2, height=0.18, color="#ff7f0e", label="program (compensated targets)")
    ax.set_yticks(y)
    ax.set_yticklabels([f"q{j + 1}" for j in range(6)])
    ax.set_xlabel("joint angle (deg)")
    ax.set_title("Joint ranges: robot limits, the model's fitted range, the program")
    fig.legend(loc="outside lower center", ncol=3, fontsize=8)
    ax.grid(axis="x", alpha=0.3)
    return fig


def _filled_hull(ax, points: np.ndarray, label: str) -> None:
    try:
        hull = ConvexHull(points)
    except QhullError:
        return
    ring = points[np.append(hull.vertices, hull.vertices[0])]
    ax.fill(ring[:, 0], ring[:, 1], color=REGION, alpha=0.6, label=label)
