"""Circles and polar moves of Klartext (TNC 640 User's Manual, "Path contours - Cartesian
coordinates" and "- polar coordinates"): the pole CC, C about it, CR by radius, CT tangent to
the previous element, LP / CP about the pole."""

from __future__ import annotations

import math

import numpy as np

from ...ir import F_ARC, Kind
from .fields import AXES, R_FIELD
from .words import PathWords


class Contours:
    """KlartextReader's circles and polar moves (a mixin: the reader's state is ``self``)."""

    def set_pole(self, words: PathWords, at: int) -> None:
        got = False
        for letter, i in (("X", 0), ("Y", 1)):
            w = words.words.get(letter)
            if w is not None:
                v, _ = self.value(w.text, w.start)
                v *= self.scale
                self.pole[i] = self.pole[i] + v if w.incremental else v
                got = True
        if not got:
            self.pole = self.pos[:2].copy()  # CC without coordinates: the last programmed position
        if np.isnan(self.pole).any():
            raise self.error(at, "pole CC not determined (no position before it)")
        self.polar = [math.nan, math.nan]

    def circle(self, kind: str, words: PathWords, start, vals, spans, at: int):
        if words.dr is None and kind != "CT":
            raise self.error(at, f"{kind} needs DR+ or DR- (direction of rotation)")
        if kind == "C":
            if np.isnan(self.pole).any():
                raise self.error(at, "C needs a pole CC before it")
            centre = self.pole
            r_start, r_end = np.hypot(*(start[:2] - centre)), np.hypot(*(self.pos[:2] - centre))
            # The TNC refuses a circle whose end is off it by more than a machine parameter's bound;
            # that bound is not in the text: this reader's own 0.016 mm (CAM posts round to 3 decimals)
            if abs(r_start - r_end) > 0.016:
                raise self.error(at, f"end point is {r_end:.4f} mm from the pole, start {r_start:.4f} mm: not on one circle")
            vals[F_ARC.start], vals[F_ARC.start + 1] = centre
            return ("C", centre, words.dr)
        if kind == "CR":
            w = words.words.get("R")
            if w is None:
                raise self.error(at, "CR needs R (the radius)")
            r, _ = self.value(w.text, w.start)
            vals[R_FIELD] = r * self.scale
            if w.plain:
                spans[R_FIELD] = (0, w.start, w.end)
            centre = self._radius_centre(start[:2], self.pos[:2], r * self.scale, words.dr == "+", w.start)
            return ("CR", centre, words.dr)
        # CT: tangent to the previous element
        if self.tangent is None or np.isnan(self.tangent).any():
            raise self.error(at, "CT needs a contour element before it (its tangent)")
        d = self.tangent
        chord = self.pos[:2] - start[:2]
        cross = d[0] * chord[1] - d[1] * chord[0]
        if abs(cross) < 1e-12:
            raise self.error(at, "CT end point on the tangent: no circle")
        normal = np.array([-d[1], d[0]])
        t = (chord @ chord) / (2.0 * (normal @ chord))
        centre = start[:2] + t * normal
        vals[F_ARC.start], vals[F_ARC.start + 1] = centre
        return ("CT", centre, "+" if cross > 0 else "-")

    def _radius_centre(self, a, b, r: float, ccw: bool, at: int) -> np.ndarray:
        """Centre of the CR arc: R+ the arc of at most 180 degrees, R- the longer one (TNC 640
        manual, "Circular path CR with defined radius"), left of the chord for DR+ and R+."""
        chord = b - a
        half = np.hypot(*chord) / 2.0
        if half == 0.0 or abs(r) < half - 1e-9:
            raise self.error(at, f"radius {abs(r):g} mm is shorter than half the chord ({half:.4f} mm): no such circle")
        u = chord / (2.0 * half)
        left = np.array([-u[1], u[0]])
        side = 1.0 if ccw == (r > 0) else -1.0
        return (a + b) / 2.0 + side * math.sqrt(max(r * r - half * half, 0.0)) * left

    def polar_move(self, kind: str, words: PathWords, start, vals, spans, at: int) -> bool:
        if np.isnan(self.pole).any():
            raise self.error(at, f"{kind} needs a pole CC before it")
        pr, pa = self.polar
        if kind == "CP":
            pr = float(np.hypot(*(start[:2] - self.pole)))  # CP keeps the distance from the pole
            if math.isnan(pa):
                pa = math.degrees(math.atan2(start[1] - self.pole[1], start[0] - self.pole[0]))
        for letter in ("PR", "PA"):
            w = words.words.get(letter)
            if w is None:
                continue
            v, _ = self.value(w.text, w.start)
            if letter == "PR":
                if kind == "CP":
                    raise self.error(w.start, "CP takes no PR (its radius is the distance from the pole)")
                v *= self.scale
                pr = pr + v if w.incremental else v
            else:
                if w.incremental and math.isnan(pa):
                    pa = math.degrees(math.atan2(start[1] - self.pole[1], start[0] - self.pole[0]))
                pa = pa + v if w.incremental else v
        if math.isnan(pr) or math.isnan(pa):
            raise self.error(at, f"{kind}: polar radius PR and angle PA not both known")
        self.polar = [pr, pa]
        self.pos[0] = self.pole[0] + pr * math.cos(math.radians(pa))
        self.pos[1] = self.pole[1] + pr * math.sin(math.radians(pa))
        vals[0], vals[1] = self.pos[0], self.pos[1]
        for letter in ("Z", "A", "B", "C"):
            w = words.words.get(letter)
            if w is not None:
                v, _ = self.value(w.text, w.start)
                i = "XYZABC".index(letter)
                v *= self.scale if i < 3 else 1.0
                self.pos[i] = self.pos[i] + v if w.incremental else v
                vals[AXES[letter]] = self.pos[i]
                if w.plain and not w.incremental:
                    spans[AXES[letter]] = (0, w.start, w.end)
        if kind == "CP":
            if words.dr is None:
                raise self.error(at, "CP needs DR+ or DR-")
            vals[F_ARC.start], vals[F_ARC.start + 1] = self.pole
        return True

    def _tangent(self, k, start, arc):
        if arc is None:
            d = self.pos[:2] - start[:2]
            n = np.hypot(*d)
            return d / n if n > 0 else self.tangent
        centre = arc[1] if arc != "CP" else self.pole
        radial = self.pos[:2] - centre
        ccw = k == Kind.ARC_CCW
        t = np.array([-radial[1], radial[0]]) if ccw else np.array([radial[1], -radial[0]])
        n = np.hypot(*t)
        return t / n if n > 0 else self.tangent

    # ------------------------------------------------------------- IR
