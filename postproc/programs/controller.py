"""What a controller does with a program: the rules of the machine that runs it.

A language (``postproc.programs.dialects``) turns text into the IR and back. The controller that runs
the program (ABB IRC5, KUKA KRC4, LinuxCNC, ...) owns what the machine then does: which
inverse-kinematics solution its configuration data select and which motions follow them,
where it leaves the exact interpolation, where an arc ends, what loads the program puts on
the arm. Compensation (``postproc.compensation``) asks the ``Controller`` object it is given
and imports no language; each language names the controller that runs it by default
(``Dialect.controller``). This base class is a controller with no rules of its own: no
configuration data, exact interpolation, no stated loads.
"""

from __future__ import annotations

import numpy as np

from .ir import Toolpath


class Controller:
    """Base class; a controller overrides the rules its manual states."""

    #: for messages, e.g. "ABB IRC5"
    name: str = "a controller with no rules of its own"
    #: the robot maker whose robots alone this controller drives, as robot files' descriptions
    #: name it first (None: any maker's, or a CNC)
    maker: str | None = None
    #: which rotary solution the controller turns a programmed tool-axis vector into: "nearest"
    #: (the shorter travel from where the axes stand, SINUMERIK TRAORI), or None where its rule is
    #: not known (five-axis compensation then refuses vector programs)
    vector_solution: str | None = None

    #: True where the posture before the program's first joint target (or configuration data
    #: that apply) may be assumed, with a note (nearest all-zero joints); False where the
    #: controller's rule reads the joints the robot starts in (URScript: the nearest IK
    #: solution), so compensation refuses those targets without --start-joints
    start_posture_assumed: bool = True

    def branch_from_conf(self, robot, solutions: np.ndarray, conf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joints (N, 6) and branch (N,) the controller takes for each target from the
        configuration data the program gives (``conf`` (N, 4), NaN where none); NaN and -1
        where the program gives none (the caller then follows the path)."""
        return np.full((len(conf), 6), np.nan), np.full(len(conf), -1)

    def branch_of_targets(self, robot, solutions: np.ndarray, tp: Toolpath, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``branch_from_conf`` for the targets ``rows`` of ``tp`` (``solutions`` their IK): a
        controller whose rule reads more of a target than its configuration data (URScript's
        get_inverse_kin qnear: six joint values) overrides this; the default reads ``tp.conf``."""
        return self.branch_from_conf(robot, solutions, tp.conf[rows])

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """(N,) True where the controller takes the target's configuration data as written
        (it then selects the branch); elsewhere the robot keeps the posture it is in
        (see postproc.robot.posture). Default: wherever the program gives configuration data."""
        return ~np.isnan(tp.conf).all(axis=1)

    def payloads(self, tp: Toolpath) -> list[tuple[float, str]]:
        """(mass kg, 'FILE, line N') of every payload the program states (none by default)."""
        return []

    def stated_loads(self, tp: Toolpath):
        """emit.load_plan.LoadPlan: the whole load each target carries where the program states
        one, for ``convert`` to carry (None: the program states none, e.g. G-code)."""
        return None

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        """``file:line: why`` where the program lets the controller leave the exact straight or
        circular interpolation between targets (the path prediction assumes it), else None."""
        return None

    def arc_ends_at_target(self, tp: Toolpath) -> np.ndarray:
        """(N,) False where a circular motion does not end at its end point (KRL's CA)."""
        return np.ones(len(tp.kind), dtype=bool)


#: the controller of a language that states no rules of its own
GENERIC = Controller()

__all__ = ["GENERIC", "Controller"]
