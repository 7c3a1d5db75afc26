"""Bulk line recognition by shape: a regular expression runs once per distinct line shape.

CAM output repeats a handful of line shapes a million times (``LIN {X 1.5,Y 2,...} C_DIS``
with other digits). A line's *shape* is its text with every run of digits shortened to
one digit ("0") or, for runs of two or more, two ("00"). The bulk regular expressions of
the KRL and RAPID parsers treat digit runs only through ``\\d+``, ``\\d*``, ``\\w*`` and
``[A-Za-z0-9]?`` (which tells one digit from more), so two lines of the same shape
either both match or both fail, and their groups cover the same shape positions. A
compiled pass computes every line's shape hash and digit runs; the regular expression
runs on one representative line per shape, and the group positions of every other line
follow from its digit-run lengths, vectorised. Lines whose shape differs from their
class representative's (a hash collision) are matched one by one.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from numba import njit

_FNV_OFFSET = np.uint64(0xCBF29CE484222325)
_FNV_PRIME = np.uint64(0x100000001B3)
_UNMAPPABLE = object()


@njit(cache=True)
def _shapes(raw, line_start, line_end, prime, offset):
    """Shape hash of each line, its first digit run, and every run's start and extra length."""
    n_lines = len(line_start)
    hashes = np.empty(n_lines, np.uint64)
    first_run = np.empty(n_lines + 1, np.int64)
    # Digit runs are separated, so there are at most (n + 1) / 2 of them (see scan_kernel).
    size = (len(raw) + 1) // 2 + 1
    run_start = np.empty(size, np.int64)
    extra = np.empty(size + 1, np.int64)  # cumulative: characters runs lose in their shape
    extra[0] = 0
    r = 0
    for li in range(n_lines):
        first_run[li] = r
        s = line_start[li]
        e = line_end[li]
        h = offset
        j = s
        while j < e:
            c = raw[j]
            if 48 <= c <= 57:
                k = j
                while k < e and 48 <= raw[k] <= 57:
                    k += 1
                h = (h ^ np.uint64(48)) * prime
                if k - j >= 2:
                    h = (h ^ np.uint64(48)) * prime
                run_start[r] = j
                extra[r + 1] = extra[r] + max(k - j - 2, 0)
                r += 1
                j = k
            else:
                h = (h ^ np.uint64(c)) * prime
                j += 1
        hashes[li] = h
    first_run[n_lines] = r
    return hashes, first_run, run_start[:r], extra[: r + 1]


@njit(cache=True)
def _same_shape(raw, a_start, a_end, b_start, b_end):
    """Whether two lines have the same shape (checks a hash match exactly)."""
    i, j = a_start, b_start
    while i < a_end and j < b_end:
        ca, cb = raw[i], raw[j]
        da, db = 48 <= ca <= 57, 48 <= cb <= 57
        if da != db:
            return False
        if da:
            ka = i
            while ka < a_end and 48 <= raw[ka] <= 57:
                ka += 1
            kb = j
            while kb < b_end and 48 <= raw[kb] <= 57:
                kb += 1
            if min(ka - i, 2) != min(kb - j, 2):
                return False
            i, j = ka, kb
        else:
            if ca != cb:
                return False
            i += 1
            j += 1
    return i == a_end and j == b_end


@njit(cache=True)
def _verify(raw, line_start, line_end, rep_of_line):
    ok = np.empty(len(line_start), np.bool_)
    for li in range(len(line_start)):
        r = rep_of_line[li]
        ok[li] = r == li or _same_shape(raw, line_start[r], line_end[r], line_start[li], line_end[li])
    return ok


@njit(cache=True)
def _map_groups(line_start, extra, first_run, lines, shapes, runs, pos, present):
    """(M, groups, 2) group spans of M lines from their shape's template: a boundary after
    k digit runs of the shape lies at its shape offset plus what those runs lost in the shape
    (one pass, without (M, groups, 2) temporaries for each step); -1 where a group is absent."""
    m, ng = len(lines), runs.shape[1]
    out = np.empty((m, ng, 2), np.int64)
    for i in range(m):
        li, s = lines[i], shapes[i]
        f = first_run[li]
        base = line_start[li] - extra[f]
        for g in range(ng):
            for side in range(2):
                out[i, g, side] = base + pos[s, g, side] + extra[f + runs[s, g, side]] if present[s, g] else -1
    return out


