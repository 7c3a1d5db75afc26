"""New Klartext five-axis programs: tool tip + rotary axis positions under M128.

The numbers (tips, the rotary positions the machine's inverse kinematics chose, feeds) are
computed by the five-axis layer (postproc.fivex); this module only writes them the TNC's way
(TNC 640 User's Manual): ``BEGIN PGM name MM``, ``TOOL CALL n Z``, ``M128`` (tool tip kept at
X Y Z while the rotary axes turn, "Miscellaneous functions for rotary axes: M128"), one
``L X Y Z <rotary> F`` block per target (FMAX for rapids: "Feed rate F"), ``M129``, ``M30``,
``END PGM``. Numbers with 4 decimals, the TNC's input resolution for mm and degrees (0.1 um,
0.0001 deg), signed as the TNC writes them (X+10.5)."""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import EmitError

MODES = ("tcpm",)
DECIMALS = 4


def _num(v: float) -> str:
    text = f"{v:+.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "+0" if text in ("-0", "+0", "+", "-") else text


def program_name(stem: str) -> str:
    """A TNC program name: letters, digits, '_' and '-' (TNC 640 manual, "File names")."""
    name = re.sub(r"[^A-Za-z0-9_-]", "_", stem) or "POSTPROC"
    return name[:24]


def tcpm_text(name: str, letters: tuple[str, ...], tip: np.ndarray, angles: np.ndarray, rapid: np.ndarray, feed: np.ndarray,
              lines: np.ndarray, header: list[str], tool: int = 1) -> str:
    """The program text; a feed move without a tip feed (the tip stands while the axes turn:
    M128's F is the tip's) is refused naming the input line."""
    bad = ~rapid & ~(np.isfinite(feed) & (feed > 0))
    if bad.any():
        i = int(np.nonzero(bad)[0][0])
        raise EmitError(f"input line {int(lines[i])}: feed move without a tool-tip feed (the tip does not move or no F): under M128 F is the tip's feed; nothing was written")
    name = program_name(name)
    body = [f"BEGIN PGM {name} MM"] + [f"; {h}" for h in header] + [f"TOOL CALL {tool} Z", "M128"]
    words = np.c_[tip, angles]
    for i in range(len(tip)):  # text assembly only: every number was computed by the caller
        coords = "  ".join(f"{k}{_num(v)}" for k, v in zip(("X", "Y", "Z") + tuple(letters), words[i]))
        body.append(f"L  {coords} {'FMAX' if rapid[i] else 'F' + _num(feed[i]).lstrip('+')}")
    body += ["M129", "M30", f"END PGM {name} MM"]
    return "".join(f"{n} {text}\n" for n, text in enumerate(body))
