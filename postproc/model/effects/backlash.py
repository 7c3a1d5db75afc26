"""Gear backlash: delta q_j = h_j s_j, half the lash times the direction the joint approached from.

The direction comes from columns s1..s6, or, when they are absent, from the order of the
rows (the sign of the change from the previous pose; the first pose counts as +1).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .base import Context, Effect, EffectSpecError, Param, parse_int_list


class Backlash(Effect):
    name = "backlash"
    kind = "joint"
    summary = "play in the gears: each joint sits half its lash off, on the side it approached from"
    finding = "residuals change with the direction each joint approached from"
    identifiability = (
        "Separable only when each joint is approached from both sides in the data; with one approach direction "
        "the play is a constant joint offset that geometric.dtheta absorbs."
    )

    def __init__(self, joints=(1, 2, 3, 4, 5, 6)):
        self.joints = tuple(sorted(set(int(j) for j in joints)))

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "Backlash":
        unknown = set(opts) - {"joints"}
        if unknown:
            raise EffectSpecError(f"{cls.name}: unknown option(s) {', '.join(sorted(unknown))} (known: joints)")
        return cls(parse_int_list(cls.name, "joints", opts.get("joints", "1,2,3,4,5,6"), 1, 6))

    def options(self) -> dict:
        return {} if self.joints == (1, 2, 3, 4, 5, 6) else {"joints": list(self.joints)}

    def params(self, robot) -> list[Param]:
        # Half the lash is a play, never negative; a degree of play is no gear any more.
        return [Param(f"{self.name}.h{j}", "deg", 0.01, 0.01, lower=0.0, upper=1.0) for j in self.joints]

    def complete(self, ctx: Context) -> tuple[Context, str | None]:
        if ctx.approach is not None:
            return ctx, None
        note = f"{self.name}: approach directions inferred from the row order (no s1..s6 columns)"
        return replace(ctx, approach=approach_from_order(ctx.q_deg)), note

    def path_columns(self, q_path_deg: np.ndarray) -> dict[str, np.ndarray]:
        return {"approach": approach_from_order(q_path_deg)}

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        basis = np.zeros((ctx.q_deg.shape[0], 6, len(self.joints)))
        for p, j in enumerate(self.joints):
            basis[:, j - 1, p] = ctx.approach[:, j - 1]
        return basis


def approach_from_order(q_deg: np.ndarray) -> np.ndarray:
    """Approach direction of each joint inferred from consecutive rows (+1 where unchanged at the start)."""
    step = np.sign(np.diff(q_deg, axis=0, prepend=q_deg[:1]))
    out = np.empty_like(step)
    out[0] = 1.0
    for_rows = step[1:]
    # A joint that did not move keeps the direction it last approached from.
    out[1:] = for_rows
    zero = out == 0
    if zero.any():
        idx = np.where(~zero, np.arange(len(out))[:, None], 0)
        np.maximum.accumulate(idx, axis=0, out=idx)
        out = np.take_along_axis(out, idx, axis=0)
    return out
