"""SINUMERIK blocks rewritten in the G-code reader's syntax, with a map back to the file.

The G-code reader (``..gcode``) already runs what Sinumerik shares with ISO G-code (G0-G3,
G17-G19, G54-G57, G90/G91, G70/G71, F, arcs) and the Sinumerik control flow (``..gcode.siemens``,
``..gcode.flow``: DEF, PROC, IF, WHILE, FOR, REPEAT, subprogram calls). What it cannot read is
rewritten here, block by block, into words it can read; every other character stays where it
was, so a plain ``X12.5`` keeps its number and the map (``OffsetMap``) takes each offset of the
rewritten text back to the file's.

Sources: SINUMERIK 840D sl "Fundamentals" programming manual (6FC5398-1BP40), sections
"Arithmetic parameters (R)", "Variable assignments and arithmetic" (``X=R1+2*SIN(30)``: an
address with an expression takes ``=``; SIN/COS/TAN in degrees), "Frames" (TRANS, ATRANS,
ROT, AROT, RPL, SCALE, ASCALE, MIRROR, AMIRROR: each in a block of its own), "Circular
interpolation" (``CR=`` radius, ``AR=`` opening angle, ``CIP`` with ``I1= J1= K1=``).

What is rewritten:
- ``R<n>`` (arithmetic parameter, global to the channel) -> ``#<1000+n>``: a global # parameter
  of the reader, out of reach of the Siemens names (``#`` is no Sinumerik character);
- ``<address>=<expression>`` -> ``<address>[<expression in LinuxCNC syntax>]``; a plain
  number after ``=`` is left as it is (the reader takes ``X=10`` with its span);
- ``CR=`` -> ``R=`` (the G-code reader's arc radius: the same rule, the short arc for a positive
  radius, the long one for a negative);
- a frame instruction's keyword -> an internal G code (``FRAME_CODES``) that ``parse.py``
  takes back; ``RPL=`` -> ``R=`` (the plane rotation's angle);
- ``A3= B3= C3=`` (tool orientation vector, ORIWKS) -> the reader's tool-axis words ``I J K``,
  the block marked with ``VECTOR_CODE``;
- words that set how the 840D moves, not where (SOFT, FFWON, ORIWKS, CYCLE832(...), ...) ->
  blanks of the same length.
What is refused with its position (``Refusal``, a ``ParseError`` once the reader has it):
``AR=``, ``CIP``, ``ORIMKS``, an arc's I J K with A3= in one block, jumps and labels, CASE,
splines, array elements, other addresses set in a motion block, and an R parameter used as
an address word. An expression the reader cannot evaluate (IC(), ATAN2, POT, DIV, TRUNC, system
variables) becomes a parameter that is never set: the target is flagged, never guessed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from lark.exceptions import LarkError

from ...parse.grammar import grammar
from ..gcode import siemens

# Frame instructions -> internal G codes (no Sinumerik or ISO G code uses 9990-9997).
FRAME_CODES = {"TRANS": 9990.0, "ATRANS": 9991.0, "ROT": 9992.0, "AROT": 9993.0, "SCALE": 9994.0, "ASCALE": 9995.0,
               "MIRROR": 9996.0, "AMIRROR": 9997.0}
FRAME_NAMES = {v: k for k, v in FRAME_CODES.items()}
SWIVEL_CODE = 9989.0  # marks a CYCLE800 call (swivel plane) for parse.py, which reads its parameters (swivel.py)
CIP_CODE = 9987.0  # marks a block with I1= J1= K1= (CIP's intermediate point) for parse.py (circle_through.py)
ARC_ANGLE_CODE = 9988.0  # marks a block with AR= (arc by its opening angle): parse.py reads the angle (arc_angle.py)
VECTOR_CODE = 9998.0  # marks a block with A3= B3= C3= (tool orientation vector) for parse.py
_VECTOR = {"A3": "I", "B3": "J", "C3": "K"}  # the reader's tool-axis words (G43.5 I J K)
R_BASE = 1000  # R<n> is the reader's #<R_BASE + n>

_FRAME_LINE = re.compile(r"^(?P<head>[ \t]*(?:/[ \t]*)?(?:[Nn]\d+[ \t]+)?)(?P<kw>AMIRROR|ASCALE|ATRANS|AROT|MIRROR|SCALE|TRANS|ROT)\b", re.IGNORECASE)
# A block that may need rewriting: an '=' (outside a comparison), an R parameter, a frame word,
# or a word refused below. Plain CAM blocks (G1 X.. Y..) never match and are not looked at.
# What may need rewriting: an '=' or a label's ':', an R parameter, a frame or refused word.
# Found with byte masks and str.find (a regular expression over 10^6 lines costs seconds):
# plain CAM blocks (N.. G1 X.. Y..) have none and are never looked at.
_KEYWORDS = ("CYCLE800", "TRANS", "ROT", "SCALE", "MIRROR", "CIP", "CASE", "SPLINE", "SOFT", "BRISK", "FFWO", "ORI", "STOPRE", "COMP", "CYCLE832")
_ALNUM = np.zeros(256, bool)
_ALNUM[[*range(48, 58), *range(65, 91), *range(97, 123), 95]] = True


def candidate_lines(text: str, raw: np.ndarray, line_starts: np.ndarray) -> np.ndarray:
    """Start offsets of the lines that may need rewriting."""
    hit = (raw == ord("=")) | (raw == ord(":"))
    if len(raw) > 1:
        r_param = ((raw[:-1] | 0x20) == ord("r")) & (raw[1:] >= 48) & (raw[1:] <= 57)  # R<digit> not inside a word
        r_param &= ~_ALNUM[np.r_[0, raw[:-2]]]
        hit[:-1] |= r_param
    found = [np.nonzero(hit)[0]]
    upper = text.upper()
    for word in _KEYWORDS:
        at = upper.find(word)
        while at >= 0:
            found.append(np.array([at]))
            at = upper.find(word, at + 1)
    positions = np.concatenate(found)
    return np.unique(line_starts[np.searchsorted(line_starts, positions, side="right") - 1])
_ITEM = re.compile(r"(?P<name>[A-Za-z_$][A-Za-z0-9_]*)[ \t]*=(?!=)")
_REFUSED: dict[str, str] = {}
_INTERMEDIATE = {"I1": "I", "J1": "J", "K1": "K"}  # CIP's intermediate point -> the reader's I J K (parse.py takes them back)
_CIP = re.compile(r"(?i)(?<![\w$])CIP(?!\w)")
# Statements refused with their reason (840D "Job Planning": program jumps, CASE, arrays;
# "Fundamentals": spline interpolation): the positions after them depend on what is not run.
_NOT_READ = re.compile(r"(?i)^[ \t]*(?:[Nn]\d+[ \t]+)?(?:[A-Za-z_]\w*:(?!=)[ \t]*)?(?:(?P<case>CASE\b)|(?P<spline>[ABC]SPLINE\b)"
                       r"|(?P<array>[A-Za-z_]\w*\[[^\]]*\][ \t]*=))")
_NOT_READ_WHY = {"case": "CASE ... OF ... GOTOF is a program jump, not followed yet",
                 "spline": "spline interpolation (ASPLINE / BSPLINE / CSPLINE) is not modelled: the path between the points is the controller's",
                 "array": "array elements and axis-indexed settings (NAME[...]=) are not read yet"}
# Addresses that do not move the tool (smoothing distances, spindle positioning): read past.
_IGNORED = {"ADIS", "ADISPOS", "SPOS", "SPOSA"}
# Words and cycles that set how the 840D moves, not where to (Fundamentals: "Acceleration
# behavior" SOFT / BRISK, "Feedforward control" FFWON / FFWOF, "Orientation reference" ORIWKS,
# the default, which is how vectors are read here; compressor COMPCAD / COMPCURV / COMPON / COMPOF
# and CYCLE832 are named by the controller's inexact_interpolation): read past. ORIMKS (vectors
# in machine coordinates) is refused.
_PASSIVE = re.compile(r"(?i)(?<![\w$])(?:SOFT|BRISK|FFWON|FFWOF|ORIWKS|STOPRE|COMPCAD|COMPCURV|COMPON|COMPOF|CYCLE832[ \t]*\([^)\n]*\))(?!\w)")
# A CYCLE800 call alone in its block: the call becomes the internal SWIVEL_CODE, blanks to its length.
_SWIVEL_LINE = re.compile(r"(?i)^[ \t]*(?:[Nn]\d+[ \t]+)?(?P<call>CYCLE800[ \t]*\([^)\n]*\))[ \t]*$")
_ORIMKS = re.compile(r"(?i)(?<![\w$])ORIMKS(?!\w)")
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)$")
_R_PARAM = re.compile(r"(?<![A-Za-z0-9_$#])R(\d+)(?![A-Za-z0-9_])", re.IGNORECASE)


class Refusal(Exception):
    """A construct not read, at an offset of the original text."""

    def __init__(self, offset: int, message: str):
        super().__init__(message)
        self.offset = offset
        self.message = message


@dataclass(frozen=True)
class OffsetMap:
    """Offsets of the rewritten text -> offsets of the file: each edit is an anchor (rewritten
    start, original start, rewritten end, original end); between anchors the texts agree."""

    new_start: np.ndarray
    old_start: np.ndarray
    new_end: np.ndarray
    old_end: np.ndarray

    def __call__(self, offsets):
        offsets = np.asarray(offsets, dtype=np.int64)
        out = offsets.copy()
        if not len(self.new_start):
            return out
        tail = offsets >= self.new_end[-1]  # after the last edit (most of a program): one shift
        out[tail] += self.old_end[-1] - self.new_end[-1]
        rest = (offsets >= self.new_start[0]) & ~tail  # before the first edit (and -1, no offset): unchanged
        if rest.any():
            o = offsets[rest]
            k = np.searchsorted(self.new_start, o, side="right") - 1
            inside = o < self.new_end[k]
            same_length = (self.new_end - self.new_start)[k] == (self.old_end - self.old_start)[k]
            # inside an edit of the same length (CR= -> R =) characters keep their places; else its start
            within = np.where(same_length, self.old_start[k] + o - self.new_start[k], self.old_start[k])
            out[rest] = np.where(inside, within, self.old_end[k] + (o - self.new_end[k]))
        return out


def expression(text: str) -> str:
    """A Sinumerik expression in the reader's syntax (R parameters as # parameters)."""
    return siemens.expression(_R_PARAM.sub(lambda m: f"#{R_BASE + int(m.group(1))}", text))


