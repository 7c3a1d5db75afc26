"""Where the region-targeted design's poses go on the simulated machining pass (issue 32, N = 100).

The same seeds, truths, candidates and targets as benchmarks/suggest.py part 2a (``_world``, PASS).
Three studies, each printing its table (``--output`` appends them to a file):

- ``candidates``: noise-only prediction (linearised, no fit) of the share of random's poses the design
  needs at random's N = 32 / 50 / 64 / 100, with the design choosing from 1,500 / 3,000 / 6,000
  candidates (the 1,500 of part 2a first, more from the same cylinder after them; random always from
  the 1,500: the same distribution), random share 0.2 and 0. The share is N0 x (design RMS at N0 /
  random's RMS at N)^2 / N with N0 = N / 2 (variance ~ 1 / N near there), also for the bound for
  distinct poses.
- ``gap``: the prediction against what a fit sees, per seed, for the design of the 48-seed run
  (1,500 candidates, random share 0.2 without the cap): the share from sqrt(E[mean square]) at
  the nominal Jacobian (what suggest-poses reports), from E[RMS] of the linearised error (what the
  benchmark's mean of fitted RMS values estimates: Jensen), from E[RMS] at the truth's Jacobian (the
  fit linearises near the truth), and the noise-free fitted error (bias: nonlinearity and the
  parameters fit cannot separate; with those set to nominal in the truth, what is left).
- ``mismatch``: a truth with an effect the model lacks (joint_harmonics on joints 2, 3, orders 3, 4,
  amplitudes N(0, A) deg), fitted without it: each design's expected true error at the targets,
  sqrt(bias^2 + noise variance) (bias: the noise-free fit; noise: the linearised prediction; exact
  for least squares), for random share 0 / 0.1 / 0.2 and random designs (24 per seed and N).
- ``before``: benchmarks/suggest.py's report of the machining pass from an earlier run's arrays
  (``--from``, default benchmarks/results/suggest.npz: the 48-seed run, 1,500 candidates, share 0.2
  uncapped) for the seeds given: the design before this change on the seeds of a new run.
- ``decompose``: from a run's arrays (``--from``), the share of random's poses at the seeds' mean
  curves by the reported prediction (root mean square error, nominal Jacobian), by the linearised
  mean RMS (what a mean of fitted RMS values estimates) and by the fits (control variate), and the
  ratios behind the differences at N = 50 and 100.
- ``timing``: suggest_poses' wall time (the faster of two calls, alternating) on seed 0's pass with the
  1,500 candidates (before) and with the default count for N (after), N = 32, 50, 100.

Run: .venv/bin/python benchmarks/suggest_sim.py candidates --seeds 0,1,2 --output benchmarks/results/suggest_sim.txt
     .venv/bin/python benchmarks/suggest_sim.py gap --seeds 0,1,2,3
     .venv/bin/python benchmarks/suggest_sim.py mismatch --seeds 0-7 --amplitudes 0,0.001
     .venv/bin/python benchmarks/suggest_sim.py timing
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import suggest as bench  # noqa: E402  (benchmarks/suggest.py: the same worlds, targets and helpers)

from postproc.model.effects import parse_effects  # noqa: E402
from postproc.model.errormodel import ErrorModel  # noqa: E402
from postproc.model.identify import fit  # noqa: E402
from postproc.model.sim import Cylinder, sample_poses, simulate  # noqa: E402
from postproc.suggest import _covariance, _expected_rms, _information, suggest_poses  # noqa: E402
from postproc.suggest.candidates import JOINT_DECIMALS, Candidates, default_count  # noqa: E402

RANDOM_NS = (32, 50, 64, 100)
HARMONICS = "joint_harmonics[joints=2,3;orders=3,4]"


def world(s: int):
    """(truth, 1,500 candidates, targets, nominal model, information at the nominal model) of seed s's pass."""
    rng, truth, cands, _ = bench._world(s)
    q_eval = sample_poses(truth.robot, truth.tool_mm, 200, bench.PASS, rng)
    nominal = ErrorModel.create(truth.robot, truth.tool_mm, parse_effects(bench.EFFECTS))
    return truth, cands, q_eval, nominal, _information(nominal, cands, None, q_eval, bench.NOISE)


def random_rms(info, s: int, draws: int = 100) -> dict[int, float]:
    """Random designs' mean predicted RMS at the targets, per random N (from the 1,500)."""
    p = info.problem
    perms = [np.random.default_rng([900 + s, d]).permutation(len(p.blocks)) for d in range(draws)]
    return {n: float(np.mean([_expected_rms(info, _covariance(p, p.information(q[:n]))) for q in perms])) for n in RANDOM_NS}


