"""The simulator: measurement sets from a 'true' robot with chosen error effects.

A true robot is an ErrorModel (nominal + effects with chosen or random magnitudes);
poses are sampled over a joint-space box or a Cartesian region (a cylinder sector as in
seed 001, or a box) with tool orientation ranges, solved by IK; measurements add tracker
and repeatability noise. Tests use it for hidden-effect cases: a truth with effects the
fitted model lacks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from postproc.errors import InputError
from postproc.robot import kinematics as kin
from postproc.robot.frames import make_transform, rot_x, rot_y, rot_z, rotvec_to_matrix
from postproc.robot.robots import RobotModel

from .effects import EffectSum
from .errormodel import ErrorModel
from .measurements import MeasurementSet


@dataclass(frozen=True)
class Cylinder:
    """A sector of a cylinder about the base z axis (seed 001 Fig. 2), TCP positions.

    The tool axis lies within ``tilt_deg`` of straight down; the rotation about it is uniform.
    """

    theta1_deg: tuple[float, float] = (-40.0, 40.0)
    radius_mm: tuple[float, float] = (700.0, 1150.0)
    z_mm: tuple[float, float] = (300.0, 800.0)
    tilt_deg: float = 30.0
    spin_deg: tuple[float, float] = (-180.0, 180.0)


@dataclass(frozen=True)
class Box:
    """An axis-aligned box of TCP positions (seed 001 Fig. 3), tool orientations as in Cylinder."""

    x_mm: tuple[float, float] = (800.0, 1200.0)
    y_mm: tuple[float, float] = (-400.0, 400.0)
    z_mm: tuple[float, float] = (300.0, 800.0)
    tilt_deg: float = 30.0
    spin_deg: tuple[float, float] = (-180.0, 180.0)


@dataclass(frozen=True)
class JointBox:
    """Uniform joint values inside ranges (degrees); None uses the robot's limits within +-170."""

    ranges_deg: tuple[tuple[float, float], ...] | None = None


def random_truth(robot: RobotModel, tool_mm, effects: EffectSum, rng: np.random.Generator, magnitude: float = 2.0) -> ErrorModel:
    """A true robot: each parameter drawn by the effect that owns it (``Effect.draw``; by
    default its initial value plus magnitude x typical x N(0, 1); compliances, for one,
    vary by +-15 % around the robot file's stiffness instead).
    The default magnitude 2 matches the shared KR160 sets (seed 001 Table 3, doubled).
    """
    model = ErrorModel.create(robot, tool_mm, effects)
    values = model.values.copy()
    for i, p in enumerate(model.params):
        values[i] = model.owner(p.name).draw(p, rng, magnitude)
        if p.lower == 0.0 and values[i] < 0:  # a play or a compliance is never negative
            values[i] = -values[i]
        values[i] = np.clip(values[i], p.lower, p.upper)
    return model.with_vector(values)


def _orientations(n: int, tilt_deg: float, spin: tuple[float, float], rng: np.random.Generator) -> np.ndarray:
    """Tool frames whose z axis is within tilt of straight down, spun uniformly about it."""
    down = rot_y(np.full(n, np.pi))  # tool z pointing -z
    tilt = np.deg2rad(tilt_deg) * np.sqrt(rng.uniform(0, 1, n))
    azimuth = rng.uniform(-np.pi, np.pi, n)
    spin_angle = np.deg2rad(rng.uniform(spin[0], spin[1], n))
    return rot_z(azimuth) @ rot_x(tilt) @ rot_z(-azimuth) @ down @ rot_z(spin_angle)


