"""Engagement from a stock mesh (Z-map approximation of stock minus swept tool)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.process.engagement import block_stock, from_stock, load_stock, program_engagement, stock_heights
from postproc.process.forces import CutParams, cutter_forces, engagement_from_width

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def block():
    return block_stock((1000.0, 100.0, 100.0))


def _pass(y, z=97.0, xs=np.arange(-20, 121, 10.0)):
    pos = np.column_stack([xs, np.full(len(xs), y), np.full(len(xs), z)])
    cutting = np.ones(len(xs), bool)
    cutting[0] = False
    return pos, cutting


def test_heights_of_a_block(block):
    h = stock_heights(block, np.array([-1.0, 0.5, 500.0, 999.5, 1001.0]), np.array([-1.0, 50.0, 101.0]))
    assert np.all(np.isinf(h[[0, 4]])) and np.all(np.isinf(h[:, [0, 2]]))
    np.testing.assert_allclose(h[1:4, 1], 100.0)
    wedge = block_stock((10.0, 10.0, 10.0))
    wedge.vertices[wedge.vertices[:, 0] > 5, 2] *= 0.5  # the top slopes from 10 mm (x 0) to 5 mm (x 10)
    assert stock_heights(wedge, np.array([9.0]), np.array([5.0]))[0, 0] == pytest.approx(5.5)


@pytest.mark.parametrize("y,width,mode", [(50.0, 20.0, "down"), (5.0, 15.0, "up"), (95.0, 15.0, "down"), (-3.0, 7.0, "up")])
def test_immersion_and_depth_of_a_straight_pass(block, y, width, mode):
    """A pass along +x at height 97 mm: 3 mm deep; the radial width is the part of the
    cutter over the block (y 0..100); stock on the left of the feed (+y) is entered at 0 deg."""
    pos, cutting = _pass(y)
    eng = from_stock(pos, cutting, 20.0, block)
    st, ex = engagement_from_width(20.0, width, mode)
    steady = eng[3:-1]
    np.testing.assert_allclose(steady[:, 0], st, atol=3.5)
    np.testing.assert_allclose(steady[:, 1], ex, atol=3.5)
    np.testing.assert_allclose(steady[:, 3], 3.0, atol=1e-9)
    assert np.all(eng[0] == 0)  # the start point does not cut


def test_removed_material_is_not_cut_twice_and_air_is_not_cut(block):
    pos, cutting = _pass(50.0)
    both = np.vstack([pos, pos[::-1]])
    eng = from_stock(both, np.r_[cutting, np.ones(len(pos), bool)], 20.0, block)
    assert np.all(eng[len(pos):] == 0)
    above, cutting = _pass(50.0, z=100.5)
    assert np.all(from_stock(above, cutting, 20.0, block) == 0)
    # zero engagement -> zero force through the model
    params = CutParams(diameter=20.0, teeth=3, feed_per_tooth=0.1, axial_depth=3.0, radial_width=10.0)
    assert np.all(cutter_forces(params, from_stock(above, cutting, 20.0, block))[0] == 0)


def test_deeper_pass_cuts_deeper_and_forces_follow(block):
    params = CutParams(diameter=20.0, teeth=3, feed_per_tooth=0.1, axial_depth=3.0, radial_width=10.0)
    shallow = from_stock(*_pass(50.0, z=98.0), 20.0, block)[5]
    deep = from_stock(*_pass(50.0, z=96.0), 20.0, block)[5]
    assert deep[3] == pytest.approx(4.0) and shallow[3] == pytest.approx(2.0)
    f = cutter_forces(params, np.array([shallow, deep]))[0]
    assert np.linalg.norm(f[1]) == pytest.approx(2 * np.linalg.norm(f[0]), rel=0.03)


def test_program_engagement_and_refusals(block, tmp_path):
    from postproc.programs import parse_program

    tp = parse_program(REPO / "examples" / "data" / "block_face.src")
    eng = program_engagement(tp, 20.0, block)
    assert np.all(eng[:, 3] == 0)  # the face pass runs on the top face (z 100): no material above the tip
    low = tmp_path / "low.src"
    low.write_text((REPO / "examples" / "data" / "block_face.src").read_text().replace("Z 100,", "Z 98,"))
    eng = program_engagement(parse_program(low), 20.0, block)
    assert np.allclose(eng[3:-2, 3], 2.0) and np.allclose(eng[3:-2, :2], [0.0, 180.0], atol=3.5)
    tilted = tmp_path / "tilted.src"
    tilted.write_text(low.read_text().replace("B 180, C 0}", "B 170, C 0}"))
    with pytest.raises(InputError, match="3-axis"):
        program_engagement(parse_program(tilted), 20.0, block)
    bad = tmp_path / "bad.stl"
    bad.write_text("not a mesh")
    with pytest.raises(InputError, match="bad.stl"):
        load_stock(bad)
    stl = tmp_path / "block.stl"
    block.export(stl)
    assert math.isclose(load_stock(stl).volume, 1e7, rel_tol=1e-9)
