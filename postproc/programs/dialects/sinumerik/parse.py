"""SINUMERIK 840D part programs (.MPF / .SPF) -> Toolpath.

The G-code reader (``..gcode.parse.GcodeParser``) reads the blocks once ``translate.py`` has
put the Sinumerik-only words in its syntax; this reader adds what it does not know:
- the programmable frames (``frames.py``), kept as the reader keeps a G68.2 tilted plane: an
  event per frame instruction, each later target's frame ``settable @ programmable``;
- the offsets back into the file (``translate.OffsetMap``): every span, insertion point and
  error position names the file's own characters, so the unchanged emit is byte-identical;
- the toolpath's dialect, ``sinumerik``.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from postproc.errors import ParseError

from ...arcs import PLANE_AXES, R_
from ...ir import F_ARC, Kind, SourceDoc, Toolpath
from ...parse.common import Builder, LineIndex
from ..gcode.blockwords import AXES
from ..gcode.parse import GcodeParser
from . import arc_angle, circle_through, frames, swivel, translate

_AX = {c: i for i, c in enumerate(AXES)}
_CALL = re.compile(r"(?im)^[ \t]*(?:N\d+[ \t]+)?[A-Z_]\w{2,}[ \t]*\(")
_LABEL = re.compile(r"(?im)^[ \t]*(?:N\d+[ \t]+)?[A-Z_]\w*:(?!=)")


def _calls_or_labels(text: str) -> bool:
    """True where a block calls a subprogram or cycle or carries a jump label: only the lines
    with a '(' or ':' are matched (a regular expression over 10^6 CAM lines costs a second)."""
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    hits = np.nonzero((raw == ord("(")) | (raw == ord(":")))[0]
    if not len(hits):
        return False
    starts = np.concatenate([[0], np.nonzero(raw == 10)[0] + 1])
    for start in np.unique(starts[np.searchsorted(starts, hits, side="right") - 1]).tolist():
        end = text.find("\n", start)
        line = text[start : len(text) if end < 0 else end]
        if _CALL.match(line) or _LABEL.match(line):
            return True
    return False
_FRAME_CODES = set(translate.FRAME_NAMES)
# Settable frames beyond G54-G57 (group 8, Fundamentals "Settable zero offset G54 to G57, G505
# to G599, G53, G500, SUPA, G153"): G500 and G505..G599 as work-offset numbers of their own
# (the G-code reader's are 1..9); their values are in the controller, not in the program.
_SETTABLE_BASE = 100
_SETTABLE = {500.0: _SETTABLE_BASE, **{float(g): _SETTABLE_BASE + g - 500 for g in range(505, 600)}}


class _MappedLines(LineIndex):
    """Line index of the rewritten text whose errors name the file's line and column."""

    def __init__(self, text: str, original: LineIndex, offsets: translate.OffsetMap):
        super().__init__(text)
        self.original = original
        self.offsets = offsets

    def error(self, path: str, offset: int, message: str):
        return self.original.error(path, int(self.offsets([offset])[0]), message)


