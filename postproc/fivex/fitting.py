"""Geometric fits for rotary-axis calibration: spheres, planes, circles (vectorised).

- ``fit_spheres``: centres of many spheres at once from grouped touch points (algebraic
  start, then Gauss-Newton with a known or a fitted radius).
- ``fit_plane``: total least squares (the eigenvalue method of seed 003).
- ``fit_circle``: least-squares (geometric) circle in a plane, with covariance.
- ``fit_circle_iterative``: seed 004's circle fit: re-centre on the current centre and fit
  again until the centre stops moving.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def fit_spheres(points: np.ndarray, group: np.ndarray, n_groups: int, radius: float | None = None, iterations: int = 20):
    """Centres (G, 3), radii (G,) and RMS residuals (G,) of spheres through grouped points.

    points (N, 3); group (N,) in 0..G-1 sorted or not; radius: the known distance from
    the touch points (probe-tip centres) to the sphere centre, or None to fit it."""
    p = np.asarray(points, float)
    counts = np.bincount(group, minlength=n_groups)
    # Algebraic start: |p|^2 = 2 c.p + k, normal equations summed per group.
    a = np.c_[2 * p, np.ones(len(p))]
    rhs = np.einsum("ni,ni->n", p, p)
    ata = np.zeros((n_groups, 4, 4))
    atb = np.zeros((n_groups, 4))
    np.add.at(ata, group, a[:, :, None] * a[:, None, :])
    np.add.at(atb, group, a * rhs[:, None])
    sol = np.linalg.solve(ata, atb[..., None])[..., 0]
    centre = sol[:, :3]
    r = np.sqrt(np.maximum(sol[:, 3] + np.einsum("gi,gi->g", centre, centre), 0.0))
    for _ in range(iterations):
        diff = p - centre[group]
        dist = np.linalg.norm(diff, axis=1)
        unit = diff / dist[:, None]
        rad = r[group] if radius is None else radius
        res = dist - rad  # d(res)/d(centre) = -unit, d(res)/d(r) = -1
        jac = np.c_[-unit, -np.ones(len(p))] if radius is None else -unit
        k = jac.shape[1]
        jtj = np.zeros((n_groups, k, k))
        jtr = np.zeros((n_groups, k))
        np.add.at(jtj, group, jac[:, :, None] * jac[:, None, :])
        np.add.at(jtr, group, jac * res[:, None])
        step = -np.linalg.solve(jtj, jtr[..., None])[..., 0]
        centre = centre + step[:, :3]
        if radius is None:
            r = r + step[:, 3]
        if np.abs(step).max() < 1e-12:
            break
    rad = r if radius is None else np.full(n_groups, float(radius))
    res = np.linalg.norm(p - centre[group], axis=1) - rad[group]
    rms = np.sqrt(np.bincount(group, res * res, minlength=n_groups) / counts)
    return centre, rad, rms


@dataclass(frozen=True)
class Plane:
    normal: np.ndarray  # (3,) unit
    centroid: np.ndarray  # (3,)
    eigenvalues: np.ndarray  # (3,) of the scatter matrix, ascending (normal's first)
    rms: float  # RMS distance of the points to the plane
    normal_sigma_rad: float  # 1-sigma tilt of the normal (largest of the two directions)


def fit_plane(points: np.ndarray) -> Plane:
    """Total least squares plane: the scatter matrix's eigenvector of the smallest eigenvalue."""
    centroid = points.mean(axis=0)
    scatter = (points - centroid).T @ (points - centroid)
    w, v = np.linalg.eigh(scatter)
    normal = v[:, 0]
    dist = (points - centroid) @ normal
    n = len(points)
    sigma2 = float(dist @ dist) / max(n - 3, 1)
    return Plane(normal, centroid, w, float(np.sqrt(np.mean(dist**2))), float(np.sqrt(sigma2 / w[1])) if w[1] > 0 else np.inf)


