"""Encoder pulses <-> joint angles with the robot's pulse data (robot file ``[pulses]``):
angle = (pulse - zero) / per_degree, as a Yaskawa controller converts them with the
pulse-per-degree figures and zero offsets of its parameters."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from postproc.errors import InputError

from ...ir import Kind, Toolpath


def pulse_data(robot) -> tuple[np.ndarray, np.ndarray]:
    """(per_degree (6,), zero (6,)) of a robot; an InputError naming its file where it has none."""
    if robot.pulses_per_deg is None or robot.zero_pulse is None:
        raise InputError(f"{robot.source_path}: no [pulses] section: INFORM pulse positions need the robot's pulses per degree and zero pulses")
    return robot.pulses_per_deg, robot.zero_pulse


def angles_of_pulses(robot, pulses: np.ndarray) -> np.ndarray:
    """Joint angles (N, 6) in degrees of encoder pulses (N, 6)."""
    per_degree, zero = pulse_data(robot)
    return (np.asarray(pulses, dtype=float) - zero) / per_degree


def pulses_of_angles(robot, angles_deg: np.ndarray) -> np.ndarray:
    """Encoder pulses (N, 6), whole numbers as a job holds them, of joint angles (N, 6) in degrees."""
    per_degree, zero = pulse_data(robot)
    return np.rint(np.asarray(angles_deg, dtype=float) * per_degree + zero)


def with_pulse_joints(tp: Toolpath, robot) -> Toolpath:
    """A copy of an INFORM toolpath whose MOVJ-to-pulse-position targets (joint targets whose
    only want was the pulse data) have their joint angles from ``robot``'s pulse data and are
    placed. Their text numbers stay pulses: the IR's values stay empty, so nothing rewrites them.
    A target unresolved for another reason (a note besides the pulses) stays so."""
    pulses = tp.extras.get("inform.pulses")
    rows = np.array([], dtype=int) if pulses is None else np.nonzero((tp.kind == Kind.ABSJ) & ~np.isnan(pulses).any(axis=1))[0]
    if not rows.size:
        return tp
    if robot.pulses_per_deg is None or robot.zero_pulse is None:  # never guessed: they stay unplaced, and the user is told why
        return replace(tp, notes=tp.notes + (f"{len(rows)} pulse position(s) stay unplaced: {robot.source_path} has no [pulses] section (pulses per degree, zero pulses)",))
    if robot.estimates.get("pulses"):  # placeholders: angles from them would be numbers the robot does not run
        return replace(tp, notes=tp.notes + (f"{len(rows)} pulse position(s) stay unplaced: the [pulses] of {robot.source_path} are estimates "
                                             "(flagged in the file); give a robot file with your controller's pulses per degree and zero pulses "
                                             "(estimate = false)",))
    joints, resolved = tp.joints.copy(), tp.resolved.copy()
    joints[rows] = angles_of_pulses(robot, pulses[rows])
    only_pulses = np.array([_only_the_pulses(tp, int(r)) for r in rows], dtype=bool)
    resolved[rows[only_pulses]] = True
    notes = tuple(n for n in tp.notes if not any(n.endswith(f"line {tp.line[r]}: {tp.target_name[r]} is in pulses: joint angles need the robot's pulse data") for r in rows[only_pulses]))
    return replace(tp, joints=joints, resolved=resolved, notes=notes + (f"{len(rows)} pulse position(s) turned into joint angles with {robot.name}'s pulse data",))


def _only_the_pulses(tp: Toolpath, row: int) -> bool:
    """True where the target's one note is that it is in pulses."""
    line = f", line {tp.line[row]}: "
    mine = [n.split(line, 1)[1] for n in tp.notes if line in n]
    return mine == [f"{tp.target_name[row]} is in pulses: joint angles need the robot's pulse data"]
