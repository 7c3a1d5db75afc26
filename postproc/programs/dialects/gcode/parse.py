"""G-code (ISO / Fanuc / LinuxCNC; Siemens TRAORI) -> Toolpath.

Every line is one block. Plain motion blocks (``N.. G0-3 X.. Y.. Z.. A.. F..`` with an
optional comment) are recognised by one regular expression over the whole text and read
by the vectorised scanner; all other blocks are parsed by ``gcode.lark``, with #
parameters evaluated in program order (a value that cannot be evaluated is flagged, never
guessed). Modal state — motion mode, units, absolute/incremental, work offset, tool
length — is then resolved over the whole block table at once: forward fills and
cumulative sums, no per-target Python loop. Programs whose end points depend on the
running state (canned cycles, G92, G10 L20 / R, G53, polar @ ^, G33.1, G41/G42 cutter
radius compensation) are run block by block by interp.py instead, as LinuxCNC's interpreter
runs them.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np
from lark import Token, Tree

from postproc.robot.frames import axis_to_quat_wxyz, make_transform, rot_x, rot_z

from ...ir import F_ARC, NF, Kind, SourceDoc, Toolpath
from ...parse import scan_kernel
from ...parse.common import Builder, LineIndex, _ranges, parse_statement, scan_numbers
from ...parse.grammar import grammar
from ...parse.line_shapes import LineShapes
from . import arcwords, flow, gwords, interp, siemens
from .blockwords import AXES
from .blockwords import Unknown as _Unknown
from .canned import PLANE_AXES
from .interp import needs_interpreter
from .offsets import Offsets

_AX = {c: i for i, c in enumerate(AXES)}
MORE = "LPQ@^D"  # repeats, dwell / G10 P, peck, polar, D (cutter compensation diameter; refused in a cycle): words only the grammar reads (no spans)
_MORE = {c: i for i, c in enumerate(MORE)}
NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)"
RE_BULK = re.compile(
    rf"^(?P<code>[ \t]*(?:[Nn][ \t]*\d+[ \t]*)?(?P<g>[Gg](?P<mode>\d+)(?![\d.])[ \t]*)?(?:[XYZABCIJKRFxyzabcijkrf][ \t]*{NUM}(?:[ \t]+(?=[XYZABCIJKRFxyzabcijkrf]))?)+)[ \t]*(?:\([^()\n]*\)[ \t]*|;[^\n]*)?\r?$",
    re.MULTILINE,
)
_LETTER_CODE = np.full(256, -1, dtype=np.int16)
for _c, _i in _AX.items():
    _LETTER_CODE[ord(_c)] = _i
    _LETTER_CODE[ord(_c.lower())] = _i
_BULK_MODES = {"0": 0.0, "1": 1.0, "2": 2.0, "3": 3.0, "00": 0.0, "01": 1.0, "02": 2.0, "03": 3.0}
_MOTION_KIND = {0: Kind.RAPID, 1: Kind.LINEAR, 2: Kind.ARC_CW, 3: Kind.ARC_CCW}
_MOTION_KIND_CODES = np.array([_MOTION_KIND[c] for c in range(4)], dtype=np.int8)
_NONMOTION = {4.0, 10.0, 28.0, 28.1, 30.0, 30.1, 52.0, 92.0, 92.1, 92.2, 92.3, 38.2, 38.3, 38.4, 38.5}
_WCS = {54.0: 1, 55.0: 2, 56.0: 3, 57.0: 4, 58.0: 5, 59.0: 6, 59.1: 7, 59.2: 8, 59.3: 9}
# Modal G codes that set one state column: G code -> (column, value).
# The modal-state columns of the block table: NaN where a block does not set them, then
# forward-filled (one list, so a new column reaches the bulk and the grammar tables alike).
_STATE_COLUMNS = ("motion", "units", "dist", "plane", "ijk", "wcs", "canned", "tlo", "h", "retract", "setup", "ccomp", "feedmode", "spindle", "turning", "toolchange")
_STATE_OF_G = {
    **{g: ("motion", g) for g in (0.0, 1.0, 2.0, 3.0)},
    80.0: ("canned", 0.0),
    **{g: ("units", g) for g in (20.0, 21.0)},
    **{g: ("dist", g) for g in (90.0, 91.0)},
    **{g: ("plane", g) for g in (17.0, 18.0, 19.0)},
    # G17.1 / G18.1 / G19.1: the U V W planes. Straight X Y Z moves run as ever; an arc or a
    # canned cycle there is refused (rs274 refuses the arc; its cycle moves U V W).
    **{g: ("plane", g) for g in (17.1, 18.1, 19.1)},
    **{g: ("ijk", g) for g in (90.1, 91.1)},  # arc centre words absolute / incremental
    **{g: ("wcs", float(w)) for g, w in _WCS.items()},
    **{g: ("tlo", g) for g in (43.0, 43.1, 43.2, 43.4, 43.5, 49.0)},
    # Cutter radius compensation (G41 / G42 tool table, G41.1 / G42.1 D diameter, G40 off):
    # run by interp.py with cutter_comp.py, the code itself kept.
    **{g: ("ccomp", g) for g in (40.0, 41.0, 41.1, 42.0, 42.1)},
    # Feed rate mode (LinuxCNC manual, "G93, G94, G95 Feed Rate Mode"): inverse time, units
    # per minute, units per spindle revolution.
    **{g: ("feedmode", g) for g in (93.0, 94.0, 95.0)},
}


_FUNCS = {"SIN": lambda v: math.sin(math.radians(v)), "COS": lambda v: math.cos(math.radians(v)), "TAN": lambda v: math.tan(math.radians(v)),
          "ASIN": lambda v: math.degrees(math.asin(v)), "ACOS": lambda v: math.degrees(math.acos(v)), "ABS": abs, "SQRT": math.sqrt,
          "EXP": math.exp, "LN": math.log, "ROUND": lambda v: float(round(v)), "FIX": lambda v: float(math.floor(v)), "FUP": lambda v: float(math.ceil(v))}
# Binary operators, built once (evaluated per executed block in loops and subs).
_BINOPS = {"+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b, "/": lambda a, b: a / b if b else math.inf,
           "MOD": lambda a, b: math.fmod(a, b) if b else math.nan, "EQ": lambda a, b: float(a == b), "NE": lambda a, b: float(a != b),
           "GT": lambda a, b: float(a > b), "GE": lambda a, b: float(a >= b), "LT": lambda a, b: float(a < b), "LE": lambda a, b: float(a <= b),
           "AND": lambda a, b: float(bool(a) and bool(b)), "OR": lambda a, b: float(bool(a) or bool(b)), "XOR": lambda a, b: float(bool(a) != bool(b))}


_UNMODELLED_AXES = frozenset("UVW")


class GcodeParser:
    tilt_word = "G68.2"  # names a tilted frame: "G54+G68.2@line12" (a dialect's own reader may say otherwise)

    def __init__(self, doc: SourceDoc):
        self.doc = doc
        self.text = doc.text
        self.lines = LineIndex(doc.text)
        self.builder = Builder("gcode", "none", [doc])
        self.params: dict = {}
        self.notes: list[str] = []
        self.g10: list[tuple[int, int, np.ndarray]] = []  # (offset, P number, X Y Z) of G10 L2/L20
        self.tilts: list[tuple[int, object]] = []  # (offset, G68.2 frame, None after G69, or "unknown")
        self.clock: int | None = None  # flow.py: execution index of the block being read (events are timed by it)
        self.event_offsets: dict[int, int] = {}  # flow.py: execution index of an event -> its offset in the text
        self.trees: dict | None = None  # flow.py: the parsed blocks, by offset
        # a SINUMERIK program (G70/G700 inch, G71/G710 metric, SUPA; its own G groups): known
        # before any block is read, flow or not (flow.py sets it again)
        self.siemens = siemens.is_siemens(doc.path, doc.text)

    def parse(self) -> Toolpath:
        text = self.text
        raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
        # RE_BULK accepts any G number (so that line shapes decide a match); only G0-G3
        # (G00-G03) blocks are bulk motion, the others go to the grammar.
        bulk = LineShapes(text, raw, self.lines.starts).match(RE_BULK)
        codes, modes = bulk.factorize("mode")
        plain = np.array([m is None or m in _BULK_MODES for m in modes], dtype=bool)
        bulk = bulk.subset(plain[codes])
        motion = np.array([_BULK_MODES.get(m, np.nan) if m is not None else np.nan for m in modes])[codes[plain[codes]]]
        bulk_starts = bulk.start
        # ---- bulk blocks, vectorised
        nb = len(bulk)
        if nb:
            code_end = bulk.span("code")[1]
            numbers = scan_numbers(text, letter_prefix=True)
            lo = np.searchsorted(numbers.start, bulk_starts)
            hi = np.searchsorted(numbers.start, code_end)
            counts = hi - lo
            idx = _ranges(lo, hi)
            row = np.repeat(np.arange(nb), counts)
            starts = numbers.start[idx]
            letter = raw[scan_kernel.prev_nonblank(raw, starts - 1)]
            code = _LETTER_CODE[letter]
            values = np.full((nb, len(AXES)), np.nan)
            spans = np.full((nb, len(AXES), 2), -1, dtype=np.int64)
            keep = code >= 0
            # One flat index (block, axis) per word, one scatter per array: a word written
            # twice in a block keeps its last number, as element-wise fancy assignment does.
            at, num = row[keep] * len(AXES) + code[keep], idx[keep]
            values.reshape(-1)[at] = numbers.value[num]
            spans.reshape(-1, 2)[at] = np.stack([starts[keep], numbers.end[num]], axis=1)
            nan = np.full(nb, np.nan)
            block = dict(offset=bulk_starts, code_end=code_end, values=values, spans=spans, nonmotion=np.zeros(nb, bool), ok=np.ones(nb, bool),
                         g53=np.zeros(nb, bool), **{k: nan for k in _STATE_COLUMNS})
            block["motion"] = motion
        else:
            block = None
        # ---- slow blocks, in order (parameters are evaluated in program order)
        skip = np.zeros(len(self.lines.starts), bool)
        skip[bulk.line] = True
        if flow.needs_flow_in(text, self.lines.starts[~skip]):  # O-words, M98, Siemens statements are never bulk lines
            return self._parse_flow()
        slow = self._slow(skip)
        tables = [t for t in (block, slow) if t is not None and len(t["offset"])]
        if not tables:
            return self.builder.build()
        if len(tables) == 1:  # a CAM program's blocks all read in bulk (or none): already one table
            table = {k: v for k, v in tables[0].items() if k != "more"}
        else:
            table = {k: np.concatenate([t[k] for t in tables]) for k in tables[0] if k != "more"}
        offset = table["offset"]
        if (offset[1:] >= offset[:-1]).all():
            order = np.arange(len(offset))  # in program order already: the stable sort would not move a block
        else:
            order = np.argsort(offset, kind="stable")
            table = {k: v[order] for k, v in table.items()}
        table["more"] = _more_words(order, len(table["offset"]) - len(slow["offset"]), slow["more"])
        return self._resolve(table)

    def _parse_flow(self) -> Toolpath:
        """Programs with O-word control flow or M98: blocks read in execution order (flow.py)."""
        runner = flow.Runner(self)
        table = self._slow(None, runner.run())
        if not len(table["offset"]):
            return runner.finish(self.builder.build())
        table["seq"] = np.arange(len(table["offset"]))
        if runner.tainted_from is not None:
            table["ok"][runner.tainted_from :] = False
        return runner.finish(self._resolve(table))

    def _when(self, start: int) -> int:
        """Time of an event (G10, G68.2) in the block table's order: its offset, or its execution index."""
        if self.clock is None:
            return start
        self.event_offsets[self.clock] = start
        return self.clock

    # ------------------------------------------------------------- slow path
    def _slow(self, skip: np.ndarray | None, starts=None) -> dict:
        g = grammar("gcode")
        out: dict[str, list] = {k: [] for k in ("offset", "code_end", "values", "spans", "nonmotion", "ok", "g53", "more") + _STATE_COLUMNS}
        stack: list[tuple[str, int]] = []
        text = self.text
        for start in self.lines.starts[~skip].tolist() if starts is None else starts:
            end = text.find("\n", start)
            end = len(text) if end < 0 else end
            line = text[start:end].rstrip("\r")
            stripped = line.strip()
            if not stripped or stripped == "%":
                continue
            tree = self.trees.get(start) if self.trees else None
            tree = tree or parse_statement(g, line, self.lines, self.doc.path, start, "G-code block")
            self._block(tree, start, out, stack)
            out["code_end"].append(start + len(_code_part(line)))
        if stack:
            want, where = stack[-1]
            raise self.lines.error(self.doc.path, where, f"O-word block opened here is never closed (missing {want})")
        n = len(out["offset"])
        return {
            "offset": np.array(out["offset"], dtype=np.int64),
            "code_end": np.array(out["code_end"], dtype=np.int64),
            "values": np.array(out["values"]).reshape(n, len(AXES)),
            "spans": np.array(out["spans"], dtype=np.int64).reshape(n, len(AXES), 2),
            "more": np.array(out["more"], dtype=float).reshape(n, len(MORE)),
            **{k: np.array(out[k], dtype=float) for k in _STATE_COLUMNS},
            "nonmotion": np.array(out["nonmotion"], dtype=bool),
            "ok": np.array(out["ok"], dtype=bool),
            "g53": np.array(out["g53"], dtype=bool),
        }

    def _eval(self, node) -> float:
        if isinstance(node, Token):
            if node.type == "GNUMBER":
                return float(node)
            raise _Unknown(str(node))
        kind = node.data
        if kind == "number":
            return float(node.children[0])
        if kind == "neg":
            return -self._eval(node.children[-1])
        if kind == "pos":
            return self._eval(node.children[-1])
        if kind == "param":
            key = self._param_key(node)
            if key not in self.params:
                raise _Unknown(f"#{key}")
            return self.params[key]
        if kind == "func":
            name, arg = str(node.children[0]).upper(), self._eval(node.children[1])
            return _FUNCS[name](arg)
        if kind == "atan2":
            return math.degrees(math.atan2(self._eval(node.children[1]), self._eval(node.children[2])))
        if kind in ("sum_expr", "prod_expr", "or_expr", "and_expr", "cmp_expr", "pow_expr"):
            ch = node.children
            acc = self._eval(ch[0])
            for op, rhs in zip(ch[1::2], ch[2::2]):
                b = self._eval(rhs)
                acc = _BINOPS[str(op).upper()](acc, b)
            if kind == "pow_expr" and len(ch) == 2:
                acc = self._eval(ch[0]) ** self._eval(ch[1])
            return acc
        if len(node.children) == 1:
            return self._eval(node.children[0])
        raise _Unknown(kind)

    def _param_key(self, node: Tree):
        ref = node.children[0]
        if isinstance(ref, Token) and ref.type == "GNUMBER":
            return int(float(ref))
        if isinstance(ref, Token):
            return str(ref).lower()
        return int(self._eval(ref))

    def _block(self, tree: Tree, start: int, out, stack) -> None:
        """One block read by the grammar: its words into the block table ``out``."""
        values = np.full(len(AXES), np.nan)
        spans = np.full((len(AXES), 2), -1, dtype=np.int64)
        more = np.full(len(MORE), np.nan)
        state = {k: np.nan for k in _STATE_COLUMNS}
        ok = True
        gcodes: list[float] = []
        assigns: list[tuple] = []
        for item in tree.children:
            if not isinstance(item, Tree):
                continue
            if item.data == "assign":
                assigns.append(self._assign(item, start))
            elif item.data == "oword":
                self._oword(item, start, stack)
            elif item.data == "keyword" and self.siemens and str(item.children[0]).upper() == "SUPA":
                gcodes.append(53.0)  # SUPA: this block in machine coordinates, as G53
            elif item.data == "keyword":
                self.notes.append(f"line {self.lines.line(start)}: {item.children[0]} (Siemens transformation) — positions are taken as programmed")
            elif item.data == "word":
                ok &= self._word(item, start, values, spans, state, gcodes, more)
        if not self.siemens:
            self._check_e_words(tree, start, gcodes)
        for key, value in assigns:  # LinuxCNC: a line's parameter settings take effect after the whole line is read
            if value is None:
                self.params.pop(key, None)  # unknown from here on, never the old value
            elif key is not None:
                self.params[key] = value
        nonmotion, g53 = self._apply_gcodes(gcodes, state, values, start)
        out["offset"].append(start)
        out["values"].append(values)
        out["more"].append(more)
        out["spans"].append(spans)
        for k, v in state.items():
            out[k].append(v)
        out["nonmotion"].append(nonmotion)
        out["ok"].append(ok)
        out["g53"].append(g53)

    def _assign(self, item: Tree, start: int) -> tuple:
        """#n = expression: (key, value) evaluated now (program order); value None where it
        cannot be (the parameter is then unknown); key None where the target is unknown."""
        try:
            key = self._param_key(item.children[0])
        except (_Unknown, ValueError, ZeroDivisionError) as exc:
            self.notes.append(f"line {self.lines.line(start)}: the parameter number cannot be evaluated ({exc})")
            return None, 0.0
        try:
            return key, self._eval(item.children[1])
        except (_Unknown, ValueError, ZeroDivisionError) as exc:
            self.notes.append(f"line {self.lines.line(start)}: parameter value cannot be evaluated ({exc})")
            return key, None

    def _oword(self, item: Tree, start: int, stack) -> None:
        """O-word blocks (sub, if, while, do, repeat) must close in order."""
        if len(item.children) < 2:
            return  # a program number (Fanuc O1000)
        kw = str(item.children[1]).lower()
        label = re.sub(r"\s+", "", str(item.children[0]).lower())
        opens = {"sub": "endsub", "if": "endif", "while": "endwhile", "do": "while", "repeat": "endrepeat"}
        if kw in opens:
            stack.append((f"{label} {opens[kw]}", start))
        elif kw in ("endsub", "endif", "endwhile", "endrepeat") or (kw == "while" and stack and stack[-1][0] == f"{label} while"):
            if not stack or stack[-1][0] != f"{label} {kw}":
                raise self.lines.error(self.doc.path, start, f"{label} {kw} does not close the open O-word block ({stack[-1][0] if stack else 'none open'})")
            stack.pop()

    def _word(self, item: Tree, start: int, values, spans, state, gcodes, more) -> bool:
        """One letter word into the block's values / state; False where its value is unknown."""
        letter = str(item.children[0]).upper()
        vnode = item.children[1]
        why = None if self.siemens else gwords.letter_refusal(letter)
        if why is not None:
            raise self.lines.error(self.doc.path, self._word_offset(item, start), why)
        if letter in _UNMODELLED_AXES and not self.siemens:
            # A U V W axis moves the machine, but the IR has no place for it: refuse, never drop.
            raise self.lines.error(self.doc.path, self._word_offset(item, start),
                                   f"axis word {letter}: the {letter} axis moves the machine but postproc models only X Y Z A B C")
        known = True
        try:
            value = self._eval(vnode)
        except (_Unknown, ValueError, ZeroDivisionError) as exc:
            # +inf: an axis, -inf: a feed, unknown until the next absolute word (never the old value)
            value, known = (np.inf if letter in "XYZABC" else -np.inf if letter == "F" else np.nan), False
            self.notes.append(f"line {self.lines.line(start)}: {letter} value cannot be evaluated ({exc}); the target is flagged")
        if letter == "G":
            why = None if self.siemens or not known else gwords.refusal(round(value, 1))
            if why is not None:
                raise self.lines.error(self.doc.path, self._word_offset(item, start), why)
            gcodes.append(round(value, 1))
        elif letter == "M" and known and not self.siemens and (why := gwords.m_refusal(value)) is not None:
            raise self.lines.error(self.doc.path, self._word_offset(item, start), why)
        elif letter == "M" and known and not self.siemens and (why := gwords.m_note(value)) is not None:
            self.notes.append(f"line {self.lines.line(start)}: {why}")
        elif letter == "H":
            state["h"] = value
        elif letter == "S":
            state["spindle"] = value if known else -np.inf  # unknown from here on, never the old S
        elif letter == "M" and value in (3.0, 4.0, 5.0):
            state["turning"] = value  # spindle clockwise / counterclockwise / stopped: G74 G84 G86 G87 G88 need it turning
        elif letter == "M" and value == 6.0:
            state["toolchange"] = value  # M6: refused under G41 / G42 (interp.py)
        elif letter in _MORE:
            more[_MORE[letter]] = value
        elif letter in _AX:
            values[_AX[letter]] = value
            if isinstance(vnode, Tree) and vnode.data in ("number", "neg", "pos") and _plain_number(vnode):
                tok_start, tok_end = _token_span(vnode)
                spans[_AX[letter]] = (start + tok_start, start + tok_end)
        return known

    def _check_e_words(self, tree: Tree, start: int, gcodes: list[float]) -> None:
        """rs274 takes an E word only with G70, G76, M66, M67 or M68 in the same block."""
        words = [item for item in tree.children if isinstance(item, Tree) and item.data == "word"]
        e_words = [item for item in words if str(item.children[0]).upper() == "E"]
        if not e_words or any(gc in gwords.E_USERS_G for gc in gcodes):
            return
        for item in words:
            if str(item.children[0]).upper() == "M" and getattr(item.children[1], "data", None) == "number" and float(item.children[1].children[0]) in gwords.E_USERS_M:
                return
        raise self.lines.error(self.doc.path, self._word_offset(e_words[0], start), gwords.E_REFUSAL)

    @staticmethod
    def _word_offset(item: Tree, start: int) -> int:
        """Offset of a word in the file (``start``: its block's)."""
        return start + item.meta.start_pos if hasattr(item, "meta") and not item.meta.empty else start

    def _apply_gcodes(self, gcodes: list[float], state: dict, values, start: int) -> tuple[bool, bool]:
        """The block's G codes into its modal state; returns (no motion in this block, G53)."""
        nonmotion = g53 = False
        for gc in gcodes:
            if self.siemens and gc in (70.0, 700.0, 71.0, 710.0):
                state["units"] = 20.0 if gc in (70.0, 700.0) else 21.0  # SINUMERIK inch / metric
            elif gc in _STATE_OF_G:
                key, value = _STATE_OF_G[gc]
                state[key] = value
                nonmotion |= gc in (43.1, 43.2)  # their X Y Z words are tool length offsets, not a move
            elif gc in (33.0, 33.1):  # spindle-synchronized feed (motion group 1); G33.1 rigid tap: back to its start (interp.py)
                state["motion"] = 1.0
                state["setup"] = gc
            elif 73.0 <= gc <= 89.0:
                state["canned"] = gc
            elif gc in (98.0, 99.0):
                state["retract"] = gc
            elif gc == 53.0:
                g53 = True
            elif gc == 68.2:
                nonmotion = True
                self._tilt(values, start)
            elif gc == 69.0:
                self.tilts.append((self._when(start), None))
            elif gc in (68.0, 68.3, 68.4):
                self.notes.append(f"line {self.lines.line(start)}: G{gc:g} coordinate rotation is not evaluated; later targets are flagged")
                self.tilts.append((self._when(start), "unknown"))
            elif gc in _NONMOTION:
                nonmotion = True
                state["setup"] = gc
                if gc == 10.0:
                    self._g10(values, start)
        return nonmotion, g53

    def _tilt(self, values, start) -> None:
        """G68.2 X Y Z I J K (P0: Euler ZXZ): a tilted working plane until G69."""
        line = self.text[start : self.text.find("\n", start) if self.text.find("\n", start) >= 0 else len(self.text)]
        p = re.search(r"[Pp][ \t]*(\d+)", line)
        if p and p.group(1) != "0":
            self.notes.append(f"line {self.lines.line(start)}: G68.2 P{p.group(1)} is not evaluated (only P0, Euler ZXZ); later targets are flagged")
            self.tilts.append((self._when(start), "unknown"))
            return
        v = np.nan_to_num(values)
        rot = rot_z(np.radians(v[_AX["I"]])) @ rot_x(np.radians(v[_AX["J"]])) @ rot_z(np.radians(v[_AX["K"]]))
        self.tilts.append((self._when(start), make_transform(rot, v[:3])))

    def _g10(self, values, start) -> None:
        """G10 L2/L20 Pn X Y Z: a work offset set in the program (recorded as an event)."""
        line = self.text[start : self.text.find("\n", start) if self.text.find("\n", start) >= 0 else len(self.text)]
        p = re.search(r"[Pp][ \t]*(\d+)", line)
        lcode = re.search(r"[Ll][ \t]*(\d+)", line)
        if p and lcode and lcode.group(1) in ("2", "20"):
            self.g10.append((self._when(start), int(p.group(1)), np.nan_to_num(values[:3])))

    # -------------------------------------------------------------- modal state
    def _resolve(self, t: dict) -> Toolpath:
        """The targets of the block table ``t`` (program order) with every modal state applied."""
        if needs_interpreter(t):
            return self._resolve_blocks(t)
        motion = _ffill(t["motion"], np.nan)
        units = _ffill(t["units"], 21.0)
        dist = _ffill(t["dist"], 90.0)
        canned = _ffill(t["canned"], 0.0)
        linear_scale = np.where(units == 20.0, 25.4, 1.0)
        values = t["values"]
        has_axis = ~np.isnan(values[:, :6]).all(axis=1)
        arc_motion = np.isin(motion, (2.0, 3.0))
        circle = arcwords.full_circles(t, arc_motion & ~has_axis & ~t["nonmotion"] & (canned == 0.0), self._error_at)
        moves = (has_axis | circle) & ~t["nonmotion"] & (canned == 0.0) & ~np.isnan(motion)
        absolute = _absolute_positions(values, moves | t["g53"], dist, linear_scale)
        absolute[np.isinf(absolute)] = np.nan  # axes that follow from a word the program cannot evaluate
        rows = np.nonzero(moves)[0]
        ir_values, ir_spans, scale = _ir_numbers(t, rows, absolute, linear_scale)
        speed = _ffill(values[:, _AX["F"]] * linear_scale, np.nan)[rows]
        unknown_feed = np.isneginf(speed) & (motion[rows] != 0.0)  # feed moves at an F the program cannot know (G0 has none)
        resolved = (t["ok"][rows] & ~np.isnan(absolute[rows, :3]).any(axis=1) & ~unknown_feed & ~self._under_cutter_comp(t, rows)
                    & ~self._tool_axis_unknown(t, rows, moves & (dist == 90.0) & ~t["g53"]))
        speed[np.isneginf(speed)] = np.nan
        frame_idx = self._work_offsets(t, rows, _ffill(t["wcs"], 1.0).astype(int))
        self._tilted_planes(t, rows, frame_idx, resolved)
        g53 = t["g53"][rows]
        if g53.any():
            frame_idx[g53] = self.builder.frame_index("machine", np.eye(4), True)
        tlo = _ffill(t["tlo"], 49.0)
        tool_idx = self._tool_lengths(t, rows, tlo)
        arc = arcwords.arc_words(t, rows, arc_motion[rows], _ffill(t["plane"], 17.0)[rows], _ffill(t["ijk"], 91.1)[rows],
                                 linear_scale[rows], ir_values, ir_spans, scale, self.text, self._error_at)
        # Under G43.5, I J K of a G2/G3 block are its centre: the tool axis stays (arcwords.carry_tool_axis).
        axis_rows = _tool_axes(t, rows, np.where(arc_motion, 49.0, tlo), ir_values, ir_spans)
        if axis_rows.any():
            self.builder.orientation_kind = "axis"
        self.builder.notes.extend(self.notes)
        offsets = t["offset"][rows]
        m = len(rows)
        self.builder.add_block(
            t["seq"][rows] if "seq" in t else offsets,  # flow.py: execution order
            kind=_MOTION_KIND_CODES[motion[rows].astype(int)],
            line=self.lines.line(offsets),
            values=ir_values,
            spans=ir_spans,
            scale=scale,
            relative=(dist[rows] == 91.0),
            frame=frame_idx,
            tool=tool_idx,
            resolved=resolved,
            speed=speed,
            # Missing axis words are inserted at the end of the block's code (before any comment).
            insert_at=np.stack([np.zeros(m, np.int64), t["code_end"][rows]], axis=1),
            **({"arc": arc} if arc is not None else {}),
            **self._feed_columns(t, rows, motion[rows]),
        )
        tp = _with_modal_positions(self.builder.build(), absolute[rows], ir_values, axis_rows)
        return arcwords.carry_tool_axis(tp, arc_motion[rows] & (tlo[rows] == 43.5))

    def _feed_columns(self, t: dict, rows: np.ndarray, motion: np.ndarray) -> dict:
        """The IR's feed_mode and spindle columns of the targets ``rows``. LinuxCNC manual,
        "G93, G94, G95 Feed Rate Mode": in G93 "an F word must appear on every line that has a
        G1, G2, or G3 motion", F is not modal; a feed move without its own F is refused as
        LinuxCNC refuses it (the F of a block before would be a wrong time), and so is a canned
        cycle in G93 (rs274: "Cannot feed with zero feed rate")."""
        mode = _ffill(t["feedmode"], 94.0)[rows]
        spindle = _ffill(t["spindle"], np.nan)[rows]
        spindle[np.isinf(spindle)] = np.nan
        g93 = mode == 93.0
        cycle = g93 & (_ffill(t["canned"], 0.0)[rows] != 0.0)
        missing = g93 & ~cycle & (motion != 0.0) & np.isnan(t["values"][rows, _AX["F"]])
        for bad, why in ((cycle, "a canned cycle in G93 inverse-time mode (LinuxCNC refuses it: its moves have no time of their own)"),
                         (missing, "feed move in G93 inverse-time mode without its own F word (F is not modal in G93)")):
            if bad.any():
                raise self._error_at(int(t["offset"][rows[np.argmax(bad)]]), why)
        return {"feed_mode": mode.astype(np.int8), "spindle": spindle}

    def _under_cutter_comp(self, t: dict, rows: np.ndarray) -> np.ndarray:
        """(len(rows),) True where G41/G42 (or G41.1/G42.1) is active: the path the controller
        runs is offset from these targets by a radius the IR does not model (noted once)."""
        active = _ffill(t["ccomp"], 40.0)[rows] != 40.0
        if active.any():
            first = int(self.lines.line(t["offset"][rows[np.argmax(active)]]))
            self.builder.notes.append(f"line {first}: cutter radius compensation (G41/G42) is active: the controller offsets the path by the "
                                      f"tool radius, which is not modelled; {int(active.sum())} target(s) under it are flagged")
        return active

    def _error_at(self, offset: int, message: str):
        """A ParseError at a character offset of the program (file:line:column)."""
        return self.lines.error(self.doc.path, int(offset), message)

    def _resolve_blocks(self, t: dict) -> Toolpath:
        """The targets of a program read block by block (interp.py: canned cycles, G92,
        G10 L20 / R, G53, polar words). Targets the controller makes without axis words
        for them (cycle moves, polar ends) have no span and nowhere to insert one."""
        scale = np.where(_ffill(t["units"], 21.0) == 20.0, 25.4, 1.0)
        dist = _ffill(t["dist"], 90.0)
        mode, sets_mode = interp.modal_mode(t["motion"], t["canned"])
        plane = _ffill(t["plane"], 17.0)
        modal = {"scale": scale.tolist(), "dist": dist.tolist(), "plane": plane.tolist(), "wcs": _ffill(t["wcs"], 1.0).astype(int).tolist(),
                 "retract": _ffill(t["retract"], 99.0).tolist(), "motion": _ffill(t["motion"], np.nan).tolist(), "mode": mode.tolist(), "sets_mode": sets_mode.tolist(),
                 "circle": self._block_circles(t, mode).tolist(), "ijk": _ffill(t["ijk"], 91.1).tolist(),
                 "turning": _ffill(t["turning"], 5.0).tolist()}
        try:
            moves = interp.run(t, AXES + MORE, modal, self.lines.line(t["offset"]))
        except interp.BlockError as exc:
            raise self.lines.error(self.doc.path, int(t["offset"][exc.row]), str(exc)) from None
        rows, own = moves.row, ~moves.generated
        m = len(rows)
        ir_values, ir_spans, ir_scale = np.full((m, NF), np.nan), np.full((m, NF, 3), -1, dtype=np.int64), np.ones((m, NF))
        point = np.hstack([moves.position, moves.abc])
        written = np.hstack([moves.programmed, moves.abc])  # the text's numbers: under G41/G42 the path (position) is offset from them
        for k, f in _IR_FIELD_OF_AXIS.items():
            word = own & ~np.isnan(t["values"][rows, k])
            ir_values[:, f] = np.where(word, written[:, k], np.nan)
            _put_spans(ir_spans, np.nonzero(own)[0], f, t["spans"][rows[own], k])
            if k < 3:
                ir_scale[:, f] = scale[rows]
        frame_idx, frame_ok = self._frames_of(moves.frame, moves.frames)
        plain_move = ~t["nonmotion"] & np.isin(mode, (0.0, 1.0, 2.0, 3.0)) & (dist == 90.0) & ~t["g53"]  # a cycle block never makes Z known again
        unknown_end = np.isin(t["setup"], interp.UNKNOWN_END_CODES)
        if unknown_end.any():
            self.notes.append(f"line {int(self.lines.line(t['offset'][np.argmax(unknown_end)]))}: G28/G30 end at the position stored on the "
                              "controller, G38.x where the probe touches: not known at post time; the axes they move are unknown (their "
                              "targets flagged) until the program gives them in G90 again")
        if not moves.exact.all():
            first = int(self.lines.line(t["offset"][rows[np.argmin(moves.exact)]]))
            self.notes.append(f"line {first}: an axis left out here keeps a value the controller re-read through a work offset the "
                              f"program does not set (a G53 move, a change of G54-G59.3, G10, G92/G52 there), or after a tool length change by a "
                              f"length it does not give; {int((~moves.exact).sum())} target(s) flagged")
        self.notes.extend(moves.notes)
        resolved = (t["ok"][rows] & ~np.isnan(moves.position).any(axis=1) & frame_ok & (moves.ccomp != 2) & moves.exact
                    & ~self._tool_axis_unknown(t, rows, plain_move | (t["setup"] == 92.0), interpreted=True))
        machine = moves.frame < 0
        self._tilted_planes(t, rows, frame_idx, resolved)
        frame_idx[machine] = self.builder.frame_index("machine", np.eye(4), True)
        tlo = _ffill(t["tlo"], 49.0)
        tool_idx = self._tool_lengths(t, rows, tlo, moves.latched)
        # G2/G3 targets: their I J K / R words, plane, IJK mode and turns, as the vectorised reader gives them (arcwords).
        arc_move = np.isin(moves.motion, (2, 3))
        arc = arcwords.arc_words(t, rows, arc_move, plane[rows], _ffill(t["ijk"], 91.1)[rows], scale[rows], ir_values, ir_spans, ir_scale,
                                 self.text, self._error_at)
        arc = _offset_arcs(arc, moves, plane[rows], ir_values, ir_spans)
        axis_rows = _tool_axes(t, rows, np.where(arc_move, 49.0, tlo[rows]), ir_values, ir_spans, per_row=True) & own
        if axis_rows.any():
            self.builder.orientation_kind = "axis"
        self.builder.notes.extend(self.notes)
        offsets = t["offset"][rows]
        insert_at = np.stack([np.where(own, 0, -1), np.where(own, t["code_end"][rows], -1)], axis=1)
        order = t["seq"][rows] if "seq" in t else offsets  # flow.py: execution order (a loop body's text runs several times)
        self.builder.add_block(order, kind=_MOTION_KIND_CODES[moves.motion], line=self.lines.line(offsets), values=ir_values, spans=ir_spans, scale=ir_scale,
                               relative=(dist[rows] == 91.0) & own, frame=frame_idx, tool=tool_idx, resolved=resolved,
                               speed=self._speeds_of(t, rows, scale), insert_at=insert_at,
                               **self._synced_feed_mode(t, rows, self._feed_columns(t, rows, moves.motion.astype(float))),
                               **({"arc": arc} if arc is not None else {}), **({"ccomp": moves.ccomp} if moves.ccomp.any() else {}),
                               **({"rotary_offset": moves.rotary} if (moves.rotary != 0).any() else {}))
        tp = _with_modal_positions(self.builder.build(), point, ir_values, axis_rows)
        return arcwords.carry_tool_axis(tp, arc_move & (tlo[rows] == 43.5))

    def _speeds_of(self, t: dict, rows: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """The speed column (mm/min as F is written) of targets read block by block; a G33 /
        G33.1 move (LinuxCNC manual, "G33 Spindle Synchronized Motion", "G33.1 Rigid Tapping")
        runs at K (distance per revolution) times the spindle speed S (NaN where S is not known)."""
        speed = _ffill(t["values"][:, _AX["F"]] * scale, np.nan)[rows]
        synced = np.isin(t["setup"][rows], (33.0, 33.1))
        if synced.any():
            spindle = _ffill(t["spindle"], np.nan)[rows]
            spindle[np.isinf(spindle)] = np.nan
            speed[synced] = (t["values"][rows, _AX["K"]] * scale[rows] * spindle)[synced]
        return speed

    @staticmethod
    def _synced_feed_mode(t: dict, rows: np.ndarray, columns: dict) -> dict:
        """G33 / G33.1 moves run at K x S whatever G93 / G94 / G95 is in force: their speed
        column is that in mm/min already (feed mode 94)."""
        synced = np.isin(t["setup"][rows], (33.0, 33.1))
        if synced.any():
            columns["feed_mode"] = np.where(synced, 94, columns["feed_mode"]).astype(np.int8)
        return columns

    def _block_circles(self, t: dict, mode: np.ndarray) -> np.ndarray:
        """(n,) G2/G3 blocks with centre words and no end-point word: full circles back to
        the start (as in the vectorised reader; a radius-format one is refused)."""
        present = ~np.isnan(t["values"][:, :6]).all(axis=1) | ~np.isnan(t["more"][:, 3:5]).all(axis=1)  # X Y Z A B C, polar @ ^
        return arcwords.full_circles(t, np.isin(mode, (2.0, 3.0)) & ~present & ~t["nonmotion"], self._error_at)

    def _frames_of(self, frame: np.ndarray, keys: list) -> tuple[np.ndarray, np.ndarray]:
        """Frame index of each target (``frame`` indexes the frame ``keys``, see interp.Offsets.key;
        -1 the machine frame), and False where the frame is not a number (an offset taken
        from a point that is not known)."""

        ids, finite = np.zeros(len(keys) + 1, np.int32), np.ones(len(keys) + 1, bool)
        for k, key in enumerate(keys):
            system, set_at, g92_at, known = key[0], key[3], key[5], key[6]
            name = f"G{_WCS_NAMES[system - 1]:g}" + (f"@line{set_at}" if set_at is not None else "") + (f"+G92@line{g92_at}" if g92_at is not None else "")
            transform = Offsets.transform(key)
            finite[k] = bool(np.isfinite(transform).all())
            ids[k] = self.builder.frame_index(name, transform if finite[k] else None, known and finite[k])
        ids[-1] = self.builder.frame_index("machine", np.eye(4), True)
        unknown = sorted({f"G{_WCS_NAMES[key[0] - 1]:g}" for key in keys if key[3] is None})
        if unknown:
            self.notes.append(f"work offset(s) {', '.join(unknown)} are not set in the program (no G10): positions are relative to them")
        touched = sorted({f"G{_WCS_NAMES[key[0] - 1]:g}@line{key[3]}" for key in keys if key[3] is not None and not key[6]})
        if touched:
            self.notes.append(f"work offset(s) {', '.join(touched)} are set by G10 from a point (L20) or on some axes only (L2) where the "
                              "machine position is not known from the program: their origins are not known")
        return ids[frame], finite[frame]

    def _work_offsets(self, t: dict, rows: np.ndarray, wcs: np.ndarray) -> np.ndarray:
        """Frame index of each target: its work offset as set by G10 in the program before it;
        one the program never sets is unknown (identity stands in, flagged)."""
        unknown = []
        g10 = sorted(self.g10, key=lambda event: event[0])
        frame_idx = np.zeros(len(rows), np.int32)
        for w in np.unique(wcs[rows]):
            sel = wcs[rows] == w
            events = [(o, off) for o, p, off in g10 if p == w]
            name = f"G{_WCS_NAMES[w - 1]:g}"
            if not events:
                frame_idx[sel] = self.builder.frame_index(name, None)
                unknown.append(name)
                continue
            at = np.searchsorted(np.array([o for o, _ in events]), t.get("seq", t["offset"])[rows][sel], side="right") - 1
            ids = np.array([self.builder.frame_index(f"{name}@{i}", make_transform(np.eye(3)[None], off[None])[0]) for i, (_, off) in enumerate(events)])
            frame_idx[sel] = np.where(at >= 0, ids[np.maximum(at, 0)], self.builder.frame_index(name, None))
        if unknown:
            self.notes.append(f"work offset(s) {', '.join(unknown)} are not set in the program (no G10): positions are relative to them")
        return frame_idx

    def _tilted_planes(self, t: dict, rows: np.ndarray, frame_idx: np.ndarray, resolved: np.ndarray) -> None:
        """G68.2 tilts each later target's frame (in place) until G69; a tilt that is not
        evaluated unresolves the targets under it."""
        if not self.tilts:
            return
        offs = np.array([o for o, _ in self.tilts])
        at = np.searchsorted(offs, t.get("seq", t["offset"])[rows], side="right") - 1
        for k in np.unique(at[at >= 0]):
            tilt = self.tilts[k][1]
            sel = at == k
            if tilt is None:
                continue
            if isinstance(tilt, str):
                resolved[sel] = False
                continue
            for f in np.unique(frame_idx[sel]):
                both = sel & (frame_idx == f)
                name = f"{self.builder.frame_names[f]}+{self.tilt_word}@line{self.lines.line(self.event_offsets.get(self.tilts[k][0], self.tilts[k][0]))}"
                frame_idx[both] = self.builder.frame_index(name, self.builder.frames[f] @ tilt, self.builder.frame_known[f])

    def _tool_lengths(self, t: dict, rows: np.ndarray, tlo: np.ndarray, latched: dict | None = None) -> np.ndarray:
        """Tool index of each target: the H number of the active G43 (its length is in the
        machine's tool table, not the program: an unknown tool), unless the program set that
        entry before the G43 block (G10 L1 / L10, ``latched``: G43 row -> length): then the tool
        "H1@line7 (length 100 set by G10)" (the G43's line), the tip that length along the tool's z, known. G43 without H
        takes the loaded tool's length (tool "G43"); G43.1 / G43.2 set or add lengths given in
        the block (tool "G43.1@lineN"): unknown tools too, never the flange."""
        hnum = _ffill(t["h"], np.nan)
        tool_idx = np.zeros(len(rows), np.int32)
        code = tlo[rows]
        dynamic = np.isin(code, (43.1, 43.2))
        by_h = (code != 49.0) & ~dynamic & ~np.isnan(hnum[rows])
        set_by = np.where(~np.isnan(t["tlo"]), np.arange(len(t["tlo"])), -1)  # the block whose G43 / G49 is in force
        np.maximum.accumulate(set_by, out=set_by)
        by_block = np.full(len(t["tlo"]) + 1, np.nan)  # the length each G43 H block latched; the last slot: none (set_by -1)
        if latched:
            by_block[list(latched)] = list(latched.values())
        lengths = by_block[set_by[rows]]
        from_program = by_h & (code == 43.0) & ~np.isnan(lengths)
        for b in np.unique(set_by[rows][from_program]):
            sel = from_program & (set_by[rows] == b)
            name = f"H{hnum[b]:g}@line{int(self.lines.line(t['offset'][b]))} (length {latched[int(b)]:.9g} set by G10)"
            tool_idx[sel] = self.builder.tool_index(name, make_transform(np.eye(3), np.array([0.0, 0.0, latched[int(b)]])), True)
        by_h &= ~from_program
        for h in np.unique(hnum[rows][by_h]):
            tool_idx[by_h & (hnum[rows] == h)] = self.builder.tool_index(f"H{h:g}", None)
        for c in np.unique(code[(code != 49.0) & ~dynamic & ~by_h & ~from_program]):
            tool_idx[(code == c) & ~by_h & ~from_program] = self.builder.tool_index(f"G{c:g}", None)
        if dynamic.any():  # the length each G43.1 / G43.2 block set (interp.ToolTable.g43), known where the program gives it
            set_at = np.where(np.isin(t["tlo"], (43.1, 43.2)), np.arange(len(t["tlo"])), -1)
            np.maximum.accumulate(set_at, out=set_at)
            for b in np.unique(set_at[rows][dynamic]):
                name, length = f"G{t['tlo'][b]:g}@line{self.lines.line(t['offset'][b])}", (latched or {}).get(int(b), np.nan)
                tool = None if np.isnan(length) else make_transform(np.eye(3), np.array([0.0, 0.0, length]))
                tool_idx[dynamic & (set_at[rows] == b)] = self.builder.tool_index(name + ("" if tool is None else f" (length {length:.9g})"), tool)
        if ((code != 49.0) & ~from_program).any():
            self.notes.append("tool lengths (G43 H, G43 without H, G43.1/G43.2) are in the machine's tool table or set in a block: "
                              "flange poses need them (--tool NAME=...); TCP positions do not")
        return tool_idx

    def _tool_axis_unknown(self, t: dict, rows: np.ndarray, resets: np.ndarray, interpreted: bool = False) -> np.ndarray:
        """(len(rows),) True for targets whose Z the controller moves by a tool length change
        the program does not give: after G43 / G43.1 / G43.2 / G49 changes the offset, the
        current point is re-read for the new tool (LinuxCNC: Z = the old Z - the change of
        length), so a target that leaves Z out before the next absolute Z word (``resets``:
        a G90 move with Z, G92 Z) is unknown; so is a G53 target under an offset (its words
        are for the spindle, not the tool tip). Noted with the first line. ``interpreted``: the
        targets were read block by block (interp.py), whose ToolTable re-reads the current
        point by the change as rs274 does (flagging it where the change is not known): only
        the G53 case is left here."""
        tlo, hnum = _ffill(t["tlo"], 49.0), _ffill(t["h"], np.nan)
        state = np.where(tlo == 49.0, -1.0, tlo * 1e6 + np.nan_to_num(hnum, nan=-1.0))
        change = (state != np.concatenate([[-1.0], state[:-1]])) | np.isin(t["tlo"], (43.1, 43.2))
        has_z = ~np.isnan(t["values"][:, _AX["Z"]])
        n = np.arange(len(tlo))
        last_change = np.maximum.accumulate(np.where(change, n, -1))
        last_reset = np.maximum.accumulate(np.where(resets & has_z, n, -1))
        stale = (last_change[rows] > last_reset[rows]) & (not interpreted) | (t["g53"][rows] & (state[rows] != -1.0))
        if stale.any():
            self.notes.append(f"line {int(self.lines.line(t['offset'][rows[np.argmax(stale)]]))}: Z left out after a tool length change (or a G53 move "
                              f"under one): the controller's tool-tip Z there depends on the length; {int(stale.sum())} target(s) flagged")
        return stale


_WCS_NAMES = [54, 55, 56, 57, 58, 59, 59.1, 59.2, 59.3]


def _offset_arcs(arc: np.ndarray | None, moves, plane: np.ndarray, ir_values: np.ndarray, ir_spans: np.ndarray) -> np.ndarray | None:
    """Arcs of the compensated path (G41/G42: the programmed arcs at the offset radius and the
    corner arcs the controller adds): their centre as absolute I J (G90.1 form) in the IR, so
    that postproc.programs.arcs reads the arc the machine cuts from the offset start; a corner arc has
    no words of its own (no spans). ``moves.centre`` is (first, second) of the move's plane
    (``plane``, G17 or G18). ``arc`` is changed in place."""
    at = np.nonzero(~np.isnan(moves.centre[:, 0]))[0]
    if not len(at):
        return arc
    if arc is None:
        arc = np.full((len(moves.row), 3), np.nan)
    arc[at, 0], arc[at, 1] = plane[at], 1.0
    arc[at, 2] = np.where(np.isnan(arc[at, 2]), 1.0, arc[at, 2])
    ir_values[at, F_ARC] = np.nan
    for p, (first, second, _) in PLANE_AXES.items():
        on = at[plane[at] == p]
        ir_values[on, F_ARC.start + first], ir_values[on, F_ARC.start + second] = moves.centre[on, 0], moves.centre[on, 1]
    generated = at[moves.generated[at]]
    ir_spans[generated, F_ARC] = -1
    return arc


def _more_words(order: np.ndarray, n_bulk: int, slow_more: np.ndarray) -> np.ndarray:
    """(n, len(MORE)) L P Q @ ^ D of every block in program order: only grammar blocks have
    them (a read-only NaN view where none has any, so that plain programs pay nothing)."""
    n = len(order)
    if not (~np.isnan(slow_more)).any():
        return np.broadcast_to(np.full(len(MORE), np.nan), (n, len(MORE)))
    more = np.full((n, len(MORE)), np.nan)
    rows = np.nonzero(order >= n_bulk)[0]
    more[rows] = slow_more[order[rows] - n_bulk]
    return more


def _ffill(col: np.ndarray, default: float) -> np.ndarray:
    """Modal value of each block: the last one set at or before it, else ``default``."""
    has = ~np.isnan(col)
    idx = np.where(has, np.arange(len(col)), -1)
    np.maximum.accumulate(idx, out=idx)
    return np.where(idx >= 0, col[np.maximum(idx, 0)], default)


def _absolute_positions(values: np.ndarray, counted: np.ndarray, dist: np.ndarray, linear_scale: np.ndarray) -> np.ndarray:
    """(n, 6) absolute X Y Z A B C of every block (mm, degrees): an absolute word resets
    the axis, an incremental one (G91) adds to it; only ``counted`` blocks move it."""
    n = len(values)
    absolute = np.full((n, 6), np.nan)
    for k in range(6):
        v = values[:, k] * (linear_scale if k < 3 else 1.0)
        has = ~np.isnan(v) & counted
        rel = has & (dist == 91.0)
        reset = has & (dist != 91.0)
        cum = np.cumsum(np.where(rel, v, 0.0))
        base = np.where(reset, v - cum, np.nan)
        known = np.where(reset, np.arange(n), -1)
        np.maximum.accumulate(known, out=known)
        absolute[:, k] = np.where(known >= 0, base[np.maximum(known, 0)], np.nan) + cum
    return absolute


_IR_FIELD_OF_AXIS = {0: 0, 1: 1, 2: 2, 3: 13, 4: 14, 5: 15}  # X Y Z -> x y z; A B C -> e1 e2 e3 (axes 0..5 in order: _ir_numbers)


def _ir_numbers(t: dict, rows: np.ndarray, absolute: np.ndarray, linear_scale: np.ndarray):
    """IR values (m, NF), spans (m, NF, 3) and scale (m, NF) of the axis words of the blocks ``rows``."""
    m = len(rows)
    fields = list(_IR_FIELD_OF_AXIS.values())  # of the axes 0..5, in order
    ir_values = np.full((m, NF), np.nan)
    ir_spans = np.full((m, NF, 3), -1, dtype=np.int64)
    scale = np.ones((m, NF))
    words = t["spans"][:, :6][rows]  # (m, 6, 2): all six axes at once, not one column at a time
    ir_values[:, fields] = np.where(~np.isnan(t["values"][:, :6][rows]), absolute[rows, :6], np.nan)
    have = words[..., :1] >= 0
    ir_spans[:, fields, :1] = np.where(have, 0, -1)
    ir_spans[:, fields, 1:] = np.where(have, words, -1)
    scale[:, fields[:3]] = linear_scale[rows][:, None]
    return ir_values, ir_spans, scale


def _put_spans(ir_spans: np.ndarray, at: np.ndarray, field: int, spans: np.ndarray) -> None:
    """Spans (start, end) of the one source, -1 where none, into IR field ``field`` of rows ``at``."""
    have = spans[:, 0] >= 0
    if not have.all():  # a CAM program writes most axes on every block: no copies then
        at, spans = at[have], spans[have]
    ir_spans[at, field, 0] = 0
    ir_spans[at, field, 1:] = spans


def _tool_axes(t: dict, rows: np.ndarray, tlo: np.ndarray, ir_values: np.ndarray, ir_spans: np.ndarray, per_row: bool = False) -> np.ndarray:
    """G43.5 (TCP with tool axis vectors): I J K are the tool axis, not an arc centre. Puts
    them in IR fields o1..o3 (in place); returns the targets that have one. ``tlo`` is per
    block, or per target of ``rows`` with ``per_row``."""
    ijk = [_AX["I"], _AX["J"], _AX["K"]]
    axis_rows = ((tlo if per_row else tlo[rows]) == 43.5) & ~np.isnan(t["values"][rows[:, None], ijk]).any(axis=1)
    axis_at = rows[axis_rows]  # only these blocks' words are read (not a copy of every block's)
    for f_ir, k in zip((3, 4, 5), ijk):
        ir_values[axis_rows, f_ir] = t["values"][axis_at, k]
        _put_spans(ir_spans, np.nonzero(axis_rows)[0], f_ir, t["spans"][axis_at, k])
    return axis_rows


def _with_modal_positions(tp: Toolpath, absolute: np.ndarray, ir_values: np.ndarray, axis_rows: np.ndarray) -> Toolpath:
    """Positions with modal axes (a block without X keeps the previous X), rotary axes as
    external axes, and tool-axis orientations."""
    m = len(absolute)
    ext = np.full((m, 6), np.nan)
    ext[:, :3] = absolute[:, 3:6]
    orientation = np.full((m, 4), np.nan)
    if axis_rows.any():
        orientation[axis_rows] = axis_to_quat_wxyz(ir_values[axis_rows, 3:6])
    return replace(tp, position=absolute[:, :3], ext=ext, orientation=orientation)


def _code_part(line: str) -> str:
    """A block without its trailing comment and whitespace."""
    cut = len(line)
    for ch in "(;":
        i = line.find(ch)
        if i >= 0:
            cut = min(cut, i)
    return line[:cut].rstrip(" \t\r")


def _plain_number(node) -> bool:
    if isinstance(node, Tree) and node.data in ("neg", "pos"):
        return _plain_number(node.children[-1])
    return isinstance(node, Tree) and node.data == "number"


def _token_span(node) -> tuple[int, int]:
    """Span of a literal word value, sign included."""
    if node.data in ("neg", "pos"):
        inner_start, inner_end = _token_span(node.children[-1])
        return node.meta.start_pos, inner_end
    tok = node.children[0]
    return tok.start_pos, tok.end_pos
