"""compensate on SINUMERIK programs with A3= B3= C3= tool-axis vectors (TRAORI, ORIWKS).

The vectors are the tool axis in the workpiece frame; the 840D turns each into the rotary
solution with the shorter travel (Function Manual Special Functions, F2 "Multi-axis
transformations", "Orientation programming"). Compensation writes the tip and vector whose
nominal TRAORI solution is the true machine's axes for the intended tip and axis: run by the
true machine, the written numbers reach the intended tips.
"""

from __future__ import annotations

import re

import numpy as np
from test_sinumerik import AT_ZERO, TRUE, _read, _skeleton, impeller_in_sinumerik
from typer.testing import CliRunner

from postproc.cli import app
from postproc.fivex.kinematics import fk, ik
from postproc.fivex.machine import load_machine
from postproc.jobs.five_axis.compensate import actual_tip
from postproc.jobs.five_axis.program import from_toolpath


def test_compensated_vectors_land_on_the_true_machine(tmp_path):
    nominal, true = load_machine("xyzac-trt"), load_machine(TRUE)
    angles, _ = _read(tmp_path, impeller_in_sinumerik(), "ANGLES.MPF")
    rows = iter(from_toolpath(angles.with_frames({"G54": np.eye(4)}), nominal).axis)
    text = re.sub(r" A(\S+) C(\S+)", lambda m: " A3={:.7f} B3={:.7f} C3={:.7f}".format(*next(rows)), impeller_in_sinumerik())
    src, out = tmp_path / "VECTORS.MPF", tmp_path / "VECTORS_COMP.MPF"
    src.write_text(text, encoding="latin-1")
    result = CliRunner().invoke(app, ["compensate", str(src), "--model", str(TRUE), "--input-axes", "tip", "-o", str(out), *AT_ZERO])
    assert result.exit_code == 0, result.output
    after_text = out.read_text(encoding="latin-1")
    assert _skeleton(after_text) == _skeleton(text) and after_text != text
    assert after_text.splitlines()[:5] == text.splitlines()[:5]  # frame block and R parameters untouched

    def reached(name: str, program: str):
        tp, _ = _read(tmp_path, program, name)
        path = from_toolpath(tp.with_frames({"G54": np.eye(4)}), nominal)  # tips and axes in the machine frame (TRANS applied)
        cmd = ik(nominal, path.tip, path.axis).axes  # the 840D's nominal TRAORI, nearest solution
        return path.tip, path.axis, actual_tip(true, None, cmd), fk(true, cmd)[1]

    intended, intended_axis, before, before_axis = reached("B.MPF", text)
    *_, after, after_axis = reached("A.MPF", after_text)
    err_before, err_after = (np.linalg.norm(p - intended, axis=1) for p in (before, after))
    assert err_before.max() > 0.1 and err_after.max() < 0.002  # 3 decimals of X Y Z, 7 of the vectors
    # the tool axis on the part: the true rotary lines tilt it by ~4e-4 rad; the rewritten vectors put it back
    tilt_before, tilt_after = (np.arccos(np.clip(np.einsum("ni,ni->n", a, intended_axis), -1, 1)) for a in (before_axis, after_axis))
    assert tilt_before.max() > 2e-4 and tilt_after.max() < 1e-6, (tilt_before.max(), tilt_after.max())


def test_a_first_vector_with_two_solutions_in_the_limits_is_refused(tmp_path):
    """A first vector tilted 30 deg: A = -30 or A = +30 (C turned 180) are both inside
    xyzac-trt's A limits (-100..50); the 840D takes the one nearest where the axes stand,
    which the program does not say: refused with its line, not guessed."""
    text = re.sub(r" A(\S+) C(\S+)", " A3=0 B3=-0.5 C3=0.8660254", impeller_in_sinumerik())
    src = tmp_path / "TILT.MPF"
    src.write_text(text, encoding="latin-1")
    result = CliRunner().invoke(app, ["compensate", str(src), "--model", str(TRUE), "--input-axes", "tip", "-o", str(tmp_path / "OUT.MPF"), *AT_ZERO])
    assert result.exit_code == 2 and "two rotary solutions" in result.output and "TILT.MPF:" in result.output, result.output
    assert not (tmp_path / "OUT.MPF").exists()
