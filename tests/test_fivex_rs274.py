"""Emitted five-axis programs judged by LinuxCNC's own interpreter (rs274, linuxcnc-uspace).

Each case converts a program for a machine; rs274 reads the emitted program and its
canonical motion (STRAIGHT_TRAVERSE / STRAIGHT_FEED end points, 4 decimals) is turned back
into tool tips through the machine kinematics:
- LinuxCNC TCP mode: the canonical X Y Z A C (B C) are the tip in the workpiece frame;
  LinuxCNC's inverse kinematics (trtfuncs.c xyzac-trt, 5axiskins.c; re-derived below) give
  the joints, and the machine model's forward kinematics the tip;
- mode none: the canonical values are the machine axes; the (calibrated) machine's forward
  kinematics gives the tip.
The tips must equal the intended ones within 1e-3 mm. rs274's outputs are kept in
tests/data/rs274/ so that CI checks them without LinuxCNC; where rs274 is installed the
programs are run again and must give the recorded output.
Record again: .venv/bin/python tests/test_fivex_rs274.py --record
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from postproc.fivex.kinematics import fk
from postproc.fivex.machine import load_machine
from postproc.jobs.five_axis.emit import emit
from postproc.jobs.five_axis.program import from_toolpath
from postproc.programs import parse_program

HERE = Path(__file__).parent
RECORDED = HERE / "data" / "rs274"
CALIBRATED = HERE / "data" / "fivex" / "xyzac-trt-calibrated.toml"
CASES = {  # name: (program, machine, mode, input axes)
    "impeller_linuxcnc": ("corpus/fivex/impeller-7bl-xyzac-head.ngc", "xyzac-trt", "linuxcnc", "tip"),
    "impeller_none_calibrated": ("corpus/fivex/impeller-7bl-xyzac-head.ngc", str(CALIBRATED), "none", "tip"),
    "tilted_linuxcnc": ("corpus/fivex/tilted_pass.mod", "xyzac-trt", "linuxcnc", None),
    "tilted_none_calibrated": ("corpus/fivex/tilted_pass.mod", str(CALIBRATED), "none", None),
    "milling_wobj_linuxcnc": ("corpus/rapid/milling_wobj.mod", "xyzac-trt", "linuxcnc", None),
    "tilted_5axiskins_linuxcnc": ("corpus/fivex/tilted_pass.mod", "xyzbc-5axiskins", "linuxcnc", None),
}
CANON = re.compile(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED)\(([^)]*)\)")
has_rs274 = shutil.which("rs274") is not None


def build(name: str):
    program, machine_name, mode, input_axes = CASES[name]
    machine = load_machine(machine_name)
    tp = parse_program(HERE / program)
    if tp.frame_known is not None and "G54" in tp.frame_names and not tp.frame_known[tp.frame_names.index("G54")]:
        tp = tp.with_frames({"G54": np.eye(4)})  # the impeller never sets G54: zero, the frame it was written for (fivex/offsets.py)
    path = from_toolpath(tp, machine, input_axes)
    return machine, emit(machine, path, mode)


def run_rs274(text: str, tmp: Path) -> str:
    """rs274's canonical output; an interpreter error (exit status 1, message on stderr) fails."""
    prog = tmp / "prog.ngc"
    prog.write_text(text, encoding="latin-1")
    proc = subprocess.run(["rs274", "-g", str(prog)], capture_output=True, timeout=120, cwd=tmp)
    assert proc.returncode == 0, f"rs274 rejected the program: {proc.stderr.decode('latin-1')}"
    return proc.stdout.decode("latin-1")


def canonical_axes(canon: str, letters=("A", "C")) -> np.ndarray:
    """(M, 5) X Y Z and the machine's two rotary axes of every straight move (rs274 prints
    x, y, z, a, b, c)."""
    rows = [[float(v) for v in args.split(",")] for _, args in CANON.findall(canon)]
    arr = np.array(rows)
    return arr[:, [0, 1, 2] + [3 + "ABC".index(k) for k in letters]]


