"""Reading the bulk of CAM output at once: runs of lines that are each one plain ``L`` block
(absolute plain numbers, no M, no comment), found by line shape (postproc.programs.parse.line_shapes:
one regular expression per distinct shape) and read with one vectorised number scan. The
reading is the one the general path gives block by block (parse.KlartextReader.path_block):
modal axes and feed carried forward, R0/RL/RR from the block that states it on."""

from __future__ import annotations

import math
import re

import numpy as np

from ...ir import Kind
from ...parse.common import _ranges, scan_numbers
from ...parse.line_shapes import LineShapes
from .blocks import PlainRun
from .fields import AXES, COLUMNS, SIDE

# One plain L block alone on its line (block number, absolute plain numbers, no M, no comment):
# digit runs only through \d+ / \d* so that lines of one shape match alike (line_shapes.py).
_PLAIN_LINE = re.compile(r"[ \t]*(?:\d+[ \t]+)?L(?P<words>(?:[ \t]+[XYZABC][+-]?(?:\d+\.?\d*|\.\d+))+)(?:[ \t]+(?P<comp>R0|RL|RR))?"
                         r"(?:[ \t]+(?:(?P<fmax>FMAX)|F(?P<feed>\d+\.?\d*)))?[ \t]*\r?")


class BulkReading:
    """KlartextReader's bulk path (a mixin: the reader's state is ``self``)."""

    def _plain_lines(self) -> np.ndarray:
        """(lines,) True where the line is one plain L block (the bulk of CAM output), found by
        shape (postproc.programs.parse.line_shapes: one regular expression run per distinct line shape)."""
        raw = np.frombuffer(self.text.encode("latin-1"), np.uint8)
        starts = np.concatenate([[0], np.nonzero(raw == 10)[0] + 1]).astype(np.int64)
        flags = np.zeros(len(starts), bool)
        if len(raw) == 0:
            return flags
        self.raw = raw
        self.plain = LineShapes(self.text, raw, starts).match(_PLAIN_LINE)
        flags[self.plain.line] = True
        self.plain_row = np.full(len(starts), -1, np.int64)
        self.plain_row[self.plain.line] = np.arange(len(self.plain))
        return flags

    def plain_run(self, run: PlainRun) -> None:
        """Lines run.first..run.end-1, each a plain L block, read at once: their numbers from one
        vectorised scan of the text, the modal axes and feed carried forward as the TNC does
        (the same reading as path_block gives them one by one)."""
        if self.numbers is None:
            self.numbers = scan_numbers(self.text, letter_prefix=True, raw=self.raw)
        rows = self.plain_row[run.first:run.end]
        n = len(rows)
        ws, we = (a[rows] for a in self.plain.span("words"))
        nums = self.numbers
        lo, hi = np.searchsorted(nums.start, ws), np.searchsorted(nums.start, we)
        count = hi - lo
        owner = np.repeat(np.arange(n), count)
        pick = _ranges(lo, hi)
        num_start, num_end, value = nums.start[pick], nums.end[pick], nums.value[pick]
        letter = self.raw[num_start - 1]
        table = np.empty((n, COLUMNS))
        cells = []
        first_row = self.rows_all()
        unknown_rows = np.zeros(n, bool)
        for col, ch in enumerate(b"XYZABC"):
            sel = letter == ch
            r, v = owner[sel], value[sel] * (self.scale if col < 3 else 1.0)
            given = np.full(n, np.nan)
            given[r] = v
            table[:, 7 + col] = carried(given, self.pos[col])
            if self.unknown[col]:  # from a parameter the text does not determine, until the axis is given
                known_from = int(r[0]) if len(r) else n
                unknown_rows[:known_from] = True
                self.unknown[col] = known_from == n
            cells.append(np.c_[r + first_row, np.full(len(r), AXES[chr(ch)]), v, num_start[sel], num_end[sel]])
        fs, _ = self.plain.span("feed")
        fs = fs[rows]
        feed = np.full(n, np.nan)
        has_feed = fs >= 0
        if has_feed.any() and math.isnan(self.feed_scale):
            raise self.error(int(fs[has_feed][0]), "F in an INCH program: its unit is not read (give the program in MM)")
        feed[has_feed] = nums.value[np.searchsorted(nums.start, fs[has_feed])] * self.feed_scale
        feed = carried(feed, self.feed)
        rapid = self.plain.present("fmax")[rows]
        table[:, 0] = np.where(rapid, int(Kind.RAPID), int(Kind.LINEAR))
        table[:, 1] = np.arange(run.first, run.end) + 1
        table[:, 2] = np.where(rapid, np.nan, feed)
        table[:, 3] = self.tool
        table[:, 4] = self._frame_index()
        table[:, 6] = ws
        table[:, 13] = self.tcpm
        table[:, 14] = SIDE[self.comp]
        table[:, 15] = self.radius
        compensated = np.zeros(n, bool)
        cs, _ = self.plain.span("comp")
        cs = cs[rows]
        if (cs >= 0).any() or self.comp != "R0":  # R0 / RL / RR from the block that states it on
            for i in range(n):
                if cs[i] >= 0:
                    self.comp, self.comp_line = self.text[cs[i]:cs[i] + 2], run.first + i + 1
                table[i, 14] = SIDE[self.comp]
                if self.comp != "R0":
                    compensated[i] = not self._state_resolved(run.first + i + 1, False)  # with its note
        table[:, 5] = ~compensated & ~unknown_rows & (self.tilt_line == 0)
        if unknown_rows.any():
            self.notes[f"line {run.first + 1}: position from a Q parameter the text does not determine"] = None
        if self.tilt_line:
            self._state_resolved(run.first + 1, False)  # the note
        self.tangent = _last_direction(self.pos[:2], table[:, 7:9], self.tangent)
        self.pos[:] = table[-1, 7:13]
        self.feed = float(feed[-1])
        self.add_segment(table, np.concatenate(cells))


def carried(given: np.ndarray, before: float) -> np.ndarray:
    """Modal values: each NaN takes the last given value before it (``before`` at the start)."""
    idx = np.where(np.isnan(given), -1, np.arange(len(given)))
    np.maximum.accumulate(idx, out=idx)
    return np.where(idx >= 0, given[np.maximum(idx, 0)], before)


def _last_direction(before: np.ndarray, ends: np.ndarray, tangent):
    """Direction (unit, XY) of the last of these straight moves that moves in the plane, from
    ``before`` through ``ends``: what a CT after them is tangent to (``tangent`` if none moves)."""
    d = ends - np.vstack([before[None, :], ends[:-1]])
    length = np.hypot(d[:, 0], d[:, 1])
    moving = np.nonzero(length > 0)[0]
    return tangent if not len(moving) else d[moving[-1]] / length[moving[-1]]