_WORD_OPS = {"DIV", "MOD", "AND", "OR", "XOR", "NOT", "B_AND", "B_OR", "B_XOR", "B_NOT"}


def _pieces(code: str) -> list[tuple[int, int]]:
    """(start, end) of the blank-separated pieces of a block (blanks inside brackets or quotes kept)."""
    items, depth, quote, start = [], 0, False, None
    for i, ch in enumerate(code):
        if ch == '"':
            quote = not quote
        if not quote:
            depth += (ch in "([") - (ch in ")]")
        if ch in " \t" and depth == 0 and not quote:
            if start is not None:
                items.append((start, i))
                start = None
        elif start is None:
            start = i
    if start is not None:
        items.append((start, len(code)))
    return items


def _split_items(code: str) -> list[tuple[int, int]]:
    """(start, end) of the items of a block: blank-separated pieces, joined again where a blank
    sits inside an assignment or expression (``X = 7 DIV 3``, ``R1 = R2 + 1``)."""
    items: list[list[int]] = []
    for a, b in _pieces(code):
        piece, prev = code[a:b], code[items[-1][0] : items[-1][1]] if items else ""
        joins = items and (prev[-1] in "=+-*/<>(," or piece[0] in "=+*/<>)" or piece.strip("+-*/<>=") == "" or piece.upper() in _WORD_OPS
                           or (prev.upper().split() or [""])[-1] in _WORD_OPS)
        if joins:
            items[-1][1] = b
        else:
            items.append([a, b])
    return [(a, b) for a, b in items]


