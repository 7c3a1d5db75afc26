"""Emit a modified Toolpath by splicing its changed numbers into the original text.

Only numbers of targets whose values changed are rewritten, each in place of the old
number, keeping its style (sign, leading zero) and at least its number of decimals
(more where those would round the new value by more than the field's tolerance). A
component the text leaves out (``LIN {X 10}``, a G-code axis word kept modal) is inserted
where the dialect allows. Everything else — comments, spacing, line endings, encoding —
is the original byte for byte.
"""

from __future__ import annotations

import numpy as np

from ..errors import EmitError
from ..ir import F_POS, FIELDS, Toolpath
from . import number_kernel

# Largest rounding error accepted when writing a field (mm for positions, degrees for
# angles, unit quaternion components).
TOLERANCE = np.array([5e-4] * 3 + [5e-7] * 4 + [5e-5] * 6 + [5e-4] * 6)
MAX_DECIMALS = 9


def format_like(old: str, value: float, tol: float) -> str:
    """Write value in the style of ``old`` with as many decimals as the tolerance needs."""
    body = old.lstrip("+-")
    decimals = len(body.split(".", 1)[1]) if "." in body and "e" not in body.lower() else 0
    for d in range(decimals, MAX_DECIMALS + 1):
        if abs(round(value, d) - value) <= tol:
            decimals = d
            break
    else:
        decimals = MAX_DECIMALS
    text = f"{value:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]  # no "-0.000"
    had_dot_style = "." in body
    if decimals == 0 and had_dot_style:
        text += "."
    if old.startswith("+") and not text.startswith("-"):
        text = "+" + text
    if body.startswith(".") and text.lstrip("+-").startswith("0."):
        sign = text[0] if text[0] in "+-" else ""
        text = sign + text.lstrip("+-")[1:]
    return text


def choose_decimals(values: np.ndarray, tol: np.ndarray, old_decimals: np.ndarray) -> np.ndarray:
    """Fewest decimals, at least the old number's, that write each value within its tolerance."""
    decimals = np.full(len(values), MAX_DECIMALS)
    undecided = np.ones(len(values), dtype=bool)
    for d in range(0, MAX_DECIMALS + 1):
        ok = undecided & (d >= old_decimals) & (np.abs(np.round(values, d) - values) <= tol)
        decimals[ok] = d
        undecided &= ~ok
        if not undecided.any():
            break
    return decimals


class _BulkEdits:
    """The changed numbers of targets, as arrays: where they are, and how to write them."""

    COLUMNS = ("digits", "decimals", "negative", "plus", "dot_style", "no_lead_zero")

    def __init__(self, original: Toolpath, rows, fields, values, tol):
        spans = original.spans[rows, fields]
        self.file, self.start, self.end = spans[:, 0], spans[:, 1], spans[:, 2]
        self.rows, self.fields = rows, fields
        style = {k: np.zeros(len(rows), bool) for k in ("plus", "no_lead_zero", "dot_style")}
        old_decimals = np.zeros(len(rows), np.int64)
        for f in np.unique(self.file).tolist():
            sel = self.file == f
            raw = np.frombuffer(original.sources[f].text.encode("latin-1"), dtype=np.uint8)
            got = number_kernel.old_styles(raw, self.start[sel], self.end[sel])
            for k in style:
                style[k][sel] = got[k]
            old_decimals[sel] = got["old_decimals"]
        self.decimals = choose_decimals(values, tol, old_decimals)
        self.digits, self.negative, too_big = number_kernel.round_digits(values, self.decimals)
        self.plus, self.no_lead_zero, self.dot_style = style["plus"], style["no_lead_zero"], style["dot_style"]
        # Numbers with more than 18 digits are written by Python (as literal edits).
        self.literal = {i: format_like(original.sources[int(self.file[i])].text[self.start[i] : self.end[i]], float(values[i]), float(tol[i])) for i in np.nonzero(too_big)[0].tolist()}
        self.key = self.file * (1 << 40) + self.start
        self._sorted = None

    def written(self) -> np.ndarray:
        """The value each new text reads back as (float of the written digits, exactly)."""
        out = np.where(self.negative, -1.0, 1.0) * self.digits / (10.0**self.decimals)
        for i, text in self.literal.items():
            out[i] = float(text)
        return out

    def text(self, i: int) -> str:
        if i in self.literal:
            return self.literal[i]
        return number_kernel.number_text(int(self.digits[i]), int(self.decimals[i]), bool(self.negative[i]), bool(self.plus[i]), bool(self.dot_style[i]), bool(self.no_lead_zero[i]))

    def refuse_conflicts(self, original: Toolpath) -> None:
        """Two targets sharing one number (a named point) may not ask for different new text."""
        order = np.argsort(self.key, kind="stable")
        k = self.key[order]
        dup = np.nonzero(k[1:] == k[:-1])[0]
        for j in dup.tolist():
            a, b = order[j], order[j + 1]
            if self.text(a) != self.text(b) if a in self.literal or b in self.literal else (self.digits[a], self.decimals[a], self.negative[a]) != (self.digits[b], self.decimals[b], self.negative[b]):
                name = original.target_name[self.rows[a]] or "?"
                raise EmitError(
                    f"{original.sources[int(self.file[a])].path}: {FIELDS[self.fields[a]]} of point '{name}' is used by lines "
                    f"{original.line[self.rows[a]]} and {original.line[self.rows[b]]} with different new values ({self.text(a)} and {self.text(b)})"
                )
        # One edit per number from here on.
        first = np.ones(len(k), bool)
        first[1:] = k[1:] != k[:-1]
        self._sorted = order[first]

    def lookup(self, file: int, start: int) -> int | None:
        """Index of the edit at a number's position, if any."""
        order = self._sorted
        keys = self.key[order]
        i = int(np.searchsorted(keys, file * (1 << 40) + start))
        return int(order[i]) if i < len(keys) and keys[i] == file * (1 << 40) + start else None

    def keys(self) -> np.ndarray:
        return self.key[self._sorted]

    def for_file(self, file: int) -> np.ndarray:
        """Edit indices of one file, in text order."""
        return self._sorted[self.file[self._sorted] == file]