def sample_poses(robot: RobotModel, tool_mm, n: int, region, rng: np.random.Generator, reference_q=None) -> np.ndarray:
    """n joint vectors (N, 6) reaching TCP targets in ``region`` inside the joint limits.

    Targets are solved by analytic IK on the branch nearest ``reference_q`` (default: the
    middle of the joint ranges, which keeps the set in one configuration family).
    """
    if isinstance(region, JointBox):
        lo = np.maximum(robot.lower_deg, -170.0)
        hi = np.minimum(robot.upper_deg, 170.0)
        if region.ranges_deg is not None:
            lo, hi = np.array(region.ranges_deg, dtype=float).T
        out = np.empty((0, 6))
        for _ in range(200):
            q = rng.uniform(lo, hi, size=(2 * n, 6))
            out = np.concatenate([out, q[kin.within_limits(robot, q)]])
            if len(out) >= n:
                return out[:n]
        raise InputError("joint ranges lie outside the robot's limits: no pose can be sampled")
    ref = np.clip(np.zeros(6), robot.lower_deg, robot.upper_deg) if reference_q is None else np.asarray(reference_q, dtype=float)
    tool_t = np.eye(4)
    tool_t[:3, 3] = np.asarray(tool_mm, dtype=float)
    inv_tool = np.linalg.inv(tool_t)
    out = np.empty((0, 6))
    for _ in range(200):
        m = 3 * n
        if isinstance(region, Cylinder):
            th = np.deg2rad(rng.uniform(*region.theta1_deg, m))
            r = rng.uniform(*region.radius_mm, m)
            pos = np.column_stack([r * np.cos(th), r * np.sin(th), rng.uniform(*region.z_mm, m)])
            rot = rot_z(th) @ _orientations(m, region.tilt_deg, region.spin_deg, rng)
        elif isinstance(region, Box):
            pos = np.column_stack([rng.uniform(*region.x_mm, m), rng.uniform(*region.y_mm, m), rng.uniform(*region.z_mm, m)])
            rot = _orientations(m, region.tilt_deg, region.spin_deg, rng)
        else:
            raise InputError(f"unknown workspace region {region!r}")
        flange = make_transform(rot, pos) @ inv_tool
        q, idx = kin.select_nearest(robot, kin.ik(robot, flange), ref)
        out = np.concatenate([out, q[idx >= 0]])
        if len(out) >= n:
            return out[:n]
    raise InputError("the workspace region is (almost) out of reach: too few targets have an IK solution inside the limits")


