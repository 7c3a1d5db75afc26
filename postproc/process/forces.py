"""Mechanistic milling force (seed 002 eq. 14-17, after Engin & Altintas' general end mill model).

Linear edge + shear model on every axial element of every flute in cut:

    dFt = (Ktc h + Kte) db,  dFr = (Krc h + Kre) db,  dFa = (Kac h + Kae) db,
    h = f sin(phi) sin(kappa),  db = dz / sin(kappa)

with f the feed per tooth (mm), phi the immersion angle of the edge, kappa the axial
immersion angle of the cutter envelope at height z (90 deg on the flank, less on a
corner radius) and Kc in N/mm^2, Ke in N/mm. The element forces are turned into the
cutter frame by the matrix A(phi, kappa) of eq. 15 and summed.

Cutter frame (CST): x along the feed, z along the cutter axis from the tip towards the
spindle, y = z x x. The spindle turns clockwise seen from +z; phi is measured clockwise
from +y, so an edge at phi = 90 deg points along the feed (largest chip). Engagement is
the immersion range [phi_start, phi_exit] and the axial range [z_low, z_high] (mm above
the tip). The mean force is the average over a tooth period, the peak the largest
resultant over it.

Lead and tilt (deg) say how the cutter axis leans from the surface normal n: lead
towards the feed (about y), tilt sideways (about x). They set n in the cutter frame
(``surface_normal_cutter``); with both zero n is the cutter axis, i.e. the opposite of a
robot tool's z axis (spec/cli.md).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from postproc.errors import InputError


class CutFileError(InputError):
    """A cutting-parameter file is missing, malformed or out of range: names file and key."""

    def __init__(self, path: str | Path, key: str, message: str):
        self.path, self.key = str(path), key
        super().__init__(f"{self.path}: key '{key}': {message}")


# Default coefficients: Al6082-T6 with a cemented carbide end mill, dry (the 6xxx alloy
# nearest to the seed's Al6065), as tabulated in Table 5 of Z. Zhao et al., "Milling Force
# Model for Aviation Aluminum Alloy: Academic Insight and Perspective Analysis", Chinese
# Journal of Mechanical Engineering 34 (2021) 107, doi:10.1186/s10033-021-00536-9
# (row [189] there). Kc in N/mm^2, Ke in N/mm.
ALUMINIUM_SOURCE = (
    "Al6082-T6, carbide, dry: Table 5 (row [189]) of Zhao et al., Chinese J. Mech. Eng. 34 (2021) 107, "
    "doi:10.1186/s10033-021-00536-9"
)
ALUMINIUM = {"ktc": 631.0, "krc": 99.0, "kac": 273.0, "kte": 13.0, "kre": 10.0, "kae": 2.8}

# key: (unit, lower bound, upper bound, default or None when required)
_SCHEMA: dict[str, dict[str, tuple[str, float, float, Any]]] = {
    "tool": {
        "diameter": ("mm", 0.1, 500.0, None),
        "corner_radius": ("mm", 0.0, 250.0, 0.0),
        "teeth": ("1", 1, 32, None),
        "helix": ("deg", 0.0, 60.0, 30.0),
    },
    "material": {
        "ktc": ("N/mm^2", 0.0, 1e5, ALUMINIUM["ktc"]),
        "krc": ("N/mm^2", 0.0, 1e5, ALUMINIUM["krc"]),
        "kac": ("N/mm^2", 0.0, 1e5, ALUMINIUM["kac"]),
        "kte": ("N/mm", 0.0, 1e4, ALUMINIUM["kte"]),
        "kre": ("N/mm", 0.0, 1e4, ALUMINIUM["kre"]),
        "kae": ("N/mm", 0.0, 1e4, ALUMINIUM["kae"]),
    },
    "cut": {
        "feed_per_tooth": ("mm", 0.0, 5.0, None),
        "axial_depth": ("mm", 0.0, 500.0, None),
        "radial_width": ("mm", 0.0, 500.0, None),
        "lead": ("deg", -60.0, 60.0, 0.0),
        "tilt": ("deg", -60.0, 60.0, 0.0),
    },
}
_MODES = ("down", "up", "centre")


@dataclass(frozen=True)
class CutParams:
    """Tool, material and cut of one operation (mm, deg, N/mm^2, N/mm)."""

    diameter: float
    teeth: int
    feed_per_tooth: float
    axial_depth: float
    radial_width: float
    corner_radius: float = 0.0
    helix: float = 30.0
    ktc: float = ALUMINIUM["ktc"]
    krc: float = ALUMINIUM["krc"]
    kac: float = ALUMINIUM["kac"]
    kte: float = ALUMINIUM["kte"]
    kre: float = ALUMINIUM["kre"]
    kae: float = ALUMINIUM["kae"]
    lead: float = 0.0
    tilt: float = 0.0
    mode: str = "down"  # down (climb), up (conventional) or centre (symmetric about the feed)
    source: str = ALUMINIUM_SOURCE

    def engagement(self) -> tuple[float, float, float, float]:
        """(phi_start, phi_exit, z_low, z_high) of the stated radial width and axial depth (deg, mm)."""
        return engagement_from_width(self.diameter, self.radial_width, self.mode) + (0.0, self.axial_depth)


def engagement_from_width(diameter: float, width, mode: str = "down"):
    """Immersion range (deg) of a radial width of cut: down milling exits at 180 deg, up
    milling enters at 0 deg, centre is symmetric about the feed. Vectorised over width."""
    ratio = np.clip(np.asarray(width, dtype=float) / diameter, 0.0, 1.0)
    sweep = np.degrees(np.arccos(1.0 - 2.0 * ratio))  # the arc of the cutter inside the stock
    if mode == "down":
        return 180.0 - sweep, np.full_like(sweep, 180.0)
    if mode == "up":
        return np.zeros_like(sweep), sweep
    if mode == "centre":
        return 90.0 - sweep / 2.0, 90.0 + sweep / 2.0
    raise InputError(f"milling mode '{mode}' is not one of {', '.join(_MODES)}")


def load_cut_params(path: str | Path) -> CutParams:
    """Read a cut file ([tool], [material], [cut] and [units]); every error names file and key."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise CutFileError(path, "<file>", f"cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise CutFileError(path, "<syntax>", str(exc)) from None
    return parse_cut_params(data, str(path))


