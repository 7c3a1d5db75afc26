"""Predictors from outside the package: the interface a plugin predictor follows, and the table of them.

The built-in predictors (gpr, tr-gpr, pso-bp, grid) are wired into ``identify.fit_predictor``
and ``state``; a plugin predictor is a ``PluginPredictor`` subclass, found by
``postproc.plugins`` in a file given by ``--plugins``, ``POSTPROC_PLUGINS`` or the
``postproc.predictors`` entry-point group, and used as ``fit --predictor NAME``.
"""

from __future__ import annotations

import numpy as np

from postproc.errors import InputError

#: postproc.model.learn.features.KINDS, not imported from there: that package loads scikit-learn,
#: and every model file read consults this table (test_plugins checks the two agree).
FEATURE_KINDS = ("pose", "joints+disp", "position", "tcp+joints", "joints", "tcp+joints+travel")


class PluginPredictor:
    """Base class of a predictor written outside postproc (scikit-learn conventions).

    Set ``name`` (the ``--predictor`` value) and ``features`` (what it is fed: ``pose``
    = the nominal position and orientation of the measured point, ``joints+disp`` = the
    joints and the displacement from the first pose, ``position`` = x, y, z mm,
    ``tcp+joints`` = x, y, z mm and the 6 joints in degrees, ``joints`` = the 6 joints,
    ``tcp+joints+travel`` = ``tcp+joints`` and log(1 + mm) of the TCP travel of the move into
    the pose and of the two moves before it: the pose's history in the path), then:

    - ``__init__(self, random_state=0)``;
    - ``fit(self, X, y)`` with X (N, features) and y (N, 3) mm, returning self; a predictor
      that can trust poses unequally may take ``fit(self, X, y, sample_weight=None)``:
      under ``--noise-model settle`` it is given (N,) weights, 1 / each pose's relative noise
      variance (``postproc.model.noise_model``); one without the argument is refused there;
    - ``predict(self, X)`` -> (N, 3) mm;
    - ``to_state(self)`` -> a JSON-ready dict, and the classmethod ``from_state(cls, state)``
      that rebuilds the fitted predictor from it (the model file stores the state).
    """

    name: str = ""
    features: str = "pose"

    def __init__(self, random_state: int = 0):
        self.random_state = random_state

    def fit(self, X: np.ndarray, y: np.ndarray) -> "PluginPredictor":
        raise NotImplementedError

    def predict(self, X: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def to_state(self) -> dict:
        raise NotImplementedError

    @classmethod
    def from_state(cls, state: dict) -> "PluginPredictor":
        raise NotImplementedError


# Module-level on purpose, like the effect catalog: a model file names its predictor and
# is read anywhere (workers too). Only ``register`` (called by postproc.plugins) adds to it.
PREDICTORS: dict[str, type[PluginPredictor]] = {}
BUILTIN = ("gpr", "tr-gpr", "pso-bp", "grid")


def register(cls: type[PluginPredictor], where: str) -> None:
    """Add a plugin predictor class; the same name from the same module again replaces it."""
    if not (isinstance(cls, type) and issubclass(cls, PluginPredictor) and cls.name):
        raise InputError(f"{where}: not a PluginPredictor subclass with a name")
    if cls.name in BUILTIN:
        raise InputError(f"{where}: predictor '{cls.name}' is a built-in predictor's name; choose another")
    if cls.features not in FEATURE_KINDS:
        raise InputError(f"{where}: predictor '{cls.name}' has features '{cls.features}', not one of {', '.join(FEATURE_KINDS)}")
    held = PREDICTORS.get(cls.name)
    if held is not None and held.__module__ != cls.__module__:
        raise InputError(f"{where}: predictor '{cls.name}' is already defined by {held.__module__}")
    PREDICTORS[cls.name] = cls


def predictor_names() -> tuple[str, ...]:
    """Every ``--predictor`` value: the built-ins, then the plugins loaded."""
    return BUILTIN + tuple(PREDICTORS)


def state_of(est: PluginPredictor) -> dict:
    """The saved state of a plugin predictor, tagged with its name (``type``)."""
    return {**est.to_state(), "type": est.name}


def from_state(state: dict) -> PluginPredictor | None:
    """The plugin predictor a saved state names, None when no loaded plugin has that name."""
    cls = PREDICTORS.get(state.get("type"))
    return None if cls is None else cls.from_state(state)
