"""The public API for writing an error effect outside postproc: ``from postproc.model.effects.api import ...``.

Everything an effect of your own needs is here; nothing else in postproc is promised to
stay as it is. ``postproc effect new NAME`` writes a commented starting file,
``postproc effect check FILE`` checks it, and ``--plugins FILE`` (or ``POSTPROC_PLUGINS``,
or an entry point in the group ``postproc.model.effects``) loads it: see docs/own-effect.md.

An effect is an ``Effect`` subclass with a ``name`` (the ``--effects`` spelling, unique),
a ``kind`` (how it perturbs the robot, one of ``KINDS``), its parameters (``params``,
a list of ``Param``) and, by kind, its physics:

``joint``      ``prepare(ctx, robot)`` returns d(joint offset)/d(parameters), an array
               (N, 6, P) in degrees per unit of each parameter: the controller commands
               q, the joints stand at q + basis @ values. Linear in the parameters.
``cartesian``  ``prepare(ctx, robot)`` returns (N, 3, P) mm per unit: a displacement of
               the measured point in the robot base frame. Linear in the parameters.
``geometry``   ``apply_dh`` / ``dh_derivatives``: a change of the DH table (see ``DH``).
``tool``       ``tool_basis()`` (3, P) mm per unit: the measured point's flange offset.
``base``       ``transform`` / ``base_jacobian``: robot base -> measurement frame.

``prepare`` runs once per measurement set (and once per program in compensation), never
per parameter value; it must be vectorised over the N poses (no Python loop over poses).

The context (``Context``) an effect reads, field by field (N poses):

=================  ==========  ============================================================
field              shape       meaning, unit
=================  ==========  ============================================================
``q_deg``          (N, 6)      commanded joint values, degrees (the controller's sense)
``gravity_torque`` --          always None: compute it with ``gravity_torque(robot,
                               ctx.q_deg, payload_kg, payload_com_mm)`` (N*m, (N, 6)); the
                               effect knows the payload it models (an option, say)
``force_torque``   (N, 6)      N*m, joint torques of the external force, J^T F at the
                               commanded joints (None without force columns / ``--force``)
``force_n``        (N, 3)      N, the external force on the tool, robot base frame (or None)
``approach``       (N, 6)      +1 / -1: the direction each joint last moved to reach the pose
                               (None unless measured, or inferred by an effect's ``complete``)
``temp_c``         (N,)        degC, cell / structure temperature (None without it)
``time_s``         (N,)        s, time of the measurement / of the target (None without it)
``tool_mm``        (3,)        mm, the nominal measured point (TCP) in the flange frame
=================  ==========  ============================================================

A column the effect cannot do without goes in ``needs`` (``force``, ``approach``,
``temp``, ``t``): a measurement set without it is then refused with the file and
column named, and ``consumes`` (``force``, ``temp``) makes ``compensate`` ask for
``--force`` / ``--temp``.

The robot (``RobotModel``) gives ``d_mm``, ``a_mm``, ``alpha_deg``, ``theta0_deg`` (the
DH table), ``joint_sign``, ``lower_deg`` / ``upper_deg``, ``mass_kg`` (6,),
``com_mm`` (6, 3) and ``stiffness_nm_per_rad`` (6,). Helpers: ``fk`` (poses (N, 4, 4), mm),
``joint_frames`` (DH frames 0..6: rotations (N, 7, 3, 3), origins (N, 7, 3) mm),
``jacobian`` ((N, 6, 6): mm/rad and rad/rad), ``gravity_torque`` ((N, 6) N*m).

Every effect also says in plain words: ``summary`` (what it models), ``finding`` (what
the residual looks like when it is missing) and ``identifiability`` (which parameters
the data cannot separate, and what absorbs them); ``effect check`` requires all three.
"""

from __future__ import annotations

from postproc.robot.kinematics import fk, gravity_torque, jacobian, joint_frames
from postproc.robot.robots import RobotModel

from ..predictor_plugins import PluginPredictor
from .base import DH, DH_CHANNELS, KINDS, Context, Effect, EffectSpecError, EffectSum, Param, parse_int_list

__all__ = [
    "DH",
    "DH_CHANNELS",
    "KINDS",
    "Context",
    "Effect",
    "EffectSpecError",
    "EffectSum",
    "Param",
    "PluginPredictor",
    "RobotModel",
    "fk",
    "gravity_torque",
    "jacobian",
    "joint_frames",
    "parse_int_list",
]
