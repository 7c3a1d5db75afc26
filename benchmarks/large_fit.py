"""Large fits (issue 17): a timed hybrid physics + GPR fit on 10^5 simulated poses, and the
local GP experts against an exact GP on the real UR10 data (Series A, 11,911 poses).

Run:
  .venv/bin/python benchmarks/large_fit.py sim [N=100000]
      a simulated KR160 whose truth has joint harmonics (orders 2, 3 on joints 2, 3, 5) the physics model lacks; the physics
      (geometric, base_frame, tool_offset, joint_compliance) and then the GPR on its residual
      are fitted on N poses; prints each stage's time, the peak RSS and the RMS on 2,000
      held-out poses (physics alone, hybrid). Target: <= 15 min and <= 8 GB on 2 cores.
  .venv/bin/python benchmarks/large_fit.py ur10 [path/to/ur10_ipa] [SUBSAMPLE=2000]
      Series A split at random into 90 % training, 10 % held out; physics fitted on the
      training poses; the residual GPR fitted three ways and scored on the held-out poses:
      an exact GP on a SUBSAMPLE-pose random subsample (what an exact GP can take), the
      local experts on the same subsample (both run: they must agree), and the local
      experts on every training pose (full size: they must do better).
Every fit runs in this one process: the peak RSS printed is the largest of them all.
"""

from __future__ import annotations

import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

import postproc
from postproc.model.effects import parse_effects
from postproc.model.identify import Stats, fit, fit_predictor, residuals

PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"


def peak_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2


def cpu_s() -> float:
    """CPU seconds this process has used (all its threads): on a shared machine the wall time
    is contention, the CPU time is the method's cost (wall >= CPU / 2 on a dedicated 2-core one)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(v**2, axis=1))))


def timed(label: str, call):
    t0, c0 = time.perf_counter(), cpu_s()
    out = call()
    print(f"  {label:<52}{time.perf_counter() - t0:8.1f} s wall {cpu_s() - c0:8.1f} s CPU   peak RSS so far {peak_gb():5.2f} GB", flush=True)
    return out


def sim(n: int) -> None:
    from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate

    robot = postproc.load_robot("kr160_r1570")
    tool = np.array([0.0, 0.0, 200.0])
    rng = np.random.default_rng(0)
    truth = random_truth(robot, tool, parse_effects(PHYSICS + ",joint_harmonics[joints=2,3,5;orders=2,3]"), rng, magnitude=2.0)
    print(f"simulated KR160, truth {truth.effects.spec()}, {n:,} training + 2,000 held-out poses; model {PHYSICS} + gpr")
    data = timed("simulate", lambda: simulate(truth, sample_poses(robot, tool, n + 2000, Cylinder(), rng), rng, noise_mm=0.01))
    train, test = data.subset(np.arange(n)), data.subset(np.arange(n, n + 2000))
    t0, c0 = time.perf_counter(), cpu_s()
    physics = timed("physics fit", lambda: fit(robot, tool, parse_effects(PHYSICS), train, cv_folds=0).model)
    hybrid = timed(f"gpr on the residual ({n:,} poses)", lambda: fit_predictor(physics, train, "gpr"))
    total, cpu = time.perf_counter() - t0, cpu_s() - c0
    print(f"  fit total {total:.1f} s wall ({total / 60:.1f} min), {cpu:.1f} s CPU ({cpu / 120:.1f} min on 2 cores), method {hybrid.residual.estimator.method_}, peak RSS {peak_gb():.2f} GB "
          f"(target <= 15 min, <= 8 GB: {'met' if min(total, cpu / 2) <= 900 and peak_gb() <= 8 else 'MISSED'})")
    print(f"  held-out RMS: physics {Stats.of(residuals(physics, test)).rms_mm:.4f} mm, hybrid {Stats.of(residuals(hybrid, test)).rms_mm:.4f} mm")


def ur10(root: Path, subsample: int) -> None:
    from postproc.model.formats.ur10_ipa import read_series
    from postproc.model.learn import GPRPredictor
    from postproc.model.learn.features import features

    data, tool = read_series(root / "Series_A")
    robot = postproc.load_robot("ur10")
    rng = np.random.default_rng(0)
    order = rng.permutation(len(data))
    n_test = len(data) // 10
    train, test = data.subset(np.sort(order[n_test:])), data.subset(np.sort(order[:n_test]))
    print(f"UR10 Series A: {len(train):,} training poses, {len(test):,} held out; physics {PHYSICS}")
    physics = timed("physics fit", lambda: fit(robot, tool, parse_effects(PHYSICS), train, cv_folds=0).model)
    target = train.measured_mm - physics.predict(train)
    truth = test.measured_mm - physics.predict(test)
    X = features(robot, physics.tool_mm, train.q_deg, "pose")
    Xt = features(robot, physics.tool_mm, test.q_deg, "pose")
    sub = np.sort(rng.choice(len(train), min(subsample, len(train)), replace=False))
    runs = {
        f"exact GP on a {len(sub):,}-pose subsample": (GPRPredictor(anisotropic=True, method="exact"), sub),
        f"local experts on the same {len(sub):,} poses": (GPRPredictor(anisotropic=True, method="local"), sub),
        f"local experts on all {len(train):,} poses": (GPRPredictor(anisotropic=True, method="local"), np.arange(len(train))),
    }
    predictions = {}
    print(f"  held-out RMS, physics alone: {rms(truth):.4f} mm")
    for label, (est, rows) in runs.items():
        timed(label, lambda: est.fit(X[rows], target[rows]))
        predictions[label] = est.predict(Xt)
        print(f"      held-out RMS {rms(truth - predictions[label]):.4f} mm ({len(est.experts_) if est.method_ == 'local' else 1} GP(s))", flush=True)
    exact, local_same = list(predictions.values())[:2]
    print(f"  exact vs local on the same subsample: RMS difference of their predictions {rms(exact - local_same):.4f} mm")
    print(f"  peak RSS {peak_gb():.2f} GB")


if __name__ == "__main__":
    mode = sys.argv[1] if len(sys.argv) > 1 else "sim"
    if mode == "sim":
        sim(int(sys.argv[2]) if len(sys.argv) > 2 else 100_000)
    elif mode == "ur10":
        default = Path(os.environ.get("POSTPROC_SHARED", Path(__file__).resolve().parents[2] / "shared")) / "data" / "ur10_ipa"
        ur10(Path(sys.argv[2]) if len(sys.argv) > 2 else default, int(sys.argv[3]) if len(sys.argv) > 3 else 2000)
    else:
        sys.exit(__doc__)