class SinumerikParser(GcodeParser):
    tilt_word = "FRAME"  # frame names: "G54+FRAME@line12"

    def __init__(self, doc: SourceDoc):
        original = LineIndex(doc.text)
        try:
            text, self.offsets = translate.rewrite(doc.text)
        except translate.Refusal as exc:
            raise original.error(doc.path, exc.offset, exc.message) from None
        super().__init__(SourceDoc(doc.path, text, doc.role))
        self.original = doc
        self.siemens = True
        self.builder = Builder("sinumerik", "none", [doc])
        self.lines = _MappedLines(text, original, self.offsets)
        self.frame = np.eye(4)  # the programmable frame, as the blocks read so far leave it
        self.swivel = np.eye(4)  # the CYCLE800 swivel frame (a system frame below the programmable one)
        self.cip_points: list[tuple[int, np.ndarray]] = []  # (line, intermediate point mm) of each CIP block read, in order
        self.opening_angles: dict[int, float] = {}  # line -> AR= opening angle (deg) of the arc in that block
        self.plane = 17.0
        self.to_mm = 1.0

    def parse(self) -> Toolpath:
        if _calls_or_labels(self.text):  # a call or a jump label: the flow reader knows them
            return self._cip_arcs(self._opening_angle_arcs(self._back_to_file(self._parse_flow())))
        return self._cip_arcs(self._opening_angle_arcs(self._back_to_file(super().parse())))

    def _cip_arcs(self, tp: Toolpath) -> Toolpath:
        """CIP blocks (read as G3 with the intermediate point in I J K): the plane arc through
        start, intermediate and end point (``circle_through.py``), its centre absolute, without
        spans (the file's numbers are the intermediate point's, never written over)."""
        if not self.cip_points:
            return tp
        lines = {line for line, _ in self.cip_points}
        rows = np.nonzero((tp.file == 0) & np.isin(tp.line, list(lines)))[0]
        if len(rows) != len(self.cip_points):
            raise self._at_word(self.cip_points[0][0], "I1", "I1= J1= K1= in a block that is not one arc target (CIP X.. Y.. Z..)")
        values, resolved, kind, arc = tp.values.copy(), tp.resolved.copy(), tp.kind.copy(), tp.arc.copy()
        spans = tp.spans.copy()
        for row, (_, middle) in zip(rows.tolist(), self.cip_points, strict=True):  # one 2x2 solve per CIP block (few in a program)
            line = int(tp.line[row])
            if row == 0 or tp.kind[row] != Kind.ARC_CCW:
                raise self._at_word(line, "I1", "I1= J1= K1= outside a CIP arc after a target (CIP with a start)")
            if tp.relative[row]:
                raise self._at_word(line, "CIP", "CIP under G91 (intermediate point relative to the start) is not read")
            if np.isnan(middle).any():
                raise self._at_word(line, "CIP", "CIP needs all three of I1= J1= K1= (an intermediate coordinate left out is not guessed)")
            known = tp.frame[row] == tp.frame[row - 1] and resolved[row - 1] and not np.isnan(tp.position[[row - 1, row]]).any()
            spans[row, F_ARC, 1:] = -1
            if not known:
                resolved[row] = False
                continue
            try:
                plane, centre, ccw = circle_through.plane_arc(tp.position[row - 1], middle, tp.position[row])
            except circle_through.NotRead as exc:
                raise self._at_word(line, "CIP", str(exc)) from None
            kind[row] = Kind.ARC_CCW if ccw else Kind.ARC_CW
            arc[row, :2] = (plane, 1.0)  # the centre as coordinates (G90.1-like)
            values[row, F_ARC] = np.nan
            first, second, _ = PLANE_AXES[plane]
            values[row, F_ARC.start + first], values[row, F_ARC.start + second] = centre[first], centre[second]
        others = np.nonzero(np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW)) & np.isnan(values[:, F_ARC]).all(axis=1))[0]
        if len(others):
            raise self._at_word(int(tp.line[others[0]]), "", "an arc without centre words in a program with CIP (a CIP continued "
                                "modally?): write CIP with its intermediate point in every block")
        return replace(tp, values=values, resolved=resolved, kind=kind, arc=arc, spans=spans)

    def _opening_angle_arcs(self, tp: Toolpath) -> Toolpath:
        """AR= arcs: the R word their chord (in their own frame) and opening angle give
        (``arc_angle.py``); an arc whose start is unknown or in another frame stays flagged."""
        if not self.opening_angles:
            return tp
        rows = np.nonzero((tp.file == 0) & np.isin(tp.line, list(self.opening_angles)))[0]
        arc = np.isin(tp.kind[rows], (Kind.ARC_CW, Kind.ARC_CCW)) & (rows > 0)
        if not arc.all():
            raise self._at_opening_angle(int(tp.line[rows[~arc][0]]), "AR= in a block that is not an arc after a target (G2 / G3 with a start)")
        axes = np.array([PLANE_AXES[int(p)] for p in tp.arc[rows, 0]], dtype=int).reshape(-1, 3)[:, :2]
        start = np.take_along_axis(tp.position[rows - 1], axes, axis=1)
        end = np.take_along_axis(tp.position[rows], axes, axis=1)
        angles = np.array([self.opening_angles[int(line)] for line in tp.line[rows]])
        radius = arc_angle.signed_radius(start, end, angles)
        same = np.linalg.norm(end - start, axis=1) <= 1e-9
        if same.any():
            raise self._at_opening_angle(int(tp.line[rows[same][0]]), "AR= arc whose end point is its start: the opening angle gives no circle")
        known = ~np.isnan(radius) & (tp.frame[rows] == tp.frame[rows - 1]) & tp.resolved[rows - 1]
        values, resolved = tp.values.copy(), tp.resolved.copy()
        values[rows, R_] = radius
        resolved[rows[~known]] = False
        return replace(tp, values=values, resolved=resolved)

    def _assign(self, item, start: int) -> tuple:
        """R1=10 R2=R1*2: the 840D runs a block's assignments left to right (Fundamentals,
        "Arithmetic parameters"), each seeing the one before (LinuxCNC sets them after the line)."""
        key, value = super()._assign(item, start)
        if value is None:
            self.params.pop(key, None)
        elif key is not None:
            self.params[key] = value
        return key, value

    def _apply_gcodes(self, gcodes: list[float], state: dict, values, start: int) -> tuple[bool, bool]:
        """The frame instructions (internal G codes from translate.py) here, the rest as G-code."""
        for gc in gcodes:
            if gc in (17.0, 18.0, 19.0):
                self.plane = gc
            elif gc in (70.0, 700.0, 71.0, 710.0):
                self.to_mm = 25.4 if gc in (70.0, 700.0) else 1.0
            elif gc in _SETTABLE:
                state["wcs"] = float(_SETTABLE[gc])
            elif gc == translate.VECTOR_CODE:
                # A3= B3= C3= under TRAORI (ORIWKS: in the workpiece frame, turned by the frames): the G-code
                # reader's tool-axis vectors (G43.5 I J K), modal, an arc's I J K staying its centre
                state["tlo"] = 43.5
        if translate.CIP_CODE in gcodes:
            # I1 J1 K1 (read into I J K): the intermediate point, taken out before the reader sees arc centre words
            ijk = [_AX["I"], _AX["J"], _AX["K"]]
            self.cip_points.append((self.lines.line(start), values[ijk] * self.to_mm))
            values[ijk] = np.nan
            gcodes = [gc for gc in gcodes if gc != translate.CIP_CODE]
        if translate.ARC_ANGLE_CODE in gcodes:
            try:
                self.opening_angles[self.lines.line(start)] = arc_angle.opening_angle(self._file_line(start))
            except arc_angle.NotRead as exc:
                raise self._at_opening_angle(self.lines.line(start), str(exc)) from None
            gcodes = [gc for gc in gcodes if gc != translate.ARC_ANGLE_CODE]
        if translate.SWIVEL_CODE in gcodes:
            self._swivel(start)
            return True, False
        mine = [gc for gc in gcodes if gc in _FRAME_CODES]
        if not mine:
            return super()._apply_gcodes([gc for gc in gcodes if gc not in _SETTABLE and gc != translate.VECTOR_CODE], state, values, start)
        if len(mine) > 1 or len(gcodes) > 1:
            raise self._error_at(start, "a frame instruction (TRANS, ROT, ...) takes a block of its own (840D Fundamentals, \"Frames\")")
        xyz, rpl = values[[_AX["X"], _AX["Y"], _AX["Z"]]], values[_AX["R"]]
        if np.isinf(xyz).any() or np.isinf(rpl):
            self.notes.append(f"line {self.lines.line(start)}: {translate.FRAME_NAMES[mine[0]]} value cannot be evaluated; later targets are flagged")
            self.frame = np.full((4, 4), np.nan)
            self.tilts.append((self._when(start), "unknown"))
            return True, False
        if np.isnan(self.frame).any() and translate.FRAME_NAMES[mine[0]] not in frames.ABSOLUTE:
            self.tilts.append((self._when(start), "unknown"))  # added to a frame that is not known: not known either
            return True, False
        try:
            self.frame = frames.step(self.frame, translate.FRAME_NAMES[mine[0]], xyz, rpl, self.plane, self.to_mm)
        except frames.FrameRefused as exc:
            raise self._error_at(start, str(exc)) from None
        self._frame_event(start)
        return True, False

    def _frame_event(self, start: int) -> None:
        """Later targets' frame: settable @ swivel @ programmable (Fundamentals, "Frame chain")."""
        chain = self.swivel @ self.frame
        if np.isnan(chain).any():
            self.tilts.append((self._when(start), "unknown"))
            return
        identity = np.allclose(chain, np.eye(4), atol=0.0, rtol=0.0)
        self.tilts.append((self._when(start), None if identity else chain))

    def _at_opening_angle(self, line: int, message: str) -> ParseError:
        return self._at_word(line, "AR", message)

    def _at_word(self, line: int, word: str, message: str) -> ParseError:
        """A ParseError at the first ``word`` of a line of the file (its start where there is none)."""
        text = self.original.text.split("\n")[line - 1]
        column = text.upper().find(word) + 1 if word else 1
        return ParseError(self.original.path, line, max(column, 1), message, text.rstrip("\r"))

    def _file_line(self, start: int) -> str:
        """The file's own line holding offset ``start`` of the rewritten text."""
        at = int(self.offsets([start])[0])
        text = self.original.text
        end = text.find("\n", at)
        return text[text.rfind("\n", 0, at) + 1 : len(text) if end < 0 else end]

    def _swivel(self, start: int) -> None:
        """CYCLE800: the swivel frame from the call's parameters (``swivel.py``), read from the
        file's own line; one that cannot be worked out flags the targets after it, with the reason."""
        line = self._file_line(start)
        moves = swivel.moves_not_in_program(line)
        if moves:
            self.notes.append(f"line {self.lines.line(start)}: {moves}")
        try:
            self.swivel = swivel.swivel_frame(self.swivel, line, self.to_mm)
        except swivel.Unknown as exc:
            self.notes.append(f"line {self.lines.line(start)}: {exc}; later targets are flagged")
            self.swivel = np.full((4, 4), np.nan)
        self._frame_event(start)

    def _resolve(self, t: dict) -> Toolpath:
        """The G-code reader's modal resolution, after refusing an axis block that comes
        before any G0/G1/G2/G3: the 840D then moves in the group-1 reset mode, which is
        machine data (MD 20150 $MC_GCODE_RESET_VALUES), not in the program."""
        motion_known = np.maximum.accumulate(np.where(~np.isnan(t["motion"]), np.arange(len(t["motion"])), -1)) >= 0
        has_axis = ~np.isnan(t["values"][:, :6]).all(axis=1) & ~t["nonmotion"]
        bad = has_axis & ~motion_known
        if bad.any():
            raise self._error_at(int(t["offset"][np.argmax(bad)]), "axis words before any G0 / G1 / G2 / G3: the motion mode at the "
                                 "program start is the controller's reset value (machine data 20150), not in the program")
        return super()._resolve(t)

    def _resolve_blocks(self, t: dict) -> Toolpath:
        """Programs the G-code interpreter runs block by block (cutter compensation, cycles):
        its work-offset tables know G54-G57 only, so G500 / G505.. there are refused."""
        settable = t["wcs"] >= _SETTABLE_BASE
        if settable.any():
            raise self._error_at(int(t["offset"][np.argmax(settable)]), "G500 / G505..G599 in a program with cutter radius compensation "
                                 "(G41/G42) or a cycle are not read yet: use G54..G57")
        return super()._resolve_blocks(t)

    def _work_offsets(self, t: dict, rows: np.ndarray, wcs: np.ndarray) -> np.ndarray:
        """G54-G57 as the G-code reader names them; G500, G505.. by their own names, unknown
        (the program cannot set them: no G10 in Sinumerik)."""
        siemens = wcs[rows] >= _SETTABLE_BASE
        frame_idx = np.zeros(len(rows), np.int32)
        frame_idx[~siemens] = super()._work_offsets(t, rows[~siemens], wcs)
        names = []
        for w in np.unique(wcs[rows][siemens]):
            names.append(f"G{500 + w - _SETTABLE_BASE}")
            frame_idx[wcs[rows] == w] = self.builder.frame_index(names[-1], None)
        if names:
            self.notes.append(f"settable frame(s) {', '.join(names)} are the controller's (not in the program): positions are relative to them")
        return frame_idx

    def _back_to_file(self, tp: Toolpath) -> Toolpath:
        """Offsets of the rewritten main text -> the file's; the file itself as source 0."""
        sources = (self.original,) + tuple(tp.sources[1:])
        if not len(tp) or not len(self.offsets.new_start):
            return replace(tp, sources=sources)
        fields = {}
        for name in ("spans", "offset_span"):
            arr = getattr(tp, name)
            if arr is None:
                continue
            arr = arr.copy()
            main = (arr[..., 0] == 0) & (arr[..., 1] >= 0)
            arr[..., 1] = np.where(main, self.offsets(arr[..., 1]), arr[..., 1])
            arr[..., 2] = np.where(main, self.offsets(arr[..., 2] - 1) + 1, arr[..., 2])  # an end is one past a character
            fields[name] = arr
        if tp.insert_at is not None:
            ins = tp.insert_at.copy()
            main = (ins[:, 0] == 0) & (ins[:, 1] >= 0)
            ins[:, 1] = np.where(main, self.offsets(ins[:, 1]), ins[:, 1])
            fields["insert_at"] = ins
        return replace(tp, sources=sources, **fields)
