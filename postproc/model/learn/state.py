"""Saving and restoring the base learners (GPR, PSO-BP network, grid) as JSON-ready dicts.

The transfer learner (``transfer.TrGPRPredictor``) saves itself through ``to_state`` and
stores its GPR learners with these functions; ``residual`` restores either kind. This
module imports no other learner module, so ``residual`` -> ``transfer`` -> ``state`` has
no circle.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from postproc.errors import InputError

from ..predictor_plugins import PluginPredictor, state_of
from ..predictor_plugins import from_state as plugin_from_state
from .gp import GPRPredictor
from .grid import GridPredictor
from .local_gp import Regions
from .nn import PSOBPPredictor


def estimator_state(est) -> dict:
    if isinstance(est, GPRPredictor) and getattr(est, "method_", "exact") == "local":
        r = est.regions_
        return {"type": "gpr-local", "params": est.get_params(), "X": est.X_train_.tolist(), "y": est.y_train_.tolist(),
                "members": [m.tolist() for m in est.members_], "thetas": [_theta(e).tolist() for e in est.experts_], "noise_groups": _groups(est),
                "lo": _finite_or_none(r.lo), "hi": _finite_or_none(r.hi), "margin": r.margin.tolist(),
                "center": est.region_center_.tolist(), "scale": est.region_scale_}
    if isinstance(est, GPRPredictor):
        return {"type": "gpr", "params": est.get_params(), "X": est.X_train_.tolist(), "y": est.y_train_.tolist(),
                "theta": _theta(est.gpr_).tolist(), "weights": None if est.weights_ is None else est.weights_.tolist(), "noise_groups": _groups(est)}
    if isinstance(est, PSOBPPredictor):
        return {"type": "pso-bp", "params": est.get_params(), "weights": est.weights_.tolist(), "shapes": [list(s) for s in est.shapes_],
                "x_mean": est.x_mean_.tolist(), "x_std": est.x_std_.tolist(), "y_mean": est.y_mean_.tolist(), "y_std": est.y_std_.tolist()}
    if isinstance(est, GridPredictor):
        return {"type": "grid", "params": est.get_params(), "axes": [a.tolist() for a in est.axes_], "values": est.interp_.values.tolist()}
    if isinstance(est, PluginPredictor):
        return state_of(est)
    if hasattr(est, "to_state"):
        return est.to_state()
    raise InputError(f"cannot save a predictor of type {type(est).__name__}")


def base_estimator_from_state(state: dict):
    """A GPR, PSO-BP network or grid predictor from its saved state."""
    kind = state["type"]
    if kind == "gpr":
        est = GPRPredictor(**state["params"])
        w = state.get("weights")
        return est.fit_fixed(np.asarray(state["X"]), np.asarray(state["y"]), np.asarray(state["theta"]), None if w is None else np.asarray(w), _groups_of(state))
    if kind == "gpr-local":

        regions = Regions(_inf_from_none(state["lo"], -np.inf), _inf_from_none(state["hi"], np.inf), np.asarray(state["margin"], dtype=float))
        return GPRPredictor(**state["params"]).restore_local(np.asarray(state["X"], dtype=float), np.asarray(state["y"], dtype=float), regions,
                                                             [np.asarray(m, dtype=int) for m in state["members"]], state["thetas"], state["center"], state["scale"],
                                                             _groups_of(state))
    if kind == "pso-bp":
        est = PSOBPPredictor(**state["params"])
        est.weights_ = np.asarray(state["weights"], dtype=float)
        est.shapes_ = [tuple(s) for s in state["shapes"]]
        for key in ("x_mean", "x_std", "y_mean", "y_std"):
            setattr(est, f"{key}_", np.asarray(state[key], dtype=float))
        est.n_features_in_ = len(est.x_mean_)
        return est
    if kind == "grid":

        est = GridPredictor(**state["params"])
        est.axes_ = [np.asarray(a) for a in state["axes"]]
        est.interp_ = RegularGridInterpolator(est.axes_, np.asarray(state["values"]), method="linear", bounds_error=False, fill_value=np.nan)
        est.n_features_in_ = 3
        return est
    plugin = plugin_from_state(state)
    if plugin is not None:
        return plugin
    raise ValueError(f"unknown predictor type '{kind}' (a predictor of your own: load its file with --plugins PATH or POSTPROC_PLUGINS)")


def _theta(gpr) -> np.ndarray:
    """A fitted GP's hyperparameters: the kernel's, with the noise groups' levels where it has them."""
    return getattr(gpr, "theta_full_", gpr.kernel_.theta)


def _groups(est) -> list | None:
    groups = getattr(est, "noise_groups_", None)
    return None if groups is None else groups.tolist()


def _groups_of(state: dict) -> np.ndarray | None:
    """The poses' noise groups of a saved GP (None: one noise level; files before the noise model)."""
    groups = state.get("noise_groups")
    return None if groups is None else np.asarray(groups, dtype=np.int64)


def _finite_or_none(a: np.ndarray) -> list:
    """JSON has no infinity: the outer regions' open sides are stored as null."""
    return [[None if not np.isfinite(v) else float(v) for v in row] for row in a]


def _inf_from_none(rows: list, fill: float) -> np.ndarray:
    return np.array([[fill if v is None else v for v in row] for row in rows], dtype=float)