def _text_values(modified: Toolpath, original: Toolpath) -> np.ndarray:
    """New numbers as the text writes them: undo the scale, and make G91-style increments."""
    values = modified.values.copy()
    rel = modified.relative
    if rel.any():
        # Increments are relative to the previous target's (new) position.
        prev = np.vstack([np.zeros((1, 3)), modified.position[:-1]])
        values[rel, F_POS] = values[rel, F_POS] - np.nan_to_num(prev[rel])
    if modified.offset is not None:
        values = values - modified.offset
    return values / modified.scale


def splice(original: Toolpath, modified: Toolpath, insert_field=None) -> list[str]:
    """New text of every source of ``original`` with the numbers ``modified`` changed.

    ``insert_field(source_index, field_name, text)`` returns the text to insert for a
    component the target lacks, or None where the dialect cannot take one.
    """
    if len(original) != len(modified) or original.sources != modified.sources:
        raise EmitError("the modified toolpath does not come from this program (targets or sources differ)")
    new = _text_values(modified, original)
    old = _text_values(original, original)
    spans = original.spans
    derived = np.zeros(spans.shape[:2], dtype=bool)
    if original.offset_span is not None:
        derived = original.offset_span[:, :, 1] >= 0
    changed = (spans[:, :, 1] >= 0) & ~np.isnan(new) & (new != old) & ~original.relative[:, None] & ~derived
    edits: dict[tuple[int, int], tuple[int, str, int, int]] = {}  # (file, start) -> (end, text, row, field)

    def tol(r, f):
        return float(TOLERANCE[f] / max(abs(original.scale[r, f]), 1e-12))

    written = np.array(modified.position, dtype=float)  # positions as the new text will give them

    def put(r, f, value):
        file, start, end = (int(v) for v in spans[r, f])
        text = format_like(original.sources[file].text[start:end], float(value), tol(r, f))
        if f < 3 and not original.relative[r]:
            written[r, f] = float(text) * original.scale[r, f] + (original.offset[r, f] if original.offset is not None else 0.0)
        key = (file, start)
        other = edits[key][1] if key in edits else None
        if other is None and bulk is not None and (i := bulk.lookup(file, start)) is not None:
            other = bulk.text(i)
        if other is not None and other != text:
            other_row = edits[key][2] if key in edits else int(bulk.rows[bulk.lookup(file, start)])
            raise EmitError(
                f"{original.sources[file].path}: {FIELDS[f]} of point '{original.target_name[r] or '?'}' is used by lines "
                f"{original.line[other_row]} and {original.line[r]} with different new values ({other} and {text})"
            )
        edits[key] = (end, text, r, f)
        return float(text)

    rows, fields = np.nonzero(changed)
    bulk = None
    if len(rows):
        bulk = _BulkEdits(original, rows, fields, new[rows, fields], TOLERANCE[fields] / np.maximum(np.abs(original.scale[rows, fields]), 1e-12))
        bulk.refuse_conflicts(original)
        pos = fields < 3
        if pos.any():
            vals = bulk.written()[pos]
            r, f = rows[pos], fields[pos]
            off = original.offset[r, f] if original.offset is not None else 0.0
            keep = ~original.relative[r]
            written[r[keep], f[keep]] = (vals * original.scale[r, f] + off)[keep]
    # Offsets (RAPID Offs) against the value their base point is written with.
    for r, f in zip(*np.nonzero(derived & (spans[:, :, 1] >= 0))):
        key = (int(original.offset_span[r, f, 0]), int(original.offset_span[r, f, 1]))
        base_edit = bulk.lookup(*key) if bulk is not None else None
        base_text = edits[key][1] if key in edits else (bulk.text(base_edit) if base_edit is not None else None)
        base = float(base_text) if base_text is not None else original.offset[r, f]
        target = modified.values[r, f]
        if not np.isnan(target) and target != original.values[r, f] or base_text is not None:
            put(r, f, (target - base) / original.scale[r, f])
    # A number written as an expression (G-code X[#1*2]) is there but cannot be rewritten.
    fixed = ~np.isnan(original.values[:, F_POS]) & (spans[:, F_POS, 1] < 0)
    moved = ~np.isclose(modified.position, original.position, rtol=0, atol=0, equal_nan=True)
    if (fixed & moved).any():
        r, f = (int(v[0]) for v in np.nonzero(fixed & moved))
        raise EmitError(f"{original.sources[int(original.file[r])].path}, line {original.line[r]}: {FIELDS[f]} is not a plain number in the text and cannot be changed")
    # Components the text leaves out (partial aggregates, modal axes) inherit the previous
    # target's value: write one only where the new value differs from what it inherits.
    inherited = np.vstack([np.full((1, 3), np.nan), modified.position[:-1]])
    differs = ~np.isclose(modified.position, inherited, rtol=0, atol=TOLERANCE[F_POS] * 1e-3)
    # (An unmoved target still needs one when the target it inherits from moved.)
    missing = differs & ~np.isnan(modified.position) & np.isnan(original.values[:, F_POS]) & (spans[:, F_POS, 1] < 0)
    if missing.any() and (insert_field is None or original.insert_at is None):
        r = int(np.nonzero(missing.any(axis=1))[0][0])
        raise EmitError(f"line {original.line[r]}: target has no {FIELDS[int(np.nonzero(missing[r])[0][0])]} in the text to change")
    # One pass in program order over incremental targets and targets that need a word added:
    # each increment is taken from where the previous target is written (rounding included),
    # so rounding never accumulates along a run of incremental moves.
    inserts: dict[tuple[int, int], list[str]] = {}
    for r in np.nonzero(original.relative | missing.any(axis=1))[0].tolist():
        prev_written = np.nan_to_num(written[r - 1]) if r > 0 else np.zeros(3)
        prev_original = np.nan_to_num(original.position[r - 1]) if r > 0 else np.zeros(3)
        for f in range(3):
            if original.relative[r] and spans[r, f, 1] >= 0 and not np.isnan(modified.values[r, f]):
                inc = (modified.values[r, f] - prev_written[f]) / original.scale[r, f]
                old_inc = (original.values[r, f] - prev_original[f]) / original.scale[r, f]
                if inc != old_inc:
                    inc = put(r, f, inc)
                written[r, f] = prev_written[f] + inc * original.scale[r, f]
            elif missing[r, f]:
                file, offset = (int(v) for v in original.insert_at[r])
                if offset < 0:
                    raise EmitError(f"line {original.line[r]}: target has no {FIELDS[f]} in the text and none can be added")
                value = modified.position[r, f] - (prev_written[f] if original.relative[r] else 0.0)
                text = format_like("0.000", float(value / original.scale[r, f]), tol(r, f))
                piece = insert_field(file, FIELDS[f], text)
                if piece is None:
                    raise EmitError(f"line {original.line[r]}: cannot add {FIELDS[f]} to this target")
                written[r, f] = (prev_written[f] if original.relative[r] else 0.0) + float(text) * original.scale[r, f]
                pieces = inserts.setdefault((file, offset), [])
                if piece not in pieces:
                    pieces.append(piece)
            elif original.relative[r] and np.isnan(original.values[r, f]):
                written[r, f] = prev_written[f]  # an axis an incremental move leaves alone
    for (file, offset), pieces in inserts.items():
        edits[(file, offset)] = (offset, "".join(pieces), -1, -1)
    edited = np.array([f * (1 << 40) + st for f, st in edits], dtype=np.int64)
    if bulk is not None:
        edited = np.concatenate([edited, bulk.keys()])
    _check_shared(original, modified, edited)
    texts = [doc.text for doc in original.sources]
    for file in range(len(texts)):
        literal = sorted((start, end, text) for (f, start), (end, text, _, _) in edits.items() if f == file)
        numbers = bulk.for_file(file) if bulk is not None else np.zeros(0, np.int64)
        if not literal and not len(numbers):
            continue
        if literal and len(numbers):
            # A number both changed as a target's and written by a special case: it must agree.
            lit_starts = np.array([st for st, _, _ in literal])
            clash = np.isin(bulk.start[numbers], lit_starts)
            for i in numbers[clash].tolist():
                text = next(t for st, _, t in literal if st == bulk.start[i])
                if text != bulk.text(i):
                    raise EmitError(f"{original.sources[file].path}, line {original.line[bulk.rows[i]]}: one number asked to be written as both {bulk.text(i)} and {text}")
            numbers = numbers[~clash]
        starts = np.concatenate([bulk.start[numbers] if bulk is not None else np.zeros(0, np.int64), np.array([st for st, _, _ in literal], dtype=np.int64)])
        ends = np.concatenate([bulk.end[numbers] if bulk is not None else np.zeros(0, np.int64), np.array([e for _, e, _ in literal], dtype=np.int64)])
        cols = {k: np.concatenate([getattr(bulk, k)[numbers] if bulk is not None else np.zeros(0), np.zeros(len(literal))]) for k in _BulkEdits.COLUMNS}
        order = np.argsort(starts, kind="stable")
        position = np.empty(len(order), np.int64)
        position[order] = np.arange(len(order))
        literals = {int(position[len(numbers) + j]): text for j, (_, _, text) in enumerate(literal)}
        literals.update({int(position[k]): bulk.literal[i] for k, i in enumerate(numbers.tolist()) if i in bulk.literal} if bulk is not None and bulk.literal else {})
        new_bytes = number_kernel.splice_bytes(texts[file].encode("latin-1"), starts[order], ends[order], {k: v[order] for k, v in cols.items()}, literals)
        texts[file] = new_bytes.decode("latin-1")
    return texts


