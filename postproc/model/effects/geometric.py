"""DH parameter errors of every joint: delta theta, d, a, alpha (seed 001 eq. 3)."""

from __future__ import annotations

import numpy as np

from .base import DH, Effect, Param

# Typical magnitudes: seed 001 Table 3, which the shared KR160 sets double.
_TYPICAL = {"dtheta": (0.005, 0.005, 0.005, 0.01, 0.01, 0.01), "dalpha": (0.005, 0.005, 0.005, 0.01, 0.01, 0.01), "dd": (0.25,) * 6, "da": (0.15,) * 6}
_KINDS = ("dtheta", "dd", "da", "dalpha")  # parameter order per joint, matching DH_CHANNELS
# Which of two inseparable DH errors is kept: joint offset, twist, length a, offset d.
_KEEP_ORDER = {"dtheta": 0, "dalpha": 1, "da": 2, "dd": 3}


def _selectors() -> dict[str, np.ndarray]:
    """channel -> (6, 24): d(channel_i)/d(parameter) for the parameter order of ``params``."""
    out = {}
    for c, channel in enumerate(("theta", "d", "a", "alpha")):
        sel = np.zeros((6, 24))
        sel[np.arange(6), 4 * np.arange(6) + c] = 1.0
        out[channel] = sel
    return out


_SELECTORS = _selectors()


class Geometric(Effect):
    name = "geometric"
    kind = "geometry"
    stage = 0  # additive: before any scaling of the lengths
    first_step = True
    summary = "errors of the arm's geometry: each joint's zero offset, link lengths and twists (24 DH parameters)"
    finding = "residuals follow the arm's geometry (link lengths, offsets and twists)"
    identifiability = (
        "Of the 24 DH errors only about 20-24 are separable from position data: with parallel axes 2 and 3, d2 and "
        "d3 are one offset; the first joint's errors duplicate the base frame and the last joint's the tool offset. "
        "The inseparable ones are fixed at zero and reported with the parameters that absorb them."
    )

    def params(self, robot) -> list[Param]:
        out = []
        for i in range(6):
            out.append(Param(f"{self.name}.dtheta{i + 1}", "deg", 0.01, _TYPICAL["dtheta"][i]))
            out.append(Param(f"{self.name}.dd{i + 1}", "mm", 0.1, _TYPICAL["dd"][i]))
            out.append(Param(f"{self.name}.da{i + 1}", "mm", 0.1, _TYPICAL["da"][i]))
            out.append(Param(f"{self.name}.dalpha{i + 1}", "deg", 0.01, _TYPICAL["dalpha"][i]))
        return out

    def keep_priority(self, param_name: str) -> tuple:
        kind = param_name[len(self.name) + 1 : -1]
        return (2, _KEEP_ORDER[kind], int(param_name[-1]))

    def apply_dh(self, dh: DH, values: np.ndarray, data) -> DH:
        geo = np.asarray(values).reshape(6, 4)
        return DH(dh.theta + geo[:, 0], dh.d + geo[:, 1], dh.a + geo[:, 2], dh.alpha + geo[:, 3])

    def dh_derivatives(self, dh_in: DH, values: np.ndarray, data) -> tuple[dict, dict]:
        return {}, dict(_SELECTORS)  # constant (6, 24): the model broadcasts them over the poses
