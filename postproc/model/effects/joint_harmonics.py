"""Cyclic joint errors (gear and reducer eccentricity): delta q_j = sum_k a_jk sin(k q_j) + b_jk cos(k q_j).

Without options the fit chooses the joints and orders the data support (see
``postproc.model.identify.select_terms``, best subset with a stability check) and records them in the model file.
With ``max_order=K`` (and optionally ``joints=``) it chooses among every order 1..K instead,
by forward selection with cross-validation that holds out whole commanded positions
(``postproc.model.identify.select_cyclic_terms``): a joint's cyclic error as a long Fourier
series, which dense data (e.g. the UR10's Series A) support with tens of terms.

Source: a strain-wave (harmonic drive) gear's transmission error is periodic; besides the
fast components tied to the wave generator, eccentric and tilted mounting of the circular
spline and flexspline make it vary once and twice per output revolution, i.e. orders 1 and
2 of the joint angle (Ghorbel, Gandhi & Alpeter, "On the kinematic error in harmonic drive
gears", ASME J. Mechanical Design 123(1), 2001, 90-97; Tuttle & Seering, IEEE Trans.
Robotics and Automation 12(3), 1996, 368-374). Orders 1 and 2 are separable from the
geometry and the compliance only on a joint that turns over much of a revolution: over a
range of less than about 90 degrees sin/cos of order 1 and 2 are nearly a constant, a slope
and a curvature, which the joint offset, the DH errors and the gravity compliance already
carry; the candidate search then finds no support for them, and says so. An output-side
angle sensor (an integrated joint module's magnetic encoder) errs by a Fourier series in
the shaft angle as well, at orders its construction sets (Hu, Zhan, Han, Hu, Ye & Yu, "An
angle error compensation method based on harmonic analysis for integrated joint modules",
Sensors 20(6), 1715, 2020): the UR10's order 17 on joints 1-3 (docs/guide/explain.md)
fits that reading better than the gear's.
"""

from __future__ import annotations

import numpy as np

from .base import Context, Effect, EffectSpecError, Param, parse_int_list

CANDIDATE_ORDERS = (1, 2, 3, 4)
# Highest order a term may name: a strain-wave gear's transmission error has its main
# component at twice the wave generator's speed, i.e. at order 2 x ratio of the joint angle
# (about 200 on a 1:100 or 1:101 reducer) and harmonics of it above; 1000 leaves room for
# twice that on ratios up to 1:250 and stays far below what a float angle can resolve.
MAX_ORDER = 1000


