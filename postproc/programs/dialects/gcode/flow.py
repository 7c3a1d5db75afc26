"""G-code control flow, executed as LinuxCNC's interpreter executes it.

O-word subroutines (``o<name> sub`` / ``call [args]`` / ``return [value]`` / ``endsub``),
``if/elseif/else``, ``while``, ``do ... while``, ``repeat``, ``break``/``continue`` and Fanuc
``M98 P.. L..`` calls of ``O<n> ... M99``: the program is walked with a program counter and
every executed block is handed, in execution order, to the parser's block reader, which
evaluates its # parameters at that moment. A text span executed several times (a loop body,
a sub) thus gives several IR rows that share spans.

Parameter scopes follow LinuxCNC (docs "O Codes", "Parameters"): a ``call`` opens a new
scope where #1..#30 are the call's arguments (0 where not given) and named parameters
without a leading underscore are local; ``#<_name>`` and #31 and up are global; ``return
[e]`` / ``endsub [e]`` set ``#<_value>`` and ``#<_value_returned>``. ``M98`` shares the
caller's parameters (Fanuc).

A decision the program text cannot make (a condition or count reading a parameter that is
unknown at post time: ``#<_hal[...]>``, an unset ``#5220``) is never guessed: from that block
on, every target is flagged unresolved, every loop body runs once and every if-branch is
listed once, so each target is still reported with its line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from lark import Tree

from ...ir import SourceDoc, Toolpath
from ...parse.common import LineIndex, parse_statement
from ...parse.grammar import grammar
from . import siemens
from .blockwords import Unknown

# Executed blocks (lines) before the program is refused: bounds time and memory of a
# `while [1]` (one IR row is ~1 kB while the block table is built).
MAX_EXECUTED_BLOCKS = 1_000_000
MAX_CALL_DEPTH = 100  # nested calls (LinuxCNC's own limit is lower); deeper is refused
# After this many blocks, each O-word line compares the run's state with one saved earlier
# (Brent's cycle detection): the same state twice is a loop that never ends, refused at once
# instead of after MAX_EXECUTED_BLOCKS (seconds and ~1 GB of block table).
CYCLE_CHECK_AFTER = 1_000

# Searched in the lower-cased text, and only where a cheap substring test finds a keyword:
# a plain CAM file of 10^6 lines never runs them.
_FLOW = re.compile(r"(?m)^[ \t]*(?:/[ \t]*)?(?:n[ \t]*\d+[ \t]*)?o[ \t]*(?:\d+|<[^>\n]*>)[ \t]*(?:sub|call|if|while|do|repeat)\b")
_M98 = re.compile(r"m[ \t]*9[89](?!\d)")
_FLOW_WORDS = ("sub", "call", "if", "while", "do", "repeat", "proc", "extern", "def", "for", "goto")
_OPENS = {"sub": "endsub", "if": "endif", "while": "endwhile", "do": "while", "repeat": "endrepeat", "for": "endfor"}
_LOOPS = ("while", "do", "repeat", "for")
_SIEMENS_FLOW = re.compile(r"(?m)^[ \t]*(?:n\d+[ \t]+)?(?:proc|extern|def|if|while|for|repeat|goto[fbc]?)[ \t]")  # N20 IF ...: block numbers too


_CALL = re.compile(r"(?im)^[ \t]*(?:[Nn][ \t]*\d+[ \t]*)?[Oo][ \t]*<([^>\n]+)>[ \t]*call\b")
_SUB = re.compile(r"(?im)^[ \t]*(?:[Nn][ \t]*\d+[ \t]*)?[Oo][ \t]*<([^>\n]+)>[ \t]*sub\b")
MAX_SIDE_FILES = 50


def _name(label: str) -> str:
    return re.sub(r"\s+", "", label).lower()


def side_files(doc: SourceDoc) -> list[SourceDoc]:
    """Files of the subs the program calls but does not define: LinuxCNC looks for
    ``o<name> call`` in ``<name>.ngc`` on its subroutine path; here, beside the program
    (and beside those files, for the subs they call)."""
    docs, looked = [doc], set()
    for d in docs:
        low = d.text.lower()
        if "call" not in low and "extern" not in low:
            continue
        defined = {_name(n) for dd in docs for n in _SUB.findall(dd.text)}
        wanted = [(n, (f"{n}.ngc",)) for n in map(_name, _CALL.findall(d.text))]
        wanted += [(n.lower(), (f"{n}.SPF", f"{n}.spf", f"{n.lower()}.spf")) for n in siemens.externs(d.text)]
        for name, files in wanted:
            if name in defined or name in looked or len(docs) > MAX_SIDE_FILES:
                continue
            looked.add(name)
            path = next((p for f in files if (p := Path(doc.path).with_name(f)).is_file()), None)
            if path is not None and path.resolve() != Path(doc.path).resolve():
                docs.append(SourceDoc.read(path, "subroutine"))
    return docs[1:]


class _JoinedLines(LineIndex):
    """Lines of several files read as one text (each starting at ``bases[k]``); errors name the file."""

    def __init__(self, docs: list[SourceDoc], bases: np.ndarray, text: str):
        super().__init__(text)
        self.bases = bases
        self.parts = [(LineIndex(d.text), d.path) for d in docs]

    def part(self, offset) -> np.ndarray:
        return np.searchsorted(self.bases, offset, side="right") - 1

    def error(self, path: str, offset: int, message: str):
        k = int(self.part(offset))
        index, own_path = self.parts[k]
        return index.error(own_path, offset - int(self.bases[k]), message)


def needs_flow_in(text: str, starts) -> bool:
    """needs_flow over the lines starting at ``starts`` (the blocks the bulk reader left)."""
    pieces = []
    for start in starts.tolist():
        end = text.find("\n", start)
        pieces.append(text[start : len(text) if end < 0 else end])
    return needs_flow("\n".join(pieces))


def needs_flow(text: str) -> bool:
    """True where the program has O-word control flow or Fanuc M98/M99 calls."""
    low = text.lower()
    if "m" in low and _M98.search(low):
        return True
    if not any(word in low for word in _FLOW_WORDS):
        return False
    return _FLOW.search(low) is not None or _SIEMENS_FLOW.search(low) is not None


class Params:
    """# parameters with LinuxCNC's scopes: a dict-like view the block reader uses unchanged."""

    def __init__(self, siemens_names: bool = False):
        self.globals: dict = {}
        self.frames: list[dict] = [{}]
        self.siemens_names = siemens_names  # SINUMERIK: a DEF'd or PROC variable is local to its program

    def _where(self, key) -> dict:
        if self.siemens_names and isinstance(key, str):
            return self.frames[-1]
        if isinstance(key, int):
            return self.frames[-1] if 1 <= key <= 30 else self.globals
        return self.globals if key.startswith("_") else self.frames[-1]

    @staticmethod
    def _norm(key):
        return re.sub(r"\s+", "", key).lower() if isinstance(key, str) else key

    def __contains__(self, key) -> bool:
        key = self._norm(key)
        return key in self._where(key)

    def __getitem__(self, key):
        key = self._norm(key)
        return self._where(key)[key]

    def __setitem__(self, key, value) -> None:
        key = self._norm(key)
        self._where(key)[key] = value

    def pop(self, key, default=None):
        key = self._norm(key)
        return self._where(key).pop(key, default) if key is not None else default


