"""Each measuring session's frame shift on Series A, with the physics alone and with the cyclic terms.

Run: .venv/bin/python benchmarks/ur10_sessions.py [path/to/ur10_ipa]
Imports Series A, runs `postproc fit A.csv ... --cv 0 --session-offsets` twice (physics =
geometric, base_frame, tool_offset, joint_compliance; then with joint_harmonics[max_order=60])
and draws each session's offset (the length of its translation, mm) in both:
benchmarks/results/ur10_sessions.png; prints the offsets. About 3 min on the shared 2-core machine.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from ur10_series import ROOT, data_folder, imported  # noqa: E402

PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
FITS = {"physics": PHYSICS, "physics + cyclic terms": PHYSICS + ",joint_harmonics[max_order=60]"}
FIGURE = ROOT / "benchmarks" / "results" / "ur10_sessions.png"


def offsets(a_csv: Path, effects: str, out: Path) -> list[dict]:
    args = ["fit", str(a_csv), "--robot", "ur10", "--tool", "0,0,109", "--effects", effects, "--cv", "0", "--session-offsets", "-o", str(out)]
    proc = subprocess.run([sys.executable, "-m", "postproc", *args], capture_output=True, text=True, cwd=ROOT, check=True)
    print(f"{effects}: {next(line for line in proc.stdout.splitlines() if line.startswith('session offsets'))}")
    return json.loads(out.read_text())["session_offsets"]


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        a = imported(data_folder(sys.argv[1] if len(sys.argv) > 1 else None), "A", Path(tmp) / "A.csv")
        found = {name: offsets(a, effects, Path(tmp) / f"m{k}.json") for k, (name, effects) in enumerate(FITS.items())}
    sessions = [row["session"] for row in next(iter(found.values()))]
    poses = [row["poses"] for row in next(iter(found.values()))]
    x = np.arange(len(sessions))
    fig, ax = plt.subplots(figsize=(9, 4.2))
    for k, (name, rows) in enumerate(found.items()):
        sizes = [np.linalg.norm(row["offset_mm"]) for row in rows]
        ax.bar(x + (k - 0.5) * 0.4, sizes, width=0.4, label=name)
        for s, size in zip(sessions, sizes):
            print(f"  {name}: session {s}: {size:.3f} mm")
    ax.set_xticks(x, [f"{s}\n({n})" for s, n in zip(sessions, poses)])
    ax.set_xlabel("measuring session (poses)")
    ax.set_ylabel("session offset, mm (length of the translation)")
    ax.set_title("UR10 Series A: each tracker session's frame shift (fit --session-offsets, all poses)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=120)
    print(f"figure: {FIGURE.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
