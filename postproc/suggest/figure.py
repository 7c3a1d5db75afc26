"""The predicted error against the number of measured poses: suggested against random."""

from __future__ import annotations

import io
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import RANDOM_DRAWS  # noqa: E402


def curve_png(suggestion, title: str) -> bytes:
    """PNG bytes of the expected-RMS curve (log-log), the chosen N marked."""
    n, suggested, rand = (np.array(v, dtype=float) for v in zip(*suggestion.curve))
    fig, ax = plt.subplots(figsize=(7.0, 4.5), dpi=110)
    ax.plot(n, rand, "o-", color="#7f7f7f", label=f"random poses (mean of {RANDOM_DRAWS} draws)")
    ok = np.isfinite(suggested)
    ax.plot(n[ok], suggested[ok], "s-", color="#1f77b4", label=f"suggested ({suggestion.criterion}-optimal, greedy prefix)")
    chosen = len(suggestion.chosen)
    ax.plot([chosen], [suggestion.expected_rms_mm], "*", color="#d62728", markersize=14, label=f"chosen design, N = {chosen}")
    if suggestion.random_equivalent_n is not None:
        ax.axvline(suggestion.random_equivalent_n, color="#7f7f7f", linestyle=":", label=f"random needs N = {suggestion.random_equivalent_n}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("poses measured, N")
    ax.set_ylabel("predicted model error RMS (mm)")
    ax.set_title(f"{textwrap.fill(title, 80)}\npredicted error (noise only) at {suggestion.where}", fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()
