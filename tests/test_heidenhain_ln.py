"""Heidenhain LN (three-dimensional tool compensation): TNC 640 User's Manual, "Three-dimensional
tool compensation": X Y Z of LN are the compensated coordinates of the end point; the TNC
displaces the tool along the surface normal N by the sum of the delta values (tool table and
TOOL CALL); without M128 the tool orientation T is ignored; with M128 / TCPM the TNC turns the
rotary axes to T (or keeps the tool normal to the surface)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.programs import parse_program

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
    ("TOOL DEF 1 L+50 R+3\nTOOL CALL 1 Z S1000 DR+0.1", "", "delta values"),
    ("TOOL DEF 1 L+50 R+3\nTOOL CALL 1 Z S1000", "M128\n", "LN under M128"),
])
def test_ln_the_text_does_not_determine_is_flagged(tool, mode, why):
    tp = read(tool, mode)
    assert not tp.resolved[1]
    assert any(why in n for n in tp.notes), tp.notes
