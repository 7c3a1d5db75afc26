"""Block-by-block reading of the G-code that moves by the controller's running state.

Most programs are read by parse.py's vectorised resolver (forward fills and cumulative
sums). A block whose end point depends on where the machine is and on offsets set while
the program runs cannot be: canned cycles (their initial level, R in G91, L repeats), G92 /
G52 (the current point reads as the words), G10 L20 and G10 L2 ... R (work offsets set,
rotated, from the current point), G53 (machine coordinates in the middle of a program) and
polar ``@`` ``^`` words, G33.1 rigid taps (in and back out) and G41/G42 cutter radius
compensation (the offset path, cutter_comp.py: each move's end is decided by the next one, and
the controller adds corner arcs). Programs that have one are run here, one block after another,
with the state rs274ngc keeps (offsets.py, canned.py, polar.py, cutter_comp.py); each motion
target comes out in program coordinates of the frame it is in (machine coordinates for G53).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from postproc.errors import EmitError

from . import canned
from .canned import CycleError, CycleState
from .cutter_comp import CutterComp, Unfollowed, arc_centre
from .offsets import Offsets
from .polar import PolarError, polar_end

LENGTH_WORDS = set("XYZIJKQ@")  # words in program length units (R: a length in a cycle, degrees in G10)
SETUP_CODES = (10.0, 52.0, 92.0, 92.1, 92.2, 92.3)
# Moves that end where the program text does not say: G28 / G30 go to a position stored on the
# controller (#5161-#5163 / #5181-#5183), G38.2-G38.5 stop where the probe touches.
UNKNOWN_END_CODES = (28.0, 30.0, 38.2, 38.3, 38.4, 38.5)
COMP_ON = (41.0, 41.1, 42.0, 42.1)
RIGID_TAP = 33.1  # LinuxCNC manual, "G33.1 Rigid Tapping": to the words and back, "G33.1 moves end at the original coordinate"  # cutter radius compensation left / right (G40: off)


class BlockError(ValueError):
    """A block the controller refuses: ``row`` of the block table, rs274's reason."""

    def __init__(self, row: int, message: str):
        super().__init__(message)
        self.row = row


def needs_interpreter(t: dict) -> bool:
    """True where the block table has a construct only a block-by-block reading gets right
    (t["more"] holds the words L P Q @ ^ D)."""
    if np.isin(t["setup"], SETUP_CODES + UNKNOWN_END_CODES + (33.0, RIGID_TAP)).any() or t["g53"].any() or np.isin(t["ccomp"], COMP_ON).any():
        return True
    if np.isin(t["tlo"], (43.1, 43.2)).any():  # lengths set in the block: the current Z re-read by the ToolTable
        return True
    if np.isin(t["canned"], canned.CYCLES).any():
        return True
    return bool((~np.isnan(t["more"][:, 3:5])).any())


@dataclass
class Moves:
    """The targets of a program in order: source block, move code (0-3), end point in its
    frame (mm), rotary axes, frame (see Offsets.key; -1: the machine frame, G53), and
    whether the controller makes the move without the block's axis words saying so
    (canned-cycle moves, polar end points: not writable in place)."""

    row: np.ndarray
    motion: np.ndarray
    position: np.ndarray
    abc: np.ndarray  # programmed A B C (deg), as rs274's canonical calls print them
    rotary: np.ndarray  # A B C offsets in force (G5x + G92 + the tool offset's, deg): machine angle = abc + rotary (offsets.py)
    frame: np.ndarray  # index into frames, -1: the machine frame (G53)
    frames: list  # frame keys (Offsets.key)
    generated: np.ndarray
    exact: np.ndarray  # False: an axis of the target keeps a value re-read through a work offset the program does not set
    latched: dict  # row of a G43 H / G43.1 / G43.2 block -> the tool length (mm) it applied where the program gives it (G10 L1 / L10, G43.1 Z), NaN unknown
    centre: np.ndarray  # (n, 2) centre x y of an arc of a compensated path (G41/G42), NaN elsewhere
    ccomp: np.ndarray  # (n,) 0 no cutter compensation, 1 offset path (position), 2 under a compensation not followed (flagged)
    programmed: np.ndarray  # (n, 3) the programmed end point (the position, except under cutter compensation)
    notes: list  # why compensated targets are flagged, with their lines


