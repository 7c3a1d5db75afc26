"""Error of the measured point's offset from the flange (3 DOF: position measurements see no tool rotation)."""

from __future__ import annotations

import numpy as np

from .base import Effect, Param


class ToolOffset(Effect):
    name = "tool_offset"
    kind = "tool"
    first_step = True
    summary = "where the measured point (tracker target, tool tip) really sits on the flange (3 parameters)"
    finding = "residuals follow the tool orientation (the measured point is not where the tool says)"
    identifiability = (
        "Kept before the DH errors it duplicates: the offset along the flange z axis absorbs geometric.dd6, "
        "the offsets across it geometric.da6 and the joint-6 angle error."
    )

    def params(self, robot) -> list[Param]:
        return [Param(f"{self.name}.d{axis}", "mm", 0.1, 0.5) for axis in "xyz"]

    def keep_priority(self, param_name: str) -> tuple:
        return (0, param_name)

    def tool_basis(self) -> np.ndarray:
        return np.eye(3)
