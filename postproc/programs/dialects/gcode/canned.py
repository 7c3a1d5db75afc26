"""Canned cycles G73, G74, G81-G89 expanded into the moves LinuxCNC makes.

LinuxCNC manual, "G-code", section "Canned cycles" (G80-G89, "Preliminary and In-Between
Motion", "Retract": G98 back to the initial level, G99 to R; "L": repeats, with X Y
increments in G91; "Sticky numbers"), checked against rs274ngc's interp_cycles.cc
(convert_cycle_xy / _zx / _yz, CYCLE_MACRO): in the plane of the cycle (G17: X Y, G18:
Z X, G19: Y Z) the tool is positioned, then the perpendicular axis moves to R, to the
bottom and back. In G91, R is an increment from the initial level and the bottom an
increment from R. A cycle stays in force for later blocks with axis words until G80 or
another motion code. All lengths are mm.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .polar import polar_end, polar_step

RAPID, FEED = 0, 1  # move codes (G0, G1)
# (first, second, perpendicular) axis of the cycle plane: G17 X Y Z, G18 Z X Y, G19 Y Z X
PLANE_AXES = {17.0: (0, 1, 2), 18.0: (2, 0, 1), 19.0: (1, 2, 0)}
PERPENDICULAR = {17.0: "Z", 18.0: "Y", 19.0: "X"}
# rs274's G73/G83 back-off: G83_RAPID_DELTA, 0.010 in, times 25.4 in G21 (interp_cycles.cc of
# LinuxCNC 2.9, the Debian linuxcnc-uspace judge): the same 0.254 mm in G20 and G21, with no
# parameter or INI setting. LinuxCNC 2.10 takes a D word (and [RS274NGC]G73/G83_PECK_CLEARANCE)
# instead; 2.9 refuses a D word there, and so does ``expand``: the two controllers disagree.
PECK_CLEARANCE_MM = 0.254
CYCLES = (73.0, 74.0, 81.0, 82.0, 83.0, 84.0, 85.0, 86.0, 87.0, 88.0, 89.0)
# The cycles that use each of these words (rs274ngc's interp_check.cc; checked with rs274):
# any other cycle refuses it, e.g. a Fanuc repeat count `G81 ... K3` (LinuxCNC repeats with L).
WORD_USERS = {"P": (74.0, 82.0, 84.0, 86.0, 88.0, 89.0), "Q": (73.0, 83.0), "I": (87.0,), "J": (87.0,), "K": (87.0,)}


class CycleError(ValueError):
    """A cycle block LinuxCNC refuses (the message is rs274's reason)."""


@dataclass
class CycleState:
    """The 'sticky' numbers of the cycle in force (rs274ngc's cycle_* settings)."""

    initial: float | None = None  # initial level (cycle_il) while a run of cycles lasts
    last: float | None = None  # motion code of the last motion executed
    sticky: dict = field(default_factory=dict)  # R, the bottom word, P, Q, I, J, K
    levels: tuple = ()  # (R, clear, bottom) of the last cycle block, mm
    unknown: bool = False  # the last cycle block was not read (a word unknown at post time): so are its sticky numbers

    def end_run(self, motion: float) -> None:
        """A motion that is not a cycle ends the run: the next cycle takes a new initial level."""
        self.initial = None
        self.last = motion


@dataclass
class Block:
    """What one cycle block says (mm): words present, plane, G90/G91, G98/G99."""

    code: float
    words: dict
    plane: float
    incremental: bool
    retract_to_r: bool


def expand(block: Block, state: CycleState, cur: list) -> tuple[list[tuple[int, list]], list]:
    """Moves [(RAPID|FEED, [x, y, z])] of one cycle block from the current point ``cur``,
    and the point the interpreter holds afterwards."""
    _refuse(block)
    a_i, b_i, c_i = PLANE_AXES[block.plane]
    axis = "XYZ"
    words, same = block.words, state.last == block.code
    if not same and axis[c_i] not in words:
        raise CycleError(f"{PERPENDICULAR[block.plane]} value unspecified in the canned cycle (G{block.code:g})")
    sticky = _sticky(block, state, same, axis[c_i])
    if state.initial is None:
        state.initial = cur[c_i]
    old_cc, current_cc = state.initial, cur[c_i]
    a, b = cur[a_i], cur[b_i]
    inc = (0.0, 0.0, 0.0, 0.0)
    if block.incremental:
        inc = (words.get(axis[a_i], 0.0), words.get(axis[b_i], 0.0), words.get("@", 0.0), words.get("^", 0.0))
        r = sticky["R"] + old_cc
        bottom = r + sticky["bottom"]
    else:
        r, bottom = sticky["R"], sticky["bottom"]
        if "@" in words or "^" in words:  # G17 only (_refuse)
            a, b = polar_end(a, b, words.get("@"), words.get("^"), incremental=False)
        else:
            a, b = words.get(axis[a_i], a), words.get(axis[b_i], b)
    if r < bottom:
        raise CycleError(f"R less than {PERPENDICULAR[block.plane]} in the canned cycle (G{block.code:g})")
    moves: list[tuple[int, list]] = []

    def put(kind: int, p1: float, p2: float, p3: float) -> None:
        point = [0.0, 0.0, 0.0]
        point[a_i], point[b_i], point[c_i] = p1, p2, p3
        moves.append((kind, point))

    if old_cc < r:  # below the R plane: straight up to it first
        put(RAPID, cur[a_i], cur[b_i], r)
        old_cc = current_cc = r
    clear = r if block.retract_to_r else old_cc
    repeats = int(round(words.get("L", 1.0)))
    if repeats < 1:
        raise CycleError("cannot do zero repeats of a canned cycle (L0)")
    for repeat in range(repeats, 0, -1):
        a, b = a + inc[0], b + inc[1]
        if inc[2] or inc[3]:
            a, b = polar_step(a, b, inc[2], inc[3])
        if repeat == repeats and current_cc > r:
            put(RAPID, a, b, current_cc)
            put(RAPID, a, b, r)
        else:
            put(RAPID, a, b, clear)
            if clear > r:
                put(RAPID, a, b, r)
        _body(block, sticky, put, a, b, r, clear, bottom)
    state.last, state.levels = block.code, (r, clear, bottom)
    end = list(cur)
    end[a_i], end[b_i], end[c_i] = a, b, clear
    return moves, end


def _refuse(block: Block) -> None:
    """Cycle blocks LinuxCNC refuses, or runs off the hole's axis: a CycleError saying why."""
    if block.plane not in PLANE_AXES:  # G17.1 / G18.1 / G19.1: rs274ngc drills with U V W there
        raise CycleError(f"a canned cycle in the G{block.plane:g} plane drills with the U V W axes, which postproc does not model "
                         f"(LinuxCNC refuses X Y Z words in it)")
    if ("@" in block.words or "^" in block.words) and block.plane != 17.0:
        raise CycleError("polar words (@ ^) outside the G17 plane: LinuxCNC refuses them (\"Cannot use polar coordinate except in G17 plane\")")
    if "D" in block.words:
        raise CycleError(f"D word in G{block.code:g}: LinuxCNC 2.9's rs274 refuses it (\"D word with no G41, G41.1, G42, G42.1, G71, G71.1, "
                         f"G71.2 or G96 to use it\"), 2.10 takes it as the peck clearance: which one runs the program is not known")
    for letter, users in WORD_USERS.items():  # interp_check.cc: a word no code of the block uses is an error
        if letter in block.words and block.code not in users:
            raise CycleError(f"{letter} word with G{block.code:g}: LinuxCNC refuses it (no G code of the block uses it)")
    if "L" in block.words and block.code == 74.0:  # interp_check.cc lets L through with G73 and G81-G89 only
        raise CycleError("L word with G74: LinuxCNC refuses it (\"L word with no G10, cutter compensation, canned cycle, ...\")")
    if block.code in (74.0, 84.0) and block.plane != 17.0:
        # convert_cycle_g74_g84 passes the G18/G19 coordinates already permuted to cycle_feed,
        # which permutes them again: LinuxCNC (2.9 and 2.10) feeds to a point off the hole's
        # axis (G19 G84 Y5 Z5 X-2 feeds to X5 Y-2 Z5). Refused: neither the moves written nor those are safe to post.
        raise CycleError(f"G{block.code:g} in the G{block.plane:g} plane: LinuxCNC's rs274 feeds the tap to a point off the hole's axis "
                         f"(interp_cycles.cc permutes the axes twice); tap in G17 or write the moves out")


def check_spindle(code: float, turning: float) -> None:
    """The spindle a cycle needs (interp_cycles.cc): G84 taps with it clockwise (M3), G74
    counterclockwise (M4); G86, G87 and G88 stop and restart it, so it must turn."""
    if code == 84.0 and turning != 3.0:
        raise CycleError(f"G84 with the spindle {'counterclockwise (M4)' if turning == 4.0 else 'stopped'}: LinuxCNC refuses it (G84 taps with M3)")
    if code == 74.0 and turning != 4.0:
        raise CycleError(f"G74 with the spindle {'clockwise (M3)' if turning == 3.0 else 'stopped'}: LinuxCNC refuses it (G74 taps with M4)")
    if code in (86.0, 87.0, 88.0) and turning not in (3.0, 4.0):
        raise CycleError(f"G{code:g} with the spindle stopped: LinuxCNC refuses it (\"Spindle not turning in G{code:g}\")")


REPEATABLE = (73.0, 74.0, 81.0, 82.0, 83.0, 84.0, 85.0, 86.0, 89.0)  # every hole the same moves over its X Y


def repeat_pattern(code: float, plane: float, state: CycleState) -> list[tuple[int, float, bool]]:
    """The moves of each further hole of a cycle in force, for blocks that give only the
    hole's position in the plane (G90, no R, bottom, L, P or Q: what ``expand`` would do
    with the sticky numbers): [(RAPID|FEED, level on the drilling axis, at the previous
    hole?)]. A run of such blocks is then expanded for all holes at once."""
    r, clear, bottom = state.levels
    pattern = [(RAPID, r, True)] if state.initial < r else []  # a cycle below R goes straight up first, where it is
    pattern.append((RAPID, clear, False))
    if clear > r:
        pattern.append((RAPID, r, False))
    block = Block(code, {}, plane, False, clear == r)
    _body(block, state.sticky, lambda kind, p1, p2, p3: pattern.append((kind, p3, False)), 0.0, 0.0, r, clear, bottom)
    return pattern


def _sticky(block: Block, state: CycleState, same: bool, perpendicular: str) -> dict:
    """R, bottom, P, Q, I, J, K of this block: its words, else the values kept from the
    previous block of the same cycle (a new cycle needs its own)."""
    words, kept = block.words, state.sticky if same else {}
    if "R" not in words and "R" not in kept:
        raise CycleError(f"R clearance plane unspecified in the canned cycle (G{block.code:g})")
    out = dict(state.sticky)
    out["R"] = words.get("R", kept.get("R"))
    out["bottom"] = words.get(perpendicular, state.sticky.get("bottom"))
    for letter in "PQIJK":
        if letter in words:
            out[letter] = words[letter]
    need = {73.0: "Q", 83.0: "Q", 82.0: "P", 86.0: "P", 88.0: "P", 89.0: "P"}.get(block.code)
    if need and need not in words and not same:
        raise CycleError(f"{need} word missing with G{block.code:g}")
    if block.code == 87.0 and not same and any(k not in words for k in "IJK"):
        raise CycleError("I, J and K words are needed with G87")
    state.sticky = out
    return out


def _body(block: Block, sticky: dict, put, a: float, b: float, r: float, clear: float, bottom: float) -> None:
    """The cycle proper, once the tool is over the hole at R (interp_cycles.cc)."""
    code = block.code
    if code in (73.0, 83.0):
        _peck(code, sticky, put, a, b, r, bottom, PECK_CLEARANCE_MM)
        put(RAPID, a, b, clear)
    elif code in (81.0, 82.0, 86.0):
        put(FEED, a, b, bottom)
        put(RAPID, a, b, clear)
    elif code in (74.0, 84.0, 89.0):
        put(FEED, a, b, bottom)
        put(FEED, a, b, clear)
    elif code == 85.0:
        put(FEED, a, b, bottom)
        put(FEED, a, b, r)
        put(RAPID, a, b, clear)
    elif code == 88.0:
        put(FEED, a, b, bottom)  # then the program stops: the operator retracts by hand
    elif code == 87.0:
        _back_bore(block, sticky, put, a, b, r, clear, bottom)


def _peck(code: float, sticky: dict, put, a: float, b: float, r: float, bottom: float, back_off: float) -> None:
    """G83: feed Q deeper, rapid out to R and back down to just above the last depth;
    G73: feed Q deeper, rapid back a little (chip break)."""
    delta = sticky["Q"]
    if delta <= 0:
        raise CycleError(f"negative or zero Q value with G{code:g}")
    depth = r - delta
    while depth > bottom:
        put(FEED, a, b, depth)
        if code == 83.0:
            put(RAPID, a, b, r)
        put(RAPID, a, b, depth + back_off)
        depth -= delta
    put(FEED, a, b, bottom)


def _back_bore(block: Block, sticky: dict, put, a: float, b: float, r: float, clear: float, bottom: float) -> None:
    """G87: in beside the hole, down, over the hole, feed up to the top of the bore and back,
    out. Each axis takes its own word (I on X, J on Y, K on Z: interp_cycles.cc calls
    convert_cycle_g87 with aa+i, bb+j, top k in G17; aa+k (Z), bb+i (X), top j in G18;
    aa+j (Y), bb+k (Z), top i in G19): the offset in the plane is always an increment, the
    top absolute in G90 and an increment from the bottom in G91."""
    a_i, b_i, c_i = PLANE_AXES[block.plane]
    oa, ob = a + sticky["IJK"[a_i]], b + sticky["IJK"[b_i]]
    top = bottom + sticky["IJK"[c_i]] if block.incremental else sticky["IJK"[c_i]]
    put(RAPID, oa, ob, r)
    put(RAPID, oa, ob, bottom)
    put(RAPID, a, b, bottom)
    put(FEED, a, b, top)
    put(FEED, a, b, bottom)
    put(RAPID, oa, ob, bottom)
    put(RAPID, oa, ob, clear)
    put(RAPID, a, b, clear)