@dataclass
class Line:
    start: int
    tree: Tree
    label: str = ""  # O-word label, lower case, blanks removed ('' for a plain block)
    keyword: str = ""  # sub, call, if, ... ('' for a plain block or a Fanuc program number)
    args: list = field(default_factory=list)  # the O-word's expressions
    m: set = field(default_factory=set)  # M codes of a plain block
    words: dict = field(default_factory=dict)  # literal P and L of a plain block
    doc: int = 0  # which file
    extra: dict = field(default_factory=dict)  # Siemens statement details (siemens.classify)
    assigns: list = field(default_factory=list)  # a block of only `#n = e` settings: evaluated here, no IR row


@dataclass
class Frame:
    return_to: int  # line index to continue at after the call
    sub: str  # label ('' for the main program), or 'O<n>' of a Fanuc M98 call
    doc: int | None = None  # a Siemens subprogram: its file (leaving it returns)
    counters: dict = field(default_factory=dict)  # repeat line -> passes left
    passes_left: int = 0  # Fanuc M98 L: further passes of the sub
    entry: int = 0  # first line of the sub (Fanuc M98 repeats)


class _Cycle:
    """Brent's cycle detection over the states seen at O-word lines: a state is saved at the
    1st, 2nd, 4th, 8th ... check, and a later state equal to the saved one is a cycle."""

    def __init__(self):
        self.saved, self.checks, self.next_save = None, 0, 1

    def check(self, state: str, error) -> None:
        if state == self.saved:
            raise error()
        self.checks += 1
        if self.checks == self.next_save:
            self.saved, self.next_save = state, 2 * self.next_save


