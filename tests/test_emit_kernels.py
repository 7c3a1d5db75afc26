"""The compiled number writer writes what Python's format and the splice rules write."""

from __future__ import annotations

import numpy as np
import pytest

from postproc.programs.emit import number_kernel
from postproc.programs.emit.splice import format_like


def test_digits_are_pythons_format_for_every_value_and_precision():
    rng = np.random.default_rng(5)
    values = np.concatenate([
        rng.uniform(-5000, 5000, 30_000),
        np.round(rng.uniform(-100, 100, 30_000), 3) + 0.0005,  # halves in decimal, not in binary
        np.array([0.125, 2.675, 1.005, -0.0004, -0.0, 0.5, 1.5, 2.5, 1e15 + 0.5, 123456789.123456789, 9.9999999995]),
    ])
    decimals = rng.integers(0, 10, len(values))
    digits, negative, too_big = number_kernel.round_digits(values, decimals)
    assert too_big.tolist() == (np.abs(values) * 10.0**decimals >= 9e18).tolist()
    for v, d, g, neg, big in zip(values.tolist(), decimals.tolist(), digits.tolist(), negative.tolist(), too_big.tolist()):
        if big:
            continue  # written by Python's format in the splice
        want = format(v, f".{d}f")
        if want.startswith("-") and float(want) == 0.0:
            want = want[1:]
        assert number_kernel.number_text(g, d, neg) == want, (v, d)


def reference_format(old: str, value: float, tol: float) -> str:
    """An independent writer (plain Python, one number) the emitter must agree with:
    the fewest decimals, at least the old number's, within ``tol``, in the old style."""
    body = old.lstrip("+-")
    decimals = len(body.split(".", 1)[1]) if "." in body and "e" not in body.lower() else 0
    decimals = next((d for d in range(decimals, 10) if abs(round(value, d) - value) <= tol), 9)
    text = f"{value:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]
    if decimals == 0 and "." in body:
        text += "."
    if old.startswith("+") and not text.startswith("-"):
        text = "+" + text
    if body.startswith(".") and text.lstrip("+-").startswith("0."):
        text = (text[0] if text[0] in "+-" else "") + text.lstrip("+-")[1:]
    return text


@pytest.mark.parametrize("old", ["+1.500", ".5", "-.25", "10.", "1.5e3", "7", "+.0", "-3.0000"])
@pytest.mark.parametrize("value", [0.0, -0.25, 12.3456, -1234.5, 0.0004, 99.99951, 3.0e20, -4.5e19])
def test_styles_match_an_independent_writer(old, value):
    assert format_like(old, value, 5e-4) == reference_format(old, value, 5e-4)


def test_splice_keeps_every_other_byte():
    src = "A 1.0 ; x\\r\\nB -2.50 C +3\\n".replace("\\\\r\\\\n", "\r\n").encode("latin-1")
    text = src.decode("latin-1")
    starts = np.array([text.index("1.0"), text.index("-2.50"), text.index("C")])
    ends = np.array([starts[0] + 3, starts[1] + 5, starts[2] + 1])
    numbers = {"digits": np.array([1234, 0, 0]), "decimals": np.array([3, 2, 0]), "negative": np.array([True, False, False]),
               "plus": np.zeros(3, bool), "dot_style": np.array([True, True, False]), "no_lead_zero": np.zeros(3, bool)}
    out = number_kernel.splice_bytes(src, starts, ends, numbers, {2: "Z"})
    assert out.decode("latin-1") == text.replace("1.0", "-1.234", 1).replace("-2.50", "0.00", 1).replace("C +3", "Z +3", 1)