class ToolTable:
    """Tool lengths (Z, mm) the program sets in the tool table and the one in force, as
    rs274ngc keeps them (LinuxCNC manual: "G10 L1 Set Tool Table", "G10 L10 Set Tool Table,
    Calculated, Workpiece"; "G43 Tool Length Offset"). An entry the program does not set is
    on the controller: unknown (NaN), never zero. G43 H latches the entry's length at its
    block (a later G10 changes the table, not the offset in force)."""

    def __init__(self):
        self.entry: dict[int, float] = {}  # tool number -> length set in the program (NaN: set from what the text does not determine)
        self.entry_off_axis: dict[int, bool] = {}  # tool number -> its entry was set with X Y A B C words too (their values not kept)
        self.in_force = 0.0  # the length applied now: 0 under G49 (the state at start), NaN when it is not known
        # X Y (mm) and A B C (deg) of the offset in force: set by G43.1 / G43.2 only; the controller's tool table entries are
        # taken as lengths along the spindle (Z), as every tool length here is
        self.xy, self.abc = [0.0, 0.0], [0.0, 0.0, 0.0]
        self.latched: dict[int, float] = {}  # block row of each G43 H / G43.1 / G43.2 -> the length it applied (NaN: off the spindle axis)
        self.radius: dict[int, float] = {}  # tool number -> radius (mm) set in the program (G10 L1 / L10 / L11 R), NaN unknown

    def g43(self, row: int, code: float, h: float, known: bool, words: dict | None = None) -> list[float]:
        """The change of the X Y Z offset in force (mm; NaN where not known) a G43 / G43.1 /
        G43.2 / G49 makes, as rs274 (LinuxCNC 2.9) does it, checked in tests/test_fivex_offsets.py:
        G43 H.. and G49 replace the whole offset; G43.1 replaces the axes it names (X Y Z A B C)
        and keeps the others; G43.2 H.. adds tool H's entry. G43.2 without H, or with H and
        axis words, is refused as rs274 refuses it. The length latched for the block is NaN
        where the offset has an X or Y part (the tool is not along the spindle)."""
        if math.isnan(code):
            return [0.0, 0.0, 0.0]
        before, words = [*self.xy, self.in_force], words or {}
        if code == 49.0:
            self.in_force, self.xy, self.abc = 0.0, [0.0, 0.0], [0.0, 0.0, 0.0]
        elif code == 43.0 and not math.isnan(h) and known:
            self.in_force, self.xy, self.abc = self.entry.get(int(h), math.nan), *self._entry_off_axis(int(h))
        elif code == 43.1:
            if known:
                self.in_force = words.get("Z", self.in_force)
                self.xy = [words.get(a, v) for a, v in zip("XY", self.xy)]
                self.abc = [words.get(a, v) for a, v in zip("ABC", self.abc)]
            else:
                self.in_force, self.xy, self.abc = math.nan, [math.nan] * 2, [math.nan] * 3
        elif code == 43.2:
            if math.isnan(h) or any(a in words for a in "XYZABC"):
                raise CycleError("G43.2 needs an H word and no axis words (LinuxCNC 2.9's rs274: 'Requested tool -1 not found', "
                                 "'Can not have both H and axis words')")
            tool = int(h) if known and h == int(h) else -1
            xy, abc = self._entry_off_axis(tool) if tool >= 0 else ([math.nan] * 2, [math.nan] * 3)
            self.in_force += self.entry.get(tool, math.nan)
            self.xy, self.abc = [a + b for a, b in zip(self.xy, xy)], [a + b for a, b in zip(self.abc, abc)]
        else:  # G43 without H (the loaded tool), G43.4 / G43.5: not followed here
            self.in_force = math.nan
            if code == 43.0:  # the whole offset replaced by a controller's entry: a length (see above)
                self.xy, self.abc = [0.0, 0.0], [0.0, 0.0, 0.0]
        if code in (43.0, 43.1, 43.2) and not math.isnan(h if code != 43.1 else 0.0):
            self.latched[row] = self.in_force if self.xy == [0.0, 0.0] else math.nan
        return [a - b if a != b else 0.0 for a, b in zip([*self.xy, self.in_force], before)]

    def _entry_off_axis(self, tool: int) -> tuple[list, list]:
        """X Y and A B C of a tool table entry: unknown where the program set them, else 0 (a length)."""
        fill = math.nan if self.entry_off_axis.get(tool, False) else 0.0
        return [fill] * 2, [fill] * 3

    def g10(self, lcode: int, words: dict, known: bool, current_z: float, scale: float = 1.0) -> None:
        """G10 L1 P Z (the length is Z), L10 P Z (the length that makes the current point's Z
        read as Z with the current offsets: current Z + the length in force - Z), L11 (as if
        G59.3 were in force: not followed, the entry becomes unknown). Other axis words (X Y
        offsets, A B C) set what the length alone does not describe: the entry becomes unknown."""
        if "P" not in words:
            raise CycleError(f"G10 L{lcode} needs a P word (the tool number)")
        tool = int(words["P"])
        if tool != words["P"] or tool < 0:
            raise CycleError(f"G10 L{lcode} P{words['P']:g}: P must be a tool number (an integer >= 0)")
        others = [a for a in "XYABCUVW" if a in words]
        if "R" in words:  # the radius (program units; LinuxCNC manual, "G10 L1 Set Tool Table": R radius of tool)
            self.radius[tool] = words["R"] * scale if known else math.nan
        if "Z" not in words and not others:
            return  # the entry's length is left as it was (R, I, J, Q: radius and lathe orientation)
        self.entry_off_axis[tool] = bool(others) or not known
        if not known or others or lcode == 11:
            self.entry[tool] = math.nan
        elif lcode == 1:
            self.entry[tool] = words["Z"]
        else:
            self.entry[tool] = current_z + self.in_force - words["Z"]


