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
