"""Cutter engagement from a stock mesh and the toolpath: a Z-map (height field) approximation.

What it approximates: the stock (a trimesh mesh, workpiece frame, mm) becomes a height
field on a square grid (``cell`` mm): per cell the top of the stock, where a vertical
ray through the cell centre last leaves the mesh (trimesh's triangles, rasterised here). The cutter is a flat-bottomed cylinder of the tool's
diameter with its axis along the workpiece's -z (3-axis cutting: a tilted tool or a corner
radius is not modelled in the removal), swept along the program's cutting moves in
sub-steps of two cells; each sub-step lowers every cell under it to the tool tip (stock
minus swept tool). At each program target the engaged region is the set of cells under
the cutter's front half whose stock, as left by the sub-steps before, is above the tip:
the immersion range is the smallest and largest immersion angle of those at the cutter's
rim (within 3/4 of a cell) and the
axial range runs from the tip to the highest of them. Resolution: about one cell in depth
and cell / radius in angle. Material removed by earlier programs is not known: give the
stock as it is when this program starts.

Vectorised: every (sub-step, cell under it) pair at once; the height each cell has before
a sub-step is a segmented exclusive running minimum over the sub-steps that cover it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh

from postproc.errors import InputError
from postproc.programs.workpiece import workpiece_frame_index

from .forces import CUTTING_KINDS


def block_stock(size_mm=(1000.0, 100.0, 100.0)) -> trimesh.Trimesh:
    """A box of the given size with a corner at the workpiece origin (seed 002's block)."""
    box = trimesh.creation.box(extents=size_mm)
    box.apply_translation(np.asarray(size_mm, dtype=float) / 2.0)
    return box


def stock_heights(mesh: trimesh.Trimesh, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Top of the stock (nx, ny) at cell centres, -inf where there is none: the highest
    crossing of a vertical ray with the mesh's triangles. Vectorised rasterisation: every
    (triangle, cell inside its xy bounding box) pair at once, barycentric inside test."""
    tri = np.asarray(mesh.triangles, dtype=float)  # (T, 3, 3)
    cell_x, cell_y = xs[1] - xs[0] if len(xs) > 1 else 1.0, ys[1] - ys[0] if len(ys) > 1 else 1.0
    i0 = np.clip(np.ceil((tri[:, :, 0].min(1) - xs[0]) / cell_x - 1e-9), 0, len(xs)).astype(int)
    i1 = np.clip(np.floor((tri[:, :, 0].max(1) - xs[0]) / cell_x + 1e-9), -1, len(xs) - 1).astype(int)
    j0 = np.clip(np.ceil((tri[:, :, 1].min(1) - ys[0]) / cell_y - 1e-9), 0, len(ys)).astype(int)
    j1 = np.clip(np.floor((tri[:, :, 1].max(1) - ys[0]) / cell_y + 1e-9), -1, len(ys) - 1).astype(int)
    nx, ny = np.maximum(i1 - i0 + 1, 0), np.maximum(j1 - j0 + 1, 0)
    heights = np.full(len(xs) * len(ys), -np.inf)
    count = nx * ny
    t = np.repeat(np.arange(len(tri)), count)
    if not len(t):
        return heights.reshape(len(xs), len(ys))
    local = np.arange(len(t)) - np.repeat(np.cumsum(count) - count, count)
    ci = i0[t] + local // np.maximum(ny[t], 1)
    cj = j0[t] + local % np.maximum(ny[t], 1)
    a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
    px, py = xs[ci], ys[cj]
    det = (b[:, 1] - c[:, 1]) * (a[:, 0] - c[:, 0]) + (c[:, 0] - b[:, 0]) * (a[:, 1] - c[:, 1])
    flat = np.abs(det) < 1e-12  # a vertical triangle: no vertical ray crosses it
    det = np.where(flat, 1.0, det)
    l1 = ((b[:, 1] - c[:, 1]) * (px - c[:, 0]) + (c[:, 0] - b[:, 0]) * (py - c[:, 1])) / det
    l2 = ((c[:, 1] - a[:, 1]) * (px - c[:, 0]) + (a[:, 0] - c[:, 0]) * (py - c[:, 1])) / det
    l3 = 1.0 - l1 - l2
    eps = 1e-9
    inside = ~flat & (l1 >= -eps) & (l2 >= -eps) & (l3 >= -eps)
    z = l1 * a[:, 2] + l2 * b[:, 2] + l3 * c[:, 2]
    np.maximum.at(heights, (ci * len(ys) + cj)[inside], z[inside])
    return heights.reshape(len(xs), len(ys))


def _densify(points: np.ndarray, cutting_step: np.ndarray, substep: float):
    """Sub-step positions along the path and the sub-step index of every original point."""
    seg = np.diff(points, axis=0)
    counts = np.where(cutting_step, np.maximum(np.ceil(np.linalg.norm(seg, axis=1) / substep), 1), 1).astype(int)
    starts = np.concatenate([[0], np.cumsum(counts)])
    owner = np.repeat(np.arange(len(seg)), counts)
    frac = (np.arange(starts[-1]) - starts[owner] + 1) / counts[owner]
    inner = points[owner] + frac[:, None] * seg[owner]
    samples = np.vstack([points[:1], inner])
    return samples, starts, np.concatenate([[False], np.repeat(cutting_step, counts)])


def from_stock(positions: np.ndarray, cutting: np.ndarray, diameter: float, mesh: trimesh.Trimesh, *,
               tool_axis: np.ndarray | None = None, cell: float | None = None) -> np.ndarray:
    """Engagement (P, 4) = (phi_start deg, phi_exit deg, z_low mm, z_high mm) at each tool tip.

    positions (P, 3) tool tips in the stock's (workpiece) frame; cutting (P,) True where the
    move arriving at the point cuts; tool_axis (P, 3) the TCP z axes there (must point down
    -z: the Z-map is 3-axis). Points that do not cut, or cut air, get an empty range (0 force).
    cell: the grid size, mm (default diameter / 40: about 3 deg of immersion at the rim).
    """
    cell = diameter / 40.0 if cell is None else float(cell)
    pos = np.asarray(positions, dtype=float)
    cutting = np.asarray(cutting, dtype=bool)
    if tool_axis is not None:
        tilted = cutting & (np.asarray(tool_axis)[:, 2] > -math.cos(math.radians(1.0)))
        if tilted.any():
            raise InputError(f"target {int(np.nonzero(tilted)[0][0]) + 1}: the tool axis is not along the workpiece's -z; "
                             "engagement from a stock is a 3-axis (Z-map) approximation: give the engagement per block instead")
    radius = diameter / 2.0
    lo, hi = mesh.bounds[0, :2] - radius, mesh.bounds[1, :2] + radius
    xs, ys = np.arange(lo[0], hi[0] + cell, cell), np.arange(lo[1], hi[1] + cell, cell)
    h0 = stock_heights(mesh, xs, ys).ravel()
    # a move that arrives at a cutting target removes material all along it (sub-steps)
    samples, target_sample, sample_cuts = _densify(pos, cutting[1:], 2.0 * cell)
    # cells under each sub-step's cutter: (S, K) pairs
    k = int(math.ceil(radius / cell))
    off = np.stack(np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij"), -1).reshape(-1, 2)
    ix0 = np.rint((samples[:, 0] - xs[0]) / cell).astype(int)
    iy0 = np.rint((samples[:, 1] - ys[0]) / cell).astype(int)
    ix, iy = ix0[:, None] + off[None, :, 0], iy0[:, None] + off[None, :, 1]
    dx, dy = xs[np.clip(ix, 0, len(xs) - 1)] - samples[:, :1], ys[np.clip(iy, 0, len(ys) - 1)] - samples[:, 1:2]
    inside = (dx**2 + dy**2 <= radius**2) & (ix >= 0) & (ix < len(xs)) & (iy >= 0) & (iy < len(ys)) & sample_cuts[:, None]
    s_idx, k_idx = np.nonzero(inside)
    cell_id = ix[s_idx, k_idx] * len(ys) + iy[s_idx, k_idx]
    before = _height_before(cell_id, s_idx, samples[:, 2], h0)
    return _engagement_at_targets(samples, target_sample, cutting, s_idx, dx[s_idx, k_idx], dy[s_idx, k_idx], before, len(pos), radius, cell)


def _height_before(cell_id: np.ndarray, s_idx: np.ndarray, tip_z: np.ndarray, h0: np.ndarray) -> np.ndarray:
    """Stock height of each (sub-step, cell) pair before that sub-step: the initial height
    lowered by the tips of the earlier sub-steps over the cell (segmented exclusive minimum)."""
    order = np.lexsort((s_idx, cell_id))
    cid, z = cell_id[order], tip_z[s_idx[order]]
    start = np.ones(len(cid), dtype=bool)
    start[1:] = cid[1:] != cid[:-1]
    group = np.cumsum(start) - 1
    big = 4.0 * (np.abs(z).max(initial=0.0) + 1.0)  # later groups sit far below: the running min restarts
    running = np.minimum.accumulate(z - group * big) + group * big
    exclusive = np.full(len(cid), np.inf)
    exclusive[~start] = running[np.nonzero(~start)[0] - 1]
    out = np.empty(len(cid))
    out[order] = np.minimum(h0[cid], exclusive)
    return out


def _engagement_at_targets(samples, target_sample, cutting, s_idx, dx, dy, before, n_targets, radius, cell):
    feed = np.zeros_like(samples)
    feed[1:] = np.diff(samples, axis=0)
    feed[0] = feed[1] if len(feed) > 1 else (1.0, 0.0, 0.0)
    fx, fy = feed[:, 0], feed[:, 1]
    norm = np.hypot(fx, fy)
    fx, fy = np.where(norm > 0, fx / np.where(norm > 0, norm, 1), 1.0), np.where(norm > 0, fy / np.where(norm > 0, norm, 1), 0.0)
    target_of = np.full(len(samples), -1)
    target_of[target_sample] = np.arange(n_targets)
    t = target_of[s_idx]
    along = dx * fx[s_idx] + dy * fy[s_idx]  # towards the feed
    left = -dx * fy[s_idx] + dy * fx[s_idx]  # y_c = z x x_c: left of the feed
    depth = before - samples[s_idx, 2]
    engaged = (t >= 0) & (depth > 1e-9) & (along >= 0) & cutting[np.maximum(t, 0)]
    # The teeth cut at the rim: the immersion range comes from the engaged cells within
    # three quarters of a cell of it (the crescent's inner cells would widen the range).
    rim = engaged & (np.hypot(dx, dy) >= radius - 0.75 * cell)
    phi = np.degrees(np.arctan2(along, left))  # clockwise from +y_c towards the feed, in [0, 180]
    out = np.zeros((n_targets, 4))
    st = np.full(n_targets, np.inf)
    ex = np.full(n_targets, -np.inf)
    top = np.zeros(n_targets)
    np.minimum.at(st, t[rim], phi[rim])
    np.maximum.at(ex, t[rim], phi[rim])
    np.maximum.at(top, t[engaged], depth[engaged])
    hit = np.isfinite(st)
    out[hit, 0], out[hit, 1], out[hit, 3] = st[hit], ex[hit], top[hit]
    return out


def load_stock(path) -> trimesh.Trimesh:
    """A stock mesh from a file trimesh reads (STL, OBJ, PLY, ...), in the workpiece frame, mm."""

    try:
        mesh = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise InputError(f"{path}: cannot read the stock mesh ({exc})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError(f"{path}: no triangles in the stock mesh")
    if not Path(path).is_file():
        raise InputError(f"{path}: stock mesh not found")
    return mesh


def program_engagement(tp, diameter: float, mesh: trimesh.Trimesh, cell: float | None = None) -> np.ndarray:
    """Engagement (N, 4) of every target of a program whose Cartesian targets share one
    workpiece frame, from the stock ``mesh`` in that frame (rows of non-cutting targets empty)."""
    _, rows = workpiece_frame_index(tp)
    local = tp.target_poses()[rows]
    cutting = np.isin(tp.kind[rows], CUTTING_KINDS)
    out = np.zeros((len(tp), 4))
    out[rows] = from_stock(local[:, :3, 3], cutting, diameter, mesh, tool_axis=local[:, :3, 2], cell=cell)
    return out