def _rewrite_item(item: str, at: int, frame: bool) -> str:
    """One item of a block in the reader's syntax (``at``: its offset in the file, for refusals)."""
    m = _ITEM.match(item)
    r_word = re.fullmatch(r"(?i)R(\d+)", item)
    if r_word:
        raise Refusal(at, f"{item}: an R parameter is not an address word (write e.g. X={item})")
    if not m:
        return item
    name, value = m.group("name").upper(), item[m.end():]
    if name in _REFUSED:
        raise Refusal(at, _REFUSED[name])
    if name == "AR":  # the opening angle: line_edits blanks it and marks the block (ARC_ANGLE_CODE)
        return item
    r_param = re.fullmatch(r"R(\d+)", name)
    if r_param:
        return f"#{R_BASE + int(r_param.group(1))}={_value(value)}"
    if name in _INTERMEDIATE:
        name = _INTERMEDIATE[name].ljust(len(m.group("name")))  # "I1=40" -> "I =40": the number keeps its place
    elif name in _VECTOR:
        name = _VECTOR[name].ljust(len(m.group("name")))  # "A3=0" -> "I =0": the number keeps its place
    elif name == "CR" or (frame and name == "RPL"):
        name = "R".ljust(len(m.group("name")))  # same length: the number keeps its place (and span)
    elif name in _IGNORED:
        return " " * len(item)
    elif len(name) > 1 or name.startswith("_") or name.startswith("$"):
        raise Refusal(at, f"{m.group('name')}=: an address or variable set inside a motion block is not read "
                          "(an extra axis, a path setting, or a variable: set variables in a block of their own)")
    if _NUMBER.match(value.strip()):
        return f"{name}{item[len(m.group('name')):]}"
    if value.strip().startswith('"'):
        if name == "T":  # a tool chosen by name: its length is the controller's (D), positions are the tool tip's
            return " " * len(item)
        raise Refusal(at, f"{m.group('name')}= takes a text value here, which is not read")
    return f"{name.strip()}{_value(value)}"


