"""The output check without a whole re-parse, where it reads exactly what a re-parse would.

``programs.check_texts`` re-parses the new text and compares every compensated target's
position with the compensated value. When the splice changed nothing but the position
numbers of absolute targets in the main file, a re-parse can differ from the original
parse only in those numbers, so reading them back is the same check at a fraction of the
cost. ``positions_read_back`` walks the original and the new bytes together (compiled, one
pass) and asks of the new text:

- every byte outside the position numbers is the original's, in order, and the text ends
  where the original does (so the statements, the count of targets and every other number
  are the same);
- every position number is one number token by the parser's own rules (``scan_kernel``'s
  run and its exact value path) and, times the field's scale, is within the writing
  tolerance of the compensated position, for every target that uses it.

It also confirms, on the original text, that each position number times its scale is the
value the parser gave (the IR's contract the splice writes by); where that, or anything
above, does not hold, or the program has what reads a number in context (increments,
offsets, inherited axes, arcs, numbers in other files), it answers False and the caller
re-parses the whole text as before. It never answers True where a re-parse would fail.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..ir import F_ARC, F_POS, Kind, Toolpath
from ..parse.scan_kernel import _POW10, _run_end, _value

_REL = 1e-12  # the original's numbers must read back as the parser's values to rounding


@njit(cache=True)
def _walk(old, new, starts, ends, pow10):
    """(ok, old values, new values) of the spans (sorted, disjoint) walked in both texts."""
    m = len(starts)
    old_values = np.full(m, np.nan)
    new_values = np.full(m, np.nan)
    o = 0
    n = 0
    for k in range(m):
        s, e = starts[k], ends[k]
        gap = s - o
        if s < o or n + gap > len(new):
            return False, old_values, new_values
        for i in range(gap):
            if new[n + i] != old[o + i]:
                return False, old_values, new_values
        n += gap
        value, status = _value(old, s, e, pow10)
        if status != 0:
            return False, old_values, new_values
        old_values[k] = value
        t = n + 1 if n < len(new) and (new[n] == 45 or new[n] == 43) else n
        t_end = _run_end(new, t, len(new))
        if t_end == t:
            return False, old_values, new_values
        value, status = _value(new, n, t_end, pow10)
        if status != 0:
            return False, old_values, new_values
        new_values[k] = value
        n = t_end
        o = e
    rest = len(old) - o
    if len(new) - n != rest:
        return False, old_values, new_values
    for i in range(rest):
        if new[n + i] != old[o + i]:
            return False, old_values, new_values
    return True, old_values, new_values


def _applies(original: Toolpath, modified: Toolpath, texts: list[str], rows: np.ndarray) -> bool:
    """Only what reads each number on its own: absolute targets, no offsets or arcs, every
    checked position written in the main file, the other files unchanged."""
    if len(texts) != len(original.sources) or any(t != d.text for t, d in zip(texts[1:], original.sources[1:])):
        return False
    if original.relative.any() or (original.offset_span is not None and (original.offset_span[:, F_POS, 1] >= 0).any()):
        return False
    if np.isin(original.kind, (Kind.ARC_CW, Kind.ARC_CCW)).any() or modified.arc is not None and not np.isnan(modified.values[:, F_ARC]).all():
        return False
    pos = original.spans[:, F_POS][rows]  # the position columns only (spans has every field's)
    return bool(((pos[:, :, 0] == 0) & (pos[:, :, 1] >= 0)).all())


def positions_read_back(original: Toolpath, modified: Toolpath, texts: list[str], rows: np.ndarray, tol) -> bool:
    """True: the new main text reads back, by the checks in the module docstring, with every
    position of ``rows`` within ``tol`` (mm; one, or one per axis) of ``modified``'s. False:
    not shown this way (the caller re-parses). Other numbers lie in the stretches that must
    be the original's bytes (the re-parse does not compare them either)."""
    if not _applies(original, modified, texts, rows):
        return False
    spans = original.spans[:, F_POS]
    written = (spans[:, :, 0] == 0) & (spans[:, :, 1] >= 0)
    r, f = np.nonzero(written)
    if len(r) == written.size:  # every position number in the main file (a CAM program): the flat arrays, in nonzero's order

        def at(a):
            return np.ascontiguousarray(a).reshape(-1)
    else:

        def at(a):
            return a[r, f]
    starts, ends = at(spans[:, :, 1]).astype(np.int64), at(spans[:, :, 2]).astype(np.int64)
    if len(starts) > 1 and (starts[1:] > starts[:-1]).all():
        uniq, span_ends, k = starts, ends, np.arange(len(starts))  # each number read once, in order (no sort)
    else:
        uniq, first, k = np.unique(starts, return_index=True, return_inverse=True)
        span_ends = ends[first]
        if (ends != span_ends[k]).any():
            return False  # one number read with two lengths
    old = np.frombuffer(original.sources[0].text.encode("latin-1"), dtype=np.uint8)
    new = np.frombuffer(texts[0].encode("latin-1"), dtype=np.uint8)
    ok, old_values, new_values = _walk(old, new, uniq, span_ends, _POW10)
    if not ok:
        return False
    offset = at(original.offset[:, F_POS]) if original.offset is not None else 0.0
    scale = at(original.scale[:, F_POS])
    as_read = old_values[k] * scale + offset
    parsed, placed = at(original.values[:, F_POS]), at(original.position)
    near = _REL * np.maximum(1.0, np.abs(parsed))
    if not ((np.abs(as_read - parsed) <= near) & (np.abs(as_read - placed) <= near)).all():
        return False  # the parser reads these numbers otherwise than number x scale
    got = new_values[k] * scale + offset
    checked = np.zeros(len(original), dtype=bool)
    checked[rows] = True
    c = checked[r]
    tol = np.broadcast_to(np.asarray(tol, dtype=float), (3,))[f[c]]  # one for all axes, or one per axis
    return bool((np.abs(got[c] - modified.position[r[c], f[c]]) <= tol).all())
