"""Cyclic joint errors (gear and reducer eccentricity): delta q_j = sum_k a_jk sin(k q_j) + b_jk cos(k q_j).

Without options the fit chooses the joints and orders the data support (see
``postproc.identify.select_harmonics``) and records them in the model file.
"""

from __future__ import annotations

import numpy as np

from .base import Context, Effect, EffectSpecError, Param, parse_int_list

CANDIDATE_ORDERS = (1, 2, 3, 4)


class JointHarmonics(Effect):
    name = "joint_harmonics"
    kind = "joint"

    def __init__(self, terms: tuple[tuple[int, int], ...] | None = None):
        """terms: (joint 1..6, order >= 1) pairs; None asks the fit to choose them."""
        self.terms = None if terms is None else tuple(sorted(set(terms)))

    @classmethod
    def grid(cls, joints, orders) -> "JointHarmonics":
        return cls(tuple((j, k) for j in joints for k in orders))

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "JointHarmonics":
        unknown = set(opts) - {"joints", "orders", "terms"}
        if unknown:
            raise EffectSpecError(f"joint_harmonics: unknown option(s) {', '.join(sorted(unknown))} (known: joints, orders, terms)")
        if "terms" in opts:
            pairs = []
            for item in opts["terms"].split(","):
                try:
                    j, k = (int(v) for v in item.split(":"))
                except ValueError:
                    raise EffectSpecError(f"joint_harmonics: terms are joint:order pairs, got '{item}'") from None
                if not (1 <= j <= 6 and 1 <= k <= 12):
                    raise EffectSpecError(f"joint_harmonics: term '{item}' out of range (joint 1..6, order 1..12)")
                pairs.append((j, k))
            return cls(tuple(pairs))
        if not opts:
            return cls(None)
        joints = parse_int_list("joint_harmonics", "joints", opts.get("joints", "1,2,3,4,5,6"), 1, 6)
        orders = parse_int_list("joint_harmonics", "orders", opts.get("orders", "1,2,3,4"), 1, 12)
        return cls.grid(joints, orders)

    @property
    def resolved(self) -> bool:
        return self.terms is not None

    def options(self) -> dict:
        if self.terms is None:
            return {}
        joints = sorted({j for j, _ in self.terms})
        orders = sorted({k for _, k in self.terms})
        if set(self.terms) == {(j, k) for j in joints for k in orders}:
            return {"joints": joints, "orders": orders}
        return {"terms": [f"{j}:{k}" for j, k in self.terms]}

    def _terms(self):
        if self.terms is None:
            raise EffectSpecError("joint_harmonics without options is resolved by 'fit'; give joints and orders to use it here")
        return self.terms

    def params(self, robot) -> list[Param]:
        out = []
        for j, k in self._terms():
            out.append(Param(f"joint_harmonics.j{j}_sin{k}", "deg", 0.01, 0.01))
            out.append(Param(f"joint_harmonics.j{j}_cos{k}", "deg", 0.01, 0.01))
        return out

    def joint_basis(self, ctx: Context, robot) -> np.ndarray:
        terms = self._terms()
        q = np.deg2rad(ctx.q_deg)
        basis = np.zeros((q.shape[0], 6, 2 * len(terms)))
        for p, (j, k) in enumerate(terms):
            basis[:, j - 1, 2 * p] = np.sin(k * q[:, j - 1])
            basis[:, j - 1, 2 * p + 1] = np.cos(k * q[:, j - 1])
        return basis