def candidates_study(seeds, counts) -> list[str]:
    lines = [("candidates: noise-only share of random's poses (%) the design needs at random's N = 32 / 50 / 64 / 100 "
              "[bound for distinct poses], design from C candidates (random from the first 1,500)")]
    for s in seeds:
        truth, cands, q_eval, nominal, info = world(s)
        ran = random_rms(info, s)
        extra = np.round(sample_poses(truth.robot, truth.tool_mm, max(counts) - len(cands), Cylinder(), np.random.default_rng([100 + s, 1])),
                         JOINT_DECIMALS)
        pool = np.vstack([cands.q_deg, extra])
        for c in counts:
            chosen_from = Candidates(q_deg=pool[:c], ids=tuple(f"s{i + 1}" for i in range(c)), source="<benchmark>")
            t0 = time.perf_counter()
            for share in (0.2, 0.0):
                shares, bounds = [], []
                for n_r in RANDOM_NS:
                    n0 = n_r // 2
                    r = suggest_poses(nominal, chosen_from, n0, targets_q=q_eval, seed=s, random_share=share)
                    shares.append(100 * n0 * (r.expected_rms_mm / ran[n_r]) ** 2 / n_r)
                    bounds.append(100 * n0 * (r.bound_rms_mm / ran[n_r]) ** 2 / n_r)
                lines.append(f"  seed {s} C {c:>5} share {share:g}: " + " / ".join(f"{a:.1f} [{b:.1f}]" for a, b in zip(shares, bounds))
                             + (f"  ({time.perf_counter() - t0:.0f} s)" if share == 0.0 else ""))
            bench.say(lines[-2]), bench.say(lines[-1])
    return lines


def gap_study(seeds) -> list[str]:
    lines = [("gap: share of random's poses (%) at random's N = 32 / 50 / 64 / 100 by each measure (random: 48 designs per N), "
              "and the noise-free fitted error (mm) of the design at N = 50, 100 and random's at 50, 100 (8 designs)")]
    eff = parse_effects(bench.EFFECTS)
    for s in seeds:
        t0 = time.perf_counter()
        truth, cands, q_eval, nominal, info = world(s)
        at_truth = _information(truth, cands, None, q_eval, bench.NOISE)
        measures = _measures(info, at_truth, len(cands), np.random.default_rng([7, s]))
        fixed = set(suggest_poses(nominal, cands, 14, targets_q=q_eval, seed=s).fixed)
        separable = truth.with_vector(np.where([q.name in fixed for q in truth.params], nominal.values, truth.values))
        clean = [(simulate(t, cands.q_deg, np.random.default_rng(1), noise_mm=0.0), t.predict_prepared(t.prepare(q_deg=q_eval)))
                 for t in (truth, separable)]

        # the design of the 48-seed run this decomposes (benchmarks/results/suggest_pass_48seeds.txt): share 0.2, no cap
        designs = {n: suggest_poses(nominal, cands, n, targets_q=q_eval, seed=s, random_share=0.2).chosen for n in bench.GRID}
        draws = np.random.default_rng([11, s])
        randoms = {n: [draws.choice(len(cands), n, replace=False) for _ in range(48)] for n in RANDOM_NS}
        lines.append(f"  seed {s}: fixed by fit on all candidates: {', '.join(sorted(fixed))}")
        for label, measure in measures.items():
            curve = [measure(designs[n]) for n in bench.GRID]
            shares = [bench._share(bench.first_n_below(bench.GRID, curve, np.mean([measure(r) for r in randoms[n]])), n) for n in RANDOM_NS]
            lines.append(f"    {label:<32} " + " / ".join(f"{100 * x:.1f}" for x in shares))
        for t, label in enumerate(("noise-free fit, truth", "noise-free fit, unseparable at nominal")):
            lines.append(f"    {label:<40} design {_bias(truth, eff, clean[t], designs[50], q_eval):.5f} {_bias(truth, eff, clean[t], designs[100], q_eval):.5f}, random "
                         + " ".join(f"{np.mean([_bias(truth, eff, clean[t], r, q_eval) for r in randoms[n][:8]]):.5f}" for n in (50, 100)))
        bench.say("\n".join(lines[-6:]) + f"  ({time.perf_counter() - t0:.0f} s)")
    return lines


