"""``postproc effect new NAME``: a commented starting file for an error effect of one's own.

The file is a working effect (it passes ``postproc effect check``): a joint offset that
follows another joint's angle. The user edits its physics (``prepare``), its texts and
its parameters; everything it imports is in ``postproc.model.effects.api``.
"""

from __future__ import annotations

import re
from pathlib import Path

from postproc.errors import InputError, OutputError

from .effects import BUILTIN
from .measurements import write_text_atomic

TEMPLATE = '''"""{name}: an error effect of your own, written by `postproc effect new {name}`.

    postproc effect check {file}                                  # the contract checks
    postproc fit DATA.csv --robot R --effects geometric,{name} --plugins {file} -o model.json
    postproc compensate PROGRAM --model model.json --plugins {file} -o OUT

The model file records this file's sha256: a model fitted with it is refused (exit 2)
where the file is not loaded or has changed since. Reference: docs/own-effect.md, and
the context fields, units and helpers in postproc.model.effects.api.
"""

from __future__ import annotations

import numpy as np

# Everything an effect may use is in postproc.model.effects.api; nothing else is needed.
from postproc.model.effects.api import Context, Effect, EffectSpecError, Param, parse_int_list


class {cls}(Effect):
    # The name in --effects and in model files: lower case, unique, not a built-in effect's.
    name = "{name}"
    # How the effect perturbs the robot. "joint": an offset of the joint values, linear in the
    # parameters; prepare() returns d(offset)/d(parameters). Other kinds ("cartesian",
    # "geometry", "tool", "base"): see postproc.model.effects.api.
    kind = "joint"
    # Measurement columns it cannot do without: "force", "approach", "temp", "t".
    needs = ()
    # Inputs compensate must be given for it: "force" (--force), "temp" (--temp).
    consumes = ()
    # EDIT the three texts: the report, diagnose and `effect check` use them.
    summary = "joint offsets that follow another joint's angle (EDIT: what your effect models)"
    finding = "residuals follow the angle of another joint (EDIT: what the residual looks like without it)"
    identifiability = (
        "EDIT: which parameters the data cannot separate, and what absorbs them. Here: a constant part of "
        "the offset is absorbed by the joint zero offsets (geometric.dtheta) when both are fitted."
    )

    def __init__(self, joints=(4,), by=5):
        self.joints = tuple(joints)  # the joints (1..6) that get an offset
        self.by = int(by)  # the joint (1..6) whose angle drives it

    # ------------------------------------------------------------------ options
    # Written on the command line as {name}[joints=4;by=5] and recorded in the model file.
    def options(self) -> dict:
        return {{}} if (self.joints, self.by) == ((4,), 5) else {{"joints": list(self.joints), "by": self.by}}

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "{cls}":
        unknown = set(opts) - {{"joints", "by"}}
        if unknown:
            raise EffectSpecError(f"{{cls.name}}: unknown option(s) {{', '.join(sorted(unknown))}} (known: joints, by)")
        joints = parse_int_list(cls.name, "joints", opts.get("joints", "4"), 1, 6)
        by = parse_int_list(cls.name, "by", opts.get("by", "5"), 1, 6)
        if len(by) != 1:
            raise EffectSpecError(f"{{cls.name}}: option 'by' is one joint, got '{{opts['by']}}'")
        return cls(joints, by[0])

    # --------------------------------------------------------------- parameters
    def params(self, robot) -> list[Param]:
        # One coefficient per offset joint. scale: the size the fit works in; typical: the
        # size the simulator draws a true value with; lower/upper: what physics allows.
        return [Param(f"{{self.name}}.k{{j}}", "deg", scale=0.01, typical=0.02, lower=-1.0, upper=1.0) for j in self.joints]

    # ------------------------------------------------------------------ physics
    def prepare(self, ctx: Context, robot) -> np.ndarray:
        """d(joint offsets)/d(parameters): (N, 6, P) degrees per unit of each parameter.

        Runs once per measurement set (or program), vectorised over the N poses."""
        driver = np.sin(np.deg2rad(ctx.q_deg[:, self.by - 1]))  # EDIT: what the offset follows, (N,)
        basis = np.zeros((len(ctx.q_deg), 6, len(self.joints)))
        for k, joint in enumerate(self.joints):  # a loop over parameters, not over poses
            basis[:, joint - 1, k] = driver
        return basis
'''


def class_name(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_")) or "MyEffect"


def write_template(name: str, output: str | Path = ".") -> Path:
    """Write the template to ``output``: a ``.py`` file, or ``NAME.py`` in an existing
    folder (spec/cli.md: ``effect new NAME [-o FILE.py]``); refuses a bad or built-in name
    and an existing file."""
    if not re.fullmatch(r"[a-z][a-z0-9_]*", name):
        raise InputError(f"effect name '{name}': use lower case letters, digits and _, starting with a letter")
    if name in BUILTIN:
        raise InputError(f"effect name '{name}' is a built-in effect's; choose another")
    target = Path(output)
    path = target / f"{name}.py" if target.is_dir() else target
    if path.suffix != ".py" or not path.parent.is_dir():
        raise OutputError(f"-o {target}: give a .py file in an existing folder, or an existing folder")
    if path.exists():
        raise OutputError(f"{path}: already exists; nothing was written (remove it or choose another name or folder)")
    write_text_atomic(path, TEMPLATE.format(name=name, cls=class_name(name), file=path.name))
    return path
