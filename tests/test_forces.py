"""Mechanistic milling force model (seed 002 eq. 14-17): closed forms, limits, units, files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.process.forces import (
    CutFileError,
    CutParams,
    cutter_forces,
    cutter_frames,
    engagement_from_width,
    forces_along,
    load_cut_params,
    program_forces,
    surface_normal_cutter,
)

REPO = Path(__file__).resolve().parents[1]


def altintas_mean(p: CutParams, phi_st, phi_ex, depth):
    """Closed-form mean forces of a cylindrical end mill (Altintas, Manufacturing Automation,
    2nd ed., eq. 2.32; x feed, y normal to it; z here along the cutter axis towards the spindle)."""
    n, c = p.teeth, p.feed_per_tooth

    def fx(f):
        return n * depth * c / (8 * math.pi) * (p.ktc * math.cos(2 * f) - p.krc * (2 * f - math.sin(2 * f))) + n * depth / (2 * math.pi) * (-p.kte * math.sin(f) + p.kre * math.cos(f))

    def fy(f):
        return n * depth * c / (8 * math.pi) * (p.ktc * (2 * f - math.sin(2 * f)) + p.krc * math.cos(2 * f)) - n * depth / (2 * math.pi) * (p.kte * math.cos(f) + p.kre * math.sin(f))

    def fz(f):
        return n * depth / (2 * math.pi) * (-p.kac * c * math.cos(f) + p.kae * f)

    a, b = math.radians(phi_st), math.radians(phi_ex)
    return np.array([fx(b) - fx(a), fy(b) - fy(a), -(fz(b) - fz(a))])


@pytest.mark.parametrize("helix", [0.0, 30.0])
@pytest.mark.parametrize("width,mode", [(10.0, "down"), (5.0, "up"), (20.0, "down")])
def test_mean_force_matches_closed_form(helix, width, mode):
    p = CutParams(diameter=20.0, teeth=3, feed_per_tooth=0.1, axial_depth=5.0, radial_width=width, helix=helix, mode=mode)
    mean, peak, size = cutter_forces(p, angles=720, elements=200)
    st, ex = engagement_from_width(20.0, width, mode)
    expected = altintas_mean(p, float(st), float(ex), 5.0)
    np.testing.assert_allclose(mean[0], expected, rtol=0.01, atol=0.5)
    assert size[0] >= np.linalg.norm(mean[0])  # the peak resultant is at least the mean's


def test_zero_engagement_gives_zero_force():
    p = CutParams(diameter=16.0, teeth=4, feed_per_tooth=0.08, axial_depth=0.0, radial_width=8.0)
    mean, peak, size = cutter_forces(p)
    assert np.all(mean == 0) and np.all(peak == 0) and size[0] == 0
    q = CutParams(diameter=16.0, teeth=4, feed_per_tooth=0.08, axial_depth=4.0, radial_width=0.0)
    assert np.all(cutter_forces(q)[0] == 0)
    # per point: one engaged, one with an empty axial range, one with an empty immersion range
    eng = np.array([[90.0, 180.0, 0.0, 4.0], [90.0, 180.0, 2.0, 2.0], [120.0, 60.0, 0.0, 4.0]])
    mean, _, _ = cutter_forces(q, eng)
    assert np.linalg.norm(mean[0]) > 10 and np.all(mean[1:] == 0)


def test_force_linear_in_feed_per_tooth():
    shear_only = CutParams(diameter=20.0, teeth=3, feed_per_tooth=0.1, axial_depth=3.0, radial_width=12.0,
                           corner_radius=2.0, kte=0.0, kre=0.0, kae=0.0)
    feeds = np.array([0.05, 0.1, 0.2])
    eng = np.repeat(np.array([shear_only.engagement()]), 3, axis=0)
    mean, _, _ = cutter_forces(shear_only, eng, feeds)
    np.testing.assert_allclose(mean[1], 2 * mean[0], rtol=1e-12)
    np.testing.assert_allclose(mean[2], 4 * mean[0], rtol=1e-12)
    # with edge forces the model is affine in f: equal steps give equal increments
    full = CutParams(diameter=20.0, teeth=3, feed_per_tooth=0.1, axial_depth=3.0, radial_width=12.0, corner_radius=2.0)
    mean, _, _ = cutter_forces(full, eng, np.array([0.05, 0.1, 0.15]))
    np.testing.assert_allclose(mean[2] - mean[1], mean[1] - mean[0], rtol=1e-9, atol=1e-9)
    assert not np.allclose(mean[1], 2 * mean[0])  # the edge term is there


def test_units_scale_as_the_model_says():
    p = CutParams(diameter=20.0, teeth=2, feed_per_tooth=0.1, axial_depth=2.0, radial_width=20.0, helix=0.0, kte=0, kre=0, kae=0)
    base = cutter_forces(p)[0][0]
    # twice the depth of a flank cut, twice the force; twice every Kc, twice the force
    deeper = cutter_forces(CutParams(**{**p.__dict__, "axial_depth": 4.0}))[0][0]
    np.testing.assert_allclose(deeper, 2 * base, rtol=1e-9)
    stiffer = cutter_forces(CutParams(**{**p.__dict__, "ktc": 2 * p.ktc, "krc": 2 * p.krc, "kac": 2 * p.kac}))[0][0]
    np.testing.assert_allclose(stiffer, 2 * base, rtol=1e-9)
    # slotting with straight flutes: the mean force across the feed is Ktc a f N / 4 ... in N
    slot = altintas_mean(p, 0.0, 180.0, 2.0)
    np.testing.assert_allclose(base, slot, rtol=0.01, atol=0.2)
    assert 50.0 < np.linalg.norm(base) < 200.0  # ~ 631 N/mm^2 x 2 mm x 0.1 mm x 2 teeth / 2


def test_corner_radius_changes_axial_immersion():
    flat = CutParams(diameter=20.0, teeth=3, feed_per_tooth=0.1, axial_depth=1.0, radial_width=12.0, corner_radius=0.0)
    round_ = CutParams(diameter=20.0, teeth=3, feed_per_tooth=0.1, axial_depth=1.0, radial_width=12.0, corner_radius=4.0)
    f_flat, f_round = cutter_forces(flat)[0][0], cutter_forces(round_)[0][0]
    # on the flank the helix's axial force pulls the cutter into the work (-z); on a corner
    # the radial force turns towards the axis and pushes the cutter back out (+z)
    assert f_flat[2] < 0 < f_round[2]


def test_frames_and_normal():
    rot = np.repeat(np.diag([1.0, -1.0, -1.0])[None], 2, axis=0)  # TCP z pointing down
    frames = cutter_frames(rot, np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 5.0]]))
    np.testing.assert_allclose(frames[0], np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]]).astype(float), atol=1e-12)
    np.testing.assert_allclose(frames[1][:, 2], [0, 0, 1])  # plunge: x falls back to the TCP's
    np.testing.assert_allclose(surface_normal_cutter(0, 0), [0, 0, 1])
    n = surface_normal_cutter(10.0, 0.0)
    assert n[0] < 0 and math.isclose(np.linalg.norm(n), 1.0)
    poses = np.repeat(np.eye(4)[None], 2, axis=0)
    poses[:, :3, :3] = rot
    force, normal = forces_along(poses, np.array([True, False]), force_tool=(10.0, 20.0, 30.0))
    np.testing.assert_allclose(force[0], [10, -20, -30])
    np.testing.assert_allclose(force[1], 0)
    np.testing.assert_allclose(normal[0], [0, 0, 1])
    with pytest.raises(InputError):
        forces_along(poses, np.array([True, True]))


def test_program_forces_hook():
    from postproc.programs import parse_program

    tp = parse_program(REPO / "examples" / "data" / "block_face.src")
    params = load_cut_params(REPO / "examples" / "cut_aluminium.toml")
    force = program_forces(tp, params=params)
    assert force.shape == (len(tp), 3)
    assert np.all(force[0] == 0)  # the PTP approach does not cut
    cutting = np.linalg.norm(force[2:-1], axis=1)
    np.testing.assert_allclose(cutting, cutting[0], rtol=1e-9)  # one cut all along
    mean_cutter = cutter_forces(params)[0][0]
    np.testing.assert_allclose(cutting[0], np.linalg.norm(mean_cutter), rtol=1e-9)
    # the base frame turns with the block: $BASE A 90 puts the feed (block x) along base y
    assert abs(force[3, 1]) > 0 and math.isclose(np.linalg.norm(force[3]), np.linalg.norm(mean_cutter))


def test_cut_file_is_validated(tmp_path):
    good = (REPO / "examples" / "cut_aluminium.toml").read_text()
    p = load_cut_params(REPO / "examples" / "cut_aluminium.toml")
    assert p.diameter == 20.0 and p.teeth == 3 and "Zhao" in p.source
    cases = {
        'length = "m"': ("units.length", good.replace('length = "mm"', 'length = "m"')),
        "missing diameter": ("tool.diameter", good.replace("diameter = 20.0       # mm\n", "")),
        "text": ("cut.feed_per_tooth", good.replace("feed_per_tooth = 0.1", 'feed_per_tooth = "fast"')),
        "range": ("cut.radial_width", good.replace("radial_width = 12.0", "radial_width = 40.0")),
        "unknown": ("tool.flutes", good.replace("teeth = 3", "teeth = 3\nflutes = 3")),
        "mode": ("cut.mode", good.replace('mode = "down"', 'mode = "sideways"')),
        "corner": ("tool.corner_radius", good.replace("corner_radius = 2.0", "corner_radius = 12.0")),
        "uncited": ("source", "\n".join(line for line in good.splitlines() if not line.startswith("source"))),
        "syntax": ("<syntax>", good + "\n[cut\n"),
    }
    for name, (key, text) in cases.items():
        f = tmp_path / f"{name.replace(' ', '_')}.toml"
        f.write_text(text)
        with pytest.raises(CutFileError) as info:
            load_cut_params(f)
        assert str(f) in str(info.value) and key in str(info.value), name
    # defaults: a file with only tool and cut takes the cited aluminium coefficients
    minimal = tmp_path / "minimal.toml"
    minimal.write_text('[units]\nlength = "mm"\nangle = "deg"\nforce = "N"\n[tool]\ndiameter = 10\nteeth = 2\n[cut]\nfeed_per_tooth = 0.05\naxial_depth = 1\nradial_width = 5\n')
    m = load_cut_params(minimal)
    assert m.ktc == 631.0 and "doi:10.1186" in m.source


def test_peak_force_hook():
    from postproc.programs import parse_program

    tp = parse_program(REPO / "examples" / "data" / "block_face.src")
    params = load_cut_params(REPO / "examples" / "cut_aluminium.toml")
    mean = program_forces(tp, params=params)
    peak = program_forces(tp, params=params, statistic="peak")
    assert np.all(np.linalg.norm(peak[2:-1], axis=1) > np.linalg.norm(mean[2:-1], axis=1))
    np.testing.assert_allclose(np.linalg.norm(peak[3]), cutter_forces(params)[2][0], rtol=1e-9)
    with pytest.raises(InputError):
        program_forces(tp, params=params, statistic="median")
