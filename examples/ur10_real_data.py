"""Real laser-tracker data: identify a UR10 on one measurement series, validate on the other.

Data: data/ur10_ipa (Landgraf et al., CASE 2021, MIT). The tracker stood elsewhere for
each series, so the validation series gets its tracker-to-base transform re-registered
(6 DOF) and every other parameter is kept, as data/README.md prescribes.
Run: .venv/bin/python examples/ur10_real_data.py [path/to/ur10_ipa]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import postproc
from postproc.model.effects import parse_effects
from postproc.model.formats.ur10_ipa import read_series
from postproc.model.identify import Stats, fit, nominal_model, refit_base, residuals

root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[2] / "shared" / "data" / "ur10_ipa"
robot = postproc.load_robot("ur10")
series = {name: read_series(root / f"Series_{name}") for name in "AB"}
tool = series["A"][1]
effects = parse_effects("geometric,base_frame,tool_offset,joint_compliance")
print(f"UR10, probe at {tool.round(3).tolist()} mm in the flange frame; effects {effects.spec()}")
print(f"{'fit -> validate':<16}{'poses':>12}{'model':>9}{'RMS mm':>9}{'mean mm':>9}{'max mm':>9}")
for train_name, val_name in (("A", "B"), ("B", "A")):
    train, val = series[train_name][0], series[val_name][0]
    t0 = time.perf_counter()
    result = fit(robot, tool, effects, train, cv_folds=0)
    seconds = time.perf_counter() - t0
    nominal = Stats.of(residuals(nominal_model(robot, tool, val, registered=True), val))
    fitted = Stats.of(residuals(refit_base(result.model, val), val))
    label = f"{train_name} -> {val_name}"
    poses = f"{len(train)}/{len(val)}"
    for name, st in (("nominal", nominal), ("fitted", fitted)):
        print(f"{label:<16}{poses:>12}{name:>9}{st.rms_mm:>9.3f}{st.mean_mm:>9.3f}{st.max_mm:>9.3f}")
        label = poses = ""
    print(f"{'':<16}{'':>12}  (fit on {train_name}: {seconds:.1f} s, training RMS {result.after.rms_mm:.3f} mm, {len(result.outliers)} poses flagged)")