class Structure:
    """The static shape of the program: matching O-word lines, subs, Fanuc program numbers."""

    def __init__(self, lines: list[Line], error):
        self.partner: dict[int, int] = {}  # opening line <-> closing line
        self.clauses: dict[int, list[int]] = {}  # if line -> its elseif/else lines and endif
        self.endif_of: dict[int, int] = {}  # elseif/else line -> endif line
        self.loop_of: dict[int, int] = {}  # break/continue line -> opening line of its loop
        self.subs: dict[str, int] = {}
        self.fanuc: dict[str, int] = {}  # Fanuc program number 'O1' -> its line
        stack: list[tuple[str, str, int]] = []
        for i, ln in enumerate(lines):
            kw, label = ln.keyword, ln.label
            if not label:
                continue
            if not kw:
                self.fanuc[label] = i
            elif kw == "proc":
                self.subs[label] = i
            elif kw in ("while", "until") and stack and stack[-1][:2] == (label, "do"):
                self._close(stack, i, lines)
            elif kw in _OPENS:
                if kw == "sub":
                    self.subs[label] = i
                if kw == "if":
                    self.clauses[i] = []
                stack.append((label, kw, i))
            elif kw in ("elseif", "else"):
                if not stack or stack[-1][:2] != (label, "if"):
                    raise error(ln.start, f"o{label} {kw} is not inside o{label} if")
                self.clauses[stack[-1][2]].append(i)
            elif kw in ("endsub", "endif", "endwhile", "endrepeat", "endfor"):
                if not stack or _OPENS[stack[-1][1]] != kw or stack[-1][0] != label:
                    raise error(ln.start, f"o{label} {kw} does not close the open O-word block ({self._open_name(stack)})")
                self._close(stack, i, lines)
            elif kw in ("break", "continue"):
                loop = next((o for lab, k, o in reversed(stack) if lab == label and k in _LOOPS), None)
                if loop is None:
                    raise error(ln.start, f"o{label} {kw} is not inside an o{label} loop")
                self.loop_of[i] = loop
        if stack:
            label, kw, where = stack[-1]
            raise error(lines[where].start, f"O-word block opened here is never closed (missing o{label} {_OPENS[kw]})")

    @staticmethod
    def _open_name(stack) -> str:
        return f"o{stack[-1][0]} {stack[-1][1]}" if stack else "none open"

    def _close(self, stack, i: int, lines: list[Line]) -> None:
        _, kw, opened = stack.pop()
        self.partner[opened], self.partner[i] = i, opened
        if kw == "if":
            self.clauses[opened].append(i)
            for c in self.clauses[opened][:-1]:
                self.endif_of[c] = i


class _Refused(Exception):
    pass