class _Run:
    def __init__(self, t: dict, letters: str, modal: dict):
        self.t, self.modal = t, modal
        self.col = {c: i for i, c in enumerate(letters)}
        self.offsets, self.cycle = Offsets(), CycleState()
        self.cur, self.abc = [math.nan] * 3, [math.nan] * 3
        # Per axis: the current point's program coordinate does not depend on an origin the
        # program leaves to the controller (an unset G54 is identity here): it came from an
        # absolute word, not from a G53 move, a change of system or a G10 / G92 re-reading it there.
        self.exact, self.g92_exact, self.params_exact = [False] * 3, [True] * 3, [True] * 3
        self.m_exact = [False] * 3  # per axis: the machine position is known from the program (a G53 word, a word in a known system)
        self.last_was_cycle = False  # the last block ran a cycle (its levels are in self.cycle)
        self.out: dict[str, list] = {k: [] for k in _FIELDS}  # targets not yet in a chunk
        self.chunks: list[dict] = []  # the targets so far, as arrays
        self.frames: dict = {}  # frame key -> its number in Moves.frames
        self.tools = ToolTable()
        self.rotary_now = [0.0, 0.0, 0.0]  # A B C offsets in force (deg): machine angle = programmed + these (_keep_machine_angles)
        self.scale = 1.0  # mm per program unit of the block being read
        self.comp: _CompState | None = None  # G41/G42 in force
        self.tapping = False  # G33.1 is the motion mode in force
        self.comp_endpoint = None  # rs274ngc's check point for moved ends, where the last compensation left it
        self.arc_not_allowed = False  # the move after a G40 that ended a compensated path must be straight
        self.notes: list[str] = []

    def frame_id(self) -> int | None:
        key = self.offsets.key()
        return self.frames.setdefault(key, len(self.frames))

    def flush(self) -> None:
        if self.out["row"]:
            self.chunks.append(_chunk(**self.out))
            self.out = {k: [] for k in _FIELDS}

    def extend(self, rows: np.ndarray, motion: np.ndarray, points: np.ndarray) -> None:
        """Many generated targets at once (a run of holes), in order."""
        self.flush()
        n = len(rows)
        self.chunks.append({"row": rows, "motion": motion, "position": points, "abc": np.tile(np.array(self.abc, float), (n, 1)),
                            "rotary": np.tile(np.array(self.rotary_now, float), (n, 1)),
                            "frame": np.full(n, self.frame_id()), "generated": np.ones(n, bool), "exact": np.full(n, self._all_exact()),
                            "centre": np.full((n, 2), np.nan), "ccomp": np.zeros(n, np.int8), "programmed": points})

    def holes(self, i: int, j: int) -> None:
        """Blocks i..j-1 each give one more hole of the cycle in force and nothing else
        (``simple_holes``): every hole makes the same moves over its own X Y."""
        m = self.modal
        plane, scale = m["plane"][i], m["scale"][i]
        a_i, b_i, c_i = canned.PLANE_AXES[plane]
        pattern = canned.repeat_pattern(m["mode"][i], plane, self.cycle)
        ab = [_ffill_from(self.t["values"][i:j, self.col["XYZ"[k]]] * scale, self.cur[k]) for k in (a_i, b_i)]
        prev = [np.concatenate([[self.cur[k]], v[:-1]]) for k, v in zip((a_i, b_i), ab)]
        points = np.empty((j - i, len(pattern), 3))
        for k, (_, level, at_previous) in enumerate(pattern):
            here = prev if at_previous else ab
            points[:, k, a_i], points[:, k, b_i], points[:, k, c_i] = here[0], here[1], level
        kinds = np.tile(np.array([kind for kind, _, _ in pattern]), j - i)
        self.extend(np.repeat(np.arange(i, j), len(pattern)), kinds, points.reshape(-1, 3))
        self.cur[a_i], self.cur[b_i], self.cur[c_i] = float(ab[0][-1]), float(ab[1][-1]), self.cycle.levels[1]
        self._moved_to_words("XYZ"[a_i] + "XYZ"[b_i])  # G90 hole positions

    def words(self, i: int) -> dict:
        """The block's words (X Y Z ... as mm, A B C degrees, R as written) present in it."""
        scale = self.modal["scale"][i]
        row = self.t["values"][i].tolist() + self.t["more"][i].tolist()
        return {c: (v * scale if c in LENGTH_WORDS else v) for c, k in self.col.items() if not math.isnan(v := row[k])}

    def _all_exact(self) -> bool:
        return all(self.exact) and all(self.g92_exact)

    def emit(self, i: int, motion: int, position: list, generated: bool, machine_frame: bool = False, exact: bool | None = None,
             ccomp: int = 0, centre=(math.nan, math.nan), programmed: list | None = None, abc: list | None = None, frame: int | None = None) -> None:
        """One target of block i, in the frame in force (the machine frame for G53)."""
        frame = (-1 if machine_frame else self.frame_id()) if frame is None else frame
        exact = self._all_exact() if exact is None else exact
        for key, value in (("row", i), ("motion", motion), ("position", list(position)), ("abc", list(self.abc if abc is None else abc)), ("rotary", self.rotary_now), ("frame", frame),
                           ("generated", generated), ("exact", exact), ("centre", list(centre)), ("ccomp", ccomp),
                           ("programmed", list(position if programmed is None else programmed))):
            self.out[key].append(value)

    def block(self, i: int, line: int) -> None:
        m, t = self.modal, self.t
        self.last_was_cycle = False
        self.scale = m["scale"][i]
        words = self.words(i)
        self._modes(i, words, line)
        setup, known = t["setup"][i], bool(t["ok"][i])
        if setup in UNKNOWN_END_CODES:
            self._to_unknown_end(i, setup, words, known)
            return
        if setup in SETUP_CODES:
            self._setup(setup, words, known, line)
            self._keep_machine_angles()
        mode = m["mode"][i]
        # A G2/G3 with centre words and no end point is a full circle (modal["circle"]): it ends where it starts.
        moving = not t["nonmotion"][i] and not math.isnan(mode) and (any(c in words for c in "XYZABC@^") or m["circle"][i])
        if m["sets_mode"][i] and mode not in canned.CYCLES:
            self.cycle.end_run(mode)
        if m["sets_mode"][i]:
            self.tapping = setup == RIGID_TAP
        if moving:
            self._move(i, mode, words, known, line)

    def _modes(self, i: int, words: dict, line: int) -> None:
        """The block's non-motion groups in LinuxCNC's "Order of Execution": M6, cutter
        compensation (group 7), the coordinate system, then the tool length (group 8)."""
        t = self.t
        if self.comp is not None and t["toolchange"][i] == 6.0:  # M6 runs before group 7: "G41 M6" changes first, "G40 M6" is refused
            raise CycleError("Cannot change tools with cutter radius compensation on")
        if not math.isnan(t["ccomp"][i]):  # group 7 runs before the coordinate system, offsets and motion
            self._comp_code(i, t["ccomp"][i], words, bool(t["ok"][i]), line)
        if self.comp is not None:
            self._comp_refusals(i, words)
        before = self.offsets.index
        self.cur = self.offsets.select(int(self.modal["wcs"][i]), self.cur)
        if self.offsets.index != before:
            self._keep_machine_angles()
        if self.offsets.index != before and not (self.offsets.known[before] and self.offsets.known[self.offsets.index]):
            self.exact = [False] * 3  # the current point re-read in the new system through an origin the program does not give
            self._reread()
        change = self.tools.g43(i, t["tlo"][i], t["h"][i], bool(t["ok"][i]), words)  # group 8 runs before G10 in a block
        if not math.isnan(t["tlo"][i]):
            self._keep_machine_angles()
        for k, moved in enumerate(change):  # rs274ngc re-reads the current point for the new offset: X Y Z = the old ones - the change
            if math.isnan(moved):
                self.exact[k] = False  # by a length the program does not give: the stale value stands in, flagged
            elif moved:
                self.cur[k] -= moved

    def _move(self, i: int, mode: float, words: dict, known: bool, line: int) -> None:
        """The motion of block i in the mode in force: a cycle's holes, a G53 move or a G0-G3 /
        G33.1 move (the offset path under cutter compensation)."""
        if mode == 80.0:  # axis words after G80: Fanuc moves in the G0-G3 mode in force (rs274 refuses them)
            mode = self.modal["motion"][i]
            if math.isnan(mode):
                raise CycleError("axis words after G80 with no G0/G1/G2/G3 in force")
        if mode in canned.CYCLES and self.cycle.last == mode and self.cycle.unknown:
            known = False  # R, bottom, P, Q kept from a cycle block that was not read: this hole is not known either
        if not known:  # a word the program text does not determine: the target and all after it are flagged
            if self.comp is not None:
                self._comp_lost(line, "a move whose words cannot be evaluated")
            self.cycle.end_run(mode)
            self.cycle.unknown = mode in canned.CYCLES
            self.emit(i, 0 if mode in canned.CYCLES else int(mode), [math.nan] * 3, mode in canned.CYCLES)
            self.cur = [math.nan] * 3
            return
        if mode in canned.CYCLES:
            self._cycle(i, mode, words)
            self.last_was_cycle = True
            return
        self.cycle.end_run(mode)
        if self.t["g53"][i]:
            self._g53_move(i, mode, words)
        else:
            self._program_move(i, mode, words, line)

    def _g53_move(self, i: int, mode: float, words: dict) -> None:
        """G53: the words are machine coordinates (the tool offset off where they place the spindle)."""
        if mode not in (0.0, 1.0):  # rs274: "Must use G0 or G1 with G53"
            raise CycleError(f"G53 moves in machine coordinates with G0 or G1 only, not G{mode:g} (LinuxCNC refuses it)")
        program, machine = self.offsets.g53(words, self.cur)
        tool = [*self.tools.xy, self.tools.in_force]
        if any(tool[k] != 0.0 for k, a in enumerate("XYZ") if a in words):  # the words place the spindle: the tip is the tool offset off
            program, _ = self.offsets.g53({**words, **{a: words[a] - tool[k] for k, a in enumerate("XYZ") if a in words}}, self.cur)
        # G53 A B C words are machine angles too: programmed = the word - the rotary offsets in force
        self._rotary({a: words[a] - o for a, o in zip("ABC", self.rotary_now) if a in words}, absolute=True)
        self.cur = program
        placed = self.offsets.known[self.offsets.index] and all(self.g92_exact)
        left_out = [a not in words for a in "XYZ"]
        # an axis left out stays where the machine is: known where the machine position is
        exact = all(not out or m for out, m in zip(left_out, self.m_exact))
        self.exact = [e if out else placed for out, e in zip(left_out, self.exact)]
        self.m_exact = [m if out else True for out, m in zip(left_out, self.m_exact)]
        self.emit(i, int(mode), machine, False, machine_frame=True, exact=exact)

    def _program_move(self, i: int, mode: float, words: dict, line: int) -> None:
        """A G0-G3 or G33.1 move in the program's coordinates."""
        if mode in (2.0, 3.0) and self.arc_not_allowed:
            raise CycleError("The move just after exiting cutter compensation mode must be straight, not an arc")
        self.arc_not_allowed = False
        start = list(self.cur)
        self.cur = self._straight_end(i, words)
        if self.tapping:  # in to the words, out again to the start (a move the text has no words for)
            if self.comp is not None:
                raise CycleError("G33.1 rigid tapping under cutter radius compensation is not followed")
            self.emit(i, 1, self.cur, False)
            self.emit(i, 1, start, True)
            self.cur = start
        elif self.comp is not None:
            self._comp_move(i, int(mode), start, words, line)
        else:
            self.emit(i, int(mode), self.cur, "@" in words or "^" in words)

    # ------------------------------------------------------------ cutter radius compensation
    def _comp_code(self, i: int, code: float, words: dict, known: bool, line: int) -> None:
        """G40 / G41 / G42 / G41.1 / G42.1 (LinuxCNC manual, "Cutter Compensation")."""
        if code == 40.0:
            self._comp_off(line)
            return
        if self.comp is not None:
            raise CycleError("Cannot turn cutter radius comp on when on")
        plane = self.modal["plane"][i]
        if plane not in (17.0, 18.0):
            raise CycleError("Cutter radius compensation allowed only in XY, XZ planes")
        side = 1 if code in (41.0, 41.1) else -1
        radius, why = self._comp_radius(code, words, known)
        if radius < 0:  # a negative radius swaps the side
            radius, side = -radius, -side
        self.comp = _CompState(side, radius, line, plane, self.scale, why)
        if why is not None:
            self.notes.append(f"line {line}: G{code:g} cutter radius compensation: {why}; the targets under it are flagged (positions as programmed)")

    def _comp_radius(self, code: float, words: dict, known: bool) -> tuple[float, str | None]:
        """The radius (mm; NaN where the program text does not give it) and why it is not known."""
        d = words.get("D")
        if code in (41.1, 42.1):
            if d is None:
                raise CycleError(f"G{code:g} with no D word")
            return (d * self.scale / 2.0, None) if known and math.isfinite(d) else (math.nan, "the D word cannot be evaluated")
        if d is None:
            return math.nan, "the radius is the loaded tool's diameter in the machine's tool table (G41/G42 without D), not in the program"
        if not known or not math.isfinite(d):
            return math.nan, "the D word cannot be evaluated"
        if abs(d - round(d)) > 1e-4 or d < 0:
            raise CycleError(f"G{code:g} requires D word to be a whole number")
        radius = self.tools.radius.get(int(round(d)), math.nan)
        why = None if math.isfinite(radius) else f"tool {int(round(d))}'s diameter is in the machine's tool table (the program sets no G10 L1 P{int(round(d))} R)"
        return radius, why

    def _comp_refusals(self, i: int, words: dict) -> None:
        """What LinuxCNC refuses while G41/G42 is in force (rs274ngc's messages)."""
        t, m, c = self.t, self.modal, self.comp
        setup = t["setup"][i]
        for bad, why in ((int(m["wcs"][i]) != self.offsets.index, "Cannot change coordinate systems with cutter radius compensation on"),
                         (setup in (52.0, 92.0, 92.1, 92.2, 92.3), "Cannot change axis offsets with cutter radius comp"),
                         (setup == 10.0 and words.get("L") in (2.0, 20.0) and words.get("P", 0.0) in (0.0, float(self.offsets.index)),
                          "Cannot change the active coordinate system with cutter radius compensation on"),
                         (setup in (28.0, 30.0), "Cannot use g28 or g30 with cutter radius comp"),
                         (setup in (38.2, 38.3, 38.4, 38.5), "Cannot probe with cutter radius comp on"),
                         (bool(t["g53"][i]) and c.radius != 0.0, "Cannot use g53 with cutter radius comp"),
                         (m["mode"][i] in canned.CYCLES and bool(m["sets_mode"][i]), "Cannot use canned cycles with cutter compensation on"),
                         (not math.isnan(t["tlo"][i]), "Cannot change tool offset with cutter radius compensation on"),
                         (m["plane"][i] != c.plane, "Cannot change planes with cutter radius compensation on"),
                         (m["scale"][i] != c.scale, "Cannot change units with cutter radius comp")):
            if bad:
                raise CycleError(why)

    def _comp_move(self, i: int, mode: int, start: list, words: dict, line: int) -> None:
        """A move under G41/G42: through the offset path (cutter_comp.py), or flagged where the
        radius is not known or the case is not followed."""
        c, polar = self.comp, "@" in words or "^" in words
        if c.radius == 0.0:  # no offset (rs274ngc runs the move as if compensation were off)
            self.emit(i, mode, self.cur, polar)
            return
        if c.why is None:
            # The offset path is computed in the plane's first, second, normal axes (G17: X Y Z, G18: Z X Y, as
            # rs274ngc: left / right and G2 / G3 are as seen in (first, second), G18 arcs' centre words K I).
            ax = canned.PLANE_AXES[c.plane]
            if c.path is None:  # rs274ngc's check point outlives a compensation (an entry arc is checked against it)
                c.path = CutterComp(c.side, c.radius, c.scale, prog=[start[a] for a in ax], endpoint=self.comp_endpoint)
            extra = {"abc": list(self.abc), "frame": self.frame_id(), "exact": self._all_exact(), "prog": list(self.cur), "polar": polar}
            try:
                if mode in (0, 1):
                    c.path.straight(i, mode, [self.cur[a] for a in ax], extra)
                else:
                    if words.get("P", 1.0) != 1.0:
                        raise Unfollowed("an arc of several turns (P)")
                    in_plane = {k: words[w] for k, w in (("I", "IJK"[ax[0]]), ("J", "IJK"[ax[1]]), ("R", "R")) if w in words}
                    centre = arc_centre([start[a] for a in ax], [self.cur[a] for a in ax], in_plane, self.modal["ijk"][i] == 90.1, mode == 3, self.scale)
                    c.path.arc(i, mode, [self.cur[a] for a in ax], centre, extra)
                self._emit_comp(c.path.take(), 1)
                return
            except (ValueError, ZeroDivisionError, OverflowError) as exc:  # Unfollowed; a degenerate corner (math domain)
                self._comp_lost(line, str(exc))
        self.emit(i, mode, self.cur, polar, ccomp=2)

    def _comp_lost(self, line: int, why: str) -> None:
        """From here to G40 the offset path is not followed: its pending moves and the targets after
        them are flagged (positions as computed so far / as programmed), with the line and why."""
        c = self.comp
        if c.why is not None or c.radius == 0.0:
            return
        c.why = f"{why} (rs274ngc's offset path is not followed from here)"
        self.notes.append(f"line {line}: cutter radius compensation: {c.why}; the targets up to G40 are flagged (positions as programmed)")
        if c.path is not None:
            self._emit_comp(c.path.drop(), 2)

    def _emit_comp(self, outs: list, code: int) -> None:
        """The offset path's moves (in the plane's first, second, normal axes) as targets in X Y Z;
        an arc's centre stays (first, second), as postproc.programs.arcs reads a plane's centre."""
        ax = canned.PLANE_AXES[self.comp.plane]
        for o in outs:
            e, end = o.extra, [math.nan] * 3
            for k, a in enumerate(ax):
                end[a] = o.end[k]
            self.emit(o.row, o.motion, end, o.generated or e["polar"], exact=e["exact"], ccomp=code,
                      centre=o.centre if o.centre is not None else (math.nan, math.nan), programmed=end if o.generated else e["prog"],
                      abc=e["abc"], frame=e["frame"])

    def _comp_off(self, line: int | None = None) -> None:
        """G40 (or the end of the program): the pending offset moves go out; the next move goes
        from where the tool is to its programmed end and must be straight."""
        c = self.comp
        if c is not None and c.path is not None:
            try:
                self._emit_comp(c.path.off(), 1 if c.why is None else 2)
            except Unfollowed as exc:  # LinuxCNC refuses where G40 / M2 leaves the last moves
                self._comp_lost(c.line if line is None else line, f"{exc} (at G40 or the program's end)")
            self.arc_not_allowed = not c.path.first
            self.comp_endpoint = c.path.endpoint
        self.comp = None

    def _to_unknown_end(self, i: int, code: float, words: dict, known: bool) -> None:
        """G28 / G30 (LinuxCNC manual, G28-G28.1): a rapid to the axis words (in the system in
        force, G90/G91), then the axes named (all, without words) to the stored position;
        G38.2-G38.5: a feed toward the words that stops at the probe's contact. The end is
        not in the program: it is a target with unknown coordinates, and those axes stay
        unknown (every later target flagged) until they get an absolute word again."""
        given = [a in words for a in "XYZ"]
        homing = code in (28.0, 30.0)
        if homing and any(given):
            if known:
                self.cur = self._straight_end(i, words)
                self.emit(i, 0, self.cur, True)
            else:
                self.cur = [math.nan] * 3
        moved = [True] * 3 if homing and not any(given) else given
        if not any(moved):
            return
        self.cur = [math.nan if m else c for m, c in zip(moved, self.cur)]
        self.m_exact = [e and not m for e, m in zip(self.m_exact, moved)]
        self.emit(i, 0 if homing else 1, self.cur, True)

    def _setup(self, code: float, words: dict, known: bool, line: int) -> None:
        """G10 L2 / L20 and the G92 family; one whose words are not all known leaves the
        offsets it sets unknown (NaN: every target in them is flagged)."""
        given = [a in words for a in "XYZ"]
        if code == 10.0:
            lcode, p = words.get("L", math.nan), words.get("P", 0.0)
            if lcode in (1.0, 10.0, 11.0):
                self.tools.g10(int(lcode), words, known, self.cur[2] if self.exact[2] and self.g92_exact[2] else math.nan, self.scale)
                return
            if lcode not in (2.0, 20.0):
                return
            if not (0 <= p <= 9 and p == int(p)):
                raise CycleError(f"G10 L{lcode:g} P{p:g}: P must be 0 (the active system) to 9 (G59.3)")
            self._known_after_g10(int(lcode), int(p) or self.offsets.index, given)
            self.offsets.g10_rotary(int(lcode), int(p), words, self.abc)
            self.cur = self.offsets.g10(int(lcode), int(p), {k: v for k, v in words.items() if k in "XYZR"}, self.cur, line)
            self._reread()
            if not known:
                system = int(p) or self.offsets.index
                self.offsets.origin[system] = [math.nan] * 3
                self.offsets.origin_abc[system] = [math.nan] * 3  # its angles too: a rotary word may be the unknown one
                self.cur = [math.nan] * 3
            return
        self._exact_after_g92(code, given)
        self._reread()
        self.offsets.g92_rotary(code, words, self.abc)
        self.cur = self.offsets.g92_family(code, words, self.cur, line)
        if not known:
            self.offsets.g92, self.offsets.g92_params, self.cur = [math.nan] * 3, [math.nan] * 3, [math.nan] * 3
            self.offsets.g92_abc, self.offsets.g92_abc_params = [math.nan] * 3, [math.nan] * 3

    def _known_after_g10(self, lcode: int, system: int, given: list) -> None:
        """G10 L2 sets the origin from its words (known once every axis is given); L20 from the
        current point (known where that point's machine position is). On the active system the
        current point is re-read: exact under L20 on the given axes, inexact under L2 of a
        system whose old origin was not known."""
        offsets, active = self.offsets, system == self.offsets.index
        was = offsets.known[system]
        if lcode == 2:
            offsets.known[system] = was or all(given)
            if active and not was:
                self.exact = [False] * 3
            return
        from_point = all(m for m, g in zip(self.m_exact, given) if g)  # the machine position the origin is taken from
        offsets.known[system] = from_point and (was or all(given))
        if active:
            self.exact = [True if g else e for e, g in zip(self.exact, given)]

    def _exact_after_g92(self, code: float, given: list) -> None:
        """G92 (the current point reads as the words: the offset is as exact as the point was),
        G52 (the offset is the words), G92.1 / G92.2 / G92.3 (the point re-read without / with
        the stored offset)."""
        if code == 92.0:
            self.g92_exact = [e if g else x for e, g, x in zip(self.exact, given, self.g92_exact)]
            self.exact = [True if g else e for e, g in zip(self.exact, given)]
        elif code == 52.0:
            self.exact = [e and x if g else e for e, g, x in zip(self.exact, given, self.g92_exact)]
            self.g92_exact = [True if g else x for g, x in zip(given, self.g92_exact)]
        elif code in (92.1, 92.2):
            self.exact = [e and x for e, x in zip(self.exact, self.g92_exact)]
            self.g92_exact = [True] * 3
            self.params_exact = [True] * 3 if code == 92.1 else self.params_exact
            return
        elif code == 92.3:
            self.exact = [e and x and q for e, x, q in zip(self.exact, self.g92_exact, self.params_exact)]
            self.g92_exact = list(self.params_exact)
            return
        self.params_exact = list(self.g92_exact)

    def _reread(self) -> None:
        """The current point re-read in the frame now in force is exact where its machine position is known and the frame too."""
        placed = self.offsets.known[self.offsets.index] and all(self.g92_exact)
        self.exact = [e or (m and placed) for e, m in zip(self.exact, self.m_exact)]

    def _moved_to_words(self, axes: str) -> None:
        """Absolute words on ``axes`` in the frame in force: the program coordinate is exact, the machine one where the frame is known."""
        placed = self.offsets.known[self.offsets.index] and all(self.g92_exact)
        for k, a in enumerate("XYZ"):
            if a in axes:
                self.exact[k], self.m_exact[k] = True, placed

    def _straight_end(self, i: int, words: dict) -> list:
        incremental = self.modal["dist"][i] == 91.0
        end = [(c + words.get(a, 0.0)) if incremental else words.get(a, c) for a, c in zip("XYZ", self.cur)]
        if not incremental:
            self._moved_to_words("".join(a for a in "XYZ" if a in words))
        if "@" in words or "^" in words:
            if self.modal["plane"][i] != 17.0:  # rs274: "Cannot use polar coordinate except in G17 plane"
                raise PolarError("polar words (@ ^) outside the G17 plane: LinuxCNC refuses them")
            if "X" in words or "Y" in words:
                raise PolarError("cannot give X or Y words with polar coordinates")
            end[0], end[1] = polar_end(self.cur[0], self.cur[1], words.get("@"), words.get("^"), incremental)
            if not incremental and "@" in words and "^" in words:
                self._moved_to_words("XY")
        self._rotary(words, absolute=not incremental)
        return end

    def _keep_machine_angles(self) -> None:
        """After a block that may change the A B C offsets (G5x + G92 + the tool offset's, G43.1
        A B C; ``rotary_now``): the machine does not move, so the current programmed angle
        becomes the machine angle minus the new offsets (rs274ngc convert_setup,
        convert_axis_offsets, convert_coordinate_system, convert_tool_length_offset)."""
        before, after = self.rotary_now, [w + t for w, t in zip(self.offsets.rotary(), self.tools.abc)]
        if after != before:
            self.abc = [a + b - n for a, b, n in zip(self.abc, before, after)]
            self.rotary_now = after

    def _rotary(self, words: dict, absolute: bool) -> None:
        for k, a in enumerate("ABC"):
            if a in words:
                self.abc[k] = words[a] if absolute else self.abc[k] + words[a]

    def _cycle(self, i: int, mode: float, words: dict) -> None:
        cycle_words = {**words, **({"R": words["R"] * self.modal["scale"][i]} if "R" in words else {})}
        canned.check_spindle(mode, self.modal["turning"][i])
        block = canned.Block(mode, cycle_words, self.modal["plane"][i], self.modal["dist"][i] == 91.0, self.modal["retract"][i] == 99.0)
        moves, self.cur = canned.expand(block, self.cycle, self.cur)  # first: it refuses a plane it cannot read
        if self.modal["dist"][i] != 91.0:
            self._moved_to_words("".join(a for k, a in enumerate("XYZ") if a in words and k != canned.PLANE_AXES[block.plane][2]))
        self.cycle.unknown = False
        for kind, point in moves:
            self.emit(i, kind, point, True)