class JointHarmonics(Effect):
    name = "joint_harmonics"
    kind = "joint"
    summary = "cyclic joint errors of gears and reducers: sin/cos of a joint's angle and its multiples"
    finding = "residuals follow sin/cos of a joint angle"
    identifiability = (
        "The order-1 terms of a joint whose axis stays parallel to gravity's plane trade against its compliance and "
        "the DH errors (cos q is the gravity torque's shape); higher orders separate given a joint range of more "
        "than one period. Without options the fit keeps only the terms cross-validation supports."
    )

    def __init__(self, terms: tuple[tuple[int, int], ...] | None = None, max_order: int | None = None,
                 search_joints: tuple[int, ...] = (1, 2, 3, 4, 5, 6)):
        """terms: (joint 1..6, order >= 1) pairs; None asks the fit to choose them: among
        orders 1..4 by best subset, or, with ``max_order``, among ``search_joints`` x orders
        1..max_order by forward selection."""
        self.terms = None if terms is None else tuple(sorted(set(terms)))
        self.max_order = None if terms is not None else max_order
        self.search_joints = tuple(search_joints)
        self.term_search = "best_subset" if self.max_order is None else "forward"

    @classmethod
    def grid(cls, joints, orders) -> "JointHarmonics":
        return cls(tuple((j, k) for j in joints for k in orders))

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "JointHarmonics":
        unknown = set(opts) - {"joints", "orders", "terms", "max_order"}
        if unknown:
            raise EffectSpecError(f"{cls.name}: unknown option(s) {', '.join(sorted(unknown))} (known: joints, orders, terms, max_order)")
        if "max_order" in opts:
            if set(opts) - {"max_order", "joints"}:
                raise EffectSpecError(f"{cls.name}: max_order asks the fit to choose the terms; it goes with joints only")
            max_order = parse_int_list(cls.name, "max_order", opts["max_order"], 1, MAX_ORDER)
            if len(max_order) != 1:
                raise EffectSpecError(f"{cls.name}: max_order is one order, got '{opts['max_order']}'")
            return cls(None, max_order[0], parse_int_list(cls.name, "joints", opts.get("joints", "1,2,3,4,5,6"), 1, 6))
        if "terms" in opts:
            pairs = []
            for item in opts["terms"].split(","):
                try:
                    j, k = (int(v) for v in item.split(":"))
                except ValueError:
                    raise EffectSpecError(f"{cls.name}: terms are joint:order pairs, got '{item}'") from None
                if not (1 <= j <= 6 and 1 <= k <= MAX_ORDER):
                    raise EffectSpecError(f"{cls.name}: term '{item}' out of range (joint 1..6, order 1..{MAX_ORDER})")
                pairs.append((j, k))
            return cls(tuple(pairs))
        if not opts:
            return cls(None)
        joints = parse_int_list(cls.name, "joints", opts.get("joints", "1,2,3,4,5,6"), 1, 6)
        orders = parse_int_list(cls.name, "orders", opts.get("orders", "1,2,3,4"), 1, MAX_ORDER)
        return cls.grid(joints, orders)

    @property
    def resolved(self) -> bool:
        return self.terms is not None

    def options(self) -> dict:
        if self.terms is None:
            return {} if self.max_order is None else {"joints": list(self.search_joints), "max_order": self.max_order}
        joints = sorted({j for j, _ in self.terms})
        orders = sorted({k for _, k in self.terms})
        if set(self.terms) == {(j, k) for j in joints for k in orders}:
            return {"joints": joints, "orders": orders}
        return {"terms": [f"{j}:{k}" for j, k in self.terms]}

    def _terms(self):
        if self.terms is None:
            raise EffectSpecError(f"{self.name} without options is resolved by 'fit'; give joints and orders to use it here")
        return self.terms

    def params(self, robot) -> list[Param]:
        out = []
        for j, k in self._terms():
            out.append(Param(f"{self.name}.j{j}_sin{k}", "deg", 0.01, 0.01))
            out.append(Param(f"{self.name}.j{j}_cos{k}", "deg", 0.01, 0.01))
        return out

    def candidate_terms(self) -> list[tuple[int, int]]:
        orders = CANDIDATE_ORDERS if self.max_order is None else range(1, self.max_order + 1)
        return [(j, k) for j in self.search_joints for k in orders]

    def with_terms(self, terms) -> "JointHarmonics":
        return JointHarmonics(tuple(terms))

    def term_columns(self, dp_dq: np.ndarray, q_deg: np.ndarray, term) -> np.ndarray:
        j, k = term
        q = np.deg2rad(q_deg[:, j - 1])
        return np.stack([dp_dq[:, :, j - 1] * np.sin(k * q)[:, None], dp_dq[:, :, j - 1] * np.cos(k * q)[:, None]], axis=-1)

    def describe_finding(self) -> str:
        if not self.terms:
            return self.finding
        parts = []
        for j in sorted({j for j, _ in self.terms}):
            orders = sorted(k for jj, k in self.terms if jj == j)
            parts.append(f"joint {j}" + (f" (order {', '.join(map(str, orders))})" if orders != [1] else ""))
        return "residuals follow sin/cos of " + " and ".join(parts)

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        terms = self._terms()
        q = np.deg2rad(ctx.q_deg)
        basis = np.zeros((q.shape[0], 6, 2 * len(terms)))
        for p, (j, k) in enumerate(terms):
            basis[:, j - 1, 2 * p] = np.sin(k * q[:, j - 1])
            basis[:, j - 1, 2 * p + 1] = np.cos(k * q[:, j - 1])
        return basis
