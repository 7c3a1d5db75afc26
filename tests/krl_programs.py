"""A KRL program of the tests written as the controller's files (p.src, p.dat, $config.dat) and read back."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from postproc.programs import parse_program


def read_krl(folder: Path, src: str, dat: str, config: str | None):
    """``src`` as ``folder``/p.src beside ``dat`` (p.dat) and ``config`` ($config.dat; None: no such file), read."""
    (folder / "p.src").write_text(src)
    (folder / "p.dat").write_text(dat)
    if config is not None:
        (folder / "$config.dat").write_text(config)
    return parse_program(folder / "p.src")


def placed_positions(tp) -> np.ndarray:
    """Base-frame positions, NaN where the target is not placed (point, frame or tool unknown)."""
    return np.where(tp.placed()[:, None], tp.base_positions(), np.nan)
