"""How far suggest-poses' region-targeted designs are from the best possible (issue 32).

On the machining pass of benchmarks/suggest.py (simulated KR160, 1,500 candidates in seed 001's
cylinder, 200 targets; the same truths and candidates per seed), for each N: the design's mean
predicted error variance at the targets (noise only) divided by lower bounds no design can beat:

- ``bound, distinct``: the capped relaxation (``design.relaxed_i_design``): any N distinct poses;
- ``bound, with its random poses``: the same with the design's own random share fixed (what the
  search could still gain; the rest is the price of the random share);
- ``bound, repeats``: Kiefer's approximate design (``design.i_optimal_bound``), which may measure a
  pose many times: the looser bound the docs quoted before.

and the same ratio for a search started from the rounded relaxation instead of the greedy order.

Run: .venv/bin/python benchmarks/suggest_gap.py --seeds 3 [--n 50,64,100] [--output benchmarks/results/suggest_gap.txt]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from suggest import pass_problem  # noqa: E402  (benchmarks/suggest.py: the same candidates and targets)

from postproc.suggest import DEFAULT_RANDOM_SHARE, NEAR_TARGETS_FRACTION, fewest_poses, near_targets, random_count, suggest_poses  # noqa: E402
from postproc.suggest import design  # noqa: E402


def variance(problem, chosen) -> float:
    return -design.criterion_value(problem, problem.information(chosen), "I")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--n", default="32,50,64,100")
    parser.add_argument("--share", type=float, default=DEFAULT_RANDOM_SHARE)
    parser.add_argument("--output", type=Path, default=Path("benchmarks/results/suggest_gap.txt"))
    args = parser.parse_args()
    grid = [int(v) for v in args.n.split(",")]
    lines = [f"benchmarks/suggest_gap.py --seeds {args.seeds} --n {args.n} --share {args.share:g}",
             "N x variance / bound (1.000 = the bound reached); time: suggest_poses wall, s",
             f"{'seed':>4} {'N':>4} {'random':>6} {'/distinct':>10} {'/with its random':>17} {'/repeats':>9} {'relaxed start /distinct':>24} {'time':>6}"]
    print(lines[-1], flush=True)
    for s in range(args.seeds):
        model, cands, q_eval, problem = pass_problem(s)
        for n in grid:
            t0 = time.perf_counter()
            chosen = suggest_poses(model, cands, n, targets_q=q_eval, random_share=args.share, seed=s).chosen
            wall = time.perf_counter() - t0
            var = variance(problem, chosen)
            least = fewest_poses(len(model.params), problem.blocks.shape[-1])
            n_random = random_count(args.share, n, least)
            rng = np.random.default_rng(s)  # as suggest_poses draws its random share
            pool = near_targets(cands.q_deg, q_eval, np.arange(len(cands)), max(4 * n_random, int(NEAR_TARGETS_FRACTION * len(cands))))
            fixed = rng.choice(pool, size=n_random, replace=False) if n_random else np.zeros(0, dtype=int)
            distinct = design.relaxed_i_design(problem, n).lower_bound
            relaxed = design.relaxed_i_design(problem, n - n_random, fixed)
            start = design.exchange(problem, relaxed.rounded(fixed, n - n_random), "I", n_random)[0]
            repeats = design.i_optimal_bound(problem)[0] / n
            lines.append(f"{s:>4} {n:>4} {n_random:>6} {var / distinct:>10.4f} {var / relaxed.lower_bound:>17.4f} {var / repeats:>9.4f} "
                         f"{variance(problem, start) / distinct:>24.4f} {wall:>6.1f}")
            print(lines[-1], flush=True)
    args.output.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