def _measures(info, at_truth, count: int, mc: np.random.Generator) -> dict:
    """Each measure of a design's error at the targets, as a function of its rows."""
    p, zero = info.problem, [np.zeros((count, 3))]
    return {"sqrt E[ms], nominal (reported)": lambda rows: _expected_rms(info, _covariance(p, p.information(rows))),
            "E[rms], nominal": lambda rows: bench.linear_noise_error(info, rows, zero, mc)[1],
            "E[rms], at the truth": lambda rows: bench.linear_noise_error(at_truth, rows, zero, mc)[1]}


def _bias(truth, eff, clean, rows, q_eval) -> float:
    """The noise-free fit's RMS error at the targets: clean = (noise-free measurement, true positions there)."""
    meas, true = clean
    return bench.rms(_fitted(truth, eff, meas.subset(rows), q_eval) - true)


def mismatch_study(seeds, amplitudes, ns=(32, 50, 100), shares=(0.0, 0.1, 0.2), draws: int = 24) -> list[str]:
    eff = parse_effects(bench.EFFECTS)
    res = np.zeros((len(seeds), len(amplitudes), len(ns), len(shares) + 1))
    size = np.zeros((len(seeds), len(amplitudes)))
    for i, s in enumerate(seeds):
        t0 = time.perf_counter()
        truth, cands, q_eval, nominal, info = world(s)
        p = info.problem
        picks = {}
        draw = np.random.default_rng([600, s])
        for k, n in enumerate(ns):
            for j, share in enumerate(shares):
                picks[k, j] = [suggest_poses(nominal, cands, n, targets_q=q_eval, random_share=share, seed=s).chosen]
            picks[k, len(shares)] = [draw.choice(len(cands), n, replace=False) for _ in range(draws)]
        noise_part = {key: [_expected_rms(info, _covariance(p, p.information(rows))) for rows in rows_list] for key, rows_list in picks.items()}
        base = truth.predict_prepared(truth.prepare(q_deg=q_eval))
        for a, amp in enumerate(amplitudes):
            extended = ErrorModel.create(truth.robot, truth.tool_mm, parse_effects(bench.EFFECTS + "," + HARMONICS))
            names = [q.name for q in extended.params if q.name.startswith("joint_harmonics")]
            values = amp * np.random.default_rng([300, s]).standard_normal(len(names))
            extended = extended.with_values({**truth.as_dict(), **dict(zip(names, values))})
            clean = simulate(extended, cands.q_deg, np.random.default_rng(1), noise_mm=0.0)
            true = extended.predict_prepared(extended.prepare(q_deg=q_eval))
            size[i, a] = bench.rms(true - base)
            for key, rows_list in picks.items():
                bias = [bench.rms(_fitted(truth, eff, clean.subset(rows), q_eval) - true) for rows in rows_list]
                res[i, a][key] = np.mean(np.sqrt(np.square(bias) + np.square(noise_part[key])))
        bench.say(f"mismatch seed {s}: {time.perf_counter() - t0:.0f} s")
    lines = [f"mismatch: truth + {HARMONICS} (amplitudes N(0, A) deg), model without; expected true error RMS at the targets (mm), "
             f"sqrt(bias^2 + noise variance), mean over {len(seeds)} seeds; columns random share " + " / ".join(f"{x:g}" for x in shares)
             + f" / random ({draws} designs); then each share's difference from 0.2 (mean +- standard error over seeds)"]
    for a, amp in enumerate(amplitudes):
        lines.append(f"  A = {amp:g} deg (the effect's RMS at the targets {size[:, a].mean():.4f} mm, seeds {size[:, a].min():.4f}-{size[:, a].max():.4f}):")
        for k, n in enumerate(ns):
            m = res[:, a, k].mean(axis=0)
            diff = res[:, a, k, :len(shares)] - res[:, a, k, shares.index(0.2)][:, None]
            lines.append(f"    N {n:>3}: " + " / ".join(f"{x:.4f}" for x in m) + "   vs 0.2: "
                         + ", ".join(f"{shares[j]:g}: {1000 * diff[:, j].mean():+.2f} +- {1000 * diff[:, j].std() / np.sqrt(len(seeds)):.2f} um"
                                     for j in range(len(shares)) if shares[j] != 0.2))
    return lines


def before(source: Path, seeds: list[int]) -> list[str]:
    saved = np.load(source)
    where = {int(s): k for k, s in enumerate(saved["pass__seeds"])}
    rows = [where[s] for s in seeds]
    run = {key[len("pass__"):]: saved[key][rows] for key in saved.files if key.startswith("pass__")}
    return [f"before: {source}'s machining pass for seeds {seeds[0]}-{seeds[-1]}", *bench.region_lines({"pass": run}, len(seeds))]


