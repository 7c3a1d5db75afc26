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
from numba import njit

from postproc.errors import EmitError, SharedNumberError

from ..ir import F_ARC, F_POS, FIELDS, Toolpath
from . import number_kernel

# Largest rounding error accepted when writing a field (mm for positions, degrees for
# angles, unit quaternion components).
TOLERANCE = np.array([5e-4] * 3 + [5e-7] * 4 + [5e-5] * 6 + [5e-4] * 6 + [5e-4] * 4)
MAX_DECIMALS = 9


def format_like(old: str, value: float, tol: float) -> str:
    """Write value in the style of ``old`` with as many decimals as the tolerance needs.

    The same rules as the bulk path (``choose_decimals`` and the number kernel), for one
    number; numbers of more than 18 digits are written by Python's format."""
    raw = np.frombuffer(old.encode("latin-1"), dtype=np.uint8)
    style = number_kernel.old_styles(raw, np.array([0]), np.array([len(old)]))
    decimals = choose_decimals(np.array([value], dtype=float), np.array([tol]), style["old_decimals"])
    digits, negative, too_big = number_kernel.round_digits(np.array([value], dtype=float), decimals)
    d, plus, dot_style = int(decimals[0]), bool(style["plus"][0]), bool(style["dot_style"][0])
    if too_big[0]:  # |value| >= 1e18 / 10^d: no leading-zero or negative-zero case here
        text = f"{abs(value):.{d}f}" + ("." if d == 0 and dot_style else "")
        return ("-" if value < 0 else "+" if plus else "") + text
    return number_kernel.number_text(int(digits[0]), d, bool(negative[0]), plus, dot_style, bool(style["no_lead_zero"][0]))


def choose_decimals(values: np.ndarray, tol: np.ndarray, old_decimals: np.ndarray) -> np.ndarray:
    """Fewest decimals, at least the old number's, that write each value within its tolerance."""
    decimals = np.full(len(values), MAX_DECIMALS)
    open_ = np.arange(len(values))  # the values still undecided (each pass rounds only those)
    for d in range(0, MAX_DECIMALS + 1):
        v = values[open_]
        ok = (d >= old_decimals[open_]) & (np.abs(np.round(v, d) - v) <= tol[open_])
        decimals[open_[ok]] = d
        open_ = open_[~ok]
        if not len(open_):
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
                raise shared_number_error(original, int(self.file[a]), int(self.start[a]), int(self.fields[a]), [int(self.rows[a]), int(self.rows[b])], (self.text(a), self.text(b)))
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


def _text_values(modified: Toolpath, original: Toolpath, columns=slice(None)) -> np.ndarray:
    """New numbers as the text writes them: undo the scale, and make G91-style increments.
    ``columns``: only these fields (sorted indices), in that order."""
    values = modified.values[:, columns].copy()
    rel = modified.relative
    if rel.any():
        # Increments are relative to the previous target's (new) position.
        prev = np.vstack([np.zeros((1, 3)), modified.position[:-1]])
        pos = np.arange(len(FIELDS))[columns] < 3
        axes = np.arange(len(FIELDS))[columns][pos]
        values[np.ix_(rel, pos)] = values[np.ix_(rel, pos)] - np.nan_to_num(prev[rel][:, axes])
    if modified.offset is not None:
        values = values - modified.offset[:, columns]
    return values / modified.scale[:, columns]


def _changed_columns(modified: Toolpath, original: Toolpath) -> np.ndarray:
    """Fields whose value changed at some target (bits compared): only their numbers can be
    written anew in place (a G91 increment's position numbers are written apart, in
    ``increments_and_inserts``; scale and offset are the original's)."""
    if modified.values is original.values:
        return np.zeros(0, dtype=np.int64)
    return np.nonzero((modified.values.view(np.int64) != original.values.view(np.int64)).any(axis=0))[0]


def _seen_from_next_frame(original: Toolpath, position: np.ndarray) -> np.ndarray:
    """(N-1, 3) each target's point but the last, in the frame of the target after it: what
    that target inherits for an axis it leaves out (a G-code G92 or G10 L20 between them
    changes the frame, not where the tool is)."""
    prev = position[:-1].copy()
    change = np.nonzero(original.frame[1:] != original.frame[:-1])[0]
    if len(change):
        step = np.linalg.inv(original.frames[original.frame[change + 1]]) @ original.frames[original.frame[change]]
        prev[change] = np.einsum("nij,nj->ni", step[:, :3, :3], prev[change]) + step[:, :3, 3]
    return prev


