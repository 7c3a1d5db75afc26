"""Simulated robots whose hidden effect is not in the catalog.

The effects live in tests/plugins/hidden_<kind>.py as plugin-style files (one Effect
subclass each, absolute imports only); they are loaded from their file here and put into
the true robot directly, never registered in the package's catalog.
"""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path

import numpy as np
from helpers import TOOL, kr160

from postproc.model.effects import EffectSum, parse_effects
from postproc.model.effects.base import Effect
from postproc.model.errormodel import ErrorModel
from postproc.model.identify import fit
from postproc.model.sim import JointBox, random_truth, sample_poses, simulate

PLUGINS = Path(__file__).parent / "plugins"
MODEL = "geometric,base_frame,tool_offset,joint_compliance"
#: joints drawn independently (as tests/test_hidden_families.py): over a Cartesian region IK
#: ties joint 2 to joint 3, and a product of their angles becomes a function of one of them
BOX = JointBox(((-60, 60), (-130, -40), (40, 140), (-90, 90), (-90, 90), (-170, 170)))
#: kind -> (true values of the hidden effect's parameters, the variables diagnose must name)
HIDDEN = {
    "joint_coupling": ({"joint_coupling.c": 0.03}, {"q3", "q4"}),
    "direction_stiffness": ({"direction_stiffness.c2": 0.5 / 1.72e6}, {"s2"}),
    "time_drift": ({"time_drift.vx": 0.08, "time_drift.vy": -0.05, "time_drift.vz": 0.1}, {"time"}),
}


def hidden_effect(kind: str) -> Effect:
    """An instance of the Effect subclass in tests/plugins/hidden_<kind>.py."""
    path = PLUGINS / f"hidden_{kind}.py"
    spec = importlib.util.spec_from_file_location(f"hidden_{kind}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    (cls,) = [v for v in vars(module).values() if isinstance(v, type) and issubclass(v, Effect) and v is not Effect and v.__module__ == module.__name__]
    return cls()


def hidden_truth(kind: str, seed: int, values: dict | None = None) -> ErrorModel:
    """A random KR160 with the model's effects and the hidden one (at ``values``, default HIDDEN's)."""
    rng = np.random.default_rng(seed)
    base = random_truth(kr160(), TOOL, parse_effects(MODEL), rng)
    truth = ErrorModel.create(kr160(), TOOL, base.effects + EffectSum((hidden_effect(kind),)), base.as_dict() | (values or HIDDEN[kind][0]))
    return replace(truth, base_rotation=base.base_rotation, base_translation=base.base_translation)


def hidden_case(kind: str, seed: int, n: int = 200):
    """(truth, model of the catalog effects fitted to its measurements, the measurements)."""
    truth = hidden_truth(kind, seed)
    rng = np.random.default_rng(10_000 + seed)
    data = simulate(truth, sample_poses(kr160(), TOOL, n, BOX, rng), rng)
    model = fit(kr160(), TOOL, parse_effects(MODEL), data, cv_folds=0).model
    return truth, model, data
