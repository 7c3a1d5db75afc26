"""The IR's motion against LinuxCNC's own interpreter (rs274, Debian package linuxcnc-uspace).

Runs where rs274 is installed (the session that built the parsers installed it and ran
this test; see the closing note). Canonical STRAIGHT_TRAVERSE / STRAIGHT_FEED / ARC_FEED
end points are compared, in order, with the IR's targets of the LinuxCNC programs of the
corpus. rs274 reports program coordinates in the current length unit and takes an unknown
start position as 0; the IR flags an unknown coordinate instead (NaN), and those are left
out of the comparison.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from postproc.programs import parse_program

CORPUS = Path(__file__).parent / "corpus" / "gcode"
LINUXCNC_PROGRAMS = ["arcs_ijk.ngc", "compact_blocks.nc", "inch_program.nc", "incremental.tap", "block_delete.ngc", "work_offsets.ngc", "params_and_straight.ngc"]
CANON = re.compile(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED|ARC_FEED|USE_LENGTH_UNITS|SELECT_PLANE)\(([^)]*)\)")

pytestmark = pytest.mark.skipif(shutil.which("rs274") is None, reason="LinuxCNC's rs274 is not installed (apt-get install linuxcnc-uspace)")


def canonical_endpoints(path: Path) -> np.ndarray:
    out = subprocess.run(["rs274", "-g", str(path)], capture_output=True, timeout=60).stdout.decode("latin-1")  # comments are echoed as written
    scale, plane, points = 1.0, "XY", []
    for name, args in CANON.findall(out):
        if name == "USE_LENGTH_UNITS":
            scale = 25.4 if "INCHES" in args else 1.0
            continue
        if name == "SELECT_PLANE":
            plane = args.split("_")[-1]
            continue
        v = [float(a) for a in args.split(",")]
        if name == "ARC_FEED":
            first, second, axis_end = v[0], v[1], v[5]
            xyz = {"XY": (first, second, axis_end), "YZ": (axis_end, first, second), "XZ": (second, axis_end, first)}[plane]
        else:
            xyz = v[:3]
        points.append(np.array(xyz) * scale)
    return np.array(points)


@pytest.mark.parametrize("name", LINUXCNC_PROGRAMS)
def test_ir_motion_matches_linuxcnc(name):
    path = CORPUS / name
    tp = parse_program(path)
    canon = canonical_endpoints(path)
    machine = np.array([tp.frame_names[f] == "machine" for f in tp.frame])  # G53 moves: rs274 reports them differently
    ir = tp.position[~machine]
    assert len(canon) == len(tp), f"{name}: LinuxCNC made {len(canon)} moves, the IR has {len(tp)} targets"
    canon = canon[~machine]
    known = ~np.isnan(ir)
    np.testing.assert_allclose(ir[known], canon[known], atol=1e-4)
