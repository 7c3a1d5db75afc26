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
from ..ir import F_POS, FIELDS, NF, Toolpath

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


def format_many(original: Toolpath, rows, fields, values: np.ndarray, tol: np.ndarray) -> list[str]:
    """format_like for many numbers at once: decimals chosen vectorised, strings grouped by decimals."""
    spans = original.spans[rows, fields]
    sources = [doc.text for doc in original.sources]
    olds = [sources[fi][a:b] for fi, a, b in zip(spans[:, 0].tolist(), spans[:, 1].tolist(), spans[:, 2].tolist())]
    has_dot = np.array(["." in t and "e" not in t.lower() for t in olds], dtype=bool)
    old_dec = np.array([len(t) - t.find(".") - 1 if d else 0 for t, d in zip(olds, has_dot)], dtype=int)
    decimals = np.full(len(values), MAX_DECIMALS)
    undecided = np.ones(len(values), dtype=bool)
    for d in range(0, MAX_DECIMALS + 1):
        ok = undecided & (d >= old_dec) & (np.abs(np.round(values, d) - values) <= tol)
        decimals[ok] = d
        undecided &= ~ok
    out: list[str] = [""] * len(values)
    for d in np.unique(decimals):
        idx = np.nonzero(decimals == d)[0]
        spec = f".{int(d)}f"
        for i, v in zip(idx.tolist(), values[idx].tolist()):
            out[i] = format(v, spec)
    # Styles are rare: patch them one by one (sign, trailing dot, missing leading zero, -0).
    for i, old in enumerate(olds):
        text = out[i]
        if text.startswith("-") and float(text) == 0.0:
            text = text[1:]
        if old[:1] == "+" or has_dot[i] and decimals[i] == 0 or old.lstrip("+-")[:1] == ".":
            text = format_like(old, values[i], float(tol[i]))
        out[i] = text
    return out


def _refuse_conflicts(original: Toolpath, files, starts, texts, rows, fields) -> None:
    """Two targets sharing one number (a named point) may not ask for different new text."""
    keys = files * (1 << 40) + starts
    order = np.argsort(keys, kind="stable")
    dup = np.nonzero(keys[order][1:] == keys[order][:-1])[0]
    for k in dup:
        a, b = order[k], order[k + 1]
        if texts[a] != texts[b]:
            name = original.target_name[rows[a]] or "?"
            raise EmitError(
                f"{original.sources[int(files[a])].path}: {FIELDS[fields[a]]} of point '{name}' is used by lines "
                f"{original.line[rows[a]]} and {original.line[rows[b]]} with different new values ({texts[a]} and {texts[b]})"
            )


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
        if key in edits and edits[key][1] != text:
            other = edits[key][2]
            raise EmitError(
                f"{original.sources[file].path}: {FIELDS[f]} of point '{original.target_name[r] or '?'}' is used by lines "
                f"{original.line[other]} and {original.line[r]} with different new values ({edits[key][1]} and {text})"
            )
        edits[key] = (end, text, r, f)
        return float(text)

    rows, fields = np.nonzero(changed)
    if len(rows):
        texts_new = format_many(original, rows, fields, new[rows, fields], TOLERANCE[fields] / np.maximum(np.abs(original.scale[rows, fields]), 1e-12))
        file_ids, starts, ends = (spans[rows, fields, k] for k in range(3))
        _refuse_conflicts(original, file_ids, starts, texts_new, rows, fields)
        for key_file, key_start, key_end, text, r, f in zip(file_ids.tolist(), starts.tolist(), ends.tolist(), texts_new, rows.tolist(), fields.tolist()):
            edits[(key_file, key_start)] = (key_end, text, r, f)
        pos = fields < 3
        if pos.any():
            vals = np.array([texts_new[i] for i in np.nonzero(pos)[0]], dtype=float)
            r, f = rows[pos], fields[pos]
            off = original.offset[r, f] if original.offset is not None else 0.0
            keep = ~original.relative[r]
            written[r[keep], f[keep]] = (vals * original.scale[r, f] + off)[keep]
    # Offsets (RAPID Offs) against the value their base point is written with.
    for r, f in zip(*np.nonzero(derived & (spans[:, :, 1] >= 0))):
        key = (int(original.offset_span[r, f, 0]), int(original.offset_span[r, f, 1]))
        base = float(edits[key][1]) if key in edits else original.offset[r, f]
        target = modified.values[r, f]
        if not np.isnan(target) and target != original.values[r, f] or key in edits:
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
    _check_shared(original, modified, edits)
    texts = [doc.text for doc in original.sources]
    by_file: dict[int, list] = {}
    for (file, start), (end, text, _, _) in edits.items():
        by_file.setdefault(file, []).append((start, end, text))
    for file, items in by_file.items():
        items.sort()
        src = texts[file]
        out, pos = [], 0
        for start, end, text in items:
            out.append(src[pos:start])
            out.append(text)
            pos = end
        out.append(src[pos:])
        texts[file] = "".join(out)
    return texts


def _check_shared(original: Toolpath, modified: Toolpath, edits: dict) -> None:
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
    for key, users in by_key.items():
        if key not in edits:
            continue
        values = {float(modified.values[r, f]) for r, f in users}
        if len(values) > 1:
            lines = sorted({int(original.line[r]) for r, _ in users})
            name = original.target_name[users[0][0]] or "?"
            raise EmitError(
                f"{original.sources[key[0]].path}: point '{name}' is used by lines {', '.join(map(str, lines))}, "
                "which ask for different new values; give each use its own point"
            )
