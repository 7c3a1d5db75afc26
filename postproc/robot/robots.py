"""Robot data: the immutable ``RobotModel`` and ``load_robot`` with schema and unit checks.

Robot data lives in validated TOML files under ``robots/`` (shipped as package data),
never in classes. The schema is documented in ``robots/README.md``.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from postproc.errors import RobotFileError, UnknownRobotError

from .dh import forward_dh, opw_forward
from .ur_kinematics import is_ur_geometry

REQUIRED_UNITS = {"length": "mm", "angle": "deg", "mass": "kg", "stiffness": "N*m/rad"}
_OPW_KEYS = ("a1", "a2", "b", "c1", "c2", "c3", "c4")


@dataclass(frozen=True)
class OpwParameters:
    """Ortho-parallel form of the arm (Brandstötter et al. 2014), used by the analytic IK.

    The OPW joint angles are ``phi = signs * q - offsets`` for controller joint values q.
    """

    a1: float
    a2: float
    b: float
    c1: float
    c2: float
    c3: float
    c4: float
    signs: np.ndarray
    offsets_deg: np.ndarray


@dataclass(frozen=True)
class JointCoupling:
    """A linear limit ``lower <= coeffs . q <= upper`` (degrees), e.g. a parallel-arm J2/J3 limit."""

    coeffs: np.ndarray
    lower: float
    upper: float
    description: str


@dataclass(frozen=True)
class RobotModel:
    """A robot's nominal data. Immutable; scratch state of computations lives elsewhere.

    Standard DH (conventions.md): A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i) with
    theta_i = joint_sign_i * q_i + theta0_i, q the controller's joint value.
    """

    name: str
    description: str
    source_path: str
    verified: bool
    theta0_deg: np.ndarray
    alpha_deg: np.ndarray
    d_mm: np.ndarray
    a_mm: np.ndarray
    joint_sign: np.ndarray
    lower_deg: np.ndarray
    upper_deg: np.ndarray
    couplings: tuple[JointCoupling, ...]
    mass_kg: np.ndarray
    com_mm: np.ndarray
    stiffness_nm_per_rad: np.ndarray
    opw: OpwParameters | None
    sources: dict[str, str] = field(default_factory=dict)
    estimates: dict[str, bool] = field(default_factory=dict)
    # Yaskawa encoder pulse data (robot file [pulses]): joint angle = (pulse - zero) / per_degree
    pulses_per_deg: np.ndarray | None = None
    zero_pulse: np.ndarray | None = None

    @property
    def has_analytic_ik(self) -> bool:
        return self.opw is not None or is_ur_geometry(self)


def available_robots() -> list[str]:
    """Names of the robot files bundled with the package."""
    root = resources.files("postproc.robot_files")
    return sorted(p.name[: -len(".toml")] for p in root.iterdir() if p.name.endswith(".toml"))


def load_robot(name_or_path: str | Path) -> RobotModel:
    """Load a bundled robot by name (e.g. ``kr160_r1570``) or a robot TOML file by path."""
    candidate = Path(name_or_path)
    if candidate.suffix == ".toml" or candidate.exists():
        if not candidate.is_file():
            raise UnknownRobotError(f"{candidate}: robot file not found")
        try:
            text = candidate.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise RobotFileError(candidate, "-", f"not a robot file: byte {exc.start} is not UTF-8 text (binary or damaged file)") from None
        except OSError as exc:
            raise UnknownRobotError(f"{candidate}: cannot read robot file ({exc.strerror})") from None
        return parse_robot_toml(text, str(candidate))
    name = str(name_or_path)
    resource = resources.files("postproc.robot_files") / f"{name}.toml"
    if not resource.is_file():
        raise UnknownRobotError(
            f"unknown robot '{name}': not a bundled robot ({', '.join(available_robots())}) nor an existing file"
        )
    return parse_robot_toml(resource.read_text(encoding="utf-8"), f"robots/{name}.toml")


class _Reader:
    """Pulls typed values out of the parsed TOML, naming file and key on every error."""

    def __init__(self, data: dict[str, Any], path: str):
        self.data = data
        self.path = path

    def fail(self, key: str, message: str) -> RobotFileError:
        return RobotFileError(self.path, key, message)

    def section(self, name: str, required: bool = True) -> dict[str, Any] | None:
        value = self.data.get(name)
        if value is None:
            if required:
                raise self.fail(name, "missing section")
            return None
        if not isinstance(value, dict):
            raise self.fail(name, "must be a table")
        return value

    def check_keys(self, table: dict[str, Any], prefix: str, allowed: set[str]) -> None:
        for key in table:
            if key not in allowed:
                where = f"{prefix}.{key}" if prefix else key
                raise self.fail(where, f"unknown key (allowed: {', '.join(sorted(allowed))})")

    def number(self, table: dict[str, Any], key: str, prefix: str) -> float:
        where = f"{prefix}.{key}"
        if key not in table:
            raise self.fail(where, "missing")
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(where, f"must be a finite number, got {value!r}")
        return float(value)

    def vector(self, table: dict[str, Any], key: str, prefix: str, length: int = 6) -> np.ndarray:
        where = f"{prefix}.{key}"
        if key not in table:
            raise self.fail(where, "missing")
        value = table[key]
        if not isinstance(value, list) or len(value) != length:
            raise self.fail(where, f"must be a list of {length} numbers")
        for i, item in enumerate(value):
            if isinstance(item, bool) or not isinstance(item, (int, float)) or not math.isfinite(item):
                raise self.fail(f"{where}[{i}]", f"must be a finite number, got {item!r}")
        arr = np.array(value, dtype=float)
        arr.setflags(write=False)
        return arr

    def signs(self, table: dict[str, Any], key: str, prefix: str) -> np.ndarray:
        arr = self.vector(table, key, prefix)
        if not np.all(np.abs(arr) == 1):
            raise self.fail(f"{prefix}.{key}", "every entry must be +1 or -1")
        return arr

    def string(self, table: dict[str, Any], key: str, prefix: str) -> str:
        where = f"{prefix}.{key}" if prefix else key
        value = table.get(key)
        if not isinstance(value, str) or not value.strip():
            raise self.fail(where, "must be a non-empty string")
        return value

    def boolean(self, table: dict[str, Any], key: str, prefix: str, default: bool | None = None) -> bool:
        where = f"{prefix}.{key}" if prefix else key
        if key not in table:
            if default is None:
                raise self.fail(where, "missing (true or false)")
            return default
        value = table[key]
        if not isinstance(value, bool):
            raise self.fail(where, f"must be true or false, got {value!r}")
        return value


def parse_robot_toml(text: str, path: str) -> RobotModel:
    """Validate and build a RobotModel from TOML text; ``path`` names the file in errors."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RobotFileError(path, "<syntax>", str(exc)) from exc
    r = _Reader(data, path)
    r.check_keys(data, "", {"name", "description", "verified", "units", "kinematics", "opw", "limits", "masses", "stiffness", "pulses"})
    name = r.string(data, "name", "")
    expected_stem = Path(path).stem
    if name != expected_stem:
        raise r.fail("name", f"'{name}' does not match the file name '{expected_stem}'")
    description, verified = r.string(data, "description", ""), r.boolean(data, "verified", "")
    _check_units(r)
    sources: dict[str, str] = {}
    estimates: dict[str, bool] = {}
    fields: dict[str, Any] = {}
    # Each section reader fills the RobotModel fields it owns, its source and its estimate flag.
    for section, reader in (("kinematics", _read_kinematics), ("limits", _read_limits), ("masses", _read_masses), ("stiffness", _read_stiffness)):
        table = r.section(section)
        fields.update(reader(r, table))
        sources[section] = r.string(table, "source", section)
        estimates[section] = r.boolean(table, "estimate", section, default=False)
    opw = _read_opw(r, sources)
    fields.update(_read_pulses(r, sources, estimates))
    model = RobotModel(name=name, description=description, source_path=path, verified=verified,
                       opw=opw, sources=sources, estimates=estimates, **fields)
    if opw is not None:
        _check_opw_matches_dh(model, r)
    return model