@dataclass
class _CompState:
    """G41/G42 in force: side (+1 left), radius (mm, NaN unknown), where and how it was turned on,
    why its path is not followed (None: followed), and the offset path once a move has started it."""

    side: int
    radius: float
    line: int
    plane: float
    scale: float
    why: str | None
    path: CutterComp | None = None


_FIELDS = ("row", "motion", "position", "abc", "rotary", "frame", "generated", "exact", "centre", "ccomp", "programmed")
_FLOAT_FIELDS = ("position", "abc", "rotary", "centre", "programmed")


def _chunk(**lists) -> dict:
    return {k: np.array(v, dtype=float if k in _FLOAT_FIELDS else bool if k in ("generated", "exact") else np.int8 if k == "ccomp" else np.int64)
            for k, v in lists.items()}


def _ffill_from(col: np.ndarray, start: float) -> np.ndarray:
    """``col`` with each NaN replaced by the last value before it (``start`` before the first)."""
    values = np.concatenate([[start], col])
    idx = np.where(~np.isnan(values), np.arange(len(values)), 0)
    np.maximum.accumulate(idx, out=idx)
    return values[idx][1:]


def simple_holes(t: dict, letters: str, modal: dict) -> np.ndarray:
    """(n,) True for a block that only gives the next hole of the cycle in force: X Y (in the
    cycle's plane) and perhaps F, in G90, with every modal state as in the block before."""
    col = {c: i for i, c in enumerate(letters)}
    present = np.hstack([~np.isnan(t["values"]), ~np.isnan(t["more"])])
    xyz = present[:, [col["X"], col["Y"], col["Z"]]]
    others = present[:, [i for c, i in col.items() if c not in "XYZF"]].any(axis=1)
    plane = np.asarray(modal["plane"])
    drilling_axis = np.select([plane == 18.0, plane == 19.0], [1, 0], 2)
    mode = np.asarray(modal["mode"])

    def same(key):
        v = np.asarray(modal[key])
        return np.concatenate([[False], v[1:] == v[:-1]])

    return (xyz.any(axis=1) & ~xyz[np.arange(len(plane)), drilling_axis] & ~others & np.isin(mode, canned.REPEATABLE)
            & ~np.asarray(modal["sets_mode"]) & np.isnan(t["setup"]) & t["ok"] & ~t["g53"] & ~t["nonmotion"] & (np.asarray(modal["dist"]) == 90.0)
            & same("wcs") & same("retract") & same("scale") & same("plane") & same("mode") & same("turning"))


