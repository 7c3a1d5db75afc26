"""LinuxCNC polar coordinates: ``@`` radius and ``^`` angle (degrees) in place of X and Y.

LinuxCNC manual, G-code overview, "Polar Coordinates": in G90 the end point is
(@ cos ^, @ sin ^) about the origin of the current coordinate system, a missing @ or ^
keeps the current radius or angle; in G91 @ is added to the current radius and ^ to the
current angle (interp_find.cc find_ends). Polar words always address X and Y, whatever the
plane; they may not be mixed with X or Y words.
"""

from __future__ import annotations

import math


class PolarError(ValueError):
    """A polar move LinuxCNC refuses (X/Y given too, or indeterminate at the origin)."""


def polar_end(x: float, y: float, radius: float | None, angle: float | None, incremental: bool) -> tuple[float, float]:
    """End (x, y) of a polar move from the current (x, y); None where the word is absent."""
    if incremental:
        if x == 0 and y == 0:
            raise PolarError("G91 motion with polar coordinates is indeterminate when at the origin")
        if radius is not None:
            x, y = _grow(x, y, radius)
        if angle is not None:
            x, y = _turn(x, y, angle)
        return x, y
    if radius is not None and angle is not None:
        return radius * math.cos(math.radians(angle)), radius * math.sin(math.radians(angle))
    if radius is not None:
        if x == 0 and y == 0:
            raise PolarError("must specify the angle ^ in a polar coordinate at the origin")
        theta = math.atan2(y, x)
        return radius * math.cos(theta), radius * math.sin(theta)
    r = math.hypot(x, y)
    return r * math.cos(math.radians(angle)), r * math.sin(math.radians(angle))


def polar_step(x: float, y: float, radius_increment: float, angle_increment: float) -> tuple[float, float]:
    """One canned-cycle repeat's polar increment (interp_internal.hh CYCLE_MACRO): radius
    first, then angle, each only where non-zero."""
    if radius_increment:
        if x == 0 and y == 0:
            raise PolarError("incremental motion with polar coordinates is indeterminate when at the origin")
        x, y = _grow(x, y, radius_increment)
    if angle_increment:
        if x == 0 and y == 0:
            raise PolarError("incremental motion with polar coordinates is indeterminate when at the origin")
        x, y = _turn(x, y, angle_increment)
    return x, y


def _grow(x: float, y: float, dr: float) -> tuple[float, float]:
    theta, r = math.atan2(y, x), math.hypot(x, y) + dr
    return r * math.cos(theta), r * math.sin(theta)


def _turn(x: float, y: float, degrees: float) -> tuple[float, float]:
    theta, r = math.atan2(y, x) + math.radians(degrees), math.hypot(x, y)
    return r * math.cos(theta), r * math.sin(theta)