def _check_units(r: "_Reader") -> None:
    units = r.section("units")
    r.check_keys(units, "units", set(REQUIRED_UNITS))
    for quantity, unit in REQUIRED_UNITS.items():
        if units.get(quantity) != unit:
            raise r.fail(f"units.{quantity}", f"must be '{unit}' (conventions.md), got {units.get(quantity)!r}")


def _read_kinematics(r: "_Reader", kin: dict) -> dict:
    r.check_keys(kin, "kinematics", {"convention", "theta0", "alpha", "d", "a", "joint_sign", "source", "estimate"})
    if kin.get("convention") != "standard_dh":
        raise r.fail("kinematics.convention", "must be 'standard_dh'")
    out = {"theta0_deg": r.vector(kin, "theta0", "kinematics"), "alpha_deg": r.vector(kin, "alpha", "kinematics"),
           "d_mm": r.vector(kin, "d", "kinematics"), "a_mm": r.vector(kin, "a", "kinematics"),
           "joint_sign": r.signs(kin, "joint_sign", "kinematics")}
    for key, lengths in (("d", out["d_mm"]), ("a", out["a_mm"])):
        largest = np.abs(lengths).max()
        if 0.0 < largest < 10.0:
            raise r.fail(f"kinematics.{key}", f"lengths look like metres (largest {largest:g}); this file must use mm")
    return out


