"""Interpolation between targets as controllers do it, and path distances (postproc.compensation.segments)."""

from __future__ import annotations

import numpy as np

from postproc.compensation.segments import arc_samples, circle_through, distance_to_circles, distance_to_segments, linear_samples


def _pose(p):
    t = np.eye(4)
    t[:3, 3] = p
    return t


def test_circle_through_three_points():
    rng = np.random.default_rng(0)
    centre = rng.normal(size=(20, 3)) * 100
    radius = rng.uniform(5, 50, 20)
    u = rng.normal(size=(20, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    v = np.cross(u, rng.normal(size=(20, 3)))
    v /= np.linalg.norm(v, axis=1)[:, None]
    pts = [centre + radius[:, None] * (np.cos(a) * u + np.sin(a) * v) for a in (0.1, 1.0, 2.5)]
    c, n, r = circle_through(*pts)
    np.testing.assert_allclose(c, centre, atol=1e-8)
    np.testing.assert_allclose(r, radius, atol=1e-8)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", n, np.cross(u, v))), 1.0, atol=1e-9)


def test_arc_samples_pass_through_the_via_side_and_stay_on_the_circle():
    start, via, end = _pose([10.0, 0, 0]), _pose([0, 10.0, 0]), _pose([-10.0, 0, 0])
    poses = arc_samples(start[None], via[None], end[None], samples=9)
    pts = poses[0, :, :3, 3]
    np.testing.assert_allclose(np.linalg.norm(pts, axis=1), 10.0, atol=1e-9)
    assert (pts[:, 1] > 0).all()  # the half through the via point, not the other one
    np.testing.assert_allclose(pts[4], [0, 10.0, 0], atol=1e-9)  # the middle sample is the via point here
    assert distance_to_circles(pts[None], start[None, :3, 3], via[None, :3, 3], end[None, :3, 3]).max() < 1e-9


def test_arc_longer_than_a_half_turn():
    a = [np.cos(t) for t in (0.0, 2.0, 4.0)]
    b = [np.sin(t) for t in (0.0, 2.0, 4.0)]
    start, via, end = (_pose([a[i], b[i], 0.0]) for i in range(3))
    pts = arc_samples(start[None], via[None], end[None], samples=3)[0, :, :3, 3]
    angles = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2 * np.pi)
    np.testing.assert_allclose(angles, [1.0, 2.0, 3.0], atol=1e-9)


def test_linear_samples_and_distance():
    start, end = _pose([0, 0, 0]), _pose([100.0, 0, 0])
    pts = linear_samples(start[None], end[None], samples=4)[0, :, :3, 3]
    np.testing.assert_allclose(pts[:, 0], [20, 40, 60, 80], atol=1e-9)
    off = pts + np.array([0, 0.03, 0.04])
    np.testing.assert_allclose(distance_to_segments(off[None], start[None, :3, 3], end[None, :3, 3]), 0.05, atol=1e-12)