def plane_distances(points: np.ndarray, triples: np.ndarray) -> np.ndarray:
    """(D, N) distances of every point to the plane through each triple (D, 3) of point
    indices, NaN rows for (near-)collinear triples."""
    p0, p1, p2 = points[triples[:, 0]], points[triples[:, 1]], points[triples[:, 2]]
    normal = np.cross(p1 - p0, p2 - p0)
    norm = np.linalg.norm(normal, axis=1)
    scale = np.linalg.norm(p1 - p0, axis=1) * np.linalg.norm(p2 - p0, axis=1)
    collinear = norm < 1e-6 * np.maximum(scale, 1e-300)
    normal = normal / np.where(norm > 0, norm, 1.0)[:, None]
    dist = np.abs(np.einsum("dj,nj->dn", normal, points) - np.einsum("dj,dj->d", normal, p0)[:, None])
    dist[collinear] = np.nan
    return dist


def plane_basis(normal: np.ndarray) -> np.ndarray:
    """(2, 3) orthonormal in-plane directions e1, e2 with e1 x e2 = normal."""
    helper = np.eye(3)[np.argmin(np.abs(normal))]
    e1 = np.cross(normal, helper)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(normal, e1)])


@dataclass(frozen=True)
class Circle:
    centre: np.ndarray  # (2,) in-plane
    radius: float
    residuals: np.ndarray  # (N,) signed distance to the circle
    centre_sigma: float  # 1-sigma of the centre (largest direction), mm
    iterations: int


def _kasa(xy: np.ndarray) -> tuple[np.ndarray, float]:
    a = np.c_[2 * xy, np.ones(len(xy))]
    sol, *_ = np.linalg.lstsq(a, np.einsum("ni,ni->n", xy, xy), rcond=None)
    return sol[:2], float(np.sqrt(max(sol[2] + sol[:2] @ sol[:2], 0.0)))


def _circle_cov(xy: np.ndarray, centre: np.ndarray, radius: float) -> tuple[np.ndarray, float]:
    diff = xy - centre
    dist = np.linalg.norm(diff, axis=1)
    res = dist - radius
    jac = np.c_[-diff / dist[:, None], -np.ones(len(xy))]
    sigma2 = float(res @ res) / max(len(xy) - 3, 1)
    try:
        cov = sigma2 * np.linalg.inv(jac.T @ jac)
        sig = float(np.sqrt(max(np.linalg.eigvalsh(cov[:2, :2]).max(), 0.0)))
    except np.linalg.LinAlgError:
        sig = np.inf
    return res, sig


def fit_circle(xy: np.ndarray, iterations: int = 50) -> Circle:
    """Geometric least-squares circle (Gauss-Newton from the algebraic fit)."""
    centre, radius = _kasa(xy)
    it = 0
    for it in range(1, iterations + 1):
        diff = xy - centre
        dist = np.linalg.norm(diff, axis=1)
        jac = np.c_[-diff / dist[:, None], -np.ones(len(xy))]
        step, *_ = np.linalg.lstsq(jac, -(dist - radius), rcond=None)
        centre, radius = centre + step[:2], radius + step[2]
        if np.abs(step).max() < 1e-13:
            break
    res, sig = _circle_cov(xy, centre, radius)
    return Circle(centre, float(radius), res, sig, it)


def fit_circle_iterative(xy: np.ndarray, tol: float = 1e-10, iterations: int = 20000) -> Circle:
    """Seed 004's iterative least-squares circle: with the current centre as the origin,
    the points' distances give the radius (their mean) and the centre's correction
    (mean of p - R p/|p|, Landau's fixed-point iteration of the geometric fit), until the
    correction is below ``tol`` mm. Converges to the geometric least-squares circle."""
    centre, _ = _kasa(xy)
    radius = 0.0
    it = 0
    for it in range(1, iterations + 1):
        local = xy - centre  # the current centre is the new origin
        dist = np.linalg.norm(local, axis=1)
        radius = float(dist.mean())
        step = (local - radius * local / dist[:, None]).mean(axis=0)
        centre = centre + step
        if np.linalg.norm(step) < tol:
            break
    res, sig = _circle_cov(xy, centre, radius)
    return Circle(centre, radius, res, sig, it)