def _check_shared(original: Toolpath, modified: Toolpath, edited: np.ndarray) -> None:
    """A number used by several targets (a named point) may only change if all of them agree."""
    sp = original.spans.reshape(-1, 3)
    have = sp[:, 1] >= 0
    keys = sp[have, 0] * (1 << 40) + sp[have, 1]
    uniq, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    shared = counts[inverse] > 1
    if not shared.any():
        return
    flat = np.nonzero(have)[0][shared]
    rows, fields = flat // original.spans.shape[1], flat % original.spans.shape[1]
    by_key: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for r, f in zip(rows.tolist(), fields.tolist()):
        by_key.setdefault((int(original.spans[r, f, 0]), int(original.spans[r, f, 1])), []).append((r, f))
    edited = set(edited[np.isin(edited, uniq)].tolist())
    for key, users in by_key.items():
        if key[0] * (1 << 40) + key[1] not in edited:
            continue
        values = {float(modified.values[r, f]) for r, f in users}
        if len(values) > 1:
            lines = sorted({int(original.line[r]) for r, _ in users})
            name = original.target_name[users[0][0]] or "?"
            raise EmitError(
                f"{original.sources[key[0]].path}: point '{name}' is used by lines {', '.join(map(str, lines))}, "
                "which ask for different new values; give each use its own point"
            )
