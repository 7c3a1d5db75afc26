"""benchmarks/suggest.py's statistics (issue 32): shards of seeds merge into one run, and the
control variate that narrows the fitted shares is unbiased and does narrow them."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from postproc.suggest import design

_SPEC = importlib.util.spec_from_file_location("suggest_benchmark", Path(__file__).parents[1] / "benchmarks" / "suggest.py")
bench = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(bench)


def _shard(path: Path, seeds: list[int], noise_draws: int = 2) -> Path:
    s = np.array(seeds)
    np.savez_compressed(path, pass__suggested=s[:, None] * np.ones((1, 3)), pass__bound=s.astype(float), pass__seeds=s,
                        meta__seeds=s, meta__noise_draws=np.asarray(noise_draws), meta__random_draws=np.asarray(4),
                        meta__skip_share0=np.asarray(True), meta__minutes=np.asarray(1.5))
    return path


def test_shards_merge_in_seed_order_and_refuse_overlaps_or_other_options(tmp_path):
    runs, meta = bench.merge_shards([_shard(tmp_path / "b.npz", [2, 3]), _shard(tmp_path / "a.npz", [0, 1])])
    assert meta["seeds"].tolist() == [0, 1, 2, 3] and meta["minutes"] == 3.0 and meta["noise_draws"] == 2
    assert runs["pass"]["suggested"][:, 0].tolist() == [0, 1, 2, 3] and runs["pass"]["bound"].tolist() == [0, 1, 2, 3]
    with pytest.raises(SystemExit, match="share seeds"):
        bench.merge_shards([_shard(tmp_path / "c.npz", [1]), tmp_path / "a.npz"])
    with pytest.raises(SystemExit, match="other options"):
        bench.merge_shards([tmp_path / "a.npz", _shard(tmp_path / "d.npz", [5], noise_draws=3)])


def test_control_variate_is_unbiased_and_removes_the_noise_it_knows():
    """Fits whose error is a design's expected error plus a noise term the linearised error sees
    (and a little it does not): the controlled means keep the expected errors and lose most of the
    scatter; with the linearised error at its mean they are the plain means."""
    rng = np.random.default_rng(0)
    seeds, grid, draws, fits = 40, len(bench.GRID), 12, 6
    expected_s, expected_r = np.linspace(0.014, 0.005, grid), np.linspace(0.028, 0.007, grid)
    lin_mean_s, lin_mean_r = np.full((seeds, grid), 0.01), np.full((seeds, grid, draws), 0.01)
    lin_s = lin_mean_s[:, :, None] + rng.normal(0, 0.003, (seeds, grid, fits))
    lin_r = lin_mean_r + rng.normal(0, 0.003, (seeds, grid, draws))
    run = {"suggested_fits": expected_s[None, :, None] + 0.9 * (lin_s - lin_mean_s[:, :, None]) + rng.normal(0, 3e-4, lin_s.shape),
           "random": expected_r[None, :, None] + 0.9 * (lin_r - lin_mean_r) + rng.normal(0, 3e-4, lin_r.shape),
           "suggested_lin": lin_s, "suggested_lin_mean": lin_mean_s, "random_lin": lin_r, "random_lin_mean": lin_mean_r}
    sug, ran, beta = bench.controlled(run)
    assert np.allclose(beta, 0.9, atol=0.05)
    assert np.allclose(sug.mean(axis=0), expected_s, atol=1e-4) and np.allclose(ran.mean(axis=0), expected_r, atol=1e-4)
    plain = run["suggested_fits"].mean(axis=2)
    assert (sug.std(axis=0) < 0.3 * plain.std(axis=0)).all()
    still = dict(run, suggested_lin=np.repeat(lin_mean_s[:, :, None], fits, axis=2), random_lin=lin_mean_r.copy())
    assert np.allclose(bench.controlled(still)[0], plain)


def test_linearised_noise_error_scales_with_the_noise_and_vanishes_without_it():
    rng = np.random.default_rng(1)
    blocks = rng.normal(size=(50, 3, 4))
    problem = design.Problem.of(blocks, None, rng.normal(size=(10, 3, 4)))
    info = type("Info", (), {"problem": problem, "evaluation": rng.normal(size=(10, 3, 4))})()
    noise = rng.normal(0, bench.NOISE, (50, 3))
    rows = np.arange(20)
    values, mean = bench.linear_noise_error(info, rows, [noise, 2 * noise, 0 * noise], np.random.default_rng(2))
    assert values[2] == 0 and values[1] == pytest.approx(2 * values[0]) and mean > 0


def test_ur10_report_gives_the_floor_and_the_shares_up_to_150():
    """Part 3's report with cyclic terms: how the terms were chosen, the floor, and the design's share
    at random's N = 150 (the design reaching random's 150-pose error at 75 poses: 50 %)."""
    grid = (19, 32, 50, 64, 75, 100, 150)
    curve = np.array([0.40, 0.30, 0.26, 0.24, 0.20, 0.19, 0.18])
    random = np.array([0.60, 0.40, 0.32, 0.28, 0.25, 0.22, 0.20])
    real = {"grid": grid, "how": "cyclic terms: chosen on the candidates", "floor": {"whole": 0.22, "region": 0.19}}
    for label in ("whole", "region"):
        real[label] = {"suggested": np.tile(curve, (3, 1)), "random": np.tile(random[None, :, None], (3, 1, 2))}
    text = "\n".join(bench.ur10_lines(real, 3))
    assert "cyclic terms: chosen on the candidates" in text and "all 2,000 candidate poses: 0.2200 mm" in text and "0.1900 mm" in text
    assert "random reaches 0.2000 mm at N = 150; suggested at N = 75.0 (50 % of the poses)" in text and "N = 150: 50-50 %" in text