class Runner:
    """Walks the program and yields the start offset of each executed block, in order.

    The parser reads each yielded block before the next is asked for, so conditions see the
    parameters as the blocks before them left them."""

    def __init__(self, parser):
        self.parser = parser
        self.docs = [parser.doc] + (side_files(parser.doc) if Path(parser.doc.path).is_file() else [])
        parser.siemens = self.siemens = parser.siemens or siemens.is_siemens(parser.doc.path, parser.doc.text)
        parser.params = Params(self.siemens)
        self.ints: set[str] = set()  # Siemens INT variables (a REAL assigned is rounded)
        self.joined = None
        if len(self.docs) > 1:
            texts = [d.text if d.text.endswith("\n") else d.text + "\n" for d in self.docs]
            bases = np.cumsum([0] + [len(t) for t in texts[:-1]]).astype(np.int64)
            parser.text = "".join(texts)
            parser.lines = self.joined = _JoinedLines(self.docs, bases, parser.text)
        self.labels: dict[str, int] = {}  # Siemens jump label ("file index:name") -> line index
        self.block_numbers: dict[int, list[int]] = {}  # Siemens N number -> line indices (jump targets)
        self.lines = self._read_lines()
        parser.trees = {ln.start: ln.tree for ln in self.lines if ln.tree is not None}
        self.shape = Structure(self.lines, self._error)
        self.tainted_from: int | None = None  # first row whose position depends on a guess: none are made
        self.rows = 0
        main_len = len(self.docs[0].text)
        self.main_end = next((i for i, ln in enumerate(self.lines) if ln.start >= main_len), len(self.lines))

    def finish(self, tp: Toolpath) -> Toolpath:
        """The toolpath with rows read from a sub's own file pointing into that file."""
        if self.joined is None or not len(tp):
            return replace(tp, sources=tuple(self.docs)) if self.joined is not None else tp
        bases, at = self.joined.bases, tp.insert_at[:, 1]
        part = self.joined.part(at)
        line = np.array([self.joined.parts[k][0].line(a - bases[k]) for k, a in zip(part.tolist(), at.tolist())], dtype=tp.line.dtype)
        spans = tp.spans.copy()
        have = spans[:, :, 1] >= 0
        span_part = self.joined.part(spans[:, :, 1])
        spans[:, :, 0] = np.where(have, span_part, -1)
        spans[:, :, 1:] -= np.where(have, bases[span_part], 0)[:, :, None]
        insert_at = np.stack([part, at - bases[part]], axis=1).astype(tp.insert_at.dtype)
        return replace(tp, sources=tuple(self.docs), file=part.astype(tp.file.dtype), line=line, spans=spans, insert_at=insert_at)

    # ------------------------------------------------------------ reading
    def _error(self, offset: int, message: str):
        text = self.parser.text
        while offset < len(text) and text[offset] in " \t":  # point at the block, not its indent
            offset += 1
        return self.parser.lines.error(self.parser.doc.path, offset, message)

    def _read_lines(self) -> list[Line]:
        g, text, p = grammar("gcode"), self.parser.text, self.parser
        out, blocks = [], []
        bases = self.joined.bases if self.joined is not None else np.zeros(1, np.int64)
        for start in p.lines.starts.tolist():
            end = text.find("\n", start)
            line = text[start : len(text) if end < 0 else end].rstrip("\r")
            if not line.strip() or line.strip() == "%":
                continue
            doc = int(np.searchsorted(bases, start, side="right") - 1)
            if self.siemens:
                line = self._jump_marks(line, len(out), start, doc)
                if not line.strip():
                    out.append(Line(start, None, keyword="nop", doc=doc))  # a label alone: a jump target
                    continue
            statement = siemens.classify(line) if self.siemens else None
            if statement is not None:
                out.append(self._siemens_line(Line(start, None, doc=doc), statement, blocks))
                continue
            tree = parse_statement(g, line, p.lines, p.doc.path, start, "G-code block")
            out.append(self._classify(Line(start, tree, doc=doc)))
        if blocks:
            raise self._error(blocks[-1][2], f"{blocks[-1][0]} opened here is never closed")
        return out

    def _jump_marks(self, line: str, index: int, start: int, doc: int) -> str:
        """Records the block's jump label and N number (Siemens jump targets); the block without its label."""
        label, number, end = siemens.label_of(line)
        if label is not None:
            key = f"{doc}:{label}"  # labels are per program file
            if key in self.labels:
                raise self._error(start, f"jump label {label.upper()} is defined twice in this program (the 840D refuses it)")
            self.labels[key] = index
        if number is not None:
            self.block_numbers.setdefault(number, []).append(index)
        return " " * end + line[end:]

    _SIEMENS_KW = {"IF": "if", "ELSE": "else", "ENDIF": "endif", "WHILE": "while", "ENDWHILE": "endwhile", "FOR": "for", "ENDFOR": "endfor",
                   "REPEAT": "do", "UNTIL": "until", "RET": "ret", "PROC": "proc", "DEF": "def", "ASSIGN": "assign", "CALL": "scall",
                   "EXTERN": "nop", "MSG": "nop"}
    _SIEMENS_OPENS = {"IF": "ENDIF", "WHILE": "ENDWHILE", "FOR": "ENDFOR", "REPEAT": "UNTIL"}

    def _siemens_line(self, ln: Line, statement, blocks: list) -> Line:
        """A SINUMERIK statement as an O-word line: IF/WHILE/FOR/REPEAT get a label of their own."""
        kw, extra = statement
        goto = siemens.jump(kw, extra["rest"]) if kw in ("IF", "GOTOF", "GOTOB", "GOTO", "GOTOC") else None
        if goto is not None:  # GOTOF LABEL, IF cond GOTOB N100 (one block: no ENDIF)
            ln.keyword = "goto"
            cond, extra["direction"], extra["target"] = goto
            ln.extra = extra
            ln.args = [self._expr(ln, cond)] if cond else []
            return ln
        if kw not in self._SIEMENS_KW:
            raise self._error(ln.start, f"Siemens {kw} is not supported (jumps and endless loops are not unrolled)")
        ln.keyword, ln.extra = self._SIEMENS_KW[kw], extra
        if kw in self._SIEMENS_OPENS:
            ln.label = f"siemens{ln.start}"
            blocks.append((kw, ln.label, ln.start))
        elif kw in ("ELSE", "ENDIF", "ENDWHILE", "ENDFOR", "UNTIL"):
            opener = {"ELSE": "IF", "ENDIF": "IF", "ENDWHILE": "WHILE", "ENDFOR": "FOR", "UNTIL": "REPEAT"}[kw]
            if not blocks or blocks[-1][0] != opener:
                raise self._error(ln.start, f"{kw} does not close the open block ({blocks[-1][0] if blocks else 'none open'})")
            ln.label = blocks[-1][1]
            if kw != "ELSE":
                blocks.pop()
        elif kw == "PROC":
            ln.label, extra["params"] = siemens.proc_signature(extra["rest"])
        rest = extra.get("rest", "")
        if kw in ("IF", "WHILE", "UNTIL"):
            ln.args = [self._expr(ln, rest)]
        elif kw == "FOR":
            m = re.match(r"(?i)\s*([A-Za-z_]\w*)\s*=(.*)\bTO\b(.*)", rest)
            if not m:
                raise self._error(ln.start, "FOR takes `FOR var = start TO end`")
            extra["var"] = m.group(1).lower()
            ln.args = [self._expr(ln, m.group(2)), self._expr(ln, m.group(3))]
        elif kw == "ASSIGN":
            ln.args = [self._expr(ln, extra["expr"])]
        elif kw == "CALL":
            ln.label = extra["name"].lower()
            ln.args = [self._expr(ln, a) for a in extra["args"]]
        elif kw == "DEF":
            extra["kind"], names = siemens.definitions(rest)
            extra["names"] = [(n, self._expr(ln, v) if v else None) for n, v in names]
        return ln

    def _expr(self, ln: Line, text: str):
        """A Siemens expression as a grammar tree (None where it cannot be read: then unknown)."""
        text = text.split(";")[0]
        try:
            tree = grammar("gcode").parse(f"o1 if {siemens.expression(text)}")
        except Exception:  # noqa: BLE001 - any expression we cannot translate is an unknown value, never a guess
            return None
        return tree.children[0].children[2]

    def _classify(self, ln: Line) -> Line:
        for item in ln.tree.children:
            if not isinstance(item, Tree):
                continue
            if item.data == "oword":
                ln.label = re.sub(r"\s+", "", str(item.children[0])[1:].lower()).strip("<>")
                ln.label = str(int(ln.label)) if ln.label.isdigit() else ln.label  # O0001 is O1 (M98 P1)
                if len(item.children) > 1:
                    ln.keyword = str(item.children[1]).lower()
                    ln.args = list(item.children[2:])
            elif item.data == "word":
                letter = str(item.children[0]).upper()
                value = _literal(item.children[1])
                if letter == "M" and value is not None:
                    ln.m.add(round(value, 1))
                elif letter in "PL" and value is not None:
                    ln.words[letter] = value
        items = [i for i in ln.tree.children if isinstance(i, Tree) and i.data != "comment"]
        if items and all(i.data == "assign" for i in items):
            ln.assigns = items
        if ln.keyword and any(isinstance(i, Tree) and i.data == "word" for i in ln.tree.children):
            raise self._error(ln.start, f"o{ln.label} {ln.keyword}: an O-word line takes no other words")
        return ln

    # ------------------------------------------------------------ running
    def run(self):
        """Generator of executed block offsets (the parser's clock is set before each)."""
        frames = [Frame(len(self.lines), "")]
        pc, executed = 0, 0
        cycle = _Cycle()
        while True:
            if len(frames) > 1 and frames[-1].doc is not None and (pc >= len(self.lines) or self.lines[pc].doc != frames[-1].doc):
                pc = self._return(frames)  # a Siemens subprogram ends with its file
                continue
            if pc >= len(self.lines) or (pc >= self.main_end and len(frames) == 1):
                return
            executed += 1
            if executed > MAX_EXECUTED_BLOCKS:
                raise self._error(self.lines[pc].start, f"more than {MAX_EXECUTED_BLOCKS:,} blocks executed: a loop that does not end at post time is refused")
            ln = self.lines[pc]
            if ln.keyword:
                if executed > CYCLE_CHECK_AFTER:
                    cycle.check(self._state(pc, frames), lambda: self._error(ln.start, (
                        f"back at this line with the same parameters, counters and calls after {executed:,} blocks executed: "
                        "a loop that does not end at post time is refused")))
                pc = self._oword(pc, ln, frames)
                if pc is None:  # RET of the main program
                    return
                continue
            if ln.assigns:
                self._set_params(ln)
                pc += 1
                continue
            if ln.label and not ln.keyword:  # a Fanuc program number: its body runs only when called
                pc = self._skip_fanuc(pc) if len(frames) == 1 else pc + 1
                continue
            self.parser.clock = self.rows
            self.rows += 1
            yield ln.start
            if ln.m & {2.0, 30.0}:
                return
            pc = self._m98_m99(pc, ln, frames)

    def _state(self, pc: int, frames: list[Frame]) -> str:
        """All that the rest of the run depends on (the block reader only reads parameters);
        repr keeps -0.0 apart from 0.0, so equal states run alike."""
        params = self.parser.params
        calls = [(f.return_to, f.sub, f.doc, f.counters, f.passes_left, f.entry) for f in frames]
        return repr((pc, self.tainted_from is None, sorted(self.ints), params.globals, params.frames, calls))

    def _set_params(self, ln: Line) -> None:
        """A block of parameter settings only: read all, then set (as the block reader does)."""
        params = self.parser.params
        for key, value in [self.parser._assign(item, ln.start) for item in ln.assigns]:
            if value is None:
                params.pop(key, None)
            elif key is not None:
                params[key] = value

    def _skip_fanuc(self, pc: int) -> int:
        """Main-program flow reaching `O1`: LinuxCNC skips the Fanuc sub to its M99."""
        for j in range(pc + 1, len(self.lines)):
            if 99.0 in self.lines[j].m:
                return j + 1
        return len(self.lines)

    def _m98_m99(self, pc: int, ln: Line, frames: list[Frame]) -> int:
        if 98.0 in ln.m:
            label = f"{ln.words.get('P', float('nan')):g}"
            entry = self.shape.fanuc.get(label)
            if entry is None:
                raise self._error(ln.start, f"M98 P{label}: no O{label} in this program")
            passes = int(ln.words.get("L", 1))
            if passes <= 0:
                return pc + 1
            self._push(frames, Frame(pc + 1, f"O{label}", passes_left=passes - 1, entry=entry + 1), ln)
            return entry + 1
        if 17.0 in ln.m and self.siemens:
            return self._return(frames) if len(frames) > 1 else len(self.lines)
        if 99.0 in ln.m:
            if len(frames) == 1 or not frames[-1].sub.startswith("O"):
                raise self._error(ln.start, "M99 outside an M98 call (a main program's M99 repeats it forever)")
            frame = frames[-1]
            if frame.passes_left > 0 and not self._unsure():
                frame.passes_left -= 1
                return frame.entry
            frames.pop()
            return frame.return_to
        return pc + 1

    def _push(self, frames: list[Frame], frame: Frame, ln: Line) -> None:
        if len(frames) > MAX_CALL_DEPTH:
            raise self._error(ln.start, f"calls nested deeper than {MAX_CALL_DEPTH}: recursion that does not end at post time is refused")
        frames.append(frame)

    def _where(self, offset: int) -> str:
        """`line N` of the program, or `FILE:N` in a sub's own file."""
        if self.joined is None:
            return f"line {self.parser.lines.line(offset)}"
        k = int(self.joined.part(offset))
        index, path = self.joined.parts[k]
        line = int(index.line(offset - int(self.joined.bases[k])))
        return f"line {line}" if k == 0 else f"{Path(path).name}:{line}"

    def _unsure(self) -> bool:
        return self.tainted_from is not None

    def _taint(self, ln: Line, what: str) -> None:
        if self.tainted_from is None:
            self.tainted_from = self.rows
            self.parser.notes.append(
                f"{self._where(ln.start)}: {what} cannot be decided at post time; "
                "from here on each target is listed once and flagged unresolved")

    def _value(self, ln: Line, node, what: str):
        """An O-word expression's value, or None (and the run is marked unsure) when unknown."""
        if node is None:
            return self._value_none(ln, what)
        try:
            return self.parser._eval(node)
        except (Unknown, ValueError, ZeroDivisionError, KeyError) as exc:
            self._taint(ln, f"{what} ({exc})")
            return None

    def _oword(self, pc: int, ln: Line, frames: list[Frame]) -> int:
        handler = getattr(self, f"_kw_{ln.keyword}")
        return handler(pc, ln, frames)

    # ---- subs
    def _kw_sub(self, pc, ln, frames):
        return self.shape.partner[pc] + 1  # a definition: skipped

    def _kw_call(self, pc, ln, frames):
        entry = self.shape.subs.get(ln.label)
        if entry is None:
            raise self._error(ln.start, f"o<{ln.label}> call: no o<{ln.label}> sub in this program, and no {self._sub_file(ln.label)} beside it")
        if self._unsure() and any(f.sub == ln.label for f in frames):
            return pc + 1  # recursion under an unknown condition: listed once already
        args = []
        for node in ln.args:
            value = self._value_quiet(node)
            args.append(value)
        params = self.parser.params
        self._push(frames, Frame(pc + 1, ln.label), ln)
        params.frames.append({i: a for i, a in enumerate(args + [0.0] * (30 - len(args)), start=1) if a is not None})
        return entry + 1

    def _value_quiet(self, node):
        """An argument's value, None when unknown (reading it in the sub then flags the target)."""
        if node is None:
            return None
        try:
            return self.parser._eval(node)
        except (Unknown, ValueError, ZeroDivisionError, KeyError):
            return None

    def _sub_file(self, label: str) -> str:
        return str(Path(self.parser.doc.path).with_name(f"{label}.ngc"))

    # ---- Siemens
    def _return(self, frames: list[Frame]) -> int:
        frame = frames.pop()
        self.parser.params.frames.pop()
        return frame.return_to

    def _kw_nop(self, pc, ln, frames):
        return pc + 1

    def _kw_proc(self, pc, ln, frames):
        return pc + 1  # the head of the program being run (its parameters are not known)

    def _kw_ret(self, pc, ln, frames):
        return self._return(frames) if len(frames) > 1 else None

    def _kw_def(self, pc, ln, frames):
        for name, node in ln.extra["names"]:
            if ln.extra["kind"] == "INT":
                self.ints.add(name)
            self._set(name, 0.0 if node is None else self._value_quiet(node))
        return pc + 1

    def _set(self, name: str, value) -> None:
        """A Siemens variable; INT rounds (half away from zero); an unknown value stays unknown."""
        params = self.parser.params
        if value is None:
            params.pop(name)
            return
        if name in self.ints:
            value = float(np.sign(value) * np.floor(abs(value) + 0.5))
        params[name] = value

    def _kw_assign(self, pc, ln, frames):
        node = ln.args[0]
        self._set(ln.extra["name"].lower(), None if node is None else self._value_quiet(node))
        return pc + 1

    def _kw_scall(self, pc, ln, frames):
        entry = self.shape.subs.get(ln.label)
        if entry is None:
            self._taint(ln, f"subprogram {ln.extra['name']} (its {ln.extra['name']}.SPF is not beside the program)")
            return pc + 1
        names = self.lines[entry].extra.get("params", [])
        values = [None if a is None else self._value_quiet(a) for a in ln.args]
        self._push(frames, Frame(pc + 1, ln.label, doc=self.lines[entry].doc), ln)
        self.parser.params.frames.append({n: v for n, v in zip(names, values) if v is not None})
        return entry + 1

    def _kw_for(self, pc, ln, frames):
        counters = frames[-1].counters
        var = ln.extra["var"]
        if pc not in counters:  # entering: var = start
            self._set(var, self._value(ln, ln.args[0], "FOR start") if ln.args[0] is not None else self._value_none(ln, "FOR start"))
        elif self._unsure():
            counters.pop(pc)
            return self.shape.partner[pc] + 1
        else:
            value = self.parser.params[var] if var in self.parser.params else None
            self._set(var, None if value is None else value + 1)
        counters[pc] = 1
        if self._unsure():
            return pc + 1
        end = self._value(ln, ln.args[1], "FOR end") if ln.args[1] is not None else self._value_none(ln, "FOR end")
        current = self.parser.params[var] if var in self.parser.params else None
        if end is None or current is None:
            self._taint(ln, "the FOR loop's count")
            return pc + 1
        if current <= end:
            return pc + 1
        counters.pop(pc)
        return self.shape.partner[pc] + 1

    def _value_none(self, ln: Line, what: str):
        self._taint(ln, f"{what} (an expression that is not read)")
        return None

    def _kw_endfor(self, pc, ln, frames):
        return self.shape.partner[pc]

    def _kw_until(self, pc, ln, frames):
        opened = self.shape.partner[pc]
        if self._unsure():
            return pc + 1
        cond = self._value(ln, ln.args[0], "UNTIL condition") if ln.args[0] is not None else self._value_none(ln, "UNTIL condition")
        return pc + 1 if cond is None or cond else opened + 1

    def _kw_return(self, pc, ln, frames):
        return self._leave(ln, frames)

    def _kw_endsub(self, pc, ln, frames):
        return self._leave(ln, frames)

    def _leave(self, ln: Line, frames: list[Frame]) -> int:
        params = self.parser.params
        if len(frames) == 1 or frames[-1].sub != ln.label:
            raise self._error(ln.start, f"o{ln.label} {ln.keyword} outside a call of o{ln.label}")
        value = self._value_quiet(ln.args[0]) if ln.args else None  # read in the sub's scope
        frame = frames.pop()
        params.frames.pop()
        params.globals["_value_returned"] = 1.0 if ln.args else 0.0
        if value is not None:
            params.globals["_value"] = value
        elif ln.args:
            params.globals.pop("_value", None)  # an unknown return value stays unknown
        return frame.return_to

    # ---- if / elseif / else
    def _kw_goto(self, pc, ln, frames):
        """SINUMERIK GOTOF / GOTOB / GOTO / GOTOC (Job Planning, "Program jumps to jump markers"):
        GOTOF searches towards the end, GOTOB towards the start, GOTO forward then back, GOTOC
        as GOTO without the alarm when the target is missing; the target is a label or a block
        number. Under an undecidable condition, or backwards once the run is unsure, the jump
        is not taken (each target listed once, flagged) rather than guessed."""
        if ln.args:
            cond = self._value(ln, ln.args[0], "IF condition of a jump")
            if cond is None or not cond:
                return pc + 1
        direction, target = ln.extra["direction"], ln.extra["target"]
        found = self._jump_target(pc, ln, direction, target)
        if found is None:
            if direction == "GOTOC":
                return pc + 1
            raise self._error(ln.start, f"{direction} {target}: no jump label or block number {target} "
                                        f"{'after' if direction == 'GOTOF' else 'before' if direction == 'GOTOB' else 'in'} this block (840D alarm 14080)")
        if found <= pc and self._unsure():
            return pc + 1
        return found

    def _jump_target(self, pc: int, ln: Line, direction: str, target: str) -> int | None:
        """Line index of a jump's target within the block's own file, or None."""
        name = target.lower()
        digits = name[1:] if name[:1] == "n" and name[1:].isdigit() else name
        key = f"{ln.doc}:{name}"
        candidates = [self.labels[key]] if key in self.labels else []
        if digits.isdigit():
            candidates += self.block_numbers.get(int(digits), [])
        same_file = [i for i in candidates if self.lines[i].doc == ln.doc and i != pc]
        forward = sorted(i for i in same_file if i > pc)
        backward = sorted((i for i in same_file if i < pc), reverse=True)
        order = {"GOTOF": forward, "GOTOB": backward}.get(direction, forward + backward)
        return order[0] if order else None

    def _kw_if(self, pc, ln, frames):
        if self._unsure():
            return pc + 1
        cond = self._value(ln, ln.args[0], f"{_shown(ln)} condition")
        if cond is None or cond:
            return pc + 1
        for c in self.shape.clauses[pc]:
            cl = self.lines[c]
            if cl.keyword == "elseif":
                v = self._value(cl, cl.args[0], f"{_shown(cl)} condition")
                if v is None or v:
                    return c + 1
            else:  # else or endif
                return c + 1
        raise AssertionError("an if has its endif")

    def _kw_elseif(self, pc, ln, frames):
        return pc + 1 if self._unsure() else self.shape.endif_of[pc] + 1  # reached from a taken branch

    _kw_else = _kw_elseif

    def _kw_endif(self, pc, ln, frames):
        return pc + 1

    # ---- loops
    def _kw_while(self, pc, ln, frames):
        opened = self.shape.partner[pc]
        if self.lines[opened].keyword == "do":  # the end of a do-while
            if self._unsure():
                return pc + 1
            cond = self._value(ln, ln.args[0], f"{_shown(ln)} condition")
            return opened + 1 if cond else pc + 1
        if self._unsure() and frames[-1].counters.get(pc):  # unsure: one pass
            frames[-1].counters.pop(pc)
            return opened + 1
        cond = True if self._unsure() else self._value(ln, ln.args[0], f"{_shown(ln)} condition")
        if cond is None or cond:
            frames[-1].counters[pc] = 1
            return pc + 1
        frames[-1].counters.pop(pc, None)
        return opened + 1

    def _kw_endwhile(self, pc, ln, frames):
        return self.shape.partner[pc]

    def _kw_do(self, pc, ln, frames):
        return pc + 1

    def _kw_repeat(self, pc, ln, frames):
        count = 1 if self._unsure() else self._value(ln, ln.args[0], f"{_shown(ln)} count")
        count = 1 if count is None else int(count)
        if count <= 0:
            return self.shape.partner[pc] + 1
        frames[-1].counters[pc] = count
        return pc + 1

    def _kw_endrepeat(self, pc, ln, frames):
        opened = self.shape.partner[pc]
        left = frames[-1].counters.get(opened, 1) - 1
        if left > 0 and not self._unsure():
            frames[-1].counters[opened] = left
            return opened + 1
        frames[-1].counters.pop(opened, None)
        return pc + 1

    def _kw_break(self, pc, ln, frames):
        opened = self.shape.loop_of[pc]
        frames[-1].counters.pop(opened, None)
        return self.shape.partner[opened] + 1

    def _kw_continue(self, pc, ln, frames):
        opened = self.shape.loop_of[pc]
        close = self.shape.partner[opened]
        if self._unsure():
            frames[-1].counters.pop(opened, None)
            return close + 1
        if self.lines[opened].keyword == "while":
            return opened
        return close  # do: evaluate the closing while; repeat: count the pass at endrepeat


def _shown(ln: Line) -> str:
    """How a control line is named in a note: `o100 while`, or the Siemens keyword."""
    if ln.label.startswith("siemens"):
        return {"do": "REPEAT", "until": "UNTIL"}.get(ln.keyword, ln.keyword.upper())
    return f"o{ln.label} {ln.keyword}"


def _literal(node) -> float | None:
    if isinstance(node, Tree) and node.data == "number":
        return float(node.children[0])
    if isinstance(node, Tree) and node.data in ("neg", "pos") and _literal(node.children[-1]) is not None:
        return -_literal(node.children[-1]) if node.data == "neg" else _literal(node.children[-1])
    return None