def _read_limits(r: "_Reader", limits: dict) -> dict:
    r.check_keys(limits, "limits", {"lower", "upper", "coupling", "source", "estimate"})
    lower = r.vector(limits, "lower", "limits")
    upper = r.vector(limits, "upper", "limits")
    bad = np.nonzero(lower >= upper)[0]
    if bad.size:
        raise r.fail("limits.lower", f"joint {bad[0] + 1}: lower limit {lower[bad[0]]:g} is not below upper {upper[bad[0]]:g}")
    couplings = []
    for i, entry in enumerate(limits.get("coupling", [])):
        prefix = f"limits.coupling[{i}]"
        if not isinstance(entry, dict):
            raise r.fail(prefix, "must be a table")
        r.check_keys(entry, prefix, {"coeffs", "lower", "upper", "description"})
        c_lo, c_hi = r.number(entry, "lower", prefix), r.number(entry, "upper", prefix)
        if c_lo >= c_hi:
            raise r.fail(f"{prefix}.lower", "must be below upper")
        couplings.append(JointCoupling(r.vector(entry, "coeffs", prefix), c_lo, c_hi, r.string(entry, "description", prefix)))
    return {"lower_deg": lower, "upper_deg": upper, "couplings": tuple(couplings)}


def _read_masses(r: "_Reader", masses: dict) -> dict:
    r.check_keys(masses, "masses", {"mass", "com", "source", "estimate"})
    mass = r.vector(masses, "mass", "masses")
    if np.any(mass < 0):
        raise r.fail("masses.mass", "masses must be >= 0 kg")
    com_rows = masses.get("com")
    if not isinstance(com_rows, list) or len(com_rows) != 6:
        raise r.fail("masses.com", "must be a list of 6 [x, y, z] centres of mass (mm, DH frame i)")
    com = np.stack([r.vector({"com": row}, "com", f"masses.com[{i}]", length=3) for i, row in enumerate(com_rows)])
    com.setflags(write=False)
    return {"mass_kg": mass, "com_mm": com}


def _read_stiffness(r: "_Reader", stiff: dict) -> dict:
    r.check_keys(stiff, "stiffness", {"k", "source", "estimate"})
    k = r.vector(stiff, "k", "stiffness")
    if np.any(k <= 0):
        raise r.fail("stiffness.k", "joint stiffness must be > 0 N*m/rad")
    if k.max() < 1e3:
        raise r.fail("stiffness.k", f"values look like 10^6 N*m/rad or kN*m/rad (largest {k.max():g}); give N*m/rad")
    return {"stiffness_nm_per_rad": k}


def _read_opw(r: "_Reader", sources: dict) -> "OpwParameters | None":
    opw_table = r.section("opw", required=False)
    if opw_table is None:
        return None
    r.check_keys(opw_table, "opw", set(_OPW_KEYS) | {"signs", "offsets", "source"})
    sources["opw"] = r.string(opw_table, "source", "opw")
    return OpwParameters(*(r.number(opw_table, key, "opw") for key in _OPW_KEYS),
                         signs=r.signs(opw_table, "signs", "opw"), offsets_deg=r.vector(opw_table, "offsets", "opw"))


def _read_pulses(r: "_Reader", sources: dict, estimates: dict) -> dict:
    """The optional [pulses] section: per_degree (pulses per degree, signed) and zero
    (the pulse count at 0 deg) of each axis, as a Yaskawa controller converts them."""
    table = r.section("pulses", required=False)
    if table is None:
        return {}
    r.check_keys(table, "pulses", {"per_degree", "zero", "source", "estimate"})
    sources["pulses"] = r.string(table, "source", "pulses")
    estimates["pulses"] = r.boolean(table, "estimate", "pulses", default=False)
    per_degree = r.vector(table, "per_degree", "pulses")
    if np.any(np.abs(per_degree) < 1.0):
        raise r.fail("pulses.per_degree", "pulses per degree must be at least 1 in magnitude (an encoder count, not degrees per pulse)")
    return {"pulses_per_deg": per_degree, "zero_pulse": r.vector(table, "zero", "pulses")}


def _check_opw_matches_dh(model: RobotModel, reader: _Reader) -> None:
    """The OPW section must describe the same arm as the DH table, or IK would silently disagree with FK."""
    q = np.random.default_rng(12345).uniform(-170.0, 170.0, size=(16, 6))
    t_dh = forward_dh(q * model.joint_sign + model.theta0_deg, model.d_mm, model.a_mm, model.alpha_deg)
    t_opw = opw_forward(model.opw, q)
    pos_err = np.abs(t_dh[:, :3, 3] - t_opw[:, :3, 3]).max()
    rot_err = np.abs(t_dh[:, :3, :3] - t_opw[:, :3, :3]).max()
    if pos_err > 1e-6 or rot_err > 1e-9:
        raise reader.fail(
            "opw", f"does not describe the DH table's arm (position differs by {pos_err:.3g} mm, rotation by {rot_err:.3g})"
        )
