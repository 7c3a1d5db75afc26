"""Data-driven predictors of what the physics model leaves, as scikit-learn estimators.

Each follows scikit-learn's conventions (``__init__`` stores arguments only, ``fit``
returns self, learned state ends in ``_``), so they can be cloned, cross-validated and
compared. Inputs and outputs are arrays: X (N, features), y (N, 3) position errors in mm.
"""

from .gp import GPRPredictor
from .grid import GridPredictor, OutsideGridError
from .nn import PSOBPPredictor, hidden_size_table
from .residual import FEATURES, Residual
from .transfer import TrGPRPredictor, region_similarity

__all__ = ["FEATURES", "GPRPredictor", "GridPredictor", "OutsideGridError", "PSOBPPredictor", "Residual", "TrGPRPredictor", "hidden_size_table", "region_similarity"]
