"""AR= arcs (circle by its end point and opening angle) as the radius arcs the IR holds.

SINUMERIK 840D sl Fundamentals (6FC5398-1BP40), "Circular interpolation", "Circle with
opening angle and center point / end point (AR)": ``G2/G3 X.. Y.. AR=a`` goes from the start
to the end point through the opening angle ``a`` (0 < a < 360 degrees), clockwise (G2) or
counter-clockwise (G3) in the active plane. The chord d and the angle give the radius
``d / (2 sin(a/2))``; an angle up to 180 degrees is the short arc, more the long one: the
same arc as a radius arc with ``R = +r`` or ``-r`` (``postproc.programs.arcs.centre_from_radius``).
The IR keeps that radius as the arc's R word, without a span: the file's number is the angle,
never written over with a radius.
"""

from __future__ import annotations

import re

import numpy as np

_AR = re.compile(r"(?i)(?<![A-Za-z0-9_$])AR[ \t]*=[ \t]*(?P<value>[^ \t;]*)")
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


class NotRead(ValueError):
    """An opening angle that cannot be used (the message says why)."""


def opening_angle(line: str) -> float:
    """The AR= value of a block (degrees): a number in (0, 360)."""
    m = _AR.search(line.partition(";")[0])
    if m is None or not _NUMBER.fullmatch(m.group("value")):
        raise NotRead(f"AR={m.group('value') if m else ''} is not a number (an expression is not evaluated here)")
    angle = float(m.group("value"))
    if not 0.0 < angle < 360.0:
        raise NotRead(f"AR={m.group('value')}: the opening angle must lie between 0 and 360 degrees")
    return angle


def signed_radius(start_2d: np.ndarray, end_2d: np.ndarray, angle_deg: np.ndarray) -> np.ndarray:
    """Radius-arc R (M,) of arcs (M, 2 in-plane points) with opening angles (M,): + up to 180
    degrees (the short arc), - beyond; NaN where start and end coincide (no chord)."""
    chord = np.linalg.norm(np.asarray(end_2d) - np.asarray(start_2d), axis=1)
    half = np.radians(np.asarray(angle_deg, float)) / 2.0
    radius = chord / (2.0 * np.sin(half))
    return np.where(chord > 1e-9, np.where(angle_deg <= 180.0, radius, -radius), np.nan)
