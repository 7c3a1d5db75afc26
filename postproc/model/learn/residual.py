"""A predictor attached to an error model: what to feed it, how to save and restore it.

``Residual`` wraps a fitted estimator with its feature kind, so that ``ErrorModel``
adds ``residual.predict(robot, tool, q)`` to the physics. ``to_state`` / ``from_state``
make it JSON: the GPR is stored as its training data and optimised kernel (restored
exactly by refitting with the kernel fixed), the network as its weights, the grid as its
nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postproc.errors import ModelFileError

from .features import HISTORY_KINDS, features
from .state import base_estimator_from_state, estimator_state
from .transfer import TrGPRPredictor

FEATURES = {"gpr": "pose", "tr-gpr": "pose", "pso-bp": "joints+disp", "grid": "position"}


@dataclass(frozen=True)
class Residual:
    kind: str
    feature_kind: str
    estimator: object
    reference: np.ndarray | None = None  # pso-bp: the displacement reference point

    @property
    def reads_history(self) -> bool:
        """Whether its inputs include the targets before each pose (``previous_q_deg``)."""
        return self.feature_kind in HISTORY_KINDS

    def inputs(self, robot, tool_mm, q_deg, previous_q_deg=None):
        return features(robot, tool_mm, q_deg, self.feature_kind, self.reference, previous_q_deg)

    def predict(self, robot, tool_mm, q_deg, previous_q_deg=None) -> np.ndarray:
        """(N, 3) predicted residual; ``previous_q_deg`` (N, k, 6): the targets before each pose
        in path order (postproc.model.path_history), needed where ``reads_history``."""
        return np.asarray(self.estimator.predict(self.inputs(robot, tool_mm, q_deg, previous_q_deg)), dtype=float).reshape(-1, 3)

    # ------------------------------------------------------------- state
    def to_state(self) -> dict:
        est = self.estimator
        state = {"kind": self.kind, "features": self.feature_kind, "reference": None if self.reference is None else self.reference.tolist()}
        state["estimator"] = estimator_state(est)
        return state

    @classmethod
    def from_state(cls, state: dict, source: str) -> "Residual":
        try:
            est = estimator_from_state(state["estimator"])
            ref = state.get("reference")
            return cls(state["kind"], state["features"], est, None if ref is None else np.asarray(ref, dtype=float))
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelFileError(f"{source}: key 'predictor': not a readable predictor ({exc})") from None


def estimator_from_state(state: dict):
    """Any predictor from its saved state: the transfer learner here, the base learners in ``state``."""
    if state["type"] == "tr-gpr":
        return TrGPRPredictor.from_state(state)
    return base_estimator_from_state(state)