def run(t: dict, letters: str, modal: dict, lines: np.ndarray, fast: bool = True) -> Moves:
    """Every motion target of the block table ``t`` (program order). ``modal`` holds the
    forward-filled modal columns: scale (mm per program unit), dist, plane, wcs, retract,
    motion (the G0-G3 in force), mode (the motion or cycle code in force) and sets_mode
    (the block names one), circle (a G2/G3 block that is a full circle: no end-point word)
    and turning (the spindle: M3, M4 or M5 in force)."""
    state = _Run(t, letters, modal)
    n = len(t["offset"])
    simple = simple_holes(t, letters, modal) if fast else np.zeros(n, bool)
    # end of the run of simple hole blocks that starts at each block
    run_end = np.minimum.accumulate(np.where(simple, n, np.arange(n))[::-1])[::-1]
    i = 0
    while i < n:
        try:
            state.block(i, int(lines[i]))
        except (ValueError, OverflowError) as exc:  # CycleError, PolarError; int() of an infinite word value
            raise BlockError(i, str(exc)) from None
        i += 1
        if i < n and simple[i] and state.last_was_cycle:
            end = int(run_end[i])
            state.holes(i, end)
            i = end
    state._comp_off()  # the program ends under G41/G42: its last offset moves as they stand
    state.flush()
    empty = {"position": (0, 3), "abc": (0, 3), "rotary": (0, 3), "programmed": (0, 3), "centre": (0, 2)}
    parts = {k: np.concatenate([c[k] for c in state.chunks]) if state.chunks else np.zeros(empty.get(k, 0)) for k in _FIELDS}
    return Moves(row=parts["row"].astype(np.int64), motion=parts["motion"].astype(np.int64), position=parts["position"].reshape(-1, 3).astype(float),
                 abc=parts["abc"].reshape(-1, 3).astype(float), rotary=parts["rotary"].reshape(-1, 3).astype(float), frame=parts["frame"].astype(np.int64), frames=list(state.frames), generated=parts["generated"].astype(bool),
                 exact=parts["exact"].astype(bool), latched=dict(state.tools.latched), centre=parts["centre"].reshape(-1, 2).astype(float),
                 ccomp=parts["ccomp"].astype(np.int8), programmed=parts["programmed"].reshape(-1, 3).astype(float), notes=state.notes)


