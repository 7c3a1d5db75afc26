"""What every error effect declares: its parameters, the columns it needs, how it perturbs the robot.

Effects are small immutable objects that add up: ``Geometric() + JointCompliance()`` is an
``EffectSum``. Each contributes in one of four ways, which ``postproc.errormodel`` composes:

- ``joint``: an offset of the joint values, linear in the effect's parameters
  (``joint_basis`` gives d(delta q)/d(parameters), degrees per parameter unit);
- ``geometry``: changes of the DH table (``geometry_terms``);
- ``tool``: the measured point's offset from the flange;
- ``base``: the transform from robot base to measurement frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


class EffectSpecError(InputError):
    """An effect name or option that does not exist or does not fit the data."""


@dataclass(frozen=True)
class Param:
    """One identifiable parameter: name (global: effects may share one), unit, scale, and a
    typical magnitude used by the simulator for random true robots."""

    name: str
    unit: str
    scale: float
    typical: float
    initial: float = 0.0
    lower: float = -np.inf
    upper: float = np.inf


@dataclass(frozen=True)
class Context:
    """Per-pose data an effect may read, computed once per measurement set (never per parameter)."""

    q_deg: np.ndarray  # (N, 6)
    gravity_torque: np.ndarray  # (N, 6) N*m at the commanded joints
    force_torque: np.ndarray | None  # (N, 6) N*m, J^T F at the commanded joints
    approach: np.ndarray | None  # (N, 6)
    temp_c: np.ndarray | None  # (N,)
    time_s: np.ndarray | None  # (N,)


class Effect:
    """Base class. Subclasses set ``name`` and ``kind`` and override what their kind needs."""

    name: str = ""
    kind: str = ""  # "joint", "geometry", "tool" or "base"
    #: measurement column groups the effect reads (see MeasurementSet.has)
    needs: tuple[str, ...] = ()

    def params(self, robot) -> list[Param]:
        raise NotImplementedError

    def options(self) -> dict:
        """Options as recorded in the model file (and written in brackets on the command line)."""
        return {}

    def spec(self) -> str:
        opts = self.options()
        if not opts:
            return self.name
        body = ";".join(f"{k}={','.join(str(v) for v in vals) if isinstance(vals, (list, tuple)) else vals}" for k, vals in opts.items())
        return f"{self.name}[{body}]"

    def joint_basis(self, ctx: Context, robot) -> np.ndarray:
        """(N, 6, P) degrees of joint offset per unit of each of this effect's parameters."""
        raise NotImplementedError

    def __add__(self, other: "Effect | EffectSum") -> "EffectSum":
        return EffectSum((self,)) + other

    def __repr__(self) -> str:
        return self.spec()

    def __eq__(self, other) -> bool:
        return isinstance(other, Effect) and self.spec() == other.spec()

    def __hash__(self) -> int:
        return hash(self.spec())


@dataclass(frozen=True)
class EffectSum:
    """An ordered set of effects; adding one that is already present is an error."""

    effects: tuple[Effect, ...] = ()

    def __add__(self, other: "Effect | EffectSum") -> "EffectSum":
        extra = other.effects if isinstance(other, EffectSum) else (other,)
        names = [e.name for e in self.effects]
        for e in extra:
            if e.name in names:
                raise EffectSpecError(f"effect '{e.name}' appears twice")
            names.append(e.name)
        return EffectSum(self.effects + tuple(extra))

    def __iter__(self):
        return iter(self.effects)

    def __len__(self) -> int:
        return len(self.effects)

    def names(self) -> list[str]:
        return [e.name for e in self.effects]

    def get(self, name: str) -> Effect | None:
        return next((e for e in self.effects if e.name == name), None)

    def spec(self) -> str:
        return ",".join(e.spec() for e in self.effects) or "none"


def parse_int_list(effect: str, key: str, text: str, low: int, high: int) -> tuple[int, ...]:
    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise EffectSpecError(f"{effect}: option '{key}' must be integers, got '{text}'") from None
    bad = [v for v in values if not low <= v <= high]
    if bad or not values:
        raise EffectSpecError(f"{effect}: option '{key}' must list values in {low}..{high}, got '{text}'")
    return tuple(sorted(set(values)))