def decompose(source: Path) -> list[str]:
    saved = np.load(source)
    run = {key[len("pass__"):]: saved[key] for key in saved.files if key.startswith("pass__")}
    sug, ran, _ = bench.controlled(run)
    random_lin = np.nanmean(run["random_lin_mean"], axis=2)
    curves = {"prediction, root mean square (reported)": (run["theory_suggested"], run["random_pred_pop"]),
              "linearised, mean RMS": (run["suggested_lin_mean"], random_lin),
              "fitted, control variate": (sug, ran)}
    lines = [f"decompose: {source}, {len(run['seeds'])} seeds; share of random's poses (%) at random's N = 32 / 50 / 64 / 100, seeds' mean curves"]
    for label, (design_curve, random_curve) in curves.items():
        a, b = design_curve.mean(axis=0), random_curve.mean(axis=0)
        lines.append(f"  {label:<42} " + " / ".join(
            f"{100 * bench._share(bench.first_n_below(bench.GRID, a, b[bench.GRID.index(n)]), n):.1f}" for n in RANDOM_NS))
    for n in (50, 100):
        k = bench.GRID.index(n)
        lines.append(f"  N {n}: mean RMS / root mean square: design {run['suggested_lin_mean'][:, k].mean() / run['theory_suggested'][:, k].mean():.3f}, "
                     f"random {random_lin[:, k].mean() / run['random_pred_pop'][:, k].mean():.3f}; fitted / linearised mean RMS: design "
                     f"{sug[:, k].mean() / run['suggested_lin_mean'][:, k].mean():.3f}, random {ran[:, k].mean() / random_lin[:, k].mean():.3f}")
    return lines


def timing_study(s: int = 0) -> list[str]:
    truth, cands, q_eval, nominal, _ = world(s)
    pool, _ = bench._more_candidates(s, truth, cands, [])
    lines = ["timing: suggest_poses on the machining pass, seed 0, the faster of two calls"]
    for n in (32, 50, 100):
        best = {"before": np.inf, "after": np.inf}
        for _ in range(2):
            for label, chosen_from in (("before", cands), ("after", bench._first(pool, default_count(n)))):
                t0 = time.perf_counter()
                suggest_poses(nominal, chosen_from, n, targets_q=q_eval, seed=s)
                best[label] = min(best[label], time.perf_counter() - t0)
        lines.append(f"  N {n}: 1,500 candidates {best['before']:.1f} s, the default {default_count(n):,} {best['after']:.1f} s")
    return lines


def _fitted(truth, eff, meas, q_eval) -> np.ndarray:
    model = fit(truth.robot, truth.tool_mm, eff, meas, cv_folds=0).model
    return model.predict_prepared(model.prepare(q_deg=q_eval))


def _seeds(text: str) -> list[int]:
    """'0,1,2' or '0-7'."""
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(x) for x in text.split(",")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", choices=("candidates", "gap", "mismatch", "timing", "before", "decompose"))
    parser.add_argument("--from", dest="source", type=Path, default=Path("benchmarks/results/suggest.npz"), help="before: the earlier run's arrays")
    parser.add_argument("--seeds", type=_seeds, default=[0, 1])
    parser.add_argument("--counts", default="1500,3000,6000", help="candidates: the candidate counts the design chooses from")
    parser.add_argument("--amplitudes", default="0,0.001", help="mismatch: harmonic amplitudes, deg")
    parser.add_argument("--output", type=Path, help="append the table to this file")
    args = parser.parse_args()
    t0 = time.perf_counter()
    if args.study == "candidates":
        lines = candidates_study(args.seeds, [int(c) for c in args.counts.split(",")])
    elif args.study == "gap":
        lines = gap_study(args.seeds)
    elif args.study == "before":
        lines = before(args.source, args.seeds)
    elif args.study == "decompose":
        lines = decompose(args.source)
    elif args.study == "timing":
        lines = timing_study()
    else:
        lines = mismatch_study(args.seeds, [float(a) for a in args.amplitudes.split(",")])
    command = " ".join(["benchmarks/suggest_sim.py", *sys.argv[1:]])
    text = "\n".join([f"{command}  ({(time.perf_counter() - t0) / 60:.1f} min)", *lines]) + "\n"
    print(text)
    if args.output is not None:
        with open(args.output, "a") as fh:
            fh.write(text + "\n")


if __name__ == "__main__":
    main()
