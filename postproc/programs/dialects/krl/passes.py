"""KRL: $BASE, $TOOL and points changed inside a FOR body, followed pass by pass.

KUKA System Software 8.x, Operating and Programming Instructions for System Integrators,
"FOR ... TO ... ENDFOR": the body runs once per value of the counter, in order; "System
variables": $BASE / $TOOL keep what the last executed assignment gave them. So
``FOR I = 1 TO 3`` with ``$BASE.X = $BASE.X + 100`` and ``LIN XP1`` in its body runs
XP1 under three bases, and the code after ENDFOR under the third.

A FOR is followed here when its passes are known (a literal count, loops.py; a WHILE or
REPEAT over a counter, counters.py, likewise), it is not
inside another block of the first DEF, and its body has no other block and no call (its
statements are then straight-line code, once per pass). Its body's changes are replayed
once per pass at "stretched" offsets: pass p of a body [a, b) lies at
a + p (b - a) + shift, and everything after the loop moves on by (n - 1)(b - a), so the
replay (state.py) and the rows' lookups keep execution order. Any other loop keeps the
old rule: its changes make what they change unknown from the loop on (noted targets).
With calls followed (calls.py) offsets of the first DEF are real * SCALE: the stretch
applies to the real part.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from dataclasses import dataclass, replace

import numpy as np

_BLOCK = re.compile(r"^[ \t]*(?:IF|FOR|WHILE|LOOP|REPEAT|SWITCH|SPLINE|PTP_SPLINE)\b", re.IGNORECASE | re.MULTILINE)


@dataclass
class Followed:
    start: int  # real offset of the FOR line
    end: int  # real offset of the ENDFOR line
    counter: str
    values: list[int]
    update: tuple[int, int] | None = None  # WHILE/REPEAT over a counter: (real offset of I = I + k, k)

    def value(self, real: int, pass_index: int) -> int:
        """The counter where ``real`` runs in that pass (after the update: the new value)."""
        after = self.update is not None and real > self.update[0]
        return self.values[pass_index] + (self.update[1] if after else 0)

    def __post_init__(self):
        # the first pass with each counter value, as list.index gives it, in one dict: a
        # pass-by-pass index() was quadratic in the passes (minutes for 30,000)
        self._pass_at = {v: i for i, v in reversed(list(enumerate(self.values)))}

    def pass_of(self, real: int, value: int) -> int:
        return self._pass_at[value - (self.update[1] if self.update is not None and real > self.update[0] else 0)]


class Passes:
    def __init__(self, loops: list[Followed], scale: int):
        self.loops = sorted(loops, key=lambda lp: lp.start)
        self.scale = scale
        self._starts = [lp.start for lp in self.loops]
        shifts, total = [], 0
        for lp in self.loops:
            shifts.append(total)
            total += (len(lp.values) - 1) * (lp.end - lp.start)
        self._shifts = shifts

    def loop_of(self, real: int) -> int | None:
        k = bisect_right(self._starts, real) - 1
        return k if k >= 0 and real < self.loops[k].end else None

    def place(self, real: int, pass_index: int = 0) -> int:
        """Stretched real offset of ``real`` (in pass ``pass_index`` when inside a followed loop)."""
        k = bisect_right(self._starts, real) - 1
        if k < 0:
            return real
        lp = self.loops[k]
        if real < lp.end:
            return real + self._shifts[k] + pass_index * (lp.end - lp.start)
        return real + self._shifts[k] + (len(lp.values) - 1) * (lp.end - lp.start)

    def virtual(self, v: int, pass_index: int = 0) -> int:
        real, rest = divmod(v, self.scale)
        return self.place(real, pass_index) * self.scale + rest

    def events(self, events: list) -> list:
        """Every event at its stretched place; one in a followed body once per pass, straight-line."""
        if not self.loops:
            return events
        out = []
        for ev in events:
            k = self.loop_of(ev.line_offset) if not ev.anytime else None
            if k is None or ev.offset // self.scale != self.loops[k].start:  # outside, or a subprogram's change
                out.append(replace(ev, offset=self.virtual(ev.offset)))
                continue
            lp = self.loops[k]
            for p in range(len(lp.values)):
                at = self.place(ev.line_offset, p) * self.scale
                out.append(replace(ev, offset=at, exact=ev.rhs is not None, env={lp.counter: lp.value(ev.line_offset, p)}))
        return out

    def rows(self, virtual: np.ndarray, envs: list[dict]) -> np.ndarray:
        """The rows' stretched virtual offsets (-1 stays: a row no call reaches)."""
        if not self.loops:
            return virtual
        out = virtual.copy()
        for i, v in enumerate(virtual.tolist()):
            if v < 0:
                continue
            real = v // self.scale
            k = self.loop_of(real)
            p = self.loops[k].pass_of(real, envs[i][self.loops[k].counter]) if k is not None else 0
            out[i] = self.virtual(v, p)
        return out


def followable(text: str, loops, calls, depth_of: dict[int, int], line_starts: np.ndarray, first_def: tuple[int, int]) -> list[Followed]:
    """The FORs of the first DEF whose changes are followed pass by pass (module docstring)."""
    out = []
    for lp in loops:
        if lp.values is None or not lp.values or depth_of.get(lp.first_line) != 0:
            continue
        if not first_def[0] <= lp.first_line <= first_def[1]:
            continue
        start, end = int(line_starts[lp.first_line - 1]), int(line_starts[lp.last_line - 1])
        body_start = int(line_starts[lp.first_line]) if lp.first_line < len(line_starts) else end
        if _BLOCK.search(text, body_start, end) or any(lp.first_line < c.line < lp.last_line for c in calls):
            continue
        update = (int(line_starts[lp.update[0] - 1]), lp.update[1]) if lp.update is not None else None
        out.append(Followed(start, end, lp.counter, list(lp.values), update))
    return out
