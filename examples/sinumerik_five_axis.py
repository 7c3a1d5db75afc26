"""A SINUMERIK 840D five-axis part program: calibrate the machine, compensate, convert.

The part is LinuxCNC's impeller demo (tests/corpus/fivex, as postproc writes it for LinuxCNC
TCP: tests/data/rs274/impeller_linuxcnc.ngc) written for an 840D: TRAORI (tool tip + A/C),
its tips in a frame that R parameters and TRANS move (tests/test_sinumerik.py builds it the
same way). The machine is a table-table xyzac-trt whose A and C axes are off their nominal
lines (simulated, as examples/fivex_calibration.py: tilts of a few 1e-4 rad, offsets of
0.1-0.2 mm). Steps, each the CLI's own call:
1. rtcp-calibrate: probe touches -> calibrated machine file (+ Siemens $TC_CARR data);
2. compensate --model calibrated.toml --input-axes tip: the program's numbers for the real
   machine, nothing but numbers changed (the frame and R parameter blocks stay);
3. the true machine runs both programs under the 840D's nominal TRAORI: tip error per target;
4. convert --to sinumerik: a RAPID five-axis pass written as a TRAORI program.
The figure shows the tip error of every target before and after compensation, and the part
in its programmed (TRANS-lated) frame and in the machine frame.

Run: .venv/bin/python examples/sinumerik_five_axis.py [OUT_DIR]   (default: out/sinumerik)
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))  # the Sinumerik impeller is built by the tests' own function

from test_sinumerik import impeller_in_sinumerik  # noqa: E402

from postproc.fivex.machine import load_machine  # noqa: E402
from postproc.fivex.simulate import perturbed, probe_rows, rows_csv  # noqa: E402
from postproc.jobs.five_axis.commands import compensate_five_program, convert_five, rtcp_calibrate  # noqa: E402
from postproc.jobs.five_axis.compensate import actual_tip, controller_axes  # noqa: E402
from postproc.jobs.five_axis.program import from_toolpath  # noqa: E402
from postproc.programs import parse_program  # noqa: E402

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/sinumerik")
out.mkdir(parents=True, exist_ok=True)
rng = np.random.default_rng(2024)
AT_ZERO = {"G54": np.eye(4)}  # the part's G54 is the machine zero with the rotary axes at zero

# 1. The machine as built, probed, calibrated (`postproc rtcp-calibrate probes.csv --machine xyzac-trt -o calibrated.toml`).
nominal = load_machine("xyzac-trt")
true = perturbed(nominal, rng, tilt_rad=(2e-4, 5e-4), offset_mm=(0.1, 0.2))
plan = {"A": (np.linspace(-80.0, 40.0, 13), [10.0, 60.0, 90.0]), "C": (np.arange(0.0, 360.0, 30.0), [80.0, 30.0, 40.0])}
probes = out / "probes.csv"
probes.write_text("# simulated touches (sphere radius 12.5 mm, tip radius 3 mm)\n" + rows_csv(probe_rows(true, plan, rng, noise_mm=0.001, touch_radius=15.5)))
doc, cal = rtcp_calibrate(probes, "xyzac-trt", out / "calibrated.toml", sphere_radius=12.5, tip_radius=3.0)
for path, label in doc["files"].items():
    print(f"rtcp-calibrate wrote {path}: {label}")

# 2. The 840D program and its compensation (`postproc compensate IMPELLER.MPF --model calibrated.toml --input-axes tip --frame G54=0,0,0,0,0,0 -o ...`).
program = out / "IMPELLER.MPF"
program.write_text(impeller_in_sinumerik(), encoding="latin-1")
compensated = out / "IMPELLER_COMP.MPF"
for line in compensate_five_program(program, out / "calibrated.toml", compensated, input_axes="tip", frames=AT_ZERO):
    print(f"compensate: {line}")

# 3. Both programs on the true machine, each run by the 840D's nominal TRAORI.
tp, new = (parse_program(p).with_frames(AT_ZERO) for p in (program, compensated))
intended = from_toolpath(tp, nominal, "tip")
errors = {}
for key, prog in (("as written", tp), ("compensated", new)):
    five = from_toolpath(prog, nominal, "tip")
    reached = actual_tip(true, None, controller_axes(nominal, five.tip, five.angles, "tip"))
    errors[key] = np.linalg.norm(reached - intended.tip, axis=1)
    print(f"true machine, {key}: tip error max {errors[key].max():.4f} mm, RMS {np.sqrt(np.mean(errors[key] ** 2)):.4f} mm")

# 4. Any five-axis input as a TRAORI program (`postproc convert tilted_pass.mod --to sinumerik --machine xyzac-trt -o TILTED.MPF`).
for line in convert_five(HERE.parent / "tests" / "corpus" / "fivex" / "tilted_pass.mod", "sinumerik", out / "TILTED.MPF", "xyzac-trt", None):
    print(f"convert: {line}")

# 5. Figure.
fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5.2), constrained_layout=True)
rows = np.arange(1, len(tp) + 1)
left.semilogy(rows, errors["as written"], color="tab:red", lw=1, label=f"as written: max {errors['as written'].max():.3f} mm")
left.semilogy(rows, np.maximum(errors["compensated"], 1e-6), color="tab:blue", lw=1,
              label=f"compensated for the calibrated machine: max {errors['compensated'].max():.4f} mm")
left.axhline(0.05, color="0.4", ls="--", lw=1, label="0.05 mm")
left.set_xlabel("target (program order)")
left.set_ylabel("tool-tip error on the true machine (mm)")
left.set_title("IMPELLER.MPF (TRAORI) on the simulated true xyzac-trt")
left.set_ylim(1e-5, 1.0)
left.legend(loc="lower right", fontsize=9)
programmed = tp.position
right.plot(programmed[:, 0], programmed[:, 1], color="tab:orange", lw=0.8, label="as programmed (in the TRANS frame: X=R1 Y=R2 Z=R3)")
right.plot(intended.tip[:, 0], intended.tip[:, 1], color="tab:green", lw=0.8, label="in the machine frame (G54 at zero)")
right.set_aspect("equal", adjustable="datalim")
right.set_xlabel("X (mm)")
right.set_ylabel("Y (mm)")
right.set_title("the impeller roughing pass, top view")
right.legend(loc="upper left", fontsize=9)
fig.savefig(out / "sinumerik_five_axis.png", dpi=100)
print(f"figure: {out / 'sinumerik_five_axis.png'}")
