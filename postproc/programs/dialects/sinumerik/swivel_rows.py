"""Which CYCLE800 each target of a SINUMERIK program is read under (the IR's extras).

The parser records one ``Swivel`` per CYCLE800 call, in execution order; ``extras`` gives every
target the call in force at it, as the Toolpath's per-target columns
``sinumerik.swivel_line`` (the call's line, 0 before any), ``sinumerik.swivel_state`` (STATES),
``sinumerik.swivel_dir`` (``_DIR``) and ``sinumerik.swivel_rotation`` (3x3, the swivel frame's
rotation in the settable frame; NaN unless active). ``swivel_place.py`` turns them into the
rotary positions the 840D turns to.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import swivel

STATES = {"none": 0, "active": 1, "deselected": 2, "unknown": 3}


@dataclass(frozen=True)
class Swivel:
    line: int
    state: int  # STATES
    direction: float  # _DIR (NaN unless active)
    rotation: np.ndarray  # (3, 3) the swivel frame's rotation (NaN unless active)

    @classmethod
    def of(cls, line_no: int, text: str, frame: np.ndarray) -> "Swivel":
        """The call in ``text`` (its line ``line_no``) that left the swivel frame ``frame``."""
        nan = np.full((3, 3), np.nan)
        if np.isnan(frame).any():
            return cls(line_no, STATES["unknown"], np.nan, nan)
        params = swivel.arguments(text)  # read before (swivel_frame): a literal list
        if str(params["_TC"]).strip() in ("0", ""):
            return cls(line_no, STATES["deselected"], np.nan, nan)
        return cls(line_no, STATES["active"], float(params["_DIR"]), frame[:3, :3].copy())


def extras(events: list[tuple[int, Swivel]], times: np.ndarray) -> dict[str, np.ndarray]:
    """The per-target columns for targets at ``times`` (the parser's event clock)."""
    at = np.searchsorted(np.array([when for when, _ in events]), times, side="right") - 1
    table = [Swivel(0, STATES["none"], np.nan, np.full((3, 3), np.nan))] + [s for _, s in events]
    pick = at + 1
    return {"sinumerik.swivel_line": np.array([s.line for s in table], np.int64)[pick],
            "sinumerik.swivel_state": np.array([s.state for s in table], np.int8)[pick],
            "sinumerik.swivel_dir": np.array([s.direction for s in table])[pick],
            "sinumerik.swivel_rotation": np.stack([s.rotation for s in table])[pick]}
