"""Figures of docs/languages/heidenhain.md: the five-axis Klartext example compensated with a
calibrated machine and checked on the simulated true machine, and its tool path.

Run: .venv/bin/python examples/heidenhain/figures.py [--out docs/img]
Calibrates xyzac-trt from the simulated probing (tests/data/fivex/probes_xyzac_sim.csv),
compensates tests/corpus/heidenhain/tcpm_pass.h with the calibration, and runs the program
as written and as compensated on the true machine (tests/data/fivex/xyzac-trt-true.toml):
a TNC with the nominal kinematics commands the axes, the true machine puts the tip.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  after the backend
import numpy as np  # noqa: E402

from postproc.fivex.kinematics import fk  # noqa: E402
from postproc.fivex.machine import load_machine  # noqa: E402
from postproc.jobs.five_axis.commands import compensate_five_program, rtcp_calibrate  # noqa: E402
from postproc.jobs.five_axis.compensate import actual_tip, controller_axes  # noqa: E402
from postproc.programs import parse_program  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
PROGRAM = REPO / "tests" / "corpus" / "heidenhain" / "tcpm_pass.h"
PROBES = REPO / "tests" / "data" / "fivex" / "probes_xyzac_sim.csv"
TRUE = REPO / "tests" / "data" / "fivex" / "xyzac-trt-true.toml"
AT_ZERO = {"PRESET": np.eye(4)}


def landed(tp, nominal, true):
    cmd = controller_axes(nominal, tp.position, tp.ext[:, [0, 2]], "tip")
    return actual_tip(true, None, cmd), fk(nominal, cmd)[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "img")
    args = parser.parse_args()
    nominal, true = load_machine("xyzac-trt"), load_machine(TRUE)
    with tempfile.TemporaryDirectory() as tmp:
        cal = Path(tmp) / "cal.toml"
        rtcp_calibrate(PROBES, "xyzac-trt", cal)
        out = Path(tmp) / "comp.h"
        compensate_five_program(PROGRAM, cal, out, input_axes="tip", frames=AT_ZERO)
        before, after = parse_program(PROGRAM), parse_program(out)
    tip_before, meant = landed(before, nominal, true)
    tip_after, _ = landed(after, nominal, true)
    err_before = np.linalg.norm(tip_before - meant, axis=1) * 1000
    err_after = np.linalg.norm(tip_after - meant, axis=1) * 1000
    lines = before.line

    fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
    x = np.arange(len(lines))
    ax.bar(x - 0.2, err_before, 0.4, label=f"as written (max {err_before.max():.0f} µm)")
    ax.bar(x + 0.2, err_after, 0.4, label=f"compensated with the calibration (max {err_after.max():.1f} µm)")
    ax.set_xticks(x, [str(v) for v in lines])
    ax.set_xlabel("program line (tcpm_pass.h)")
    ax.set_ylabel("tool tip error on the true machine (µm)")
    ax.set_title("Klartext M128 program on xyzac-trt: nominal TNC kinematics, true machine")
    ax.legend()
    fig.savefig(args.out / "heidenhain_compensation.png", dpi=110)
    plt.close(fig)

    _, axis = fk(nominal, np.c_[np.zeros((len(before), 3)), before.ext[:, [0, 2]]])
    fig, (top, tilt) = plt.subplots(1, 2, figsize=(9, 4.2), layout="constrained")
    top.plot(meant[:, 0], meant[:, 1], "o-", label="tool tip (X Y as programmed)")
    top.quiver(meant[:, 0], meant[:, 1], axis[:, 0], axis[:, 1], color="tab:orange", angles="xy", scale_units="xy", scale=0.1,
               label="tool axis seen from above (x 10 mm)")
    ends = np.vstack([meant[:, :2], meant[:, :2] + 10 * axis[:, :2]])
    top.set_xlim(ends[:, 0].min() - 3, ends[:, 0].max() + 3)
    top.set_ylim(ends[:, 1].min() - 6, ends[:, 1].max() + 3)
    top.set_aspect("equal")
    top.set_xlabel("X (mm)")
    top.set_ylabel("Y (mm)")
    top.set_title("top view, workpiece frame")
    top.legend(loc="lower left", fontsize=8)
    tilt.plot(lines, np.degrees(np.arccos(np.clip(axis[:, 2], -1, 1))), "o-", label="tool axis tilt from Z")
    tilt.plot(lines, before.ext[:, 0], "s--", label="A as programmed")
    tilt.set_xlabel("program line (tcpm_pass.h)")
    tilt.set_ylabel("angle (deg)")
    tilt.set_title("tool tilt under M128")
    tilt.legend()
    fig.suptitle("tcpm_pass.h: the five-axis example read with machine xyzac-trt")
    fig.savefig(args.out / "heidenhain_path.png", dpi=110)
    plt.close(fig)
    print(f"max tip error {err_before.max():.1f} -> {err_after.max():.2f} µm; wrote {args.out}/heidenhain_compensation.png, heidenhain_path.png")


if __name__ == "__main__":
    main()
