"""Compiled byte scanner: the free-standing numbers of a text, with exact values.

One sequential pass over the bytes finds each number's span (the same rules as the
grammars' number token: digits with an optional point and exponent, a unary sign, not
glued to a name) and reads its value. Values are correctly rounded: a number with at
most 15 significant digits and a decimal exponent within +-22 is an exact integer times
an exact power of ten (one rounding, Clinger's fast path); any other number is marked
for Python's own ``float``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# Characters that make a number part of an identifier (as str.isalnum() or '_$.').
WORD = np.array([chr(c).isalnum() or chr(c) in "_$." for c in range(256)], dtype=np.bool_)
_POW10 = np.array([10.0**k for k in range(23)])  # all exact in binary64

INVALID = 2  # status: not a number Python's float accepts -> NaN
SLOW = 1  # status: valid but outside the fast path -> Python float()


@njit(cache=True, inline="always")
def _is_digit(c):
    return 48 <= c <= 57


@njit(cache=True, inline="always")
def _is_letter(c):
    lower = c | 32
    return 97 <= lower <= 122


@njit(cache=True)
def _run_end(raw, i, n):
    """End of the number run starting at ``i`` (digits, points, exponent with its sign)."""
    j = i
    while j < n:
        c = raw[j]
        if _is_digit(c) or c == 46:
            j += 1
        elif (c == 101 or c == 69) and 1 <= j <= n - 2 and (_is_digit(raw[j - 1]) or raw[j - 1] == 46):
            nxt = raw[j + 1]
            if _is_digit(nxt):
                j += 1
            elif (nxt == 43 or nxt == 45) and j + 2 < n and _is_digit(raw[j + 2]):
                j += 2
            else:
                break
        else:
            break
    return j


@njit(cache=True)
def _value(raw, s, e, pow10):
    """(value, status) of raw[s:e]; status 0 exact, 1 needs Python's float, 2 invalid."""
    pos = s
    neg = False
    if raw[pos] == 45 or raw[pos] == 43:
        neg = raw[pos] == 45
        pos += 1
    mant = np.int64(0)
    digits = 0
    scale = 0
    seen_point = False
    any_digit = False
    while pos < e and raw[pos] != 101 and raw[pos] != 69:
        c = raw[pos]
        if _is_digit(c):
            any_digit = True
            if mant == 0 and c == 48:
                if seen_point:
                    scale -= 1
            elif digits < 18:
                mant = mant * 10 + (c - 48)
                digits += 1
                if seen_point:
                    scale -= 1
            else:
                digits += 1  # beyond int64: only Python can round it
                if not seen_point:
                    scale += 1
        elif c == 46:
            if seen_point:
                return np.nan, INVALID
            seen_point = True
        else:
            return np.nan, INVALID
        pos += 1
    if not any_digit:
        return np.nan, INVALID
    exponent = 0
    if pos < e:  # an exponent
        pos += 1
        exp_neg = False
        if pos < e and (raw[pos] == 45 or raw[pos] == 43):
            exp_neg = raw[pos] == 45
            pos += 1
        if pos >= e:
            return np.nan, INVALID
        while pos < e:
            c = raw[pos]
            if not _is_digit(c):
                return np.nan, INVALID
            if exponent < 100000:
                exponent = exponent * 10 + (c - 48)
            pos += 1
        if exp_neg:
            exponent = -exponent
    if mant == 0:
        return (-0.0 if neg else 0.0), 0
    power = exponent + scale
    if digits > 15 or power > 22 or power < -22:
        return np.nan, SLOW
    value = float(mant)
    value = value * pow10[power] if power >= 0 else value / pow10[-power]
    return (-value if neg else value), 0


@njit(cache=True)
def _scan(raw, word, letter_prefix, starts, ends, values, status, pow10):
    """Record the numbers of ``raw`` in the output arrays (sized for the most there can be); returns the count."""
    n = len(raw)
    count = 0
    i = 0
    while i < n:
        c = raw[i]
        if not (_is_digit(c) or c == 46):
            i += 1
            continue
        s = i
        e = _run_end(raw, i, n)
        i = e
        has_digit = False
        for k in range(s, e):
            if _is_digit(raw[k]):
                has_digit = True
                break
        if not has_digit:
            continue
        if s > 0:
            before = raw[s - 1]
            if word[before] and not (letter_prefix and _is_letter(before)):
                continue  # glued to a name: p10, tool0
            if before == 45 or before == 43:
                # A sign is the number's own unless it is a binary operator (after a
                # name, digit or ')'); G-code's X-10 keeps it after the word letter.
                binary = False
                if s - 1 > 0:
                    bs = raw[s - 2]
                    binary = (word[bs] and not (letter_prefix and _is_letter(bs))) or bs == 41
                if not binary:
                    s -= 1
        starts[count] = s
        ends[count] = e
        v, st = _value(raw, s, e, pow10)
        values[count] = v
        status[count] = st
        count += 1
    return count


def scan(raw: np.ndarray, letter_prefix: bool):
    """starts, ends (int64), values (float64), status (int8) of every number in ``raw``."""
    # Numbers are separated, so there are at most (n + 1) / 2; np.empty commits only the
    # pages the scan writes, so the generous size costs address space, not memory (and
    # the results are views: a copy would fault in every page a second time).
    size = (len(raw) + 1) // 2 + 1
    starts = np.empty(size, np.int64)
    ends = np.empty(size, np.int64)
    values = np.empty(size, np.float64)
    status = np.empty(size, np.int8)
    count = _scan(raw, WORD, letter_prefix, starts, ends, values, status, _POW10)
    return starts[:count], ends[:count], values[:count], status[:count]


@njit(cache=True)
def _prev_nonblank(raw, positions):
    out = np.empty(len(positions), np.int64)
    for k in range(len(positions)):
        j = positions[k]
        while j > 0 and (raw[j] == 32 or raw[j] == 9):
            j -= 1
        out[k] = j
    return out


def prev_nonblank(raw: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """For each position, the nearest index at or before it that is not a blank (0 if none)."""
    return _prev_nonblank(raw, np.maximum(np.asarray(positions, dtype=np.int64), 0))

