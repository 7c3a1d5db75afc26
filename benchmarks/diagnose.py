"""diagnose and ladder on 600 poses, with the machine idle and with a second CPU-bound job
running (targets on 2 cores: diagnose <= 15 s, ladder <= 60 s; issue 26).

Run: .venv/bin/python benchmarks/diagnose.py [--n 600] [--timeout 300] [--label after]
Each measurement runs in a fresh process with the BLAS thread settings the user has (no
OPENBLAS_NUM_THREADS given), so the library's own thread limits are what is measured; a
run past --timeout is recorded as such. The true robot has geometry, gravity compliance,
an external load and backlash; the model has geometry only, so diagnose has every catalog
effect the data's columns allow to try. The figures go to stdout and, with --label, to
benchmarks/results/diagnose_<label>.txt.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

TARGETS_S = {"diagnose": 15.0, "ladder": 60.0}
TRUTH = "geometric,base_frame,tool_offset,joint_compliance,external_load,backlash"
MODEL = "geometric,base_frame,tool_offset"


def _child(case: str, n: int) -> None:
    """Time one command in this process (data made first, outside the clock)."""
    import numpy as np

    import postproc
    from postproc.model.diagnose import diagnose, ladder
    from postproc.model.effects import parse_effects
    from postproc.model.identify import fit
    from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate

    robot = postproc.load_robot("kr160_r1570")
    tool = [0.0, 0.0, 200.0]
    rng = np.random.default_rng(0)
    truth = random_truth(robot, tool, parse_effects(TRUTH), rng)
    data = simulate(truth, sample_poses(robot, tool, n, Cylinder(), rng), rng)
    model = fit(robot, tool, parse_effects(MODEL), data, cv_folds=0).model if case == "diagnose" else None
    t0 = time.perf_counter()
    if case == "diagnose":
        result = diagnose(model, data)
        detail = f"{len(result.candidates)} candidates, top {result.candidates[0].effect if result.candidates else '-'}"
    else:
        rows = ladder(robot, tool, data)
        detail = "steps " + " -> ".join(r["added"] for r in rows)
    print(f"{time.perf_counter() - t0:.2f} {detail}")


def _burner() -> subprocess.Popen:
    """A second CPU-bound job: numpy products with the default thread count, forever."""
    code = "import numpy as np\na = np.random.rand(600, 600)\nwhile True:\n    a = np.tanh(a @ a)\n"
    return subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _measure(case: str, n: int, timeout: float, loaded: bool) -> str:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    burner = _burner() if loaded else None
    t0 = time.perf_counter()
    try:
        done = subprocess.run([sys.executable, __file__, "--child", case, "--n", str(n)], capture_output=True, text=True, timeout=timeout, env=env)
        if done.returncode != 0:
            return f"failed ({done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode})"
        seconds, _, detail = done.stdout.strip().splitlines()[-1].partition(" ")
        verdict = "met" if float(seconds) <= TARGETS_S[case] else "MISSED"
        return f"{float(seconds):7.1f} s  (target {TARGETS_S[case]:.0f} s: {verdict}; {detail})"
    except subprocess.TimeoutExpired:
        return f"> {timeout:.0f} s  (stopped; target {TARGETS_S[case]:.0f} s: MISSED; wall {time.perf_counter() - t0:.0f} s)"
    finally:
        if burner is not None:
            burner.kill()
            burner.wait()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=600)
    parser.add_argument("--timeout", type=float, default=300.0)
    parser.add_argument("--cases", default="diagnose,ladder")
    parser.add_argument("--label", default=None, help="write benchmarks/results/diagnose_LABEL.txt as well")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        _child(args.child, args.n)
        return
    lines = [f"benchmarks/diagnose.py --n {args.n} --timeout {args.timeout:.0f} ({os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start: "
             f"'idle' means no second job of ours; truth {TRUTH}; diagnose's model {MODEL})"]
    print(lines[0], flush=True)
    for case in args.cases.split(","):
        for loaded in (False, True):
            line = f"{case:<9} {'with a second CPU-bound job' if loaded else 'machine otherwise idle':<28} {_measure(case, args.n, args.timeout, loaded)}"
            print(line, flush=True)
            lines.append(line)
    if args.label:
        out = Path(__file__).parent / "results" / f"diagnose_{args.label}.txt"
        out.write_text("\n".join(lines) + "\n")
        print(f"written to {out}")


if __name__ == "__main__":
    main()
