"""DH parameter errors of every joint: delta theta, d, a, alpha (seed 001 eq. 3)."""

from __future__ import annotations

from .base import Effect, Param

# Typical magnitudes: seed 001 Table 3, which the shared KR160 sets double.
_TYPICAL = {"dtheta": (0.005, 0.005, 0.005, 0.01, 0.01, 0.01), "dalpha": (0.005, 0.005, 0.005, 0.01, 0.01, 0.01), "dd": (0.25,) * 6, "da": (0.15,) * 6}


class Geometric(Effect):
    name = "geometric"
    kind = "geometry"

    def params(self, robot) -> list[Param]:
        out = []
        for i in range(6):
            out.append(Param(f"geometric.dtheta{i + 1}", "deg", 0.01, _TYPICAL["dtheta"][i]))
            out.append(Param(f"geometric.dd{i + 1}", "mm", 0.1, _TYPICAL["dd"][i]))
            out.append(Param(f"geometric.da{i + 1}", "mm", 0.1, _TYPICAL["da"][i]))
            out.append(Param(f"geometric.dalpha{i + 1}", "deg", 0.01, _TYPICAL["dalpha"][i]))
        return out
