"""LN blocks (three-dimensional tool compensation), read as the TNC runs them.

TNC 640 User's Manual, "Three-dimensional tool compensation": LN X Y Z NX NY NZ (TX TY TZ).
- X Y Z are the end point; the TNC normalizes N and T.
- "The TNC displaces the tool in the direction of the surface-normal vectors by the sum of
  the delta values (tool table and TOOL CALL)": the tip goes to X Y Z + (DL + DR + DR2) N/|N|.
  A TOOL DEF tool has no table row, so its deltas are TOOL CALL's; a tool from the tool table
  has deltas the text does not give (flagged).
- Without M128 the tool orientation T is ignored. With M128 / TCPM the TNC turns the rotary
  axes so that the tool axis is T (N where T is not given), the tip at X Y Z; which rotary
  solution it takes is placed with a machine (ln_placement). Under M128 a delta value moves
  the tool across the direction of motion (peripheral milling): flagged, not read.
"""

from __future__ import annotations

import math

import numpy as np

SOURCE_TEXT, SOURCE_PLANE_Q, SOURCE_LN = 0, 1, 2  # where a rotary position in force comes from


class LnBlocks:
    """KlartextReader's LN reading (a mixin: the reader's state is ``self``)."""

    def ln_target(self, words, line: int, at: int) -> tuple[np.ndarray, np.ndarray, bool]:
        """(offset of the tip from X Y Z (3,), tool axis under M128 (3,) or NaN, whether the tip
        is determined by the text); notes say why not."""
        normal = self._ln_vector(words, ("NX", "NY", "NZ"), at, required=True)
        if self.tcpm:
            tool = self._ln_vector(words, ("TX", "TY", "TZ"), at, required=False)
            axis = normal if np.isnan(tool).any() else tool
            self.set_rotary_source(np.ones(3, bool), SOURCE_LN)
            self.pos[3:] = np.nan
            self.unknown[3:] = True
            self.notes[f"line {line}: LN under M128 / TCPM: the TNC turns the rotary axes to the tool orientation "
                       f"{'T' if axis is not normal else 'N (no T given)'}: placed with a machine (convert / compensate --machine)"] = None
            if self.ln_delta != 0.0:
                self.notes[f"line {line}: LN under M128 with delta values (DL / DR / DR2, or a tool table's): the TNC moves the tool across "
                           "the direction of motion by them (peripheral milling): not read"] = None
            return np.zeros(3), axis, self.ln_delta == 0.0
        if math.isnan(self.ln_delta):
            self.notes[f"line {line}: LN: the TNC moves the tool along N by the tool's delta values (tool table and TOOL CALL), which the text "
                       "does not give (a tool from the tool table): not read"] = None
            return np.zeros(3), np.full(3, np.nan), False
        self.notes["LN without M128: the tip goes to X Y Z + (DL + DR + DR2) N/|N| (TOOL DEF tool: the deltas of TOOL CALL); T changes nothing "
                   "(TNC 640 manual, three-dimensional tool compensation)"] = None
        return self.ln_delta * normal, np.full(3, np.nan), not np.isnan(normal).any()

    def _ln_vector(self, words, keys: tuple[str, str, str], at: int, required: bool) -> np.ndarray:
        given = [words.words.get(k) for k in keys]
        if not any(given):
            if required:
                raise self.error(at, f"LN needs the surface normal {' '.join(keys)}")
            return np.full(3, np.nan)
        v = np.array([0.0 if w is None else self.value(w.text, w.start)[0] for w in given])
        norm = np.linalg.norm(v)
        if norm == 0.0:
            raise self.error(given[0].start if given[0] else at, f"LN: {'/'.join(keys)} is a zero vector")
        return v / norm

    def set_rotary_source(self, axes: np.ndarray, source: int) -> None:
        """Rotary axes ``axes`` (A B C mask) now hold a value from ``source``; kept per target."""
        new = np.where(axes, source, self.rotary_source).astype(np.int8)
        if (new != self.rotary_source).any():
            self.rotary_source = new
            self.rotary_events.append((self.rows_all(), new))

    def rotary_source_rows(self, n: int) -> np.ndarray:
        """(n, 3) per target: where A B C in force come from (SOURCE_*)."""
        out = np.zeros((n, 3), np.int8)
        for row, source in self.rotary_events:
            out[row:] = source
        return out
