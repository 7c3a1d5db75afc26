"""Heidenhain LN (three-dimensional tool compensation): TNC 640 User's Manual, "Three-dimensional
tool compensation": X Y Z of LN are the compensated coordinates of the end point; the TNC
displaces the tool along the surface normal N by the sum of the delta values (tool table and
TOOL CALL); without M128 the tool orientation T is ignored; with M128 / TCPM the TNC turns the
rotary axes to T (or keeps the tool normal to the surface).

Machine values: xyzac-trt turns the table by Rx(A) Rz(C) (machines/xyzac-trt.toml), so a
tool axis u is reached where Rx(A) Rz(C) u = z."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.fivex.machine import load_machine
from postproc.programs import dialects, parse_program

LN = "LN X+31.737 Y+21.954 Z+33.165 NX+0.2637581 NY+0.0078922 NZ-0.8764339 TX+0.0078922 TY-0.8764339 TZ+0.2590319 F1000"


def read(tool: str, mode: str = ""):
    text = f"BEGIN PGM N MM\n{tool}\nL X+0 Y+0 Z+50 R0 FMAX\n{mode}{LN}\nEND PGM N MM\n"
    return parse_program(Path("n.h"), data=text.encode("latin-1"))


def test_ln_without_delta_values_goes_to_x_y_z():
    """A TOOL DEF tool (no table row) called without DL / DR / DR2: the sum of the delta values
    is 0, so the tool goes to X Y Z as written; without M128, T changes nothing."""
    tp = read("TOOL DEF 1 L+50 R+3\nTOOL CALL 1 Z S1000")
    assert tp.resolved.all()
    np.testing.assert_allclose(tp.position[1], [31.737, 21.954, 33.165])


@pytest.mark.parametrize("tool, mode, why", [
    ("TOOL CALL 1 Z S1000", "", "delta values"),  # a tool from the tool table: its deltas are not in the text
    ("TOOL DEF 1 L+50 R+3\nTOOL CALL 1 Z S1000", "M128\n", "LN under M128"),
])
def test_ln_the_text_does_not_determine_is_flagged(tool, mode, why):
    tp = read(tool, mode)
    assert not tp.resolved[1]
    assert any(why in n for n in tp.notes), tp.notes


XYZ = np.array([31.737, 21.954, 33.165])
N = np.array([0.2637581, 0.0078922, -0.8764339])


def test_ln_moves_the_tip_along_n_by_the_sum_of_the_delta_values():
    """TOOL DEF tool (no table row): the deltas are TOOL CALL's, DL+0.05 DR+0.1 DR2-0.02: the tip is
    X Y Z + 0.13 N/|N|. The text keeps X Y Z: a tip moved by d is written as X Y Z + d."""
    tp = read("TOOL DEF 1 L+50 R+3\nTOOL CALL 1 Z S1000 DL+0.05 DR+0.1 DR2-0.02")
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[1], XYZ + 0.13 * N / np.linalg.norm(N), atol=1e-12)
    moved = dialects.of(tp).contour_for(tp, tp.position + [0.01, 0, 0])
    np.testing.assert_allclose(moved.values[1, :3], XYZ + [0.01, 0, 0], atol=1e-12)
    np.testing.assert_allclose(moved.position[1], tp.position[1] + [0.01, 0, 0], atol=1e-12)


S3 = np.sqrt(3.0)
M128_PROGRAM = ("BEGIN PGM N MM\nTOOL DEF 1 L+50 R+3\nTOOL CALL 1 Z S1000\nL X+0 Y+0 Z+50 {before} R0 FMAX\nM128\n"
                "LN X+1 Y+2 Z+3 NX+0 NY+0 NZ+1 TX+0 TY-0.5 TZ+0.8660254 F1000\nL X+5 Y+0 Z+10\n"
                "LN X+2 Y+2 Z+3 NX+0 NY+0 NZ+1 TX+0.5 TY+0 TZ+0.8660254\nEND PGM N MM\n")


def m128(before="A+0 C+0"):
    tp = parse_program(Path("n.h"), data=M128_PROGRAM.format(before=before).encode("latin-1")).with_frames({"PRESET": np.eye(4)}, None)
    return tp, dialects.of(tp).for_machine(tp, load_machine("xyzac-trt"))


def test_ln_under_m128_turns_to_t_the_shorter_way():
    """T = (0, -1/2, sqrt3/2) = Rx(30) z: A-30 C0 or A+30 C180; from A0 C0 the shorter way is A-30 C0.
    The L block after keeps them. T = (1/2, 0, sqrt3/2): Rz(C) T = (0, -/+1/2, sqrt3/2) at C-90 / C+90,
    then A-30 / A+30; from A-30 C0: A-30 C-90 (90 deg of travel against 150)."""
    read_only, tp = m128()
    assert not read_only.resolved[1:].any()  # without a machine: flagged
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.ext[1:, [0, 2]], [(-30, 0), (-30, 0), (-30, -90)], atol=1e-6)
    np.testing.assert_allclose(tp.position[1:], [[1, 2, 3], [5, 0, 10], [2, 2, 3]], atol=1e-12)


def test_ln_under_m128_without_the_axes_before_stays_flagged():
    _, tp = m128(before="")
    assert not tp.resolved[1:].any() and any("nearest where the axes are" in n for n in tp.notes), tp.notes


def test_ln_under_m128_is_not_compensated():
    _, tp = m128()
    with pytest.raises(InputError, match=r"n\.h:6: LN under M128 is not compensated"):
        dialects.of(tp).refuse_compensation(tp)
