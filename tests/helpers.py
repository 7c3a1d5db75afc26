"""Shared builders for tests that simulate robots."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import postproc
from postproc.model.effects import parse_effects
from postproc.model.identify import fit
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate
from postproc.robot import kinematics as kin

TOOL = np.array([0.0, 0.0, 200.0])
FRAME = "geometric,base_frame,tool_offset"
FRAME_AND_COMPLIANCE = FRAME + ",joint_compliance"
# The five-axis G-code set-up of the compensation tests: work offset G54 and a 200 mm spindle H1.
G54 = np.eye(4)
G54[:3, :3] = np.diag([1.0, -1.0, -1.0])  # the part frame's z points down: tool axis (0, 0, 1) is straight down
G54[:3, 3] = [900.0, -100.0, 350.0]
H1 = np.eye(4)
H1[:3, 3] = [0.0, 0.0, 200.0]


def identifiable_truth(robot, effects_spec: str, seed: int, n: int = 300, noise: float = 0.02):
    """A random true robot whose unidentifiable parameters sit at their initial values,
    so its parameters can be compared one by one with a fit; and its measurements."""
    effects = parse_effects(effects_spec)
    rng = np.random.default_rng(seed)
    truth = random_truth(robot, TOOL, effects, rng)
    q = sample_poses(robot, TOOL, n, Cylinder(), rng)
    probe = fit(robot, TOOL, effects, simulate(truth, q, rng, noise_mm=noise), cv_folds=0)
    initial = {p.name: p.initial for p in truth.params}
    truth = truth.with_values({name: initial[name] for name in probe.fixed})
    return truth, q, rng


def truth_and_fit(robot, effects_spec: str, seed: int, n: int = 300, region=None, cv_folds: int = 5, poses=None):
    """A random true robot with these effects and a model of the same effects fitted to n
    simulated poses of it (``poses`` may map the sampled joints, e.g. onto other branches)."""
    effects = parse_effects(effects_spec)
    rng = np.random.default_rng(seed)
    truth = random_truth(robot, TOOL, effects, rng)
    q = sample_poses(robot, TOOL, n, region or Cylinder(), rng)
    if poses is not None:
        q = poses(q, rng)
    return truth, fit(robot, TOOL, effects, simulate(truth, q, rng), cv_folds=cv_folds).model


def z_scores(result, truth) -> dict[str, float]:
    """(fitted - true) / standard error for every identified parameter; base frame compared as a whole transform."""
    z = {}
    for p in result.model.params:
        if p.name in result.fixed or p.name.startswith("base_frame."):
            continue
        z[p.name] = (result.model.value(p.name) - truth.value(p.name)) / result.std[p.name]
    if result.model.effects.get("base_frame") is not None:
        r_fit, t_fit = result.model.base_transform()
        r_true, t_true = truth.base_transform()
        dr = np.rad2deg(Rotation.from_matrix(r_fit @ r_true.T).as_rotvec())
        dt = t_fit - t_true
        for k, ax in enumerate("xyz"):
            for kind, delta in (("t", dt[k]), ("r", dr[k])):
                name = f"base_frame.{kind}{ax}"
                if name not in result.fixed:
                    z[name] = delta / result.std[name]
    return z


def kr160():
    return postproc.load_robot("kr160_r1570")


def true_tcp(model, tp, q, rows=None) -> np.ndarray:
    """(N, 3) where the robot ``model`` describes puts the TCP at joints q (N, 6) of tp's targets
    ``rows`` (default all), each with its own tool (the tests' own controller model runs them)."""
    out = np.zeros((len(q), 3))
    tools = tp.tool if rows is None else tp.tool[rows]
    for t in np.unique(tools):
        sel = tools == t
        m = replace(model, tool_mm=tp.tools[t][:3, 3])
        out[sel] = m.predict_prepared(m.prepare(q_deg=q[sel]))
    return out


def nearest_walk(robot, flange: np.ndarray, q_start: np.ndarray) -> np.ndarray:
    """Joints (N, 6) a controller takes for straight moves to the flange poses: each IK solution
    nearest the previous joints, turns unwrapped (written here, apart from postproc's posture code)."""
    q_prev, reached = np.asarray(q_start, float), []
    for sols in kin.ik(robot, flange):
        ok = [s for s in sols if not np.isnan(s).any()]
        steps = [np.abs((s - q_prev + 180.0) % 360.0 - 180.0).sum() for s in ok]
        q_prev = q_prev + ((ok[int(np.argmin(steps))] - q_prev + 180.0) % 360.0 - 180.0)
        reached.append(q_prev)
    return np.array(reached)


def edited_csv(src: Path, dst: Path, row: int, column: str, value: str) -> Path:
    """``src`` (a measurement CSV) written to ``dst`` with the cell of ``row`` (1: the first data
    row) in ``column`` replaced by ``value``."""
    lines = src.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = value
    lines[row] = ",".join(cells)
    dst.write_text("\n".join(lines) + "\n")
    return dst
