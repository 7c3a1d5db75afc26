"""Batch throughput: N copies of a RAPID program compensated with --jobs J on a LocalCluster.

Run: .venv/bin/python benchmarks/batch.py [N=20] [J=2] [targets per program=2000]
Prints wall time (cluster start-up included) and programs/s and targets/s.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def program(path: Path, n: int) -> None:
    lines = ["MODULE Part", "  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];",
             "  TASK PERS wobjdata wTable := [FALSE,TRUE,\"\",[[1150,-100,300],[0.9659258,0,0,0.2588190]],[[0,0,0],[1,0,0,0]]];", "  PROC main()",
             # The programs' confdata [0,0,0,0] is not a KR160 posture at these targets (every
             # target used to fail with "configuration data match no IK solution"): let the
             # controller take the configuration nearest the current one, as a CAM post does.
             "    ConfL\\Off;"]
    for i in range(n):
        lines.append(f"    MoveL [[{200 * np.sin(i / 50):.3f},{150 * np.cos(i / 70):.3f},150.000],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tSpindle\\WObj:=wTable;")
    path.write_text("\n".join(lines + ["  ENDPROC", "ENDMODULE", ""]))


if __name__ == "__main__":
    import postproc
    from postproc.jobs.batch import run_batch
    from postproc.model.effects import parse_effects
    from postproc.model.model_io import save_model
    from postproc.model.sim import random_truth

    count, jobs, targets = (int(a) for a in (sys.argv[1:] + ["20", "2", "2000"][len(sys.argv) - 1 :])[:3])
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        robot = postproc.load_robot("kr160_r1570")
        model = random_truth(robot, np.array([0.0, 0.0, 200.0]), parse_effects("geometric,base_frame,tool_offset,joint_compliance"), np.random.default_rng(0))
        save_model(root / "model.json", model)
        (root / "out").mkdir()
        programs = []
        for k in range(count):
            programs.append(root / f"p{k}.mod")
            program(programs[-1], targets)
        t0 = time.perf_counter()
        results = run_batch(programs, root / "model.json", root / "out", {}, jobs=jobs)
        wall = time.perf_counter() - t0
    ok = sum(r.ok for r in results)
    for r in results:
        if not r.ok:
            print(f"failed: {r.program}: {r.error}")
    print(f"{count} programs x {targets} targets, --jobs {jobs}: {wall:.1f} s wall ({ok} written), {count / wall:.2f} programs/s, {count * targets / wall:.0f} targets/s")
