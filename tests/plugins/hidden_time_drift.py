"""A hidden effect of one variable no catalog effect reads: the measured point drifts at a
constant velocity over the session (the tracker's stand settling), delta p = v t. Thermal
growth reads the temperature, not the time; in a climate-controlled cell the two do not
go together. A plugin-style effect file: not in the catalog, loaded by tests/hidden_plugins.py.
"""

from __future__ import annotations

import numpy as np

from postproc.model.effects.api import Context, Effect, Param


class TimeDrift(Effect):
    name = "time_drift"
    kind = "cartesian"
    needs = ("t",)
    summary = "the measured point drifts at a constant velocity over the session"
    finding = "residuals drift with time"

    def params(self, robot) -> list[Param]:
        return [Param(f"{self.name}.v{axis}", "mm/h", 0.01, 0.05) for axis in "xyz"]

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        hours = np.asarray(ctx.time_s, dtype=float) / 3600.0
        basis = np.zeros((len(hours), 3, 3))
        basis[:, [0, 1, 2], [0, 1, 2]] = hours[:, None]
        return basis
