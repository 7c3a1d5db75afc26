"""The measured robot of the fit benchmarks: a KR160 R1570 with a 200 mm tool whose random true
error model has the given effects, measured at poses drawn in the default cylinder (seed 0)."""

from __future__ import annotations

import argparse

import numpy as np

import postproc
from postproc.model.effects import parse_effects
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate


def poses_option(doc: str, default: int = 1000) -> int:
    """The number of poses a benchmark was asked for (``--n``); ``doc``'s first line describes it."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--n", type=int, default=default)
    return parser.parse_args().n


def measured_truth(effects_spec: str, n: int):
    """(robot, tool, truth, data): the true model of ``effects_spec`` and ``n`` simulated measurements of it."""
    robot = postproc.load_robot("kr160_r1570")
    tool = [0.0, 0.0, 200.0]
    rng = np.random.default_rng(0)
    truth = random_truth(robot, tool, parse_effects(effects_spec), rng)
    data = simulate(truth, sample_poses(robot, tool, n, Cylinder(), rng), rng)
    return robot, tool, truth, data