def parse_cut_params(data: dict, path: str) -> CutParams:
    allowed = set(_SCHEMA) | {"units", "source"}
    for key in data:
        if key not in allowed:
            raise CutFileError(path, key, f"unknown section (allowed: {', '.join(sorted(allowed))})")
    _check_units(data.get("units"), path)
    values: dict[str, Any] = {}
    for section, keys in _SCHEMA.items():
        table = data.get(section, {})
        if not isinstance(table, dict):
            raise CutFileError(path, section, "must be a table")
        extra = set(table) - set(keys) - ({"mode"} if section == "cut" else set())
        if extra:
            raise CutFileError(path, f"{section}.{sorted(extra)[0]}", f"unknown key (allowed: {', '.join(sorted(keys))})")
        for key, (unit, lo, hi, default) in keys.items():
            values[key] = _number(table, key, section, unit, lo, hi, default, path)
    mode = data.get("cut", {}).get("mode", "down")
    if mode not in _MODES:
        raise CutFileError(path, "cut.mode", f"must be one of {', '.join(_MODES)}, got {mode!r}")
    if values["corner_radius"] > values["diameter"] / 2:
        raise CutFileError(path, "tool.corner_radius", "must not exceed half the diameter")
    if values["radial_width"] > values["diameter"]:
        raise CutFileError(path, "cut.radial_width", "must not exceed the diameter")
    source = data.get("source", ALUMINIUM_SOURCE if "material" not in data else None)
    if not isinstance(source, str) or not source.strip():
        raise CutFileError(path, "source", "a file giving [material] coefficients must cite them (source = \"...\")")
    values["teeth"] = int(values["teeth"])
    return CutParams(**values, mode=mode, source=source)


def _check_units(units, path: str) -> None:
    expected = {"length": "mm", "angle": "deg", "force": "N"}
    if units is None:
        raise CutFileError(path, "units", "missing: give [units] length = \"mm\", angle = \"deg\", force = \"N\"")
    if not isinstance(units, dict) or set(units) != set(expected):
        raise CutFileError(path, "units", f"must give exactly {', '.join(expected)}")
    for key, unit in expected.items():
        if units[key] != unit:
            raise CutFileError(path, f"units.{key}", f"must be '{unit}' (spec/conventions.md), got {units[key]!r}")


def _number(table, key, section, unit, lo, hi, default, path) -> float:
    where = f"{section}.{key}"
    if key not in table:
        if default is None:
            raise CutFileError(path, where, f"missing ({unit})")
        return float(default)
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise CutFileError(path, where, f"must be a finite number in {unit}, got {value!r}")
    if key == "teeth" and value != int(value):
        raise CutFileError(path, where, f"must be a whole number, got {value!r}")
    if not lo <= value <= hi:
        raise CutFileError(path, where, f"{value:g} {unit} is outside [{lo:g}, {hi:g}] {unit}")
    return float(value)


