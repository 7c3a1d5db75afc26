"""Rotary-axis calibration from sphere centres (seed 003, with seed 004's circle fit).

Per rotary axis, the sphere centres measured at several positions of that axis lie on a
circle about it. Seed 003:

1. Outliers off the plane: the plane through three random centres, every centre's
   distance d_i to it, sigma0 the RMS spread of the d_i about their mean (eq. 4); a centre
   whose |d_i - mean| exceeds 2 sigma0 (eq. 3) is an outlier. One draw picks the wrong
   point when it includes the outlier, so draws are repeated in seeded batches and a point
   is an outlier when most draws flag it, until the verdict is the same for three batches.
2. The total-least-squares (eigenvalue) plane of the rest: its normal is the axis direction.
3. The centres projected onto the plane, a least-squares circle, |distance - R0| per centre,
   the same 2 sigma rule (eq. 5-7) removes radial outliers; the circle of the rest gives
   the point on the axis (its centre).

Both rules are applied until they flag nothing more (two outliers of different size hide
the smaller one in the first pass), and no deviation below ``min_outlier_mm`` is ever an
outlier (on outlier-free data the 2 sigma rule alone removes about 5% of good points).
The plane is refitted on the final set. ``method="seed004"`` fits the circle with seed
004's iterative re-centred fit instead of Gauss-Newton (same optimum, checked in tests).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import CalibrationError
from .fitting import fit_circle, fit_circle_iterative, fit_plane, plane_basis, plane_distances
from .geometry import line_distance
from .machine import Machine

BATCH = 64


@dataclass(frozen=True)
class AxisFit:
    axis: str
    direction: np.ndarray  # (3,) unit, right-handed with the axis's positive rotation
    point: np.ndarray  # (3,) circle centre, on the axis
    radius: float
    rms_mm: float  # RMS distance of the kept centres to the fitted circle (3-D)
    plane_rms_mm: float
    direction_sigma_rad: float
    point_sigma_mm: float
    kept: np.ndarray  # (N,) bool
    outliers: list[dict]  # {"id", "row", "stage", "deviation_mm", "threshold_mm", "votes"}
    sense: str  # how the rotation sense was decided
    draws: int
    method: str
    plane_xy: np.ndarray = field(repr=False)  # (N, 2) in-plane coordinates of all centres
    basis: np.ndarray = field(repr=False)  # (2, 3) in-plane directions
    centroid: np.ndarray = field(repr=False)
    plane_offset: np.ndarray = field(repr=False, default=None)  # (N,) signed distance of every centre to the fitted plane, mm


def consensus_plane_outliers(points: np.ndarray, seed: int = 0, min_outlier_mm: float = 0.01, max_batches: int = 64) -> tuple[np.ndarray, np.ndarray, int]:
    """Seed 003 step 1 over seeded repeated draws: (flagged (N,) bool, vote share (N,), draws)."""
    n = len(points)
    rng = np.random.default_rng(seed)
    votes = np.zeros(n)
    valid_draws = 0
    verdicts: list[bytes] = []
    for _ in range(max_batches):
        triples = np.argsort(rng.random((BATCH, n)), axis=1)[:, :3]
        dist = plane_distances(points, triples)
        dist = dist[~np.isnan(dist).any(axis=1)]
        dev = np.abs(dist - dist.mean(axis=1, keepdims=True))
        sigma0 = dist.std(axis=1, keepdims=True)  # eq. 4: RMS spread about the mean
        votes += (dev > np.maximum(2.0 * sigma0, min_outlier_mm)).sum(axis=0)
        valid_draws += len(dist)
        verdicts.append((votes > 0.5 * max(valid_draws, 1)).tobytes())
        if len(verdicts) >= 3 and verdicts[-1] == verdicts[-2] == verdicts[-3]:
            break
    share = votes / max(valid_draws, 1)
    return share > 0.5, share, valid_draws


def _radial_outliers(dev: np.ndarray, min_outlier_mm: float) -> tuple[np.ndarray, float]:
    """Seed 003 eq. 5-7: |dD_i - K| > 2 sigma1 (and above the floor)."""
    threshold = max(2.0 * float(dev.std()), min_outlier_mm)
    return np.abs(dev - dev.mean()) > threshold, threshold


def fit_axis(axis: str, xyz: np.ndarray, ids, angle=None, method: str = "seed003", seed: int = 0, min_outlier_mm: float = 0.01,
             carrier: str = "table", remove_outliers: bool = True) -> AxisFit:
    """Direction and point of one rotary axis from its sphere centres (N, 3)."""
    if method not in ("seed003", "seed004"):
        raise CalibrationError(f"--method: '{method}' is not seed003 or seed004")
    n = len(xyz)
    if n < 4:
        raise CalibrationError(f"axis {axis}: {n} sphere positions; at least 4 are needed (3 define a circle, the 4th checks it)")
    kept = np.ones(n, bool)
    outliers: list[dict] = []
    draws = 0
    stage_pass = 0
    while remove_outliers and kept.sum() > 4:  # step 1, repeated until it flags nothing
        stage_pass += 1
        idx = np.nonzero(kept)[0]
        flagged, share, used = consensus_plane_outliers(xyz[idx], seed + stage_pass, min_outlier_mm)
        draws += used
        if not flagged.any() or kept.sum() - flagged.sum() < 4:
            break
        plane = fit_plane(xyz[idx[~flagged]])
        for k in np.nonzero(flagged)[0]:
            d = float(abs((xyz[idx[k]] - plane.centroid) @ plane.normal))
            outliers.append({"id": ids[idx[k]], "stage": "plane", "pass": stage_pass, "deviation_mm": d, "votes": float(share[k]),
                             "why": f"off the plane: {d:.4f} mm from the plane of the others; flagged by the 2-sigma rule in {share[k]:.0%} of {used} random 3-point planes"})
        kept[idx[flagged]] = False
    plane, circle, xy, basis = _plane_and_circle(xyz, kept, method)
    while remove_outliers and kept.sum() > 4:  # step 3, repeated
        idx = np.nonzero(kept)[0]
        dev = np.abs(np.linalg.norm(xy[idx] - circle.centre, axis=1) - circle.radius)
        flagged, threshold = _radial_outliers(dev, min_outlier_mm)
        if not flagged.any() or kept.sum() - flagged.sum() < 4:
            break
        for k in np.nonzero(flagged)[0]:
            outliers.append({"id": ids[idx[k]], "stage": "circle", "deviation_mm": float(dev[k]), "threshold_mm": threshold,
                             "why": f"off the circle: |distance - R| = {dev[k]:.4f} mm, more than {threshold:.4f} mm (2 sigma) from the mean"})
        kept[idx[flagged]] = False
        plane, circle, xy, basis = _plane_and_circle(xyz, kept, method)
    direction, sense = _oriented(plane.normal, xy, kept, angle, carrier)
    point = plane.centroid + circle.centre @ basis
    if direction @ plane.normal < 0:  # keep e1 x e2 = direction for the plots
        basis, xy = basis[::-1], xy[:, ::-1]
    off = (xyz[kept] - plane.centroid) @ plane.normal
    rms3d = float(np.sqrt(np.mean(circle.residuals**2 + off**2)))
    return AxisFit(axis, direction, point, circle.radius, rms3d, plane.rms, plane.normal_sigma_rad, circle.centre_sigma, kept, outliers, sense,
                   draws, method, xy, basis, plane.centroid, (xyz - plane.centroid) @ direction)


def _plane_and_circle(xyz: np.ndarray, kept: np.ndarray, method: str):
    plane = fit_plane(xyz[kept])
    if plane.eigenvalues[1] < 1e-9 * max(plane.eigenvalues[2], 1e-300):
        raise CalibrationError("the sphere centres are collinear: they do not span a circle")
    basis = plane_basis(plane.normal)
    xy = (xyz - plane.centroid) @ basis.T
    circle = (fit_circle if method == "seed003" else fit_circle_iterative)(xy[kept])
    return plane, circle, xy, basis


def _oriented(normal: np.ndarray, xy: np.ndarray, kept: np.ndarray, angle, carrier: str) -> tuple[np.ndarray, str]:
    """The normal's sign making the centres turn right-handed with increasing angle (row
    order when no angles are given); a head axis moves the probe, so the centres turn back."""
    pts = xy[kept]
    if angle is not None and not np.isnan(np.asarray(angle)[kept]).any():
        a = np.asarray(angle)[kept]
        order = np.argsort(a)
        step = np.sign(np.diff(a[order]))
        how = "from the angles"
    else:
        order = np.arange(len(pts))
        step = np.ones(len(pts) - 1)
        how = "from the row order (no angles given): rows taken as increasing angle"
    c = pts.mean(axis=0)
    p = pts[order] - c
    turn = float(np.sum(step * (p[:-1, 0] * p[1:, 1] - p[:-1, 1] * p[1:, 0])))  # > 0: counter-clockwise about +normal
    sign = 1.0 if turn >= 0 else -1.0
    if carrier == "head":
        sign = -sign
    return sign * normal, how


def compare_nominal(fit: AxisFit, nominal_direction: np.ndarray, nominal_point: np.ndarray) -> dict:
    """Distance between the fitted and the nominal axis lines (not between points), their angle,
    and the offset of the nominal line from the fitted circle centre."""
    dist, angle = line_distance(fit.point, fit.direction, nominal_point, nominal_direction)
    diff = fit.point - nominal_point
    offset = float(np.linalg.norm(diff - (diff @ nominal_direction) * nominal_direction))
    return {"line_distance_mm": dist, "angle_rad": angle, "offset_at_centre_mm": offset}


@dataclass(frozen=True)
class Calibration:
    nominal: Machine
    machine: Machine  # with the calibrated axes
    fits: dict  # axis name -> AxisFit
    plain: dict  # axis name -> AxisFit without outlier removal (plain least squares, for comparison)
    rows: dict  # axis name -> tuple of 1-based data rows of its centres
    ids: dict  # axis name -> list of the centres' ids

    def as_json(self) -> dict:
        axes = {}
        for name, fit in self.fits.items():
            nom = next(ax for ax in self.nominal.rotary if ax.name == name)
            removed = [{**o, "row": self.rows[name][self.ids[name].index(o["id"])]} for o in fit.outliers]
            axes[name] = {
                "direction": fit.direction.tolist(), "point": fit.point.tolist(), "outliers": [o["id"] for o in fit.outliers],
                "rms_mm": fit.rms_mm, "removed": removed, "radius_mm": fit.radius, "plane_rms_mm": fit.plane_rms_mm,
                "direction_sigma_rad": fit.direction_sigma_rad, "point_sigma_mm": fit.point_sigma_mm,
                "positions": int(len(fit.kept)), "kept": int(fit.kept.sum()), "sense": fit.sense, "method": fit.method, "draws": fit.draws,
                "vs_nominal": compare_nominal(fit, nom.direction, nom.point),
                "without_outlier_removal": {"direction": self.plain[name].direction.tolist(), "point": self.plain[name].point.tolist(),
                                            "rms_mm": self.plain[name].rms_mm},
            }
        return {"machine": self.nominal.name, "axes": axes}


def calibrate_machine(machine, centres, method: str = "seed003", seed: int = 0, min_outlier_mm: float = 0.01) -> Calibration:
    """Fit every rotary axis that ``centres`` (probes.Centres) has positions of."""
    fits, plain, rows, id_map = {}, {}, {}, {}
    names = machine.rotary_names
    for name in sorted(set(centres.axis)):
        if name not in names:
            raise CalibrationError(f"the probe file has positions of axis {name}; machine {machine.name} has rotary axes {', '.join(names)}")
        sel = np.array([a == name for a in centres.axis])
        ids = [i for i, s in zip(centres.ids, sel) if s]
        carrier = machine.rotary[names.index(name)].carrier
        args = (name, centres.xyz[sel], ids, centres.angle[sel])
        fits[name] = fit_axis(*args, method=method, seed=seed, min_outlier_mm=min_outlier_mm, carrier=carrier)
        plain[name] = fit_axis(*args, method=method, carrier=carrier, remove_outliers=False)
        rows[name] = tuple(r for r, s in zip(centres.rows, sel) if s)
        id_map[name] = ids
    calibrated = machine.with_axes({n: (f.direction, f.point) for n, f in fits.items()},
                                   {"method": method, "axes": ", ".join(fits), "from": "postproc rtcp-calibrate"})
    return Calibration(machine, calibrated, fits, plain, rows, id_map)
