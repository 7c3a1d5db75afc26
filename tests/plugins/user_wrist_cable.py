"""user_wrist_cable: the wrist cable pack twists joint 4 as joint 5 bends (a test plugin, NOT in the catalog).

Written by `postproc effect new user_wrist_cable`; edited: the texts and the driver in prepare().

    postproc effect check user_wrist_cable.py                                  # the contract checks
    postproc fit DATA.csv --robot R --effects geometric,user_wrist_cable --plugins user_wrist_cable.py -o model.json
    postproc compensate PROGRAM --model model.json --plugins user_wrist_cable.py -o OUT

The model file records this file's sha256: a model fitted with it is refused (exit 2)
where the file is not loaded or has changed since. Reference: docs/own-effect.md, and
the context fields, units and helpers in postproc.model.effects.api.
"""

from __future__ import annotations

import numpy as np

# Everything an effect may use is in postproc.model.effects.api; nothing else is needed.
from postproc.model.effects.api import Context, Effect, EffectSpecError, Param, parse_int_list


class UserWristCable(Effect):
    # The name in --effects and in model files: lower case, unique, not a built-in effect's.
    name = "user_wrist_cable"
    # How the effect perturbs the robot. "joint": an offset of the joint values, linear in the
    # parameters; prepare() returns d(offset)/d(parameters). Other kinds ("cartesian",
    # "geometry", "tool", "base"): see postproc.model.effects.api.
    kind = "joint"
    # Measurement columns it cannot do without: "force", "approach", "temp", "t".
    needs = ()
    # Inputs compensate must be given for it: "force" (--force), "temp" (--temp).
    consumes = ()
    # EDIT the three texts: the report, diagnose and `effect check` use them.
    summary = "the wrist cable pack twists joint 4 in proportion to joint 5's bend"
    finding = "residuals follow the angle of joint 5, not joint 4's own angle"
    identifiability = (
        "Linear in joint 5's angle: the offset at q5 = 0 is zero, so the joint 4 zero offset (geometric.dtheta) "
        "stays separable; needs poses that bend joint 5 both ways."
    )

    def __init__(self, joints=(4,), by=5):
        self.joints = tuple(joints)  # the joints (1..6) that get an offset
        self.by = int(by)  # the joint (1..6) whose angle drives it

    # ------------------------------------------------------------------ options
    # Written on the command line as user_wrist_cable[joints=4;by=5] and recorded in the model file.
    def options(self) -> dict:
        return {} if (self.joints, self.by) == ((4,), 5) else {"joints": list(self.joints), "by": self.by}

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "UserWristCable":
        unknown = set(opts) - {"joints", "by"}
        if unknown:
            raise EffectSpecError(f"{cls.name}: unknown option(s) {', '.join(sorted(unknown))} (known: joints, by)")
        joints = parse_int_list(cls.name, "joints", opts.get("joints", "4"), 1, 6)
        by = parse_int_list(cls.name, "by", opts.get("by", "5"), 1, 6)
        if len(by) != 1:
            raise EffectSpecError(f"{cls.name}: option 'by' is one joint, got '{opts['by']}'")
        return cls(joints, by[0])

    # --------------------------------------------------------------- parameters
    def params(self, robot) -> list[Param]:
        # One coefficient per offset joint. scale: the size the fit works in; typical: the
        # size the simulator draws a true value with; lower/upper: what physics allows.
        return [Param(f"{self.name}.k{j}", "deg/rad", scale=0.01, typical=0.3, lower=-1.0, upper=1.0) for j in self.joints]

    # ------------------------------------------------------------------ physics
    def prepare(self, ctx: Context, robot) -> np.ndarray:
        """d(joint offsets)/d(parameters): (N, 6, P) degrees per unit of each parameter.

        Runs once per measurement set (or program), vectorised over the N poses."""
        driver = np.deg2rad(ctx.q_deg[:, self.by - 1])  # joint 5's bend, rad (N,)
        basis = np.zeros((len(ctx.q_deg), 6, len(self.joints)))
        for k, joint in enumerate(self.joints):  # a loop over parameters, not over poses
            basis[:, joint - 1, k] = driver
        return basis