# ------------------------------------------------------------------ the force model


def _edge_kappa(params: CutParams, z: np.ndarray) -> np.ndarray:
    """Axial immersion kappa (rad) of the cutter envelope at heights z above the tip: on the
    corner radius r the envelope's normal turns from the axis (tip) to radial (flank).
    The helix lag uses the flank radius throughout (on the corner an approximation)."""
    r = params.corner_radius
    cos_k = np.where(z < r, (r - np.minimum(z, r)) / max(r, 1e-12), 0.0)
    return np.arccos(np.clip(cos_k, -1.0, 1.0))


def cutter_forces(params: CutParams, engagement=None, feed_per_tooth=None, *, angles: int = 180, elements: int = 60, chunk: int = 16):
    """Mean and peak cutting force (N) in the cutter frame at each cutter-contact point.

    engagement: (P, 4) rows of (phi_start, phi_exit, z_low, z_high) in deg and mm, or None
    for the stated cut of ``params``; feed_per_tooth (P,) mm or None for params'. Returns
    (mean (P, 3), peak (P, 3), peak magnitude (P,)). A point with an empty range gives 0.
    Vectorised over points (chunks of ``chunk``), angles in a tooth period and axial elements.
    """
    eng = np.atleast_2d(np.asarray(params.engagement() if engagement is None else engagement, dtype=float))
    if eng.shape[1] != 4:
        raise InputError(f"engagement must have 4 columns (phi_start, phi_exit, z_low, z_high), got shape {eng.shape}")
    feed = np.broadcast_to(np.asarray(params.feed_per_tooth if feed_per_tooth is None else feed_per_tooth, dtype=float), (len(eng),))
    mean = np.zeros((len(eng), 3))
    peak = np.zeros((len(eng), 3))
    size = np.zeros(len(eng))
    for s in range(0, len(eng), chunk):
        mean[s : s + chunk], peak[s : s + chunk], size[s : s + chunk] = _forces_chunk(params, eng[s : s + chunk], feed[s : s + chunk], angles, elements)
    return mean, peak, size


def _forces_chunk(params: CutParams, eng: np.ndarray, feed: np.ndarray, angles: int, elements: int):
    z_top = max(float(eng[:, 3].max(initial=0.0)), 1e-9)
    dz = z_top / elements
    z = (np.arange(elements) + 0.5) * dz  # midpoints (E,)
    kappa = _edge_kappa(params, z)
    lag = z * math.tan(math.radians(params.helix)) / (params.diameter / 2.0)  # helix lag (rad)
    pitch = 2.0 * math.pi / params.teeth
    theta = np.arange(angles) * pitch / angles  # one tooth period (S,)
    flutes = np.arange(params.teeth) * pitch  # (N,)
    phi = (theta[:, None, None] + flutes[None, :, None] - lag[None, None, :]) % (2.0 * math.pi)  # (S, N, E)
    p_st, p_ex = np.radians(eng[:, 0])[:, None, None, None], np.radians(eng[:, 1])[:, None, None, None]
    in_z = (z[None, :] >= eng[:, 2:3]) & (z[None, :] < eng[:, 3:4])  # (P, E)
    cut = (phi[None] >= p_st) & (phi[None] <= p_ex) & in_z[:, None, None, :]  # (P, S, N, E)
    sk, ck = np.sin(kappa), np.cos(kappa)
    sp, cp = np.sin(phi), np.cos(phi)
    h = feed[:, None, None, None] * sp[None] * sk  # chip thickness (P, S, N, E)
    db = dz / np.maximum(sk, 1e-9)
    f_t = (params.ktc * h + params.kte) * db * cut
    f_r = (params.krc * h + params.kre) * db * cut
    f_a = (params.kac * h + params.kae) * db * cut
    # eq. 15: [dFx, dFy, dFz] = A(phi, kappa) [dFr, dFt, dFa]
    fx = (-sk * sp * f_r - cp * f_t - ck * sp * f_a).sum(axis=(2, 3))
    fy = (-sk * cp * f_r + sp * f_t - ck * cp * f_a).sum(axis=(2, 3))
    fz = (ck * f_r - sk * f_a).sum(axis=(2, 3))
    force = np.stack([fx, fy, fz], axis=-1)  # (P, S, 3)
    magnitude = np.linalg.norm(force, axis=-1)
    at = magnitude.argmax(axis=1)
    rows = np.arange(len(eng))
    return force.mean(axis=1), force[rows, at], magnitude[rows, at]