def splice(original: Toolpath, modified: Toolpath, insert_field=None) -> list[str]:
    """New text of every source of ``original`` with the numbers ``modified`` changed.

    ``insert_field(source_index, field_name, text)`` returns the text to insert for a
    component the target lacks, or None where the dialect cannot take one.
    """
    if len(original) != len(modified) or original.sources != modified.sources:
        raise EmitError("the modified toolpath does not come from this program (targets or sources differ)")
    job = _Splice(original, modified)
    job.changed_numbers()
    job.offsets()
    job.refuse_expressions()
    missing = job.missing_components(insert_field)
    job.increments_and_inserts(missing, insert_field)
    job.arc_word_inserts(insert_field)
    _check_shared(original, modified, job.edited_keys())
    return [job.file_text(file) for file in range(len(original.sources))]


class _Splice:
    """The edits of one splice: bulk number edits (arrays) and literal edits (a dict),
    and the position each target's new text will read back as."""

    def __init__(self, original: Toolpath, modified: Toolpath):
        self.original, self.modified = original, modified
        self.spans = original.spans
        self.edits: dict[tuple[int, int], tuple[int, str, int, int]] = {}  # (file, start) -> (end, text, row, field)
        self.bulk: _BulkEdits | None = None
        self.written = np.array(modified.position, dtype=float)  # positions as the new text will give them

    def tol(self, r, f) -> float:
        return float(TOLERANCE[f] / max(abs(self.original.scale[r, f]), 1e-12))

    def changed_numbers(self) -> None:
        """Every number of a target whose value changed, written in place (vectorised)."""
        original, modified, spans = self.original, self.modified, self.spans
        columns = _changed_columns(modified, original)  # the others cannot change (most of a wide IR)
        new = _text_values(modified, original, columns)
        old = _text_values(original, original, columns)
        # An incremental (G91) target's position numbers are written in increments_and_inserts;
        # its arc words (I J K relative to the arc's start, or R) are plain numbers.
        incremental = original.relative[:, None] & (columns < F_ARC.start)[None, :]
        changed = (spans[:, columns, 1] >= 0) & ~np.isnan(new) & (new != old) & ~incremental & ~self.derived()[:, columns]
        rows, at = np.nonzero(changed)
        fields = columns[at]
        new = new[rows, at]
        if not len(rows):
            return
        self.bulk = bulk = _BulkEdits(original, rows, fields, new, TOLERANCE[fields] / np.maximum(np.abs(original.scale[rows, fields]), 1e-12))
        bulk.refuse_conflicts(original)
        pos = fields < 3
        if pos.any():
            vals = bulk.written()[pos]
            r, f = rows[pos], fields[pos]
            off = original.offset[r, f] if original.offset is not None else 0.0
            keep = ~original.relative[r]
            self.written[r[keep], f[keep]] = (vals * original.scale[r, f] + off)[keep]

    def derived(self) -> np.ndarray:
        """(N, FIELDS) True where a number is an offset from another point's (RAPID Offs)."""
        if self.original.offset_span is None:
            return np.zeros(self.spans.shape[:2], dtype=bool)
        return self.original.offset_span[:, :, 1] >= 0

    def put(self, r: int, f: int, value: float) -> float:
        """Write one number of target r, field f as a literal edit; returns the value written.
        A number another target already changes must get the same text."""
        original, bulk = self.original, self.bulk
        file, start, end = (int(v) for v in self.spans[r, f])
        text = format_like(original.sources[file].text[start:end], float(value), self.tol(r, f))
        if f < 3 and not original.relative[r]:
            self.written[r, f] = float(text) * original.scale[r, f] + (original.offset[r, f] if original.offset is not None else 0.0)
        key = (file, start)
        other = self.edits[key][1] if key in self.edits else None
        if other is None and bulk is not None and (i := bulk.lookup(file, start)) is not None:
            other = bulk.text(i)
        if other is not None and other != text:
            other_row = self.edits[key][2] if key in self.edits else int(bulk.rows[bulk.lookup(file, start)])
            raise shared_number_error(original, file, start, f, [other_row, r], (other, text))
        self.edits[key] = (end, text, r, f)
        return float(text)

    def existing_text(self, key: tuple[int, int]) -> str | None:
        """The new text already decided for the number at (file, start), if any."""
        if key in self.edits:
            return self.edits[key][1]
        i = self.bulk.lookup(*key) if self.bulk is not None else None
        return self.bulk.text(i) if i is not None else None

    def offsets(self) -> None:
        """Offsets (RAPID Offs) against the value their base point is written with."""
        original = self.original
        for r, f in zip(*np.nonzero(self.derived() & (self.spans[:, :, 1] >= 0))):
            key = (int(original.offset_span[r, f, 0]), int(original.offset_span[r, f, 1]))
            base_text = self.existing_text(key)
            base = float(base_text) if base_text is not None else original.offset[r, f]
            target = self.modified.values[r, f]
            if not np.isnan(target) and target != original.values[r, f] or base_text is not None:
                self.put(r, f, (target - base) / original.scale[r, f])

    def refuse_expressions(self) -> None:
        """A number written as an expression (G-code X[#1*2]) is there but cannot be rewritten."""
        original = self.original
        fixed = ~np.isnan(original.values[:, F_POS]) & (self.spans[:, F_POS, 1] < 0)
        moved = ~_same(self.modified.position, original.position)
        if (fixed & moved).any():
            r, f = (int(v[0]) for v in np.nonzero(fixed & moved))
            raise EmitError(f"{original.sources[int(original.file[r])].path}, line {original.line[r]}: {FIELDS[f]} is not a plain number in the text and cannot be changed")

    def missing_components(self, insert_field) -> np.ndarray:
        """(N, 3) components the text leaves out (partial aggregates, modal axes) that must be
        written: they inherit the previous target's value, so only where the new value
        differs from what it inherits (an unmoved target too, when the one before moved)."""
        original, modified = self.original, self.modified
        inherited = np.vstack([np.full((1, 3), np.nan), _seen_from_next_frame(original, modified.position)])
        differs = ~np.isclose(modified.position, inherited, rtol=0, atol=TOLERANCE[F_POS] * 1e-3)
        # A word is needed where the target or the one before it moves, never where neither
        # does (the text already says where it is).
        moved = ~_same(modified.position, original.position)
        moved = moved | np.vstack([np.zeros((1, 3), bool), moved[:-1]])
        differs &= moved
        missing = differs & ~np.isnan(modified.position) & np.isnan(original.values[:, F_POS]) & (self.spans[:, F_POS, 1] < 0)
        if missing.any() and (insert_field is None or original.insert_at is None):
            r = int(np.nonzero(missing.any(axis=1))[0][0])
            raise EmitError(f"line {original.line[r]}: target has no {FIELDS[int(np.nonzero(missing[r])[0][0])]} in the text to change")
        return missing

    def increments_and_inserts(self, missing: np.ndarray, insert_field) -> None:
        """One pass in program order over incremental targets and targets that need a word
        added: each increment is taken from where the previous target is written (rounding
        included), so rounding never accumulates along a run of incremental moves."""
        original = self.original
        inserts: dict[tuple[int, int], list[str]] = {}
        for r in np.nonzero(original.relative | missing.any(axis=1))[0].tolist():
            prev_written = np.nan_to_num(self.written[r - 1]) if r > 0 else np.zeros(3)
            # How far the previous target is written from where it was (0 where unknown).
            prev_moved = np.nan_to_num(self.written[r - 1] - original.position[r - 1]) if r > 0 else np.zeros(3)
            for f in range(3):
                if original.relative[r] and self.spans[r, f, 1] >= 0 and not np.isnan(self.modified.values[r, f]):
                    self._increment(r, f, prev_moved)
                elif missing[r, f]:
                    self._insert(r, f, prev_written, insert_field, inserts)
                elif original.relative[r] and np.isnan(original.values[r, f]):
                    # an axis an incremental move leaves alone: it stays where the previous one was written
                    self.written[r, f] = original.position[r, f] + prev_moved[f]
        for (file, offset), pieces in inserts.items():
            self.edits[(file, offset)] = (offset, "".join(p for p, _ in pieces.values()), -1, -1)

    def arc_word_inserts(self, insert_field) -> None:
        """Arc words (I J K R) the compensation gives a value where the text has none (an
        omitted J reads as 0): added at the target's insertion point, after its axis words."""
        original, modified = self.original, self.modified
        new = modified.values[:, F_ARC]
        lacking = ~np.isnan(new) & np.isnan(original.values[:, F_ARC]) & (self.spans[:, F_ARC, 1] < 0) & (new != 0.0)
        for r, k in zip(*np.nonzero(lacking)):
            f = F_ARC.start + int(k)
            file, offset = (int(v) for v in original.insert_at[r]) if original.insert_at is not None else (-1, -1)
            text = format_like("0.0000", float(new[r, k] / original.scale[r, f]), self.tol(r, f))
            piece = insert_field(file, FIELDS[f], text) if insert_field is not None and offset >= 0 else None
            if piece is None:
                raise EmitError(f"line {original.line[r]}: cannot add the arc word {FIELDS[f].upper()} to this block")
            end, before, _, _ = self.edits.get((file, offset), (offset, "", -1, -1))
            self.edits[(file, offset)] = (end, before + piece, -1, -1)

    def _increment(self, r: int, f: int, prev_moved) -> None:
        """An incremental word: the text's increment is the number written there; where the
        previous target is written moved by d from where it was, the new increment is taken
        from there. The previous target is seen from this target's frame through the text
        itself (value - increment), so an offset change between them (G92, G54 -> G55) does
        not enter the increment."""
        scale = self.original.scale[r, f]
        file, start, end = (int(v) for v in self.spans[r, f])
        old_inc = float(self.original.sources[file].text[start:end])
        prev_here = self.original.values[r, f] - old_inc * scale
        moved = prev_moved[f]
        inc = (self.modified.values[r, f] - (prev_here + moved)) / scale
        unchanged = moved == 0.0 and self.modified.values[r, f] == self.original.values[r, f]
        if unchanged or abs(inc - old_inc) <= 1e-12 * max(1.0, abs(old_inc)):
            inc = old_inc  # unchanged (to rounding of the subtraction): the text stays as it is
        else:
            inc = self.put(r, f, inc)
        self.written[r, f] = self.original.values[r, f] + (inc - old_inc) * scale + moved

    def _insert(self, r: int, f: int, prev_written, insert_field, inserts) -> None:
        original = self.original
        file, offset = (int(v) for v in original.insert_at[r])
        if offset < 0:
            raise EmitError(f"line {original.line[r]}: target has no {FIELDS[f]} in the text and none can be added")
        start = prev_written[f] if original.relative[r] else 0.0
        text = format_like("0.000", float((self.modified.position[r, f] - start) / original.scale[r, f]), self.tol(r, f))
        piece = insert_field(file, FIELDS[f], text)
        if piece is None:
            raise EmitError(f"line {original.line[r]}: cannot add {FIELDS[f]} to this target")
        self.written[r, f] = start + float(text) * original.scale[r, f]
        pieces = inserts.setdefault((file, offset), {})
        if pieces.get(f, (piece, r))[0] != piece:  # one block executed several times (a loop, a sub)
            raise shared_number_error(original, file, offset, f, [pieces[f][1], r], (pieces[f][0].strip(), piece.strip()), added=True)
        pieces.setdefault(f, (piece, r))

    def edited_keys(self) -> np.ndarray:
        """file * 2^40 + start of every edited number."""
        edited = np.array([f * (1 << 40) + st for f, st in self.edits], dtype=np.int64)
        return np.concatenate([edited, self.bulk.keys()]) if self.bulk is not None else edited

    def file_text(self, file: int) -> str:
        """The new text of one source: its bulk and literal edits spliced in by the kernel."""
        original, bulk = self.original, self.bulk
        text = original.sources[file].text
        literal = sorted((start, end, t) for (f, start), (end, t, _, _) in self.edits.items() if f == file)
        numbers = bulk.for_file(file) if bulk is not None else np.zeros(0, np.int64)
        if not literal and not len(numbers):
            return text
        if literal and len(numbers):
            numbers = self._drop_agreeing_duplicates(file, literal, numbers)
        if not literal and not bulk.literal:  # the bulk edits alone, already in text order (for_file)
            starts = bulk.start[numbers]
            if len(starts) < 2 or (starts[1:] > starts[:-1]).all():
                cols = {k: getattr(bulk, k)[numbers] for k in _BulkEdits.COLUMNS}
                return number_kernel.splice_bytes(text.encode("latin-1"), starts, bulk.end[numbers], cols, {}).decode("latin-1")
        starts = np.concatenate([bulk.start[numbers] if bulk is not None else np.zeros(0, np.int64), np.array([st for st, _, _ in literal], dtype=np.int64)])
        ends = np.concatenate([bulk.end[numbers] if bulk is not None else np.zeros(0, np.int64), np.array([e for _, e, _ in literal], dtype=np.int64)])
        cols = {k: np.concatenate([getattr(bulk, k)[numbers] if bulk is not None else np.zeros(0), np.zeros(len(literal))]) for k in _BulkEdits.COLUMNS}
        order = np.argsort(starts, kind="stable")
        position = np.empty(len(order), np.int64)
        position[order] = np.arange(len(order))
        literals = {int(position[len(numbers) + j]): t for j, (_, _, t) in enumerate(literal)}
        literals.update({int(position[k]): bulk.literal[i] for k, i in enumerate(numbers.tolist()) if i in bulk.literal} if bulk is not None and bulk.literal else {})
        return number_kernel.splice_bytes(text.encode("latin-1"), starts[order], ends[order], {k: v[order] for k, v in cols.items()}, literals).decode("latin-1")

    def _drop_agreeing_duplicates(self, file: int, literal, numbers: np.ndarray) -> np.ndarray:
        """A number both changed as a target's and written by a special case must agree; the literal edit stays."""
        bulk = self.bulk
        lit_starts = np.array([st for st, _, _ in literal])
        clash = np.isin(bulk.start[numbers], lit_starts)
        for i in numbers[clash].tolist():
            text = next(t for st, _, t in literal if st == bulk.start[i])
            if text != bulk.text(i):
                raise EmitError(f"{self.original.sources[file].path}, line {self.original.line[bulk.rows[i]]}: one number asked to be written as both {bulk.text(i)} and {text}")
        return numbers[~clash]


