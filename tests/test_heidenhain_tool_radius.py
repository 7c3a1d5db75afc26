"""--tool-radius: the tool table's radius (R + DR of the table) of a tool the Klartext program
calls but does not define, so that RL / RR targets are followed (TNC 640 User's Manual, 5.3
"Tool compensation": compensation value R + DR TAB + DR TOOL CALL). The expected path is
test_heidenhain_radius_comp's square (R 2, worked there by hand): here the table gives 1.5
and TOOL CALL's DR+0.5 adds to it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import InputError
from postproc.programs import parse_program
from postproc.programs.dialects.heidenhain.tool_table import parse_tool_radii, with_tool_radii

S2 = np.sqrt(2.0)
SQUARE = ("BEGIN PGM RC MM\nTOOL CALL 5 Z S1000 DR+0.5\nL X-10 Y-10 Z+5 R0 FMAX\nL X+0 Y+0 RL F100\nL X+20\nL Y+20\nL X+0\nL Y+0\n"
          "L X-10 Y-10 R0\nEND PGM RC MM\n")
WANT = [[-10, -10], [-S2, S2], [0, 2], [18, 2], [18, 18], [2, 18], [2, 0], [-10, -10]]


def read(text=SQUARE):
    return parse_program(Path("rc.h"), data=text.encode("latin-1"))


def test_table_radius_places_the_compensated_targets():
    tp = read()
    assert not tp.resolved[1:-1].any()  # the tool table's radius is not in the text
    tp = with_tool_radii(tp, {"T5": 1.5})
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[:, :2], WANT, atol=1e-9)


@pytest.mark.parametrize("radii, why", [
    ({"T6": 2.0}, "never calls that tool"),
    ({"T5": 2.0, "T1": 1.0}, "never calls that tool"),
])
def test_a_radius_the_program_does_not_use_is_refused(radii, why):
    with pytest.raises(InputError, match=why):
        with_tool_radii(read(), radii)


def test_a_tool_the_program_defines_is_refused():
    with pytest.raises(InputError, match="defines that tool's radius itself"):
        with_tool_radii(read(SQUARE.replace("TOOL CALL 5", "TOOL DEF 5 L+50 R+1\nTOOL CALL 5")), {"T5": 1.5})


@pytest.mark.parametrize("item", ["T5", "T5=", "=2", "T5=-1", "T5=x"])
def test_option_syntax(item):
    with pytest.raises(InputError, match="--tool-radius: expected TOOL=RADIUS"):
        parse_tool_radii([item])


def test_inspect_with_tool_radius(tmp_path):
    source = tmp_path / "rc.h"
    source.write_text(SQUARE, encoding="latin-1")
    runner = CliRunner()
    res = runner.invoke(app, ["inspect", str(source), "--json", "--tool-radius", "T5=1.5"])
    assert res.exit_code == 0, res.output
    moves = json.loads(res.output)["moves"]
    np.testing.assert_allclose([m["xyz"][:2] for m in moves], WANT, atol=1e-6)
    assert [m.get("cutter_comp") for m in moves][1:3] == ["offset", "corner"]
    res = runner.invoke(app, ["inspect", str(source), "--tool-radius", "T7=1.5"])
    assert res.exit_code == 2 and "never calls that tool" in res.output, res.output



def test_compensate_with_tool_radius_refuses_an_outside_corner_with_its_line(tmp_path):
    """The option reaches compensate: the square's entry turns round an outside corner (line 5),
    a transitional arc the five-axis compensation does not write: refused with file:line and why."""
    source = tmp_path / "rc.h"
    source.write_text(SQUARE.replace("Z+5 R0 FMAX", "Z+5 A+0 C+0 R0 FMAX"), encoding="latin-1")
    true = Path(__file__).parent / "data" / "fivex" / "xyzac-trt-true.toml"
    res = CliRunner().invoke(app, ["compensate", str(source), "--model", str(true), "-o", str(tmp_path / "c.h"), "--input-axes", "tip",
                                   "--frame", "PRESET=0,0,0,0,0,0", "--tool-radius", "T5=1.5"])
    assert res.exit_code == 2 and "rc.h:5: an outside corner under RL / RR" in res.output, res.output
    assert not (tmp_path / "c.h").exists()