def surface_normal_cutter(lead_deg: float, tilt_deg: float) -> np.ndarray:
    """The surface normal n in the cutter frame for a cutter leaning by lead (towards the feed) and tilt (sideways)."""
    lead, tilt = math.radians(lead_deg), math.radians(tilt_deg)
    return np.array([-math.sin(lead) * math.cos(tilt), -math.sin(tilt), math.cos(lead) * math.cos(tilt)])


def cutter_frames(tcp_rot: np.ndarray, feed_dir: np.ndarray) -> np.ndarray:
    """Rotations (P, 3, 3) of the cutter frame (columns x feed, y, z cutter axis) from TCP
    rotations (P, 3, 3) whose z axis points from the spindle into the work (so z_cutter = -z_tcp)
    and feed directions (P, 3) in the same frame. A feed along the axis (plunge) or no feed
    falls back to the TCP's x axis."""
    z = -tcp_rot[:, :, 2]
    feed = feed_dir - np.einsum("ij,ij->i", feed_dir, z)[:, None] * z
    norm = np.linalg.norm(feed, axis=1)
    fallback = norm < 1e-9
    feed[fallback] = tcp_rot[fallback, :, 0]
    x = feed / np.linalg.norm(feed, axis=1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-1)


def to_frame(rot: np.ndarray, force_cutter: np.ndarray) -> np.ndarray:
    """eq. 16-17: forces (P, 3) in the cutter frame -> the frame the rotations (P, 3, 3) map into."""
    return np.einsum("pij,pj->pi", rot, force_cutter)


# ------------------------------------------------------------------ forces of a program

CUTTING_KINDS = (1, 2, 3, 6, 7)  # Kind.LINEAR, CIRC_VIA, CIRC_END, ARC_CW, ARC_CCW: moves that cut


def forces_along(poses: np.ndarray, cutting: np.ndarray, *, params: CutParams | None = None, force_tool=None,
                 engagement=None, statistic: str = "mean") -> tuple[np.ndarray, np.ndarray]:
    """Cutting force (P, 3) N on the tool and surface normal (P, 3) at TCP poses (P, 4, 4),
    both in the frame the poses are given in; zero force where ``cutting`` is False.

    Either ``force_tool`` (3,) N, constant in the TCP frame (normal = -z_tcp), or the
    mechanistic model ``params`` (``statistic`` "mean" over a tooth period or "peak", the
    force at the largest resultant; ``engagement`` (P, 4) per point as in ``cutter_forces``,
    else params' stated cut), whose cutter frame takes the feed from the move arriving at
    each point (the next one for the first).
    """
    if statistic not in ("mean", "peak"):
        raise InputError(f"force statistic '{statistic}' is not mean or peak")
    rot = poses[:, :3, :3]
    if (params is None) == (force_tool is None):
        raise InputError("give either a constant tool-frame force or a cutting-parameter file, not both or neither")
    if force_tool is not None:
        force = np.einsum("pij,j->pi", rot, np.asarray(force_tool, dtype=float))
        return force * cutting[:, None], -rot[:, :, 2]
    pos = poses[:, :3, 3]
    feed = np.zeros_like(pos)
    if len(pos) > 1:
        feed[1:] = np.diff(pos, axis=0)
        feed[0] = feed[1]
    frames = cutter_frames(rot, feed)
    mean, peak, _ = cutter_forces(params, engagement)
    if statistic == "peak":
        mean = peak
    if mean.shape[0] == 1:
        mean = np.repeat(mean, len(poses), axis=0)
    force = to_frame(frames, mean) * cutting[:, None]
    normal = frames @ surface_normal_cutter(params.lead, params.tilt)
    return force, normal


def program_forces(tp, *, params: CutParams | None = None, force_tool=None, engagement=None, statistic: str = "mean") -> np.ndarray:
    """The compensation hook: per-target cutting force (N, 3) in the robot base frame, N.

    Cartesian cutting moves get the model's force (mean over a tooth period, or the peak
    with ``statistic="peak"``), every other
    target (rapid, joint move, joint target) zero. ``engagement`` (N, 4) may give each
    target's (phi_start, phi_exit, z_low, z_high), e.g. from ``engagement.from_stock``.
    """
    cutting = np.isin(tp.kind, CUTTING_KINDS) & ~np.isnan(tp.position).any(axis=1)
    poses = tp.base_poses()
    poses[np.isnan(poses)] = 0.0
    eng = None if engagement is None else np.asarray(engagement, dtype=float)
    force, _ = forces_along(poses, cutting, params=params, force_tool=force_tool, engagement=eng, statistic=statistic)
    return force