def simulate(
    truth: ErrorModel,
    q_deg: np.ndarray,
    rng: np.random.Generator,
    *,
    noise_mm: float = 0.02,
    force_max_n: float = 500.0,
    with_force: bool | None = None,
    seconds_per_pose: tuple[float, float] = (20.0, 40.0),
    distortion_mm: float = 0.0,
) -> MeasurementSet:
    """Measure the true robot at q: all columns of the schema, noise ~ N(0, noise_mm) per axis.

    Forces are drawn when an effect of the truth needs them (or ``with_force``); approach
    directions are random; temperature follows a warm-up (20 -> 28 degC) when an effect of
    the truth needs it, otherwise a climate-controlled cell (21 +- 0.5 degC).
    """
    q = np.asarray(q_deg, dtype=float)
    n = len(q)
    want_force = bool(truth.effects.needing("force")) if with_force is None else with_force
    force = None
    if want_force:
        direction = rng.standard_normal((n, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        force = direction * rng.uniform(0.0, force_max_n, (n, 1))
    approach = rng.choice([-1.0, 1.0], size=(n, 6))
    time_s = np.cumsum(rng.uniform(*seconds_per_pose, n))
    if truth.effects.needing("temp"):
        temp = 20.0 + 8.0 * (1.0 - np.exp(-time_s / 1800.0)) + rng.normal(0, 0.05, n)
    else:
        temp = 21.0 + rng.uniform(-0.5, 0.5, n)
    prep = truth.prepare(q_deg=q, force_n=force, approach=approach, temp_c=temp, time_s=time_s)
    actual = truth.predict_prepared(prep)
    if distortion_mm:
        actual = actual + smooth_distortion(actual, distortion_mm)
    measured = actual + rng.normal(0.0, noise_mm, size=actual.shape)
    nominal = kin.fk(truth.robot, q, tool=truth.tool_mm)[:, :3, 3]
    return MeasurementSet(
        q_deg=q,
        measured_mm=measured,
        ids=tuple(str(i + 1) for i in range(n)),
        nominal_mm=nominal,
        force_n=force,
        approach=approach,
        temp_c=temp,
        time_s=time_s,
        source="<simulated>",
    )


def tracker_frame(model: ErrorModel, rotvec_deg, translation_mm) -> ErrorModel:
    """The same truth seen from a tracker placed elsewhere: measurements in the tracker's frame."""
    return replace(model, base_rotation=rotvec_to_matrix(rotvec_deg) @ model.base_rotation, base_translation=np.asarray(translation_mm, dtype=float) + model.base_translation)


_REGION_KEYS = {
    "cylinder": {"theta1": "theta1_deg", "radius": "radius_mm", "z": "z_mm", "tilt": "tilt_deg", "spin": "spin_deg"},
    "box": {"x": "x_mm", "y": "y_mm", "z": "z_mm", "tilt": "tilt_deg", "spin": "spin_deg"},
}


def parse_region(kind: str, text: str | None):
    """A workspace from its command-line description.

    cylinder: 'theta1=-40:40;radius=700:1150;z=300:800;tilt=30;spin=-180:180' (deg, mm)
    box:      'x=800:1200;y=-400:400;z=300:800;tilt=30'
    joints:   'q1=-40:40;q2=-30:20' (unnamed joints keep the robot's limits)
    """
    defaults = {"cylinder": Cylinder(), "box": Box(), "joints": JointBox()}
    if kind not in defaults:
        raise InputError(f"--workspace: '{kind}' is not one of {', '.join(defaults)}")
    if not text:
        return defaults[kind]
    fields: dict[str, object] = {}
    joint_ranges: dict[int, tuple[float, float]] = {}
    for item in text.split(";"):
        if not item.strip():
            continue
        key, eq, value = item.partition("=")
        key = key.strip()
        try:
            parts = tuple(float(v) for v in value.split(":"))
        except ValueError:
            raise InputError(f"--region: '{item}' must be key=low:high or key=value with numbers") from None
        if not eq or len(parts) not in (1, 2) or (len(parts) == 2 and parts[0] >= parts[1]):
            raise InputError(f"--region: '{item}' must be key=low:high (low < high) or key=value")
        if kind == "joints":
            if key not in {f"q{i}" for i in range(1, 7)} or len(parts) != 2:
                raise InputError(f"--region: joint ranges are q1..q6=low:high, got '{item}'")
            joint_ranges[int(key[1])] = parts
            continue
        name = _REGION_KEYS[kind].get(key)
        if name is None:
            raise InputError(f"--region: unknown key '{key}' for a {kind} (known: {', '.join(_REGION_KEYS[kind])})")
        if (name == "tilt_deg") != (len(parts) == 1):
            raise InputError(f"--region: '{key}' takes {'one value' if name == 'tilt_deg' else 'a range low:high'}")
        fields[name] = parts[0] if name == "tilt_deg" else parts
    if kind == "joints":
        return JointBox(tuple(joint_ranges.get(j, (-170.0, 170.0)) for j in range(1, 7)))
    return replace(defaults[kind], **fields)


def smooth_distortion(position_mm: np.ndarray, amplitude_mm: float) -> np.ndarray:
    """An error no catalog effect describes: a smooth field over the workspace (wavelengths
    of 0.4-0.7 m), e.g. a structure's deflection or a tracker's scale error. For tests of
    the data-driven predictors."""
    p = np.asarray(position_mm, dtype=float) / 1000.0
    return amplitude_mm * np.stack(
        [np.sin(2 * np.pi * p[:, 1] / 0.7) * np.cos(2 * np.pi * p[:, 2] / 0.6),
         np.sin(2 * np.pi * p[:, 0] / 0.5) * np.sin(2 * np.pi * p[:, 2] / 0.7),
         np.cos(2 * np.pi * p[:, 0] / 0.6) * np.cos(2 * np.pi * p[:, 1] / 0.4)], axis=1)