def linuxcnc_5axiskins_inverse(pos: np.ndarray, pivot: float = 250.0) -> np.ndarray:
    """5axiskins.c kinematicsInverse (w = 0): joints = pos - L (sin b cos c, sin b sin c, -cos b) - (0, 0, L); pos columns X Y Z C B."""
    c, b = np.radians(pos[:, 3]), np.radians(pos[:, 4])
    r = pivot * np.stack([np.sin(b) * np.cos(c), np.sin(b) * np.sin(c), -np.cos(b)], axis=1)
    return np.c_[pos[:, :3] - r - [0.0, 0.0, pivot], pos[:, 3:5]]


def linuxcnc_xyzac_inverse(pos: np.ndarray, dy: float = 20.0, dz: float = 10.0) -> np.ndarray:
    """trtfuncs.c xyzacKinematicsInverse, rot point 0, tool offset 0: joints = d + Rx(a) (Rz(c) p - d)."""
    a, c = np.radians(pos[:, 3]), np.radians(pos[:, 4])
    x, y, z = pos[:, 0], pos[:, 1], pos[:, 2]
    rx = np.cos(c) * x - np.sin(c) * y
    ry = np.sin(c) * x + np.cos(c) * y - dy
    rz = z - dz
    return np.stack([rx, np.cos(a) * ry - np.sin(a) * rz + dy, np.sin(a) * ry + np.cos(a) * rz + dz, pos[:, 3], pos[:, 4]], axis=1)


def tips_from_canon(name: str, machine, canon: str) -> np.ndarray:
    axes = canonical_axes(canon, machine.rotary_names)
    if CASES[name][2] == "linuxcnc":
        axes = linuxcnc_5axiskins_inverse(axes) if machine.kind == "head-head" else linuxcnc_xyzac_inverse(axes)
    tip, _ = fk(machine, axes)
    return tip


@pytest.mark.parametrize("name", sorted(CASES))
def test_recorded_program_and_canonical_motion(name):
    machine, result = build(name)
    recorded = (RECORDED / f"{name}.ngc").read_text(encoding="latin-1")
    assert result.text == recorded, f"the emitter's output changed: record again ({__doc__.splitlines()[-1]})"
    canon = (RECORDED / f"{name}.canon").read_text(encoding="latin-1")
    assert "PROGRAM_END()" in canon  # the interpreter read the whole program
    tips = tips_from_canon(name, machine, canon)
    assert len(tips) == len(result.path.tip)
    err = np.linalg.norm(tips - result.path.tip, axis=1)
    assert err.max() < 1e-3, f"{name}: canonical motion misses the intended tip by {err.max():.5f} mm"


@pytest.mark.skipif(not has_rs274, reason="LinuxCNC's rs274 is not installed (apt-get install linuxcnc-uspace)")
@pytest.mark.parametrize("name", sorted(CASES))
def test_rs274_accepts_and_matches_recording(name, tmp_path):
    _, result = build(name)
    canon = run_rs274(result.text, tmp_path)
    assert canon == (RECORDED / f"{name}.canon").read_text(encoding="latin-1")


def test_nominal_machine_axes_miss_on_the_calibrated_machine():
    """The calibration's point: machine axes from the nominal model, run on the (true)
    calibrated machine, put the tip off by about the axis errors; from the calibrated model, not."""
    true = load_machine(CALIBRATED)
    path = from_toolpath(parse_program(HERE / CASES["tilted_none_calibrated"][0]), true, None)
    nominal_axes = emit(load_machine("xyzac-trt"), path, "none", max_deviation_mm=None).axes
    calibrated_axes = emit(true, path, "none", max_deviation_mm=None).axes
    miss_nominal = np.linalg.norm(fk(true, nominal_axes)[0] - path.tip, axis=1).max()
    miss_calibrated = np.linalg.norm(fk(true, calibrated_axes)[0] - path.tip, axis=1).max()
    assert miss_nominal > 0.05 and miss_calibrated < 1e-9


def record() -> None:
    import tempfile

    RECORDED.mkdir(parents=True, exist_ok=True)
    for name in sorted(CASES):
        _, result = build(name)
        (RECORDED / f"{name}.ngc").write_text(result.text, encoding="latin-1")
        with tempfile.TemporaryDirectory() as tmp:
            canon = run_rs274(result.text, Path(tmp))
        (RECORDED / f"{name}.canon").write_text(canon, encoding="latin-1")
        print(f"{name}: {len(result.path.tip)} targets, {len(CANON.findall(canon))} canonical moves")


if __name__ == "__main__":
    if "--record" in sys.argv:
        record()
