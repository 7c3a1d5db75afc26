"""Compiled number writing and splicing for programs with a million changed numbers.

A number is written as Python's ``format(value, f".{d}f")`` would write it: the value
times 10^d is rounded half-to-even to an integer, and where the binary product could sit
on the other side of a half from the exact one, Python itself writes the number (so the
digits are always the correctly rounded ones). The splice kernel then copies the source
bytes with every edit in place: a number in its original style (a '+' kept, a trailing
point, no leading zero) or a literal piece of text.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_POW10 = np.array([10.0**k for k in range(23)])
_EXACT_INT = 2.0**53


def round_digits(values: np.ndarray, decimals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(digits, negative, too_big): |value| * 10^d rounded as Python's format rounds it, as
    an integer; ``too_big`` marks numbers whose digits do not fit 63 bits (digits 0 there)."""
    values = np.asarray(values, dtype=float)
    scaled = np.abs(values) * _POW10[decimals]
    too_big = ~(scaled < 9e18)
    scaled = np.where(too_big, 0.0, scaled)
    digits = np.rint(scaled)  # half to even, as the correctly rounded conversion
    frac = scaled - np.floor(scaled)
    # The product carries at most one rounding (half an ulp): only within a few ulps of a
    # half, or beyond exact integers, can the exact decimal round the other way.
    unsure = (np.abs(frac - 0.5) <= 4 * np.spacing(scaled)) | ~(scaled < _EXACT_INT)
    digits = digits.astype(np.int64)
    for i in np.nonzero(unsure & ~too_big)[0].tolist():
        text = format(abs(float(values[i])), f".{int(decimals[i])}f")
        digits[i] = int(text.replace(".", ""))
    return digits, (values < 0) & (digits != 0), too_big  # no "-0.000"


@njit(cache=True)
def _number_length(digits, decimals, negative, plus, dot_style, no_lead_zero):
    int_part = digits
    for _ in range(decimals):
        int_part //= 10
    n_int = 1
    v = int_part
    while v >= 10:
        v //= 10
        n_int += 1
    length = n_int + decimals + (1 if decimals > 0 else 0)
    if decimals == 0 and dot_style:
        length += 1
    if negative or plus:
        length += 1
    if no_lead_zero and int_part == 0 and decimals > 0:
        length -= 1
    return length


@njit(cache=True)
def _write_number(out, at, digits, decimals, negative, plus, dot_style, no_lead_zero):
    length = _number_length(digits, decimals, negative, plus, dot_style, no_lead_zero)
    end = at + length
    pos = end
    if decimals == 0 and dot_style:
        pos -= 1
        out[pos] = 46
    v = digits
    for _ in range(decimals):
        pos -= 1
        out[pos] = 48 + v % 10
        v //= 10
    if decimals > 0:
        pos -= 1
        out[pos] = 46
    if not (no_lead_zero and v == 0 and decimals > 0):
        while True:
            pos -= 1
            out[pos] = 48 + v % 10
            v //= 10
            if v == 0:
                break
    if negative:
        pos -= 1
        out[pos] = 45
    elif plus:
        pos -= 1
        out[pos] = 43
    return end


@njit(cache=True)
def _splice(src, starts, ends, literal, lit_start, lit_end, lit_bytes, digits, decimals, negative, plus, dot_style, no_lead_zero):
    """src with each [starts[i], ends[i]) replaced (edits sorted, not overlapping)."""
    total = len(src)
    for i in range(len(starts)):
        if literal[i]:
            total += lit_end[i] - lit_start[i]
        else:
            total += _number_length(digits[i], decimals[i], negative[i], plus[i], dot_style[i], no_lead_zero[i])
        total -= ends[i] - starts[i]
    out = np.empty(total, np.uint8)
    pos = 0
    at = 0
    for i in range(len(starts)):
        n = starts[i] - pos
        out[at : at + n] = src[pos : starts[i]]
        at += n
        if literal[i]:
            m = lit_end[i] - lit_start[i]
            out[at : at + m] = lit_bytes[lit_start[i] : lit_end[i]]
            at += m
        else:
            at = _write_number(out, at, digits[i], decimals[i], negative[i], plus[i], dot_style[i], no_lead_zero[i])
        pos = ends[i]
    out[at:] = src[pos:]
    return out


def number_text(digits: int, decimals: int, negative: bool, plus: bool = False, dot_style: bool = False, no_lead_zero: bool = False) -> str:
    """One number as the splice kernel writes it (for messages and checks)."""
    out = np.empty(40, np.uint8)
    end = _write_number(out, 0, digits, decimals, negative, plus, dot_style, no_lead_zero)
    return out[:end].tobytes().decode("latin-1")


@njit(cache=True)
def _styles(raw, starts, ends):
    """Per old number: leading '+', no leading zero ('.5'), a point anywhere, an exponent,
    and its decimals (digits after the point, 0 with an exponent)."""
    n = len(starts)
    plus = np.zeros(n, np.bool_)
    no_lead_zero = np.zeros(n, np.bool_)
    dot_style = np.zeros(n, np.bool_)
    decimals = np.zeros(n, np.int64)
    for i in range(n):
        s, e = starts[i], ends[i]
        if s >= e:
            continue
        plus[i] = raw[s] == 43
        body = s + 1 if raw[s] == 43 or raw[s] == 45 else s
        no_lead_zero[i] = body < e and raw[body] == 46
        dot = -1
        exponent = False
        for j in range(s, e):
            if raw[j] == 46 and dot < 0:
                dot = j
            elif raw[j] == 101 or raw[j] == 69:
                exponent = True
        dot_style[i] = dot >= 0
        if dot >= 0 and not exponent:
            decimals[i] = e - dot - 1
    return plus, no_lead_zero, dot_style, decimals


def old_styles(raw: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> dict:
    """Style of the numbers being replaced (see _styles), as arrays."""
    plus, no_lead_zero, dot_style, decimals = _styles(raw, np.asarray(starts, np.int64), np.asarray(ends, np.int64))
    return {"plus": plus, "no_lead_zero": no_lead_zero, "dot_style": dot_style, "old_decimals": decimals}


def splice_bytes(src: bytes, starts, ends, numbers: dict, literals: dict[int, str]) -> bytes:
    """Apply edits to ``src``: edit i is the literal text ``literals[i]`` where given, else
    the number of the arrays in ``numbers`` (digits, decimals, negative, plus, dot_style,
    no_lead_zero) at index i. Edits must be sorted and must not overlap."""
    starts = np.asarray(starts, dtype=np.int64)
    ends = np.asarray(ends, dtype=np.int64)
    n = len(starts)
    literal = np.zeros(n, np.bool_)
    lengths = np.zeros(n, np.int64)
    pieces = []
    for i, text in sorted(literals.items()):
        piece = text.encode("latin-1")
        literal[i] = True
        lengths[i] = len(piece)
        pieces.append(piece)
    lit_end = np.cumsum(lengths)
    lit_start = lit_end - lengths
    lit_bytes = np.frombuffer(b"".join(pieces) + b"\0", dtype=np.uint8)
    raw = np.frombuffer(src + b"\0", dtype=np.uint8)[: len(src)]
    cols = [np.ascontiguousarray(numbers[k]) for k in ("digits", "decimals")]
    flags = [np.ascontiguousarray(numbers[k], dtype=np.bool_) for k in ("negative", "plus", "dot_style", "no_lead_zero")]
    out = _splice(raw, starts, ends, literal, lit_start, lit_end, lit_bytes, cols[0].astype(np.int64), cols[1].astype(np.int64), *flags)
    return out.tobytes()
