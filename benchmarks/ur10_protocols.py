"""Every evaluation protocol on the real UR10 data, each row one `postproc validate` command.

Run: .venv/bin/python benchmarks/ur10_protocols.py [path/to/ur10_ipa] [--skip-hybrid]
Writes benchmarks/results/ur10_protocols.txt (the table, the command behind each row and
its wall time). Imports Series A and B with `postproc import-ur10` into a temporary folder
first. The hybrid rows (physics + GPR; local experts on ~9,500 poses of A) take most of the
time (about 2-5 min each on a shared 2-core machine); --skip-hybrid leaves them out.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ur10_series import data_folder, imported

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "ur10_protocols.txt"
PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
# Joints 1 and 2 are where a GPR on the joint angles, fitted on B's training half, puts its
# short length scales (about 4 deg: docs/guide/explain.md); orders 1-12 are the effect's whole range.
SHOULDER = "joint_harmonics[joints=1,2;orders=1,2,3,4,5,6,7,8,9,10,11,12]"
UR10 = ["--robot", "ur10", "--tool", "0,0,109", "--effects"]


def rows(a: str, b: str, hybrid: bool) -> list[tuple[str, str, list[str]]]:
    """(label, goal, validate arguments) per table row; the hybrid rows only with ``hybrid``."""
    gpr = ["--predictor", "gpr"]
    posture = [*gpr, "--gp-features", "tcp+joints"]  # the learner sees the joint angles too
    history = [*gpr, "--gp-features", "tcp+joints+travel"]  # and the TCP travel of the last three moves
    table = [
        ("A: random 20 % of poses held out, physics", "", [a, "--protocol", "random", *UR10, PHYSICS]),
        ("A: random 20 % of poses held out, hybrid", "<= 0.06", [a, "--protocol", "random", *UR10, PHYSICS, *gpr]),
        ("A: the same, hybrid with --gp-features tcp+joints", "<= 0.06", [a, "--protocol", "random", *UR10, PHYSICS, *posture]),
        ("A: the same, hybrid with --gp-features tcp+joints+travel", "<= 0.06", [a, "--protocol", "random", *UR10, PHYSICS, *history]),
        ("A: every 5th grid point held out, physics", "", [a, "--protocol", "points", *UR10, PHYSICS]),
        ("A: every 5th grid point held out, hybrid", "<= 0.20", [a, "--protocol", "points", *UR10, PHYSICS, *gpr]),
        ("A: the same, hybrid with --gp-features tcp+joints", "<= 0.20", [a, "--protocol", "points", *UR10, PHYSICS, *posture]),
        ("A: the same, hybrid with --gp-features tcp+joints+travel", "<= 0.20", [a, "--protocol", "points", *UR10, PHYSICS, *history]),
        ("A: each session held out, physics", "", [a, "--protocol", "sessions", *UR10, PHYSICS]),
        ("B: half of the commanded positions held out, physics", "< 0.30", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS]),
        ("B: the same, + joint_harmonics (terms chosen by the fit)", "< 0.30", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS + ",joint_harmonics"]),
        ("B: the same, + joint_harmonics[joints=1,2;orders=1-12]", "< 0.30", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS + "," + SHOULDER]),
        ("B: the same, hybrid", "", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS, *gpr]),
        ("B: the same, hybrid with --gp-features tcp+joints", "", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS, *posture]),
        ("B: the same, hybrid with --gp-features tcp+joints+travel", "", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS, *history]),
        ("A -> B: re-registered on half of B, physics", "vs ceiling", [a, "--protocol", "series", "--other", b, *UR10, PHYSICS]),
    ]
    return [row for row in table if hybrid or "--predictor" not in row[2]]


def run(args: list[str]) -> tuple[dict, float]:
    start = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "postproc", "validate", *args, "--json"], capture_output=True, text=True, cwd=ROOT)
    if proc.returncode != 0:
        raise SystemExit(f"postproc validate {' '.join(args)} failed:\n{proc.stderr}")
    return json.loads(proc.stdout), time.monotonic() - start


def main() -> None:
    argv = [x for x in sys.argv[1:] if x != "--skip-hybrid"]
    data = data_folder(argv[0] if argv else None)
    with tempfile.TemporaryDirectory() as tmp:
        a, b = (str(imported(data, series, Path(tmp) / f"{series}.csv")) for series in ("A", "B"))
        lines = ["| protocol | goal | n | mean | median | p95 | max | nearest training pose, median / max rad | ceiling mean |",
                 "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
        commands = []
        table = rows(a, b, "--skip-hybrid" not in sys.argv)
        for k, (label, goal, args) in enumerate(table):
            print(f"[{k + 1}/{len(table)}] {label}", file=sys.stderr, flush=True)
            doc, wall = run(args)
            e, d = doc["error"], doc["distance"]
            ceiling = f"{doc['ceiling']['mean_mm']:.3f}" if doc["ceiling"] else ""
            lines.append(f"| {label} | {goal} | {e['n']} | **{e['mean_mm']:.3f}** | {e['median_mm']:.3f} | {e['p95_mm']:.3f} | {e['max_mm']:.3f} "
                         f"| {d['median_rad']:.3f} / {d['max_rad']:.3f} | {ceiling} |")
            shown = " ".join(x.replace(tmp + "/", "") for x in args)
            commands.append(f"- {label}: `postproc validate {shown}` ({wall:.0f} s)")
            moved = [s for s in doc["sessions"] if s["moves_as_whole"]]
            commands += [f"  - session {s['session']} ({s['n']} poses) moves as a whole: rigid offset {s['offset_mm']:.3f} mm, "
                         f"mean {s['mean_mm']:.3f} -> {s['mean_after_mm']:.3f} mm without it" for s in moved]
    text = "\n".join(["UR10 protocols (mm; A.csv, B.csv from postproc import-ur10)", "", *lines, "", *commands, ""])
    RESULT.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
