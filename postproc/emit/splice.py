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
    derived = original.offset_span is not None and (original.offset_span[:, :, 1] >= 0).any()
    if derived:
        # An offset (RAPID Offs) is relative to its base point: if that point moves too, the
        # offset is taken from its new value, so the derived target lands where asked.
        base_new = {}
        plain = (original.offset_span[:, :, 1] < 0)
        for r, f in zip(*np.nonzero((spans[:, :, 1] >= 0) & plain)):
            base_new[tuple(spans[r, f])] = modified.values[r, f]
        for r, f in zip(*np.nonzero(original.offset_span[:, :, 1] >= 0)):
            key = tuple(original.offset_span[r, f])
            if key in base_new and not np.isnan(modified.values[r, f]):
                new[r, f] = (modified.values[r, f] - base_new[key]) / modified.scale[r, f]
    changed = (spans[:, :, 1] >= 0) & ~np.isnan(new) & (new != old)
    edits: dict[tuple[int, int], tuple[int, str, int, int]] = {}  # (file, start) -> (end, text, row, field)
    rows, fields = np.nonzero(changed)
    for r, f in zip(rows.tolist(), fields.tolist()):
        file, start, end = (int(v) for v in spans[r, f])
        src = original.sources[file].text
        text = format_like(src[start:end], float(new[r, f]), float(TOLERANCE[f] / max(abs(original.scale[r, f]), 1e-12)))
        key = (file, start)
        if key in edits and edits[key][1] != text:
            other = edits[key][2]
            raise EmitError(
                f"{original.sources[file].path}: {FIELDS[f]} of point '{original.target_name[r] or '?'}' is used by lines "
                f"{original.line[other]} and {original.line[r]} with different new values ({edits[key][1]} and {text})"
            )
        edits[key] = (end, text, r, f)
    # Components the text leaves out but whose value changed (partial aggregates, modal axes).
    moved = ~np.isclose(modified.position, original.position, rtol=0, atol=0, equal_nan=True)
    missing = moved & (spans[:, F_POS, 1] < 0)
    if missing.any():
        if insert_field is None or original.insert_at is None:
            r = int(np.nonzero(missing.any(axis=1))[0][0])
            raise EmitError(f"line {original.line[r]}: target has no {FIELDS[int(np.nonzero(missing[r])[0][0])]} in the text to change")
        inserts: dict[tuple[int, int], list[str]] = {}
        for r, f in zip(*np.nonzero(missing)):
            file, offset = (int(v) for v in original.insert_at[r])
            if offset < 0:
                raise EmitError(f"line {original.line[r]}: target has no {FIELDS[f]} in the text and none can be added")
            value = modified.position[r, f] / original.scale[r, f]
            piece = insert_field(file, FIELDS[f], format_like("0.000", float(value), float(TOLERANCE[f])))
            if piece is None:
                raise EmitError(f"line {original.line[r]}: cannot add {FIELDS[f]} to this target")
            inserts.setdefault((file, offset), [])
            if piece not in inserts[(file, offset)]:
                inserts[(file, offset)].append(piece)
        for (file, offset), pieces in inserts.items():
            edits[(file, offset)] = (offset, "".join(pieces), -1, -1)
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
