"""Work offsets as LinuxCNC's interpreter keeps them: G54-G59.3 origins with their XY
rotation (G10 L2 / L20 ... R), the G92 / G52 axis offset (G92.1 / G92.2 / G92.3) and G53.

The machine position of a program point p (mm) is ``rot_R(p + g92) + origin`` (LinuxCNC
manual, "Coordinate Systems": G92 is applied before the rotation, the G5x origin after;
emccanon's rotate_and_offset_pos). The state here mirrors rs274ngc's setup: the current
point in program coordinates and, when a coordinate system, offset or rotation changes,
the same update of the current point that the interpreter makes (interp_convert.cc
convert_setup, convert_axis_offsets, convert_coordinate_system), so that a later block
that leaves an axis out keeps the controller's value. All lengths are mm, angles degrees.

Rotary axes A B C: each G5x origin and the G92 offset have A B C components too (G10 L2 /
L20 P.. A.., G92 / G52 A..), added to the programmed angle with no rotation: machine angle =
programmed + G92 + G5x (LinuxCNC src/emc/task/emccanon.cc rotate_and_offset_pos:
``a += g92Offset.a; ... a += g5xOffset.a; ... a += toolOffset.a``). A change of offsets does
not move the machine: the current programmed angle becomes machine - the new offsets
(rs274's convert_setup / convert_axis_offsets / convert_coordinate_system, checked with
rs274 in tests/test_fivex_offsets.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from postproc.robot.frames import make_transform, rot_z


def rotate(x: float, y: float, degrees: float) -> tuple[float, float]:
    """(x, y) turned by ``degrees`` about Z (rs274ngc's rotate())."""
    if not degrees:
        return x, y
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return x * c - y * s, x * s + y * c


@dataclass
class Offsets:
    """G5x origins (index 1..9 = G54..G59.3), their rotations, the G92 offset and its
    stored parameters (#5211-#5213, #5210 'applied')."""

    origin: list = field(default_factory=lambda: [[0.0, 0.0, 0.0] for _ in range(10)])
    rotation: list = field(default_factory=lambda: [0.0] * 10)
    set_at: list = field(default_factory=lambda: [None] * 10)  # line of the G10 that last set each system
    # the system's origin is known in the machine frame (set by G10 L2 on every axis, or by G10 L20 from a point
    # known there); one the program does not set is on the controller: identity stands in, flagged (interp._Run)
    known: list = field(default_factory=lambda: [False] * 10)
    index: int = 1
    g92: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    g92_params: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    g92_at: int | None = None  # line of the G92 / G52 / G92.3 that set the offset now in force
    origin_abc: list = field(default_factory=lambda: [[0.0, 0.0, 0.0] for _ in range(10)])  # A B C of each G5x origin, deg
    g92_abc: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    g92_abc_params: list = field(default_factory=lambda: [0.0, 0.0, 0.0])

    # ------------------------------------------------------------ machine frame
    def machine(self, p) -> list[float]:
        """Machine position of program point ``p``."""
        x, y = rotate(p[0] + self.g92[0], p[1] + self.g92[1], self.rotation[self.index])
        o = self.origin[self.index]
        return [x + o[0], y + o[1], p[2] + self.g92[2] + o[2]]

    def key(self) -> tuple:
        """What identifies the frame program points are in now."""
        return (self.index, tuple(self.origin[self.index]), self.rotation[self.index], self.set_at[self.index], tuple(self.g92), self.g92_at,
                self.known[self.index])

    @staticmethod
    def transform(key: tuple) -> np.ndarray:
        """machine_T_program of a frame ``key``: translate(origin) . rotZ(R) . translate(g92)."""
        origin, rotation, g92 = key[1], key[2], key[4]
        turn = make_transform(rot_z(math.radians(rotation)), np.asarray(origin, float))
        return turn @ make_transform(np.eye(3), np.asarray(g92, float))

    def rotary(self) -> list[float]:
        """A B C offsets in force (G5x origin + G92), deg: machine angle = programmed + these."""
        return [o + g for o, g in zip(self.origin_abc[self.index], self.g92_abc)]

    def g10_rotary(self, lcode: int, p: int, words: dict, abc: list) -> None:
        """A B C of G10 L2 (the origin's angles are the words) or L20 (the origin such that the
        current angle ``abc`` (programmed, before this block) reads as the words) of system P."""
        p = p or self.index
        machine = [a + o for a, o in zip(abc, self.rotary())]
        for k, axis in enumerate("ABC"):
            if axis in words:
                self.origin_abc[p][k] = words[axis] if lcode == 2 else machine[k] - self.g92_abc[k] - words[axis]

    def g92_rotary(self, code: float, words: dict, abc: list) -> None:
        """A B C of G92 (the current angle reads as the word), G52 (the offset is the word),
        G92.1 / G92.2 (off; .1 clears the parameters) and G92.3 (from the parameters)."""
        if code in (92.0, 52.0):
            for k, axis in enumerate("ABC"):
                if axis in words:
                    self.g92_abc[k] = words[axis] if code == 52.0 else abc[k] + self.g92_abc[k] - words[axis]
            self.g92_abc_params = list(self.g92_abc)
        elif code in (92.1, 92.2):
            self.g92_abc = [0.0, 0.0, 0.0]
            if code == 92.1:
                self.g92_abc_params = [0.0, 0.0, 0.0]
        elif code == 92.3:
            self.g92_abc = list(self.g92_abc_params)

    # ------------------------------------------------------------ G54..G59.3
    def select(self, index: int, cur: list) -> list:
        """G54..G59.3: the current point in the new system (find_current_in_system)."""
        if index == self.index:
            return cur
        new = self._in_system(index, cur)
        self.index = index
        return new

    def _in_system(self, index: int, cur: list) -> list:
        x, y = rotate(cur[0] + self.g92[0], cur[1] + self.g92[1], self.rotation[self.index])
        o, n = self.origin[self.index], self.origin[index]
        x, y, z = x + o[0] - n[0], y + o[1] - n[1], cur[2] + self.g92[2] + o[2] - n[2]
        x, y = rotate(x, y, -self.rotation[index])
        return [x - self.g92[0], y - self.g92[1], z - self.g92[2]]

    # ------------------------------------------------------------ G10 L2 / L20
    def g10(self, lcode: int, p: int, words: dict, cur: list, line: int) -> list:
        """G10 L2 (origin = the words) or L20 (origin such that the current point reads
        as the words) of system P (0: the active one), with the R rotation (L2 only)."""
        p = p or self.index
        origin = list(self.origin[p])
        r = words["R"] if "R" in words else self.rotation[p]
        if lcode == 20:
            cx, cy, cz = self._in_system(p, cur)
            want = [words.get("X", cx), words.get("Y", cy)]
            ox, oy = rotate(cx, cy, r)
            wx, wy = rotate(want[0], want[1], r)
            origin[0], origin[1] = ox + origin[0] - wx, oy + origin[1] - wy
            if "Z" in words:
                origin[2] = cz + origin[2] - words["Z"]
        else:
            for k, axis in enumerate("XYZ"):
                if axis in words:
                    origin[k] = words[axis]
        if p == self.index:  # convert_setup: the current point follows the active system
            x, y = rotate(cur[0], cur[1], self.rotation[p])
            old = self.origin[p]
            x, y, z = x + old[0] - origin[0], y + old[1] - origin[1], cur[2] + old[2] - origin[2]
            x, y = rotate(x, y, -r)
            cur = [x, y, z]
        self.origin[p], self.rotation[p], self.set_at[p] = origin, r, line
        return cur

    # ------------------------------------------------------------ G92 family
    def g92_family(self, code: float, words: dict, cur: list, line: int) -> list:
        """G92 (the current point reads as the words), G52 (offset = the words), G92.1 /
        G92.2 (offset off; .1 also clears the parameters), G92.3 (offset from the parameters)."""
        cur = list(cur)
        if code in (92.0, 52.0):
            for k, axis in enumerate("XYZ"):
                if axis not in words:
                    continue
                if code == 52.0:
                    cur[k] += self.g92[k] - words[axis]
                    self.g92[k] = words[axis]
                else:
                    self.g92[k] = cur[k] + self.g92[k] - words[axis]
                    cur[k] = words[axis]
            self.g92_params = list(self.g92)
        elif code in (92.1, 92.2):
            cur = [c + g for c, g in zip(cur, self.g92)]
            self.g92 = [0.0, 0.0, 0.0]
            if code == 92.1:
                self.g92_params = [0.0, 0.0, 0.0]
        elif code == 92.3:
            cur = [c + g - s for c, g, s in zip(cur, self.g92, self.g92_params)]
            self.g92 = list(self.g92_params)
        self.g92_at = line if any(self.g92) else None
        return cur

    # ------------------------------------------------------------ G53
    def g53(self, words: dict, cur: list) -> tuple[list, list]:
        """End of a G53 move: (program point, machine point); the words are machine
        coordinates, an axis left out stays where it is (interp_find.cc find_ends)."""
        r, o, g = self.rotation[self.index], self.origin[self.index], self.g92
        cx, cy = rotate(cur[0] + g[0], cur[1] + g[1], r)
        px = words["X"] - o[0] if "X" in words else cx
        py = words["Y"] - o[1] if "Y" in words else cy
        px, py = rotate(px, py, -r)
        pz = words["Z"] - o[2] - g[2] if "Z" in words else cur[2]
        program = [px - g[0], py - g[1], pz]
        return program, self.machine(program)
