"""Heidenhain M140 (retraction along the tool axis) as the TNC runs it, and words the reader refuses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.programs import parse_program


def read(text):
    return parse_program(Path("r.h"), data=text.encode("latin-1"))


def test_m140_retract():
    """TNC 640 manual, "M140: Retraction from the contour in the tool-axis direction": MB d moves
    the tool d mm back along the tool axis (Z + d); MB MAX to the end of the traverse range,
    which the text does not give: flagged, and Z stays unknown until the program gives it."""
    tp = read("BEGIN PGM R MM\nTOOL CALL 1 Z S1000\nL X+1 Y+2 Z+3 R0 FMAX\nL M140 MB 50\nL M140 MB MAX\nL X+5 Y+6 R0 FMAX\n"
              "L Z+15 FMAX\nEND PGM R MM\n")
    np.testing.assert_allclose(tp.position[:2], [[1, 2, 3], [1, 2, 53]])
    assert tp.resolved.tolist() == [True, True, False, False, True]
    assert np.isnan(tp.position[2:4, 2]).all() and tp.position[4, 2] == 15


def test_a_decimal_comma_is_refused_with_its_column():
    with pytest.raises(ParseError, match=r"r\.h:3:7: ',000': a decimal comma"):
        read("BEGIN PGM R MM\nTOOL CALL 1 Z S1000\nL X+32,000 Y+0 R0 FMAX\nEND PGM R MM\n")
