"""The real UR10 tracker series as measurement CSVs, for the UR10 benchmarks: where the data
are (a path given, else ``$POSTPROC_SHARED/data/ur10_ipa``), and one series made into a CSV by
``postproc import-ur10`` (the command a user runs)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def data_folder(given: str | None) -> Path:
    """The ``ur10_ipa`` folder: ``given``, else the shared data's."""
    return Path(given) if given else Path(os.environ.get("POSTPROC_SHARED", ROOT.parent / "shared")) / "data" / "ur10_ipa"


def imported(data: Path, series: str, out: Path) -> Path:
    """``out``: Series ``series`` (A, B) of ``data`` as a measurement CSV."""
    subprocess.run([sys.executable, "-m", "postproc", "import-ur10", str(data / f"Series_{series}"), "-o", str(out)], check=True, capture_output=True, cwd=ROOT)
    return out


def bars_by_place(ax, errors: dict, place, bins: int, label, xlabel: str, title: str) -> None:
    """Mean held-out error by place after the last long move (0 .. bins - 1, the last "and
    after"), one bar per entry of ``errors`` ({name: (N,) mm}, at most two), ``label(name, err)``
    its legend text; the issue's goal (0.06 mm) dotted."""
    width = 0.38
    for shift, (name, err) in zip((-width / 2, width / 2), errors.items()):
        ax.bar([k + shift for k in range(bins)], [err[place == k].mean() for k in range(bins)], width, label=label(name, err))
    counts = [int((place == k).sum()) for k in range(bins)]
    ax.set_xticks(range(bins), [f"{k}{'+' if k == bins - 1 else ''}\n(n={n})" for k, n in enumerate(counts)], fontsize=8)
    ax.axhline(0.06, color="k", linestyle=":", label="goal: mean 0.06 mm")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("mean held-out 3-D error (mm)")
    ax.set_title(title)
    ax.legend(fontsize=8)

