"""Cutter radius compensation (G41 / G42, G41.1 / G42.1, G40) in the G17 and G18 planes, as LinuxCNC's
interpreter applies it to the path it sends to the machine.

LinuxCNC manual, "Cutter Radius Compensation": G41 keeps the tool on the left of the programmed
path, G42 on the right; the radius is half the tool-table diameter of tool D (G41 / G42) or
D / 2 (G41.1 / G42.1, D a diameter in program units; a negative radius swaps the side).
"The end point of each move depends on the next move. If the next move creates an outside
corner the move will be to the end point of the compensated cut line. If the next move creates
an inside corner the move will stop short so to not gouge the part." The entry move (the first
straight move after G41 / G42) ends one radius from its programmed end, perpendicular to it;
"the minimum length is the cutter radius". Around an outside (convex) corner the interpreter
adds an arc about the programmed corner (a straight traverse for G0); in an inside (concave)
corner the move before is cut back to where the two offset paths meet. G40: the move after it
goes from the compensated point to its programmed end, and must be straight.

The geometry below follows the rules of rs274ngc's convert_straight_comp1/comp2 and
convert_arc_comp2 (corner angle tolerance 0.05 rad, one pending move whose end the next move
decides), written from their description; the tests compare it with rs274's own output.
Everything is in program coordinates, mm, as the plane's (first, second, normal) axes: G17
X Y Z; G18 Z X Y, as rs274ngc (left / right and G2 / G3 as seen in Z X; centre words K I);
the caller (interp.py) maps them (G19 LinuxCNC refuses).

A case this module does not follow (an arc of several turns, a corner LinuxCNC
refuses as a gouge) raises ``Unfollowed``: the caller flags the targets under that compensation
as unresolved, with the line and the reason, never a guessed number.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

SMALL = 0.05  # rad: TOLERANCE_CONCAVE_CORNER of rs274ngc, the angle that tells a corner from a straight run
HALF_PI = math.pi / 2


class Unfollowed(ValueError):
    """A compensated move this module does not compute (or LinuxCNC refuses): the reason."""


@dataclass
class Out:
    """One move the controller makes under compensation (program coordinates, mm)."""

    row: int  # block of the move (a corner arc: the block whose move needs it)
    motion: int  # 0 rapid, 1 feed, 2 clockwise arc, 3 counter-clockwise arc
    end: list  # x y z
    extra: dict  # what the caller keeps with the target (rotary axes, frame, exactness)
    generated: bool = False  # a corner arc (or traverse) the program text has no block for
    centre: tuple | None = None  # arcs: centre x y
    turn: int = 0  # arcs: +1 counter-clockwise, -1 clockwise
    sweep: float = 0.0  # arcs: programmed sweep (rad, signed), 0 for corner arcs
    direction: tuple = (0.0, 0.0)  # lines: the direction rs274 checks a moved end against


def _dir(angle: float) -> tuple[float, float]:
    return math.cos(angle), math.sin(angle)


def find_turn(x1, y1, cx, cy, turn, x2, y2) -> float:
    """Signed sweep (rad, + counter-clockwise) of an arc from (x1, y1) to (x2, y2) about (cx, cy)."""
    if turn == 0:
        return 0.0
    a, b = math.atan2(y1 - cy, x1 - cx), math.atan2(y2 - cy, x2 - cx)
    if turn > 0:
        b = b + 2 * math.pi if b <= a else b
        return b - a + (turn - 1) * 2 * math.pi
    a = a + 2 * math.pi if a <= b else a
    return b - a + (turn + 1) * 2 * math.pi


def arc_centre(start, end, words: dict, ijk_absolute: bool, ccw: bool, scale: float) -> tuple[float, float]:
    """Programmed centre (x, y) of a G17 arc from I J (offsets from the start, or coordinates
    under G90.1; a word left out reads as 0) or R (R < 0: more than half a circle)."""
    if "R" in words:
        r = words["R"] * scale
        sx, sy, ex, ey = start[0], start[1], end[0], end[1]
        d = math.hypot(ex - sx, ey - sy)
        if d == 0.0:
            raise Unfollowed("radius-format arc with its end at its start")
        h = math.sqrt(max(r * r - d * d / 4.0, 0.0))
        side = 1.0 if ccw == (r > 0) else -1.0  # counter-clockwise and short: centre on the left of the chord
        lx, ly = -(ey - sy) / d, (ex - sx) / d
        return (sx + ex) / 2 + side * h * lx, (sy + ey) / 2 + side * h * ly
    i, j = words.get("I", 0.0), words.get("J", 0.0)
    return (i, j) if ijk_absolute else (start[0] + i, start[1] + j)


@dataclass
class CutterComp:
    """The compensation in force between G41 / G42 and G40: moves go in with their programmed
    end points, compensated moves come out (``emitted``) once the move after them decides
    where they end (rs274ngc's queue). ``side`` +1 left (G41), -1 right (G42); ``radius`` mm > 0."""

    side: int
    radius: float
    scale: float  # mm per program unit (rs274's tolerances are in program units)
    prog: list  # programmed current point x y z
    cur: list = field(default_factory=list)  # compensated current point
    first: bool = True
    queue: list = field(default_factory=list)
    emitted: list = field(default_factory=list)
    endpoint: tuple | None = None  # start of the pending moves, where rs274 checks a moved end against (kept from the compensation before)

    def __post_init__(self):
        self.cur = list(self.prog)

    def _inside(self, turn: int) -> bool:
        """The tool runs on the inside of an arc turning ``turn``."""
        return (self.side > 0 and turn > 0) or (self.side < 0 and turn < 0)

    def _dequeue(self) -> None:
        self.emitted.extend(self.queue)
        self.queue = []
        self.endpoint = None

    def _move_end_and_flush(self, x: float, y: float) -> None:
        """Every pending move ends at (x, y) now (an inside corner cut back), then goes out."""
        if not self.queue:
            return
        for q in self.queue:
            if q.centre is not None:
                r1 = math.hypot(q.end[0] - q.centre[0], q.end[1] - q.centre[1])
                r2 = math.hypot(x - q.centre[0], y - q.centre[1])
                if abs(r1 - r2) > 0.01 * self.scale:
                    raise Unfollowed("the compensated arc's end cannot be moved onto the next move")
                if q.sweep != 0.0 and self.endpoint is not None:
                    new = find_turn(self.endpoint[0], self.endpoint[1], q.centre[0], q.centre[1], q.turn, x, y)
                    if abs(new) > abs(q.sweep) + (0.0254 if self.scale == 1.0 else 0.001):  # rs274ngc's allowance (rad) in G21 / G20
                        raise Unfollowed("Arc move in concave corner cannot be reached by the tool without gouging")
            elif self.endpoint is not None:
                dot = q.direction[0] * (x - self.endpoint[0]) + q.direction[1] * (y - self.endpoint[1])
                if dot < 0:
                    raise Unfollowed("Straight move in concave corner cannot be reached by the tool without gouging")
            q.end[0], q.end[1] = x, y
        self._dequeue()
        self.endpoint = (x, y)

    # ------------------------------------------------------------ moves
    def straight(self, row: int, motion: int, end: list, extra: dict) -> None:
        if self.first:
            self._entry(row, motion, end, extra)
        else:
            self._straight(row, motion, end, extra)
        self.prog = list(end)

    def _entry(self, row, motion, end, extra) -> None:
        """The first move: to one radius from its end, perpendicular to it, on the side."""
        cx, cy = self.cur[0], self.cur[1]
        if math.hypot(end[0] - cx, end[1] - cy) <= self.radius:
            raise Unfollowed("Length of cutter compensation entry move is not greater than the tool radius")
        alpha = math.atan2(end[1] - cy, end[0] - cx) + self.side * HALF_PI
        ux, uy = _dir(alpha)
        self.endpoint = (cx, cy)
        self.queue.append(Out(row, motion, [end[0] + self.radius * ux, end[1] + self.radius * uy, end[2]], extra, direction=(ux, uy)))
        self.cur = list(self.queue[-1].end)
        self.first = False

    def _straight(self, row, motion, end, extra) -> None:
        ox, oy = self.prog[0], self.prog[1]
        cx, cy, cz = self.cur
        px, py, pz = end
        if px == ox and py == oy:  # no move in the plane: along Z where the tool is
            self.queue.append(Out(row, motion, [cx, cy, pz], extra, direction=(0.0, 0.0)))
            self.cur = [cx, cy, pz]
            return
        theta, alpha = math.atan2(cy - oy, cx - ox), math.atan2(py - oy, px - ox)
        if self.side > 0:
            theta = theta + 2 * math.pi if theta < alpha else theta
            beta = theta - alpha - HALF_PI
        else:
            alpha = alpha + 2 * math.pi if alpha < theta else alpha
            beta = alpha - theta - HALF_PI
        gamma = self.side * HALF_PI
        nx, ny = _dir(alpha + gamma)
        new_end = [px + self.radius * nx, py + self.radius * ny, pz]
        mid = (ox + self.radius * nx, oy + self.radius * ny)
        front = self.queue[0] if self.queue else None
        h_shape = beta > math.pi - SMALL and front is not None and front.centre is not None and not self._inside(front.turn)
        concave = beta < -SMALL or beta > math.pi + SMALL or h_shape
        if not concave and beta > SMALL:  # outside corner: an arc about the programmed corner (G0: a traverse)
            self._move_end_and_flush(cx, cy)
            if motion == 1:
                self.queue.append(Out(row, 2 if self.side > 0 else 3, [mid[0], mid[1], cz], extra, generated=True, centre=(ox, oy), turn=-self.side))
            else:
                self.queue.append(Out(row, 0, [mid[0], mid[1], cz], extra, generated=True, direction=(0.0, 0.0)))
            self._dequeue()
            self.endpoint = mid
        elif concave:
            if front is None:
                raise Unfollowed("an inside corner with no move before it under compensation")
            self._move_end_and_flush(*(self._line_line(theta, beta, gamma) if front.centre is None else self._arc_line(front, ox, oy, px, py)))
        else:  # straight on (or a tangent arc -> line)
            self._dequeue()
            self.endpoint = (cx, cy)
        self.queue.append(Out(row, motion, new_end, extra, direction=(px - ox, py - oy)))
        self.cur = new_end

    def _line_line(self, theta, beta, gamma) -> tuple[float, float]:
        """Line into line at an inside corner: the pending line stops where the offsets meet."""
        half = (beta + math.pi) / 2.0
        if half == 0.0:
            raise Unfollowed("Zero degree inside corner is invalid for cutter compensation")
        back = self.radius / math.tan(half)
        ux, uy = _dir(theta + gamma)
        return self.cur[0] + back * ux, self.cur[1] + back * uy

    def _arc_line(self, prev: Out, ox, oy, px, py) -> tuple[float, float]:
        """Arc into line at an inside corner: the point of the compensated arc one radius from the line."""
        r = self.radius
        old = math.hypot(prev.centre[0] - prev.end[0], prev.centre[1] - prev.end[1])
        th = math.atan2(py - oy, px - ox) + (HALF_PI if prev.turn > 0 else -HALF_PI)
        phi = math.atan2(prev.centre[1] - oy, prev.centre[0] - ox)
        inside = self._inside(prev.turn)
        d = (old + r if inside else old - r) * math.cos(th - phi)
        ratio = (d - r if inside else d + r) / old
        if abs(ratio) > 1.0:
            raise Unfollowed("Arc to straight motion makes a corner the compensated tool can't fit in without gouging")
        sign = -1.0 if (prev.turn > 0) == inside else 1.0
        angle = sign * math.acos(ratio) + th + math.pi
        return prev.centre[0] + old * math.cos(angle), prev.centre[1] + old * math.sin(angle)

    def arc(self, row: int, motion: int, end: list, centre: tuple, extra: dict) -> None:
        if self.first:
            self._entry_arc(row, motion, end, centre, extra)
            return
        r, (kx, ky) = self.radius, centre
        ox, oy = self.prog[0], self.prog[1]
        cx, cy, cz = self.cur
        px, py, pz = end
        turn = 1 if motion == 3 else -1
        arc_radius = math.hypot(kx - px, ky - py)
        theta = math.atan2(cy - oy, cx - ox) - self.side * HALF_PI
        delta = math.atan2(ky - oy, kx - ox)
        alpha = delta - HALF_PI if turn > 0 else delta + HALF_PI
        beta = (theta - alpha) * self.side
        beta = beta - 2 * math.pi if beta > 1.5 * math.pi else beta + 2 * math.pi if beta < -HALF_PI else beta
        inside = self._inside(turn)
        if inside:
            if arc_radius <= r:
                raise Unfollowed("Tool radius not less than arc radius with comp")
            gamma = math.atan2(ky - py, kx - px)
        else:
            gamma = math.atan2(py - ky, px - kx)
            delta += math.pi
        new_end = [px + r * math.cos(gamma), py + r * math.sin(gamma), pz]
        sweep = find_turn(ox, oy, kx, ky, turn, px, py)
        front = self.queue[0] if self.queue else None
        if beta < -SMALL or beta > math.pi + SMALL or (abs(beta - math.pi) < SMALL and not inside):
            if front is None:
                raise Unfollowed("an inside corner with no move before it under compensation")
            mid = self._line_arc(theta, beta, arc_radius, inside, turn, centre) if front.centre is None else self._arc_arc(front, arc_radius, inside, turn, centre)
            self._move_end_and_flush(*mid)
        elif beta > SMALL:  # outside corner: an arc about the programmed corner first
            mid = (ox + r * math.cos(delta), oy + r * math.sin(delta))
            self._dequeue()
            self.queue.append(Out(row, 2 if self.side > 0 else 3, [mid[0], mid[1], cz], extra, generated=True, centre=(ox, oy), turn=-self.side))
            self._dequeue()
            self.endpoint = mid
        else:
            self._dequeue()
            self.endpoint = (cx, cy)
        self.queue.append(Out(row, motion, new_end, extra, centre=(kx, ky), turn=turn, sweep=sweep))
        self.prog, self.cur = list(end), new_end

    def _entry_arc(self, row, motion, end, centre, extra) -> None:
        """An arc as the entry move: from where the tool is to one radius off the programmed
        end (toward the centre with the tool inside the arc, away from it outside), about the
        point of the line from that end to the programmed centre as far from both ends."""
        r, (kx, ky) = self.radius, centre
        cx, cy = self.cur[0], self.cur[1]
        px, py, pz = end
        turn = 1 if motion == 3 else -1
        inside = self._inside(turn)
        if inside and math.hypot(kx - cx, ky - cy) <= r:
            raise Unfollowed("Tool radius not less than arc radius with comp")
        if math.hypot(px - cx, py - cy) <= r:
            raise Unfollowed("Radius of cutter compensation entry arc is not greater than the tool radius")
        gamma = math.atan2(ky - py, kx - px) if inside else math.atan2(py - ky, px - kx)
        ex, ey = px + r * math.cos(gamma), py + r * math.sin(gamma)
        toward = math.atan2(ky - ey, kx - ex)
        cos_a = math.cos(math.atan2(cy - ey, cx - ex) - toward)
        if abs(cos_a) < 1e-6:
            raise Unfollowed("Tool radius not less than arc radius with comp")
        reach = math.hypot(cy - ey, cx - ex) / 2.0 / cos_a
        new_centre = (ex + reach * math.cos(toward), ey + reach * math.sin(toward))
        sweep = find_turn(cx, cy, new_centre[0], new_centre[1], turn, ex, ey)
        self.queue.append(Out(row, motion, [ex, ey, pz], extra, centre=new_centre, turn=turn, sweep=sweep))
        self.prog, self.cur, self.first = list(end), [ex, ey, pz], False

    def _line_arc(self, theta, beta, arc_radius, inside, turn, centre) -> tuple[float, float]:
        r = self.radius
        across = arc_radius * math.sin(beta - HALF_PI)
        dist = arc_radius - r if inside else arc_radius + r
        ratio = (across + r if inside else across - r) / dist
        if abs(ratio) > 1.0:
            raise Unfollowed("Arc move in concave corner cannot be reached by the tool without gouging")
        if inside:
            angle = theta + math.asin(ratio) * turn
        else:
            angle = theta + math.pi - math.asin(ratio) * turn
        return centre[0] + dist * math.cos(angle), centre[1] + dist * math.sin(angle)

    def _arc_arc(self, prev: Out, arc_radius, inside, turn, centre) -> tuple[float, float]:
        old = math.hypot(prev.centre[1] - prev.end[1], prev.centre[0] - prev.end[0])
        new = arc_radius - self.radius if inside else arc_radius + self.radius
        apart = math.hypot(prev.centre[1] - centre[1], prev.centre[0] - centre[0])
        if old == 0 or apart == 0:
            raise Unfollowed("Arc to arc motion is invalid because the arcs have the same center")
        cos_a = (old * old + apart * apart - new * new) / (2 * old * apart)
        if abs(cos_a) > 1.0:
            raise Unfollowed("Arc to arc motion makes a corner the compensated tool can't fit in without gouging")
        pull = math.acos(cos_a)
        toward = math.atan2(centre[1] - prev.centre[1], centre[0] - prev.centre[0])
        sign = 1.0 if (turn > 0) == self._inside(prev.turn) else -1.0
        angle = toward + sign * pull
        return prev.centre[0] + old * math.cos(angle), prev.centre[1] + old * math.sin(angle)

    def off(self) -> list:
        """G40 (or the end of the program, M2): the pending moves go out where they end now,
        with rs274ngc's checks of a moved end (Unfollowed where it refuses them)."""
        self._move_end_and_flush(self.cur[0], self.cur[1])
        return self.take()

    def drop(self) -> list:
        """The pending and decided moves as they stand (the path is given up: flagged)."""
        self._dequeue()
        return self.take()

    def take(self) -> list:
        """The moves decided so far, in order (taken out)."""
        out, self.emitted = self.emitted, []
        return out
