"""KRL functions called in expressions (``P1.X = Offset(3)``), evaluated when straight-line.

KUKA System Software 8.x, Operating and Programming Instructions for System Integrators,
"Subprograms and functions": ``DEFFCT type NAME(params) ... RETURN value ... ENDFCT``;
a function of another module is called by name when it is the module's main routine or
declared ``GLOBAL DEFFCT``; ``IN`` parameters are passed by value. "Arithmetic functions":
SIN, COS, TAN take degrees; ATAN2(Y, X) gives degrees; SQRT, ABS.

A function is evaluated here only when its body is straight-line: DECLs, assignments of
local names and one RETURN as the last statement, each of literals, parameters and locals
(anything else: a block, a call, a system variable or a global, an OUT parameter). Any
other call, or one whose arguments are not known, gives NaN: the point or frame it sets is
unknown (targets unresolved, refused for compensation), and a note names the call's line
and why — the declared value is never used in its place.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from lark import Token, Tree

from ...parse.common import LineIndex, parse_statement
from ...parse.grammar import grammar
from .state import number

_FCT = re.compile(r"^[ \t]*(?P<glob>GLOBAL[ \t]+)?DEFFCT[ \t]+[\w$]+(?:\[[^\]]*\])?[ \t]+(?P<name>[\w$]+)[ \t]*\((?P<params>[^)]*)\)(?P<body>.*?)^[ \t]*ENDFCT\b",
                  re.IGNORECASE | re.MULTILINE | re.DOTALL)
_FIRST_DEF = re.compile(r"^[ \t]*(?:GLOBAL[ \t]+)?DEF(?:FCT[ \t]+[\w$]+(?:\[[^\]]*\])?)?[ \t]+([\w$]+)", re.IGNORECASE | re.MULTILINE)
MAX_DEPTH = 32  # nested calls followed; deeper (or recursion) is not evaluated
BUILTIN = {
    "SIN": lambda a: math.sin(math.radians(a)), "COS": lambda a: math.cos(math.radians(a)),
    "TAN": lambda a: math.tan(math.radians(a)), "SQRT": lambda a: math.sqrt(a) if a >= 0 else float("nan"),
    "ABS": abs, "ATAN2": lambda y, x: math.degrees(math.atan2(y, x)),
}


@dataclass
class Function:
    name: str
    where: str  # file:line of its DEFFCT
    params: list[str]
    statements: list = field(default_factory=list)  # parse trees, in order
    why: str | None = None  # why it is not evaluated (None: straight-line)


def read_functions(docs) -> dict[str, Function]:
    """Functions of the program's .src (all) and of other modules' .src (GLOBAL or main routine)."""
    out: dict[str, Function] = {}
    for doc in docs:
        if doc.role not in ("src", "module_src"):
            continue
        first = _FIRST_DEF.search(doc.text)
        for m in _FCT.finditer(doc.text):
            visible = doc.role == "src" or m.group("glob") or (first and first.group(1).upper() == m.group("name").upper())
            name = m.group("name").upper()
            if visible and (name not in out or out[name].why == _HIDDEN):
                out[name] = _function(doc, m)
            elif name not in out:  # seen only by its own module: named in the note
                out[name] = Function(name, _function(doc, m).where, [], why=_HIDDEN)
    return out


_HIDDEN = "declared without GLOBAL in another module (not its main routine), which other modules do not see"


def _function(doc, m) -> Function:
    lines = LineIndex(doc.text)
    params = [p.split(":")[0].strip().upper() for p in m.group("params").split(",") if p.strip()]
    outs = [p for p in m.group("params").split(",") if re.search(r":\s*OUT\b", p, re.IGNORECASE)]
    fn = Function(m.group("name").upper(), f"{doc.path}:{int(lines.line(m.start()))}", params)
    if outs:
        fn.why = "it has OUT parameters"
    start = m.start("body")
    for raw in doc.text[start:m.end("body")].split("\n"):
        code = raw.split(";")[0].rstrip("\r")
        if code.strip() and fn.why is None:
            tree = parse_statement(grammar("krl"), code, lines, doc.path, start, "KRL statement")
            fn.why = _not_straight(tree.children[0] if tree.children else None, fn)
            fn.statements.append(tree.children[0] if tree.children else None)
        start += len(raw) + 1
    if fn.why is None and not (fn.statements and isinstance(fn.statements[-1], Tree) and fn.statements[-1].data == "return_"):
        fn.why = "its last statement is not RETURN"
    return fn


def _not_straight(node, fn: Function) -> str | None:
    if node is None or (isinstance(node, Tree) and node.data == "decl"):
        return None
    if isinstance(node, Tree) and node.data == "assignment" and re.fullmatch(r"[A-Za-z_]\w*", _name(node.children[0]) or "$"):
        return None
    if isinstance(node, Tree) and node.data == "return_":
        return None
    what = node.data if isinstance(node, Tree) else str(node)
    return f"its body is not straight-line ({what})"


def _name(lvalue) -> str | None:
    return str(lvalue.children[0]) if isinstance(lvalue, Tree) and lvalue.data == "lvalue" and len(lvalue.children) == 1 else None


class Caller:
    """Evaluates calls for ``state.number`` and keeps a note of each call it could not."""

    def __init__(self, docs):
        self.docs = docs
        self._functions: dict[str, Function] | None = None  # read at the first call (most programs call none)
        self.notes: list[str] = []
        self.where = 0  # line of the statement being evaluated
        self._depth = 0

    @property
    def functions(self) -> dict[str, Function]:
        if self._functions is None:
            self._functions = read_functions(self.docs)
        return self._functions

    def __call__(self, node: Tree, lookup) -> float:
        name = str(node.children[0]).upper()
        args = [number(a.children[0], lookup, self) if isinstance(a, Tree) and a.children and a.children[0] is not None else float("nan")
                for a in node.children[1:] if a is not None]
        if name in BUILTIN:
            try:
                return float(BUILTIN[name](*args))
            except (TypeError, ValueError, OverflowError):
                return float("nan")
        fn = self.functions.get(name)
        why = self._why(fn, name, args)
        if why:
            self.notes.append(f"{self.where}: {name}(): {why}: what it sets is not known")
            return float("nan")
        return self._run(fn, dict(zip(fn.params, args)))

    def _why(self, fn: Function | None, name: str, args: list[float]) -> str | None:
        if fn is None:
            return "not a function of the given files (give its module with --data MODULE.src): not evaluated"
        if fn.why:
            return f"{fn.where}: {fn.why}: not evaluated"
        if len(args) != len(fn.params) or any(math.isnan(a) for a in args):
            return "its arguments are not known at post time: not evaluated"
        if self._depth >= MAX_DEPTH:
            return f"calls nested deeper than {MAX_DEPTH}: not evaluated"
        return None

    def _run(self, fn: Function, env: dict[str, float]) -> float:
        def lookup(text):
            return env.get(text, float("nan")) if text else float("nan")

        self._depth += 1
        try:
            for st in fn.statements:
                if isinstance(st, Tree) and st.data == "assignment":
                    env[_name(st.children[0]).upper()] = number(st.children[1], lookup, self)
                elif isinstance(st, Tree) and st.data == "return_":
                    expr = next((c for c in st.children if isinstance(c, Tree)), None)
                    return number(expr, lookup, self) if expr is not None else float("nan")
        finally:
            self._depth -= 1
        return float("nan")
