"""Growth of the link lengths with temperature: d_i and a_i scale by (1 + alpha (temp - reference))."""

from __future__ import annotations

from .base import Effect, EffectSpecError, Param


class Thermal(Effect):
    name = "thermal"
    kind = "geometry"
    needs = ("temp",)

    def __init__(self, reference_c: float = 20.0):
        self.reference_c = float(reference_c)

    def options(self) -> dict:
        return {} if self.reference_c == 20.0 else {"reference": self.reference_c}

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "Thermal":
        unknown = set(opts) - {"reference"}
        if unknown:
            raise EffectSpecError(f"thermal: unknown option(s) {', '.join(sorted(unknown))} (known: reference)")
        try:
            return cls(float(opts.get("reference", 20.0)))
        except ValueError:
            raise EffectSpecError(f"thermal: option 'reference' must be a temperature in degC, got '{opts['reference']}'") from None

    def params(self, robot) -> list[Param]:
        # Steel grows about 1.2e-5 per K; a cast-aluminium arm about twice that.
        # Bounds: no structural material grows by more than 1e-4 per K.
        return [Param("thermal.alpha", "1/K", 1e-5, 1.2e-5, lower=-1e-4, upper=1e-4)]
