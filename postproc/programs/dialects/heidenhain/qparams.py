"""Q-parameter arithmetic as the TNC evaluates it (TNC 640 User's Manual, "Programming Q
parameters": "Basic arithmetic (FN 0 .. FN 5)", "Trigonometric functions (FN 6 .. FN 8,
FN 13)", "Formula entry").

A value is a float; NaN stands for a parameter whose value the program text does not
determine (set by FN 18 SYSREAD, or never set: the TNC keeps Q parameters across programs).
Formulas follow the manual's rules: ``^`` before ``*`` ``/`` before ``+`` ``-``, a function
applies to the value or bracket after it, angles in degrees, INT truncates.
``FN k: Qn = ...`` is the same arithmetic in a fixed form and is rewritten to a formula.
"""

from __future__ import annotations

import math
import re

from postproc.errors import InputError

QNAME = r"Q[LR]?\d+"
_TOKEN = re.compile(rf"\s*(?:(?P<num>\d+\.?\d*|\.\d+)|(?P<q>{QNAME})|(?P<name>SQRT|SQ|SIN|COS|TAN|ASIN|ACOS|ATAN|INT|ABS|NEG|FRAC|LN|LOG|EXP|SGN|PI|DIV|LEN)|(?P<op>[-+*/^()]))",
                    re.IGNORECASE)
_FUNCS = {
    "SQRT": math.sqrt, "SQ": lambda v: v * v, "SIN": lambda v: math.sin(math.radians(v)), "COS": lambda v: math.cos(math.radians(v)),
    "TAN": lambda v: math.tan(math.radians(v)), "ASIN": lambda v: math.degrees(math.asin(v)), "ACOS": lambda v: math.degrees(math.acos(v)),
    "ATAN": lambda v: math.degrees(math.atan(v)), "INT": lambda v: float(math.trunc(v)), "ABS": abs, "NEG": lambda v: -v,
    "FRAC": lambda v: v - math.trunc(v), "LN": math.log, "LOG": math.log10, "EXP": math.exp,
    "SGN": lambda v: float((v > 0) - (v < 0)),
}
# FN k: Qn = a OP b (TNC 640 manual, "Basic arithmetic", "Trigonometric functions"): as a formula
_FN_FORM = {0: "{a}", 1: "{a} + {b}", 2: "{a} - {b}", 3: "{a} * {b}", 4: "{a} / {b}", 5: "SQRT({a})", 6: "SIN({a})", 7: "COS({a})",
            8: "SQRT(SQ({a}) + SQ({b}))"}
_FN_OPERANDS = {1: "+", 2: "-", 3: "*", 4: "DIV", 8: "LEN"}  # FN 13 (ANG): the operand order is not read; refused


class FormulaError(InputError):
    """A formula the TNC would reject, or one this reader does not evaluate; ``at`` is the
    offset in the formula text."""

    def __init__(self, at: int, message: str):
        self.at = at
        super().__init__(message)


class Formula:
    """Recursive descent over one formula's tokens; ``q`` maps parameter names to values."""

    def __init__(self, text: str, q: dict[str, float]):
        self.q = q
        self.tokens: list[tuple[str, str, int]] = []
        pos = 0
        while pos < len(text.rstrip()):
            m = _TOKEN.match(text, pos)
            if not m or m.end() == pos:
                raise FormulaError(pos + len(text[pos:]) - len(text[pos:].lstrip()), "not a Q-parameter formula the TNC evaluates")
            kind = m.lastgroup
            self.tokens.append((kind, m.group(kind).upper(), m.start(kind)))
            pos = m.end()
        self.i = 0
        self.used: list[str] = []  # the parameters read

    def value(self) -> float:
        if not self.tokens:
            raise FormulaError(0, "empty formula")
        v = self._sum()
        if self.i < len(self.tokens):
            raise FormulaError(self.tokens[self.i][2], "unexpected token in the formula")
        return v

    def _peek(self) -> tuple[str, str, int] | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def _take(self, text: str) -> bool:
        t = self._peek()
        if t is not None and t[1] == text:
            self.i += 1
            return True
        return False

    def _sum(self) -> float:
        v = self._product()
        while True:
            if self._take("+"):
                v = v + self._product()
            elif self._take("-"):
                v = v - self._product()
            else:
                return v

    def _product(self) -> float:
        v = self._power()
        while True:
            t = self._peek()
            if self._take("*"):
                v = v * self._power()
            elif self._take("/") or self._take("DIV"):
                d = self._power()
                if d == 0:
                    raise FormulaError(t[2], "division by zero (the TNC stops with an error here)")
                v = v / d
            elif self._take("LEN"):
                v = math.hypot(v, self._power())
            else:
                return v

    def _power(self) -> float:
        v = self._unary()
        if self._take("^"):
            return v ** self._power()
        return v

    def _unary(self) -> float:
        if self._take("-"):
            return -self._unary()
        if self._take("+"):
            return self._unary()
        return self._atom()

    def _atom(self) -> float:
        t = self._peek()
        if t is None:
            raise FormulaError(len(self.tokens) and self.tokens[-1][2], "the formula ends too early")
        kind, text, at = t
        self.i += 1
        if kind == "num":
            return float(text)
        if kind == "q":
            self.used.append(text)
            return self.q.get(text, math.nan)
        if text == "(":
            v = self._sum()
            if not self._take(")"):
                raise FormulaError(at, "bracket not closed")
            return v
        if text == "PI":
            return math.pi
        if text in _FUNCS:
            arg = self._unary()
            try:
                return _FUNCS[text](arg) if not math.isnan(arg) else math.nan
            except (ValueError, OverflowError):
                raise FormulaError(at, f"{text} of {arg:g} is not defined (the TNC stops with an error here)") from None
        raise FormulaError(at, f"'{text}' cannot start a value")


def evaluate(text: str, q: dict[str, float]) -> tuple[float, list[str]]:
    """(value, parameters read) of a formula; NaN where a parameter read is not known."""
    f = Formula(text, q)
    return f.value(), f.used


FN_RE = re.compile(rf"FN\s*(\d+)\s*:\s*({QNAME})\s*=\s*(.*)$", re.IGNORECASE)
ASSIGN_RE = re.compile(rf"({QNAME})\s*=\s*(.*)$", re.IGNORECASE)


def fn_as_formula(number: int, rhs: str, at: int) -> str:
    """The right-hand side of ``FN number: Qn = rhs`` as a formula (the manual's FN forms)."""
    if number not in _FN_FORM:
        raise FormulaError(at, f"FN {number} is not arithmetic this reader evaluates")
    if number in _FN_OPERANDS:
        op = _FN_OPERANDS[number]
        m = re.match(rf"(.*?\S)\s*{re.escape(op)}\s*(.+)$", rhs) if op in "+-*" else re.match(rf"(.*?)\s+{op}\s+(.+)$", rhs, re.IGNORECASE)
        if not m:
            raise FormulaError(at, f"FN {number} needs two operands joined by {op}")
        a, b = m.group(1), m.group(2)
        return _FN_FORM[number].format(a=f"({a})", b=f"({b})")
    rhs = re.sub(r"^(SQRT|SIN|COS)\s*", "", rhs.strip(), flags=re.IGNORECASE) if number in (5, 6, 7) else rhs
    return _FN_FORM[number].format(a=f"({rhs})", b="")
