"""Series A's random held-out poses by their place after the last large move, before and after
--noise-model settle.

Run: .venv/bin/python benchmarks/ur10_noise.py [--seed S] [path/to/ur10_ipa]
Fits the fold `postproc validate A.csv --protocol random --seed S --robot ur10 --tool 0,0,109
--effects "geometric,base_frame,tool_offset,joint_compliance,joint_harmonics[max_order=60]"
--predictor gpr --gp-features tcp+joints+travel [--noise-model settle]` fits (the same split),
once with each noise model, and plots the held-out error against the variable the noise
model uses: how many targets ago the TCP last moved more than 10 mm (0: the first pose after
such a move). Writes benchmarks/results/ur10_noise.png and prints the figures (about 5-10 min
per fit on a shared 2-core machine).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from ur10_series import bars_by_place, data_folder, imported

from postproc.model.effects import parse_effects
from postproc.model.identify import residuals
from postproc.model.measurements import read_measurements
from postproc.model.noise_model import SETTLE_MM, settle_place
from postproc.model.path_history import previous_targets
from postproc.model.validate import FitSpec, fit_model, random_mask, with_order_columns
from postproc.robot.robots import load_robot

ROOT = Path(__file__).resolve().parents[1]
FIGURE = ROOT / "benchmarks" / "results" / "ur10_noise.png"
EFFECTS = "geometric,base_frame,tool_offset,joint_compliance,joint_harmonics[max_order=60]"
TOOL = np.array([0.0, 0.0, 109.0])
BINS = 6  # 0 .. 4 targets since the long move, and 5 or more


def places(robot, q_deg: np.ndarray) -> np.ndarray:
    """Targets since the TCP last moved more than SETTLE_MM, capped at BINS - 1 (the noise
    model itself caps at 3: postproc.model.noise_model.settle_place)."""
    return settle_place(robot, TOOL, q_deg, previous_targets(q_deg, BINS - 1))


def held_out(meas, test, robot, noise: str, seed: int) -> tuple[np.ndarray, float]:
    spec = FitSpec(robot, TOOL, parse_effects(EFFECTS), "gpr", {"features": "tcp+joints+travel"}, seed=seed, noise=noise)
    start = time.monotonic()
    model = fit_model(spec, meas.subset(~test), lambda message: print(f"  {noise}: {message}"[:100].ljust(100), end="\r", flush=True))
    print()
    return np.linalg.norm(residuals(model, meas.subset(test)), axis=1), time.monotonic() - start


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("data", nargs="?")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    robot = load_robot("ur10")
    with tempfile.TemporaryDirectory() as tmp:
        meas = read_measurements(imported(data_folder(args.data), "A", Path(tmp) / "A.csv"))
    meas = with_order_columns(parse_effects(EFFECTS), meas)
    test = random_mask(len(meas), 0.2, args.seed)
    place = places(robot, meas.q_deg)[test]
    errors = {}
    for noise in ("none", "settle"):
        errors[noise], seconds = held_out(meas, test, robot, noise, args.seed)
        by_place = [errors[noise][place == k].mean() for k in range(BINS)]
        print(f"--noise-model {noise}: mean {errors[noise].mean():.4f} median {np.median(errors[noise]):.4f} p95 {np.percentile(errors[noise], 95):.4f} "
              f"max {errors[noise].max():.3f} mm ({seconds:.0f} s); by targets since a long move: "
              + ", ".join(f"{k}{'+' if k == BINS - 1 else ''}: {v:.3f}" for k, v in enumerate(by_place)))
    plot(errors, place, args.seed)


def plot(errors: dict, place: np.ndarray, seed: int) -> None:
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.8))
    bars_by_place(left, errors, place, BINS, lambda noise, err: f"--noise-model {noise} (mean {err.mean():.4f} mm)",
                  f"targets since the TCP last moved more than {SETTLE_MM:.0f} mm\n(0: the first pose after the move; n: held-out poses)",
                  f"Series A, random 20 % held out (seed {seed}): error by place")
    for noise, err in errors.items():
        ordered = np.sort(err)
        right.plot(ordered, np.arange(1, len(ordered) + 1) / len(ordered), label=f"--noise-model {noise}")
    right.set_xscale("log")
    right.set_xlabel("held-out 3-D error (mm, log scale)")
    right.set_ylabel("share of held-out poses with at most this error")
    right.set_title("distribution of the held-out error")
    right.grid(True, which="both", alpha=0.3)
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)
    print(f"wrote {FIGURE.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
