"""KRL inline forms: the $TOOL and $BASE that ``BAS(#PTP_PARAMS, v)``, ``BAS(#CP_PARAMS, v)``
and ``BAS(#FRAMES)`` set from ``FDAT_ACT``.

The rule is KUKA's BAS.SRC (the system's own KRL source, KRC/R1/System/BAS.SRC, KSS 8;
seen e.g. in the public robot cell github.com/EdgarMontielG/Cell-3_R10):

- ``CASE #PTP_PARAMS``: ``PTP_DAT()``, ``FRAMES()``, ``VEL_PTP(REAL_PAR)``; ``CASE #CP_PARAMS``:
  ``CP_DAT()``, ``FRAMES()``, ``VEL_CP(REAL_PAR)``; ``CASE #FRAMES``: ``FRAMES()``.
- ``FRAMES()``: if ``FDAT_ACT.BASE_NO == 0``: ``TOOL(FDAT_ACT.TOOL_NO)``, ``BASE(0)``,
  ``SET_IPO_MODE(FDAT_ACT.IPO_FRAME)``. Otherwise ``SET_IPO_MODE``, ``TOOL(FDAT_ACT.TOOL_NO)``,
  then by ``MACHINE_FRAME_DAT[BASE_NO].MACH_DEF_INDEX``: 0 (no mechanism) -> ``BASE(BASE_NO)``
  if ``BASE_NO <= MAX_BASE``; a machine ``#ROBOT`` with ``COOP_KRC_INDEX 1`` -> ``BASE(BASE_NO)``;
  anything else (external kinematics, conveyor, a cooperating controller) -> a base computed
  by EK()/LK()/EB() at run time.
- ``TOOL(n)``: n <= 0 -> ``$TOOL = $NULLFRAME``; else ``$TOOL = TOOL_DATA[n]`` (each with
  ``TOOL_CORR`` / ``TOOL_CORR_W`` chained in when ``TOOL_CORR_ON`` / ``TOOL_CORR_W_ON``).
- ``BASE(n)``: n <= 0 -> ``$BASE = $WORLD``; else ``$BASE = BASE_DATA[n]`` (with ``BASE_CORR``
  / ``M_BASE_CORR`` when ``BASE_CORR_ON`` / ``M_BAS_COR_ON``).
- ``INITMOV()`` (``BAS(#INITMOV, 0)``) sets the four correction switches FALSE.
- ``IPO_FRAME #TCP`` is the external-TCP mode (the robot holds the workpiece): the target is
  then not $BASE : point in the robot base frame.

So the frames are exact when FDAT_ACT is known at the BAS call, IPO_FRAME is #BASE, the
corrections are off (BAS(#INITMOV) ran before in straight-line code and the program never
switches them on) and the base is not on an external mechanism; otherwise unknown, with
the reason in the notes.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

CORRECTION_SWITCHES = ("TOOL_CORR_ON", "TOOL_CORR_W_ON", "BASE_CORR_ON", "M_BAS_COR_ON")
FRAME_COMMANDS = ("PTP_PARAMS", "CP_PARAMS", "FRAMES")

_FDAT_DECL = re.compile(r"^[ \t]*DECL[ \t]+(?:GLOBAL[ \t]+)?FDAT[ \t]+(?P<name>\w+)[ \t]*=[ \t]*(?P<agg>\{[^}\n]*\})", re.IGNORECASE | re.MULTILINE)
_MFD = re.compile(r"MACHINE_FRAME_DAT\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*\{[^}\n]*?MACH_DEF_INDEX[ \t]+(-?\d+)", re.IGNORECASE)
_MDEF = re.compile(r"MACHINE_DEF\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*(\{[^\n]*)", re.IGNORECASE)
_MAX_BASE = re.compile(r"\bMAX_BASE[ \t]*=[ \t]*(\d+)", re.IGNORECASE)


@dataclass(frozen=True)
class Fdat:
    tool_no: int | None
    base_no: int | None
    ipo_frame: str | None  # "BASE" or "TCP"


def parse_fdat(aggregate: str) -> Fdat:
    """``{TOOL_NO 1,BASE_NO 2,IPO_FRAME #BASE,POINT2[] " "}`` -> Fdat (None: not given or not a literal)."""
    def number(name: str) -> int | None:
        m = re.search(rf"\b{name}[ \t]+([+-]?\d+)\b(?![.\w])", aggregate, re.IGNORECASE)
        return int(m.group(1)) if m else None
    ipo = re.search(r"\bIPO_FRAME[ \t]+#(\w+)", aggregate, re.IGNORECASE)
    return Fdat(number("TOOL_NO"), number("BASE_NO"), ipo.group(1).upper() if ipo else None)


def declared_fdats(texts: list[str]) -> dict[str, Fdat]:
    """FDAT declarations of the data lists (upper-case name -> Fdat)."""
    return {m.group("name").upper(): parse_fdat(m.group("agg")) for text in texts for m in _FDAT_DECL.finditer(text)}


class MachineFrames:
    """What $config.dat says of the mechanism each base number belongs to."""

    def __init__(self, config_text: str | None):
        text = config_text or ""
        self.given = config_text is not None
        self.mach_index = {int(n): int(k) for n, k in _MFD.findall(text)}
        self.any_machine_frame = "MACHINE_FRAME_DAT" in text.upper()
        self.machines = {int(k): agg for k, agg in _MDEF.findall(text)}
        m = _MAX_BASE.search(text)
        self.max_base = int(m.group(1)) if m else None

    def base_is_plain(self, base_no: int) -> str | None:
        """None when FRAMES() sets $BASE = BASE_DATA[base_no]; otherwise why not."""
        if self.max_base is not None and base_no > self.max_base:
            return f"BASE_NO {base_no} > MAX_BASE {self.max_base}: FRAMES() leaves $BASE as it was"
        if not self.any_machine_frame:
            return None  # no MACHINE_FRAME_DAT in the data (KR C2 data lists): BASE(n)
        index = self.mach_index.get(base_no)
        if index is None:
            return f"MACHINE_FRAME_DAT[{base_no}] is not in $config.dat: whether base {base_no} is on an external mechanism is unknown"
        if index == 0:
            return None
        machine = self.machines.get(index, "")
        mech = re.search(r"MECH_TYPE[ \t]+#(\w+)", machine, re.IGNORECASE)
        coop = re.search(r"COOP_KRC_INDEX[ \t]+(\d+)", machine, re.IGNORECASE)
        if mech and mech.group(1).upper() == "ROBOT" and coop and int(coop.group(1)) == 1:
            return None
        return f"base {base_no} belongs to MACHINE_DEF[{index}] (an external or cooperating mechanism, or not given): $BASE is computed at run time"


def frames_from_fdat(fdat: Fdat | None, machines: MachineFrames, corrections_off: bool) -> tuple[str | None, str | None, str]:
    """(right side for $TOOL, for $BASE, why unknown) that FRAMES() assigns; None where unknown."""
    if fdat is None:
        return None, None, "FDAT_ACT is not known here"
    if not corrections_off:
        return None, None, "the tool/base corrections of BAS.SRC may be on (no BAS(#INITMOV) before, or the program sets " + "/".join(CORRECTION_SWITCHES) + ")"
    if fdat.tool_no is None or fdat.base_no is None or fdat.ipo_frame is None:
        return None, None, "FDAT_ACT has no literal TOOL_NO, BASE_NO and IPO_FRAME"
    if fdat.ipo_frame != "BASE":
        return None, None, f"IPO_FRAME #{fdat.ipo_frame}: an external TCP (the robot holds the workpiece)"
    tool = "$NULLFRAME" if fdat.tool_no <= 0 else f"TOOL_DATA[{fdat.tool_no}]"
    if fdat.base_no <= 0:
        return tool, "$WORLD", ""
    why = machines.base_is_plain(fdat.base_no)
    return tool, (None if why else f"BASE_DATA[{fdat.base_no}]"), why or ""
