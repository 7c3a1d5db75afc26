"""Five-axis numbers: calibration accuracy over simulated machines, rs274 round trips, IK speed.

Run: .venv/bin/python benchmarks/fivex.py [--trials N]
Prints (1) over N simulated xyzac-trt machines with axis errors (tilts 1e-4..5e-4 rad,
offsets 0.02..0.2 mm), 1 um probing noise (touches) and three gross outliers, full and
120-degree sweeps of C: the worst direction error, line offset and whether the outliers
were found exactly; (2) the recorded rs274 canonical motion of every emitted test program
turned back into tool tips, worst error; (3) IK throughput.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from postproc.fivex.calibrate import calibrate_machine  # noqa: E402
from postproc.fivex.kinematics import fk, ik  # noqa: E402
from postproc.fivex.machine import load_machine  # noqa: E402
from postproc.fivex.probes import read_probes  # noqa: E402
from postproc.fivex.simulate import perturbed, probe_rows, rows_csv  # noqa: E402


def calibration_trials(n: int) -> None:
    nominal = load_machine("xyzac-trt")
    worst = {"full": [0.0, 0.0, 0], "partial": [0.0, 0.0, 0]}
    with tempfile.TemporaryDirectory() as tmp:
        for trial in range(n):
            rng = np.random.default_rng(1000 + trial)
            true = perturbed(nominal, rng)
            sweep = "partial" if trial % 2 else "full"
            c_angles = np.linspace(-60, 60, 13) if sweep == "partial" else np.arange(0.0, 360.0, 30.0)
            plan = {"C": (c_angles, [80.0, 30.0, 40.0]), "A": (np.linspace(-80, 40, 13), [10.0, 60.0, 90.0])}
            bad = {"C": {3: rng.normal(0, 1.0, 3), 8: rng.normal(0, 1.0, 3)}, "A": {5: rng.normal(0, 1.0, 3)}}
            path = Path(tmp) / "p.csv"
            path.write_text(rows_csv(probe_rows(true, plan, rng, noise_mm=0.001, outliers=bad, touch_radius=15.5)))
            cal = calibrate_machine(nominal, read_probes(path, sphere_radius=12.5, tip_radius=3.0))
            for ax in true.rotary:
                fit = cal.fits[ax.name]
                angle = np.arccos(min(1.0, fit.direction @ ax.direction))
                diff = fit.point - ax.point
                offset = np.linalg.norm(diff - (diff @ ax.direction) * ax.direction)
                expected = sorted(f"{ax.name}{k + 1}" for k in bad[ax.name])
                w = worst[sweep]
                w[0], w[1] = max(w[0], angle), max(w[1], offset)
                w[2] += sorted(o["id"] for o in fit.outliers) != expected
    print(f"calibration over {n} simulated machines (A: 120 deg sweep; C: full turn or 120 deg), 1 um noise, 3 gross outliers (N(0, 1 mm)):")
    for sweep, (angle, offset, misses) in worst.items():
        print(f"  C sweep {sweep:7}: worst direction error {angle:.2e} rad, worst line offset {offset:.4f} mm, axes with wrong outlier set: {misses}")


def rs274_round_trips() -> None:
    from test_fivex_rs274 import CASES, RECORDED, build, tips_from_canon

    print("recorded rs274 canonical motion -> machine kinematics -> tool tip, vs the intended tip:")
    for name in sorted(CASES):
        machine, result = build(name)
        tips = tips_from_canon(name, machine, (RECORDED / f"{name}.canon").read_text(encoding="latin-1"))
        err = np.linalg.norm(tips - result.path.tip, axis=1)
        print(f"  {name:26} {len(err):4} moves, worst {err.max():.1e} mm")


def ik_speed() -> None:
    m = load_machine("xyzac-trt")
    rng = np.random.default_rng(0)
    n = 200_000
    joints = np.c_[rng.uniform(-50, 50, (n, 3)), rng.uniform(-90, 40, n), np.cumsum(rng.uniform(-2, 2, n))]
    tip, axis = fk(m, joints)
    ik(m, tip[:100], axis[:100])  # compile the branch kernel
    t0 = time.perf_counter()
    result = ik(m, tip, axis, start_deg=joints[0, 3:5])
    dt = time.perf_counter() - t0
    back, _ = fk(m, result.axes)
    print(f"IK of {n} targets: {dt:.2f} s ({n / dt / 1e6:.2f} M targets/s), worst FK round trip {np.abs(back - tip).max():.1e} mm")


if __name__ == "__main__":
    trials = int(sys.argv[sys.argv.index("--trials") + 1]) if "--trials" in sys.argv else 20
    calibration_trials(trials)
    rs274_round_trips()
    ik_speed()