def _value(text: str) -> str:
    """The reader's form of an address value: the expression, or a parameter that is never set
    (the target is then flagged, its note naming the expression) where it cannot be read
    (IC(), ATAN2, POT, DIV, system variables' functions)."""
    try:
        out = expression(text)
        grammar("gcode").parse(f"o1 if {out}")  # a function the reader lacks (ATAN2, POT, TRUNC) fails here
        return out
    except (ValueError, LarkError):
        shown = re.sub(r"[<>\s]+", " ", text.strip())[:40]
        return f"[#<_not read: {shown}>]"


def line_edits(line: str, start: int) -> list[tuple[int, int, str]]:
    """The edits (start, end in the line, new text) that put a block of the file (offset
    ``start``) in the reader's syntax; none for a block it reads as it is."""
    code = line.partition(";")[0]
    orimks = _ORIMKS.search(code)
    if orimks:
        raise Refusal(start + orimks.start(), "ORIMKS (tool orientation vectors in machine coordinates) is not read: use ORIWKS")
    upper = code.upper()  # cheap guards: most candidate lines (R parameters, expressions) have none of the words below
    swivel = _SWIVEL_LINE.match(code) if "CYCLE800" in upper else None
    if swivel:
        a, b = swivel.span("call")
        return [(a, b, f"G{SWIVEL_CODE:g}".ljust(b - a))]
    passive = [(m.start(), m.end(), " " * (m.end() - m.start())) for m in _PASSIVE.finditer(code)]
    if passive:  # blanked (same length: every other character keeps its place), then the rest of the block as ever
        blanked = code
        for a, b, blank in passive:
            blanked = blanked[:a] + blank + blanked[b:]
        return sorted(passive + [e for e in line_edits(blanked, start) if not any(a <= e[0] < b for a, b, _ in passive)])
    not_read = _NOT_READ.match(code)
    if not_read:
        word = next(k for k in not_read.groupdict() if not_read.group(k))
        raise Refusal(start + not_read.start(word), _NOT_READ_WHY[word])
    frame = _FRAME_LINE.match(code)
    if siemens.classify(code) is not None and not frame and not re.match(r"(?i)^[ \t]*(?:[Nn]\d+[ \t]+)?R\d+[ \t]*=", code):
        # a Siemens statement (DEF, IF, FOR, a variable's assignment, a call): R parameters in it read as # parameters
        new = _R_PARAM.sub(lambda m: f"#{R_BASE + int(m.group(1))}", code)
        return [(0, len(code), new)] if new != code else []
    edits, pos = [], 0
    if frame:
        word = f"G{FRAME_CODES[frame.group('kw').upper()]:g}"
        edits.append((frame.start("kw"), frame.end("kw"), word.ljust(frame.end("kw") - frame.start("kw"))))
        pos = frame.end("kw")
    vector = None
    for a, b in _split_items(code[pos:]):
        old = code[pos + a : pos + b]
        new = _rewrite_item(old, start + pos + a, bool(frame))
        if new != old:
            edits.append((pos + a, pos + b, new))
        if old[:2].upper() in _VECTOR and old[2:].lstrip().startswith("="):
            vector = pos + a if vector is None else vector
        elif vector is not None or old[:1].upper() in "IJK" and not old[1:2].isalpha():
            centre = old[:1].upper() in "IJK" and not old[1:2].isalpha()
            if centre and any(code[pos + x : pos + x + 2].upper() in _VECTOR for x, _ in _split_items(code[pos:])):
                raise Refusal(start + pos + a, "I J K (an arc centre) and A3= B3= C3= (the tool orientation) in one block are not read")
    opening = ([(pos + a, pos + b) for a, b in _split_items(code[pos:]) if re.match(r"(?i)AR[ \t]*=", code[pos + a : pos + b])]
               if "AR" in upper else [])
    if opening:
        centre = [pos + a for a, b in _split_items(code[pos:]) if re.match(r"(?i)(?:[IJK](?![A-Za-z_])|CR[ \t]*=)", code[pos + a : pos + b])]
        if centre:
            raise Refusal(start + centre[0], "AR= with a centre (I J K) or CR= in one block (no end point: the end is computed) is not read: "
                          "write the end point with AR=")
        (a, b), = opening[:1]
        edits += [(a, a, f"G{ARC_ANGLE_CODE:g} "), (a, b, " " * (b - a))]  # the angle blanked (parse.py reads it from the file)
        edits.sort(key=lambda e: (e[0], e[1]))
    cip = _CIP.search(code) if "CIP" in upper else None
    intermediate = ([pos + a for a, b in _split_items(code[pos:]) if re.match(r"(?i)[IJK]1[ \t]*=", code[pos + a : pos + b])]
                    if "1" in upper else [])
    if cip and not intermediate:
        raise Refusal(start + cip.start(), "CIP without its intermediate point (I1= J1= K1=) in the block is not read")
    if cip:
        edits.append((cip.start(), cip.end(), "G3 "))  # read as an arc; parse.py puts its centre and direction
    if intermediate:
        edits.append((intermediate[0], intermediate[0], f"G{CIP_CODE:g} "))
        edits.sort(key=lambda e: (e[0], e[1]))
    if vector is not None:
        edits.insert(0, (vector, vector, f"G{VECTOR_CODE:g} "))  # the orientation vector's block: parse.py turns G43.5-like reading on
        edits.sort(key=lambda e: (e[0], e[1]))
    return edits


def rewrite(text: str) -> tuple[str, OffsetMap]:
    """The whole file in the reader's syntax and the offset map back (identity where nothing is rewritten)."""
    pieces, anchors, pos, shift = [], [], 0, 0
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    line_starts = np.concatenate([[0], np.nonzero(raw == 10)[0] + 1])
    for line_start in candidate_lines(text, raw, line_starts).tolist():
        end = text.find("\n", line_start)
        line = text[line_start : len(text) if end < 0 else end].rstrip("\r")
        for a, b, new in line_edits(line, line_start):
            a, b = line_start + a, line_start + b
            pieces += [text[pos:a], new]
            anchors.append((a + shift, a, a + shift + len(new), b))
            shift += len(new) - (b - a)
            pos = b
    pieces.append(text[pos:])
    cols = np.array(anchors, dtype=np.int64).reshape(-1, 4)
    return "".join(pieces), OffsetMap(cols[:, 0], cols[:, 1], cols[:, 2], cols[:, 3])