def _same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a == b elementwise, NaN equal to NaN (``np.isclose(a, b, rtol=0, atol=0, equal_nan=True)``)."""
    return (a == b) | (np.isnan(a) & np.isnan(b))


@njit(cache=True)
def _in_text_order(spans) -> bool:
    """Every number of spans (N, F, 3) after the one before it in (file, offset) order: each read once."""
    last_file, last_start = -1, -1
    for r in range(spans.shape[0]):
        for f in range(spans.shape[1]):
            file, start = spans[r, f, 0], spans[r, f, 1]
            if start < 0:
                continue
            if file < last_file or (file == last_file and start <= last_start):
                return False
            last_file, last_start = file, start
    return True


def _check_shared(original: Toolpath, modified: Toolpath, edited: np.ndarray) -> None:
    """A number used by several targets (a named point) may only change if all of them agree."""
    if _in_text_order(original.spans):
        return  # every number in text order, each read once (a long CAM program): no sort needed to know
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
    text_values = _text_values(modified, original)  # Offs(p, i*10, ..) in a loop: each pass's own offset is not in p's text
    for key, users in by_key.items():
        if key[0] * (1 << 40) + key[1] not in edited:
            continue
        values = {float(np.round(text_values[r, f], 9)) for r, f in users}
        if len(values) > 1:
            raise shared_number_error(original, key[0], key[1], users[0][1], [r for r, _ in users], tuple(f"{v:g}" for v in sorted(values)))


def shared_number_error(original: Toolpath, file: int, start: int, field: int, rows, texts, added: bool = False) -> SharedNumberError:
    """The refusal of one text position that targets ``rows`` would write differently."""
    text = original.sources[file].text
    line = text.count("\n", 0, start) + 1
    column = start - (text.rfind("\n", 0, start) + 1) + 1
    lines = sorted({int(original.line[r]) for r in rows})
    name = original.target_name[rows[0]] or ""
    what = f"{FIELDS[field]} {'to be added here' if added else 'written here'}"
    owner = f"point '{name}'" if name else "one block executed several times: a loop body or a subroutine"
    return SharedNumberError(
        original.sources[file].path, line, column,
        f"{what} ({owner}) is used by lines {', '.join(map(str, lines))}, which ask for different new values ({' and '.join(texts)}); "
        "give each use its own point (unroll the loop or the call)")