def modal_mode(motion: np.ndarray, cycle_codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mode in force at each block, the block names a motion or cycle code): G0-G3 and the
    cycles G73-G89 (G80: 80) are one modal group, the one named last is in force."""
    cycle = np.where(cycle_codes == 0.0, 80.0, cycle_codes)
    named = np.where(~np.isnan(motion), motion, cycle)
    has = ~np.isnan(named)
    idx = np.where(has, np.arange(len(named)), -1)
    np.maximum.accumulate(idx, out=idx)
    return np.where(idx >= 0, named[np.maximum(idx, 0)], np.nan), has


_GENERATOR = re.compile(r"[Gg][ \t]*0*(7[34]|8[1-9]|4[12](?:\.1)?)(?![\d.])|[@^]")


def refuse_unwritable(original, modified) -> None:
    """Compensation must never leave a move the controller makes silently uncompensated:
    a canned-cycle move or a polar end point (no axis words of its own, insert_at -1) that
    ``modified`` moves or whose previous target it moves (the cycle starts from there), or a G91 increment after a change of frame that it moves, cannot be
    written in place: EmitError naming file:line:column of the block."""
    moved = ~np.isclose(modified.position, original.position, rtol=0, atol=0, equal_nan=True).all(axis=1)
    generated = original.insert_at[:, 1] < 0 if original.insert_at is not None else np.zeros(len(original), bool)
    new_frame = np.concatenate([[False], original.frame[1:] != original.frame[:-1]])
    moved_before = np.concatenate([[False], moved[:-1]])  # a cycle starts from where the tool is: its moves follow
    after = moved & original.relative & (new_frame | np.concatenate([[False], generated[:-1]]))
    comp = (original.ccomp != 0) if original.ccomp is not None else np.zeros(len(original), bool)
    for rows, why in (((moved | np.concatenate([moved[1:], [False]])) & comp,
                       "it runs under cutter radius compensation (G41/G42): the controller offsets the programmed path by the tool radius "
                       "and decides each end point from the next move, so a compensated position cannot be written back as the block's words "
                       "(they would be offset again); post the tool-centre path without G41/G42 (CAM output with compensation 'in computer') first"),
                      ((moved | moved_before) & generated, "its moves are made by the controller (canned cycle or polar @ ^ words), not written as axis words: "
                       "compensated moves cannot be put in place; expand the cycle / polar moves to G0/G1 X Y Z blocks first"),
                      (after, "a G91 increment after an offset change or a canned cycle cannot be rewritten exactly; write the program in G90 first")):
        if rows.any():
            r = int(np.nonzero(rows)[0][0])
            doc = original.sources[int(original.file[r])]
            start = _line_start(doc.text, int(original.line[r]))
            end = doc.text.find("\n", start)
            found = _GENERATOR.search(doc.text, start, len(doc.text) if end < 0 else end)
            column = (found.start() - start + 1) if found else 1
            raise EmitError(f"{doc.path}:{original.line[r]}:{column}: this block cannot be compensated: {why}")


def _line_start(text: str, line: int) -> int:
    start = 0
    for _ in range(line - 1):
        start = text.index("\n", start) + 1
    return start
