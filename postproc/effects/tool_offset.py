"""Error of the measured point's offset from the flange (3 DOF: position measurements see no tool rotation)."""

from __future__ import annotations

from .base import Effect, Param


class ToolOffset(Effect):
    name = "tool_offset"
    kind = "tool"

    def params(self, robot) -> list[Param]:
        return [Param(f"tool_offset.d{axis}", "mm", 0.1, 0.5) for axis in "xyz"]