class LineShapes:
    """The lines of one text (without their '\\n'), grouped by shape."""

    def __init__(self, text: str, raw: np.ndarray, line_starts: np.ndarray):
        self.text = text
        self.raw = raw
        n = len(raw)
        self.line_start = np.asarray(line_starts, dtype=np.int64)
        ends = np.empty_like(self.line_start)
        ends[:-1] = self.line_start[1:] - 1
        if len(ends):
            ends[-1] = n
        self.line_end = ends
        self.hashes, self.first_run, self.run_start, self.extra = _shapes(raw, self.line_start, self.line_end, _FNV_PRIME, _FNV_OFFSET)
        first, self.shape_id = unique_runs(self.hashes)
        self.rep = first  # representative line of each shape
        self.exact = _verify(raw, self.line_start, self.line_end, first[self.shape_id])

    def match(self, regex: re.Pattern, lines: np.ndarray | None = None) -> "LineMatches":
        """The lines (all, or those given) that ``regex`` matches as a whole line, with group spans."""
        lines_given = lines
        lines = np.arange(len(self.line_start)) if lines is None else np.asarray(lines, dtype=np.int64)
        groups = list(regex.groupindex.items())
        ng = len(groups)
        shape = self.shape_id[lines]
        exact = self.exact[lines]
        # One match per shape: each group boundary as (digit runs before it, offset in the shape).
        n_shapes = len(self.rep)
        verdict = np.zeros(n_shapes, np.int8)  # 0 no match, 1 template, 2 match line by line
        runs = np.zeros((n_shapes, ng, 2), np.int64)
        pos = np.zeros((n_shapes, ng, 2), np.int64)
        present = np.zeros((n_shapes, ng), bool)
        # Every shape's representative is exact (it is its own rep): all lines cover all shapes.
        for s in (range(n_shapes) if lines_given is None else np.unique(shape[exact]).tolist()):
            template = self._template(regex, int(self.rep[s]), groups)
            if template is _UNMAPPABLE:
                verdict[s] = 2
            elif template is not None:
                verdict[s] = 1
                runs[s], pos[s], present[s] = template
        rows = np.nonzero(exact & (verdict[shape] == 1))[0]
        spans = _map_groups(self.line_start, self.extra, self.first_run, lines[rows], shape[rows], runs, pos, present)
        # Hash collisions and shapes a template cannot map: matched one by one.
        single = np.nonzero(~exact | (verdict[shape] == 2))[0]
        one_rows, one_spans = [], []
        for row in single.tolist():
            li = int(lines[row])
            m = regex.match(self.text, int(self.line_start[li]), int(self.line_end[li]))
            if m is not None and m.end() == self.line_end[li]:
                one_rows.append(row)
                one_spans.append([m.span(name) for name, _ in groups])
        if one_rows:
            rows = np.concatenate([rows, one_rows])
            spans = np.concatenate([spans, np.array(one_spans, dtype=np.int64).reshape(-1, ng, 2)])
            order = np.argsort(rows, kind="stable")
            rows, spans = rows[order], spans[order]
        keep = lines[rows]
        return LineMatches(self.text, self.raw, keep, self.line_start[keep], {name: spans[:, g] for g, (name, _) in enumerate(groups)})

    def _template(self, regex, li: int, groups):
        start, end = int(self.line_start[li]), int(self.line_end[li])
        m = regex.match(self.text, start, end)
        if m is None or m.end() != end:
            return None
        runs_lo, runs_hi = int(self.first_run[li]), int(self.first_run[li + 1])
        run_starts = self.run_start[runs_lo:runs_hi]
        ng = len(groups)
        runs = np.zeros((ng, 2), np.int64)
        pos = np.zeros((ng, 2), np.int64)
        present = np.zeros(ng, bool)
        for g, (name, _) in enumerate(groups):
            a, b = m.span(name)
            if a < 0:
                continue
            present[g] = True
            for side, q in enumerate((a, b)):
                k = int(np.searchsorted(run_starts, q, side="left"))  # runs that start before q
                if k and q < self._run_end(runs_lo + k - 1):
                    return _UNMAPPABLE  # a boundary inside a digit run
                runs[g, side] = k
                pos[g, side] = q - start - int(self.extra[runs_lo + k] - self.extra[runs_lo])
        return runs, pos, present

    def _run_end(self, r: int) -> int:
        j = int(self.run_start[r])
        raw = self.raw
        while j < len(raw) and 48 <= raw[j] <= 57:
            j += 1
        return j


@dataclass(frozen=True)
class LineMatches:
    """Whole-line matches of one regular expression: line numbers (0-based), starts, group spans."""

    text: str
    raw: np.ndarray
    line: np.ndarray
    start: np.ndarray
    spans: dict[str, np.ndarray]

    def __len__(self) -> int:
        return len(self.line)

    def span(self, group: str) -> tuple[np.ndarray, np.ndarray]:
        s = self.spans[group]
        return s[:, 0], s[:, 1]

    def present(self, group: str) -> np.ndarray:
        return self.spans[group][:, 0] >= 0

    def group(self, group: str) -> list:
        """The text of a group on every matched line (None where it did not take part)."""
        text = self.text
        return [text[a:b] if a >= 0 else None for a, b in self.spans[group].tolist()]

    def factorize(self, group: str) -> tuple[np.ndarray, list]:
        """Codes and distinct texts of a group, up to case and blanks (see factorize_spans)."""
        return factorize_spans(self.text, self.raw, self.spans[group])

    def subset(self, mask: np.ndarray) -> "LineMatches":
        return LineMatches(self.text, self.raw, self.line[mask], self.start[mask], {k: v[mask] for k, v in self.spans.items()})


