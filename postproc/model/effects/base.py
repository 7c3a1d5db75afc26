"""The Effect interface: what every error effect declares and computes.

An effect is one module in ``postproc/model/effects/`` holding one ``Effect`` subclass; the
catalog finds it by itself (``postproc.model.effects.CATALOG``). The rest of postproc only
talks to effects through this interface — it never tests an effect's name. An effect
owns:

- its parameters, their units, scales and bounds (``params``) and its options
  (``options`` / ``from_options``: the ``name[key=value;...]`` spec);
- the measurement columns it needs (``needs``) and the compensation inputs it consumes
  (``consumes``: ``force`` from ``--force``, ``temp`` from ``--temp``);
- how it perturbs the robot, by its ``kind``:

  ``joint``      an offset of the joint values, linear in the parameters
                 (``prepare`` returns d(delta q)/d(parameters), (N, 6, P) degrees per unit);
  ``geometry``   a change of the DH table (``apply_dh`` and its derivatives ``dh_derivatives``);
  ``tool``       the measured point's offset from the flange (``tool_basis``, (3, P) mm per unit);
  ``cartesian``  a displacement of the measured point in the robot base frame, linear in
                 the parameters (``prepare`` returns (N, 3, P) mm per unit);
  ``base``       the transform robot base -> measurement frame (``transform``, ``base_jacobian``);

- its identifiability notes (``identifiability``; ``keep_priority`` orders which of two
  inseparable parameters is kept), what ``diagnose`` says when it is missing
  (``finding`` / ``describe_finding``), how the simulator draws a true value (``draw``),
  and a plain-language description for the report (``summary``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from postproc.errors import InputError

#: The kinds of contribution (see the module docstring), in the order the model applies them.
KINDS = ("joint", "geometry", "tool", "cartesian", "base")
#: DH channels of a geometry change: angles in degrees, lengths in mm.
DH_CHANNELS = ("theta", "d", "a", "alpha")


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
    gravity_torque: np.ndarray | None  # (N, 6) N*m at the commanded joints (unused: effects compute their own)
    force_torque: np.ndarray | None  # (N, 6) N*m, J^T F at the commanded joints
    approach: np.ndarray | None  # (N, 6)
    temp_c: np.ndarray | None  # (N,)
    time_s: np.ndarray | None  # (N,)
    tool_mm: np.ndarray | None = None  # (3,) nominal measured point in the flange frame
    force_n: np.ndarray | None = None  # (N, 3) N, base frame
    previous_q_deg: np.ndarray | None = None  # (N, k, 6) the targets before each pose in path order (postproc.model.path_history)


@dataclass(frozen=True)
class DH:
    """A per-pose DH table: theta and alpha (N, 6) degrees, d and a (N, 6) mm."""

    theta: np.ndarray
    d: np.ndarray
    a: np.ndarray
    alpha: np.ndarray

    def channel(self, name: str) -> np.ndarray:
        return getattr(self, name)

    def with_channels(self, **channels) -> "DH":
        return replace(self, **channels)


class Effect:
    """Base class. Subclasses set ``name`` and ``kind`` and override what their kind needs."""

    name: str = ""
    kind: str = ""  # one of KINDS
    #: measurement column groups the effect reads (see MeasurementSet.has): force, approach, temp, t
    needs: tuple[str, ...] = ()
    #: inputs compensation must be given for this effect (force: --force, temp: --temp)
    consumes: tuple[str, ...] = ()
    #: plain-language description for the report
    summary: str = ""
    #: what the residual looks like when this effect is missing (diagnose's finding)
    finding: str = ""
    #: which parameters the data cannot separate, and what absorbs them
    identifiability: str = ""
    #: tried by the ladder as a first step from the nominal robot
    first_step: bool = False
    #: geometry effects are applied in increasing stage (additive errors before scalings)
    stage: int = 0
    #: the effect's prediction changes with the payload the flange carries (gravity): a
    #: model with one is only right at the load it was measured with (program_check)
    payload_dependent: bool = False

    @property
    def stated_payload_kg(self) -> float | None:
        """The payload (kg) the model was fitted at, where this effect records one."""
        return None

    # ------------------------------------------------------------ declaration

    def params(self, robot) -> list[Param]:
        raise NotImplementedError

    def options(self) -> dict:
        """Options as recorded in the model file (and written in brackets on the command line)."""
        return {}

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "Effect":
        if opts:
            raise EffectSpecError(f"effect '{cls.name}' takes no options, got '{';'.join(f'{k}={v}' for k, v in opts.items())}'")
        return cls()

    def spec(self) -> str:
        opts = self.options()
        if not opts:
            return self.name
        body = ";".join(f"{k}={','.join(str(v) for v in vals) if isinstance(vals, (list, tuple)) else vals}" for k, vals in opts.items())
        return f"{self.name}[{body}]"

    # ------------------------------------------------------ term families (fit chooses)

    @property
    def resolved(self) -> bool:
        """False for an effect whose terms the fit must choose from the data first."""
        return True

    def candidate_terms(self) -> list:
        """The terms the fit may choose from (effects that are not ``resolved``)."""
        return []

    #: how the fit chooses among ``candidate_terms``: "best_subset" (tens of candidates, a few
    #: terms; ``postproc.model.term_selection``) or "forward" (hundreds of (joint, order)
    #: candidates, tens of terms; ``postproc.model.harmonic_scan``)
    term_search: str = "best_subset"

    def with_terms(self, terms) -> "Effect":
        raise NotImplementedError

    def term_columns(self, dp_dq: np.ndarray, q_deg: np.ndarray, term) -> np.ndarray:
        """(N, 3, k) d(measured position)/d(term's coefficients), given d p/d q_j per degree (N, 3, 6)."""
        raise NotImplementedError

    # ------------------------------------------------------------- data side

    def complete(self, ctx: Context) -> tuple[Context, str | None]:
        """Fill in a column the data lack but the effect can infer; returns a note saying so."""
        return ctx, None

    def path_columns(self, q_path_deg: np.ndarray) -> dict[str, np.ndarray]:
        """Columns compensation derives from the program's joint path (in program order)."""
        return {}

    def prepare(self, ctx: Context, robot):
        """What the effect needs per data set, independent of the parameter values."""
        return None

    # --------------------------------------------------------- per kind

    def apply_dh(self, dh: DH, values: np.ndarray, data) -> DH:
        raise NotImplementedError

    def dh_derivatives(self, dh_in: DH, values: np.ndarray, data) -> tuple[dict, dict]:
        """(scale, own): out_c = scale_c * in_c + f(params) per channel c; ``scale`` maps a
        channel to (N, 6) (absent: 1), ``own`` a channel to d out_c / d params, (N, 6, P) or,
        when it does not vary over the poses, (6, P)."""
        raise NotImplementedError

    def tool_basis(self) -> np.ndarray:
        raise NotImplementedError

    def transform(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def base_jacobian(self, rotated: np.ndarray, values: np.ndarray) -> np.ndarray:
        """(N, 3, P) derivative of the measured positions; ``rotated`` = measured - translation."""
        raise NotImplementedError

    # ------------------------------------------------------------ explaining

    def keep_priority(self, param_name: str) -> tuple:
        """Sort key: among parameters the data cannot separate, the smaller key is kept."""
        return (1, param_name)

    def describe_finding(self) -> str:
        return self.finding or f"{self.name} accounts for part of the residual"

    def joint_compliance(self, values: dict[str, float]) -> np.ndarray | None:
        """The joint compliances (6,) rad/(N*m) this effect identified, from the model's
        values by parameter name; None for an effect that does not model joint stiffness."""
        return None

    def draw(self, param: Param, rng: np.random.Generator, magnitude: float) -> float:
        """A true value for the simulator: the initial value plus magnitude x typical x N(0, 1)."""
        return param.initial + magnitude * param.typical * rng.standard_normal()

    # ---------------------------------------------------------------- algebra

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

    def of_kind(self, kind: str) -> list[Effect]:
        return [e for e in self.effects if e.kind == kind]

    def replaced(self, old: Effect, new: Effect | None) -> "EffectSum":
        """The same sum with ``old`` swapped for ``new`` (or dropped when ``new`` is None)."""
        return EffectSum(tuple((new if e is old else e) for e in self.effects if not (e is old and new is None)))

    def needing(self, group: str) -> list[Effect]:
        return [e for e in self.effects if group in e.needs]

    def consuming(self, group: str) -> list[Effect]:
        return [e for e in self.effects if group in e.consumes]

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
