"""Name -> row lookup for a million declared points, without a Python loop per name.

KRL names are case-insensitive and may have blanks inside brackets (``XP[ 1 ]``). Each
name is hashed (folded: upper case, blanks skipped) by a compiled kernel; a lookup is a
binary search on the hashes and a byte-for-byte check of the folded names, so a hash
collision can never join two different names. A later declaration of a name replaces
an earlier one, as in the controller.
"""

from __future__ import annotations

import numpy as np

from .common import _ranges
from .line_shapes import _FNV_OFFSET, _FNV_PRIME, _span_hashes, same_folded_pairs


def _encode(names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Names -> one byte buffer and their (start, end) spans in it."""
    data = "".join(names).encode("latin-1")
    lengths = np.array([len(n) for n in names], dtype=np.int64)
    ends = np.cumsum(lengths)
    return np.frombuffer(data, dtype=np.uint8), np.stack([ends - lengths, ends], axis=1)


class NameTable:
    """Rows 0..count-1, each with a name; ``rows`` finds the last row of each name."""

    def __init__(self):
        self._heap: list[np.ndarray] = []  # name bytes, block by block
        self._spans: list[np.ndarray] = []  # (M, 2) spans into the joined heap
        self._hashes: list[np.ndarray] = []
        self._size = 0  # bytes in the heap so far
        self.count = 0
        self._index = None

    def add_spans(self, raw: np.ndarray, spans: np.ndarray) -> None:
        """Names given as spans of a text's bytes."""
        spans = np.ascontiguousarray(spans, dtype=np.int64).reshape(-1, 2)
        self._hashes.append(_span_hashes(raw, spans, _FNV_PRIME, _FNV_OFFSET))
        self._heap.append(raw[_ranges(spans[:, 0], spans[:, 1])])
        lengths = spans[:, 1] - spans[:, 0]
        ends = self._size + np.cumsum(lengths)
        self._spans.append(np.stack([ends - lengths, ends], axis=1))
        self._size += int(lengths.sum())
        self.count += len(spans)
        self._index = None

    def add(self, names: list[str]) -> None:
        if names:
            self.add_spans(*_encode(names))

    def _joined(self):
        if self._index is None:
            heap = np.concatenate(self._heap) if self._heap else np.zeros(0, np.uint8)
            spans = np.concatenate(self._spans) if self._spans else np.zeros((0, 2), np.int64)
            hashes = np.concatenate(self._hashes) if self._hashes else np.zeros(0, np.uint64)
            order = np.lexsort((np.arange(len(hashes)), hashes))
            sorted_h = hashes[order]
            last = np.ones(len(order), bool)  # the last row of each hash (a later declaration wins)
            last[:-1] = sorted_h[1:] != sorted_h[:-1]
            self._index = (heap, spans, hashes, sorted_h[last], order[last])
        return self._index

    def rows_of_spans(self, raw: np.ndarray, spans: np.ndarray) -> np.ndarray:
        """Row of each named span; ``count`` (one past the last row) where a name is not declared."""
        spans = np.ascontiguousarray(spans, dtype=np.int64).reshape(-1, 2)
        heap, heap_spans, hashes, keys, key_rows = self._joined()
        out = np.full(len(spans), self.count, dtype=np.int64)
        if not len(keys) or not len(spans):
            return out
        h = _span_hashes(raw, spans, _FNV_PRIME, _FNV_OFFSET)
        pos = np.minimum(np.searchsorted(keys, h), len(keys) - 1)
        hit = keys[pos] == h
        cand = key_rows[pos]
        same = np.zeros(len(spans), bool)
        rows = np.nonzero(hit)[0]
        same[rows] = same_folded_pairs(raw, spans[rows], heap, heap_spans[cand[rows]])
        out[same] = cand[same]
        # Same hash, different name (a collision): look through that hash's rows, last first.
        for i in np.nonzero(hit & ~same)[0].tolist():
            for r in np.nonzero(hashes == h[i])[0][::-1].tolist():
                if same_folded_pairs(raw, spans[i : i + 1], heap, heap_spans[r : r + 1])[0]:
                    out[i] = r
                    break
        return out

    def rows(self, names: list[str]) -> np.ndarray:
        if not names:
            return np.zeros(0, np.int64)
        return self.rows_of_spans(*_encode(names))
