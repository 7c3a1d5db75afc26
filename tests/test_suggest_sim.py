"""suggest-poses' defaults that the simulated machining pass set (issue 32): the candidates
generated grow with N, as more candidates from the same workspace let the design do better, and
the default random share stops at a few poses, as more bought nothing measurable against an
effect the model lacks."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import postproc.suggest.candidates as candidates_module
from postproc.cli import app
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.sim import Cylinder
from postproc.robot.robots import load_robot
from postproc.suggest import (
    DEFAULT_RANDOM_MOST,
    default_random_count,
    random_count,
    suggest_poses,
)
from postproc.suggest.candidates import (
    CANDIDATES_PER_POSE,
    MAX_CANDIDATES,
    MIN_CANDIDATES,
    Candidates,
    default_count,
    generate,
)

runner = CliRunner()
ROBOT = load_robot("kr160_r1570")
TOOL = np.array([0.0, 0.0, 200.0])
EFFECTS = "geometric,base_frame,tool_offset"


def test_default_candidate_count_grows_with_n_between_its_limits():
    assert [default_count(n) for n in (1, 33, 34, 50, 100, 200, 1000)] == [2000, 2000, 2040, 3000, 6000, 12000, 12000]
    assert (MIN_CANDIDATES, CANDIDATES_PER_POSE, MAX_CANDIDATES) == (2000, 60, 12000)


def test_more_candidates_from_the_same_workspace_give_a_better_region_design():
    """The design's prediction at the targets improves with 4x the candidates (drawn from the same
    cylinder: random's designs are the same population), and stays above the bound for distinct
    poses of the larger set: this fails if the search stops using what the extra candidates offer."""
    model = ErrorModel.create(ROBOT, TOOL, parse_effects(EFFECTS))
    few = generate(ROBOT, TOOL, 250, Cylinder(), np.random.default_rng(11))
    extra = generate(ROBOT, TOOL, 750, Cylinder(), np.random.default_rng(12))
    many = Candidates(q_deg=np.vstack([few.q_deg, extra.q_deg]), ids=few.ids + tuple(f"x{i}" for i in extra.ids), source="<test>")
    targets = few.q_deg[:30]
    small = suggest_poses(model, few, 40, targets_q=targets, random_share=0.0)
    large = suggest_poses(model, many, 40, targets_q=targets, random_share=0.0)
    assert large.bound_rms_mm <= large.expected_rms_mm < 0.97 * small.expected_rms_mm
    assert large.bound_rms_mm < small.bound_rms_mm


def test_the_cli_generates_the_default_count_for_n_and_refuses_a_count_with_given_candidates(tmp_path, monkeypatch):
    counts = []

    def counted(robot, tool_mm, n, *args, **kwargs):  # record the count asked for; generate few to stay fast
        counts.append(n)
        return generate(robot, tool_mm, 200, *args, **kwargs)

    monkeypatch.setattr(candidates_module, "generate", counted)
    args = ["suggest-poses", "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "geometric", "--cylinder", "", "-n", "40",
            "-o", str(tmp_path / "c.csv"), "--json"]
    assert runner.invoke(app, args).exit_code == 0
    assert runner.invoke(app, args + ["--n-candidates", "300"]).exit_code == 0
    assert counts == [default_count(40), 300]
    runs = [runner.invoke(app, args + ["-n", "60"] + share) for share in ([], ["--random-share", "0.2"])]
    assert [json.loads(r.stdout)["n_random"] for r in runs] == [4, 10]  # geometric: 27 parameters, fit needs 9
    (tmp_path / "cand.csv").write_text("id,q1,q2,q3,q4,q5,q6\n1,0,-90,90,0,0,0\n")
    result = runner.invoke(app, ["suggest-poses", "--robot", "kr160_r1570", "--effects", "geometric", "--candidates", str(tmp_path / "cand.csv"),
                                 "--n-candidates", "2000", "-n", "5", "-o", str(tmp_path / "d.csv")])
    assert result.exit_code == 2 and "--n-candidates" in result.stderr


def test_default_random_share_stops_at_a_few_poses_a_given_share_does_not():
    assert [default_random_count(n, 13) for n in (13, 14, 18, 20, 32, 40, 100, 500)] == [0, 0, 1, 1, 4, 4, 4, 4]
    assert DEFAULT_RANDOM_MOST == 4 and random_count(0.2, 100, 13) == 17
    model = ErrorModel.create(ROBOT, TOOL, parse_effects(EFFECTS))  # 33 parameters: fit needs 11 poses
    cands = generate(ROBOT, TOOL, 300, Cylinder(), np.random.default_rng(5))
    assert suggest_poses(model, cands, 60, seed=0).n_random == 4
    assert suggest_poses(model, cands, 60, seed=0, random_share=0.2).n_random == 10  # round(0.2 x 49): as given


@pytest.mark.parametrize("n", [14, 100])
def test_default_count_is_an_integer_count(n):
    assert isinstance(default_count(n), int) and default_count(n) >= n


def _benchmark():
    import importlib.util
    from pathlib import Path
    spec = importlib.util.spec_from_file_location("suggest_benchmark_sim", Path(__file__).parents[1] / "benchmarks" / "suggest.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_benchmark_takes_randoms_designs_of_the_same_seeds_from_an_earlier_run(tmp_path):
    """--random-from: random's arrays depend on the seed alone, so a run of the design only
    (--random-draws 0) is compared with the random designs an earlier run fitted for the same seeds."""
    bench = _benchmark()
    seeds = np.array([3, 1, 2])
    saved = {f"pass__{key}": seeds[:, None, None] * np.ones((1, 2, 4)) + k for k, key in enumerate(bench.RANDOM_SIDE)}
    np.savez_compressed(tmp_path / "old.npz", pass__seeds=seeds, **saved)
    run = {"seeds": np.array([1, 2]), "random": np.full((2, 2, 1), np.nan)}
    assert bench.random_from(run, tmp_path / "old.npz") == 4
    assert run["random"][:, 0, 0].tolist() == [1.0, 2.0] and run["random_lin_mean"][:, 0, 0].tolist() == [4.0, 5.0]
    with pytest.raises(SystemExit, match=r"seeds \[7\]"):
        bench.random_from({"seeds": np.array([7])}, tmp_path / "old.npz")
