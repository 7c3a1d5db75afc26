"""Growth of the link lengths with temperature: d_i and a_i scale by (1 + alpha (temp - reference))."""

from __future__ import annotations

import numpy as np

from .base import DH, Context, Effect, EffectSpecError, Param


class Thermal(Effect):
    name = "thermal"
    kind = "geometry"
    stage = 1  # scales the lengths after the additive DH errors
    needs = ("temp",)
    consumes = ("temp",)
    summary = "growth of the link lengths with the cell temperature (one expansion coefficient)"
    finding = "residuals drift with temperature"
    identifiability = (
        "Separable only when the temperature varies across the set: at one temperature the growth is a scaling of "
        "the link lengths that the geometric length errors (dd, da) absorb."
    )

    def __init__(self, reference_c: float = 20.0):
        self.reference_c = float(reference_c)

    def options(self) -> dict:
        return {} if self.reference_c == 20.0 else {"reference": self.reference_c}

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "Thermal":
        unknown = set(opts) - {"reference"}
        if unknown:
            raise EffectSpecError(f"{cls.name}: unknown option(s) {', '.join(sorted(unknown))} (known: reference)")
        try:
            return cls(float(opts.get("reference", 20.0)))
        except ValueError:
            raise EffectSpecError(f"{cls.name}: option 'reference' must be a temperature in degC, got '{opts['reference']}'") from None

    def params(self, robot) -> list[Param]:
        # Steel grows about 1.2e-5 per K; a cast-aluminium arm about twice that.
        # Bounds: no structural material grows by more than 1e-4 per K.
        return [Param(f"{self.name}.alpha", "1/K", 1e-5, 1.2e-5, lower=-1e-4, upper=1e-4)]

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        return np.asarray(ctx.temp_c, dtype=float) - self.reference_c  # (N,) temperature above the reference

    def apply_dh(self, dh: DH, values: np.ndarray, data) -> DH:
        grow = (1.0 + values[0] * data)[:, None]
        return dh.with_channels(d=dh.d * grow, a=dh.a * grow)

    def dh_derivatives(self, dh_in: DH, values: np.ndarray, data) -> tuple[dict, dict]:
        grow = (1.0 + values[0] * data)[:, None]
        scale = {"d": grow, "a": grow}
        own = {"d": (dh_in.d * data[:, None])[:, :, None], "a": (dh_in.a * data[:, None])[:, :, None]}
        return scale, own

    def draw(self, param: Param, rng: np.random.Generator, magnitude: float) -> float:
        # A structure's expansion coefficient is known to within about 20 %.
        return param.typical * (1.0 + 0.2 * rng.standard_normal())