@njit(cache=True)
def _fold(c):
    """Case- and blank-insensitive byte: lower-case letters as upper case; 0 for a blank."""
    if c == 32 or c == 9:
        return 0
    if 97 <= c <= 122:
        return c - 32
    return c


@njit(cache=True)
def _same_as_rep(raw, spans, rep):
    """Whether span i equals span rep[i] up to case and blanks (both absent, -1, counts as equal)."""
    ok = np.empty(len(spans), np.bool_)
    for i in range(len(spans)):
        r = rep[i]
        if spans[i, 0] < 0 or spans[r, 0] < 0:
            ok[i] = spans[i, 0] < 0 and spans[r, 0] < 0
        else:
            ok[i] = r == i or _same_folded(raw, spans[i, 0], spans[i, 1], raw, spans[r, 0], spans[r, 1])
    return ok


@njit(cache=True)
def _span_hashes(raw, spans, prime, offset):
    """FNV hash of each span up to case and blanks; 0 for an absent span (-1)."""
    out = np.empty(len(spans), np.uint64)
    for i in range(len(spans)):
        if spans[i, 0] < 0:
            out[i] = 0
            continue
        h = offset
        for j in range(spans[i, 0], spans[i, 1]):
            c = _fold(raw[j])
            if c != 0:
                h = (h ^ np.uint64(c)) * prime
        out[i] = h
    return out


@njit(cache=True)
def same_folded_pairs(raw_a, spans_a, raw_b, spans_b):
    """Whether span i of raw_a equals span i of raw_b up to case and blanks, for every i."""
    ok = np.empty(len(spans_a), np.bool_)
    for i in range(len(spans_a)):
        ok[i] = _same_folded(raw_a, spans_a[i, 0], spans_a[i, 1], raw_b, spans_b[i, 0], spans_b[i, 1])
    return ok


@njit(cache=True)
def _same_folded(raw_a, a, ae, raw_b, b, be):
    while True:
        while a < ae and _fold(raw_a[a]) == 0:
            a += 1
        while b < be and _fold(raw_b[b]) == 0:
            b += 1
        if a == ae or b == be:
            return a == ae and b == be
        if _fold(raw_a[a]) != _fold(raw_b[b]):
            return False
        a += 1
        b += 1


def factorize_spans(text: str, raw: np.ndarray, spans: np.ndarray) -> tuple[np.ndarray, list]:
    """Codes and distinct texts of many spans, equal up to case and blanks (RAPID and KRL
    names are case-insensitive). A span of -1 (a group that did not take part) gets the
    text None. Returns (codes (M,), texts): texts[codes[i]] is span i's text up to case
    and blanks (the first occurrence's spelling)."""
    spans = np.asarray(spans, dtype=np.int64).reshape(-1, 2)
    absent = spans[:, 0] < 0
    # Absent rows hash to 0 like any present span that hashes to 0; the check below
    # sends such a row (and any other collision) to a class of its own.
    first, inverse = unique_runs(_span_hashes(raw, spans, _FNV_PRIME, _FNV_OFFSET))
    ok = _same_as_rep(raw, spans, first[inverse])
    texts = [None if absent[r] else text[spans[r, 0] : spans[r, 1]] for r in first.tolist()]
    codes = inverse.astype(np.int64)
    # A hash collision (never seen, but possible): those rows get classes of their own.
    for i in np.nonzero(~ok)[0].tolist():
        own = None if absent[i] else text[spans[i, 0] : spans[i, 1]]
        key = None if own is None else own.upper().replace(" ", "").replace("\t", "")
        for k, t in enumerate(texts):
            if (t is None and key is None) or (t is not None and key is not None and t.upper().replace(" ", "").replace("\t", "") == key):
                codes[i] = k
                break
        else:
            codes[i] = len(texts)
            texts.append(own)
    return codes, texts


def unique_runs(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(first, inverse) of np.unique(keys, return_index=True, return_inverse=True), sorting
    only the runs of equal consecutive keys: CAM output repeats one line shape or one tool
    name over long runs, so a million keys often make a few runs and no sort of a million."""
    keys = np.asarray(keys).reshape(-1)
    if len(keys) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    starts = np.flatnonzero(np.concatenate([[True], keys[1:] != keys[:-1]]))
    _, first_run, run_inverse = np.unique(keys[starts], return_index=True, return_inverse=True)
    lengths = np.diff(np.append(starts, len(keys)))
    return starts[first_run], np.repeat(run_inverse.reshape(-1), lengths)
