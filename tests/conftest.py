"""Shared fixtures. The reference data lives in ../shared beside the checkout (or $POSTPROC_SHARED)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from helpers import kr160

REPO = Path(__file__).resolve().parents[1]


def shared_dir() -> Path:
    root = Path(os.environ.get("POSTPROC_SHARED", REPO.parent / "shared"))
    if not (root / "data").is_dir():
        # A missing reference set is a broken checkout, not a reason to skip tests.
        raise RuntimeError(f"reference data not found at {root}/data; set POSTPROC_SHARED to the shared/ folder")
    return root


@pytest.fixture(scope="session")
def shared() -> Path:
    return shared_dir()


@pytest.fixture(scope="module")
def robot():
    """The KR160 R1570 most tests simulate (a module may define its own ``robot`` instead)."""
    return kr160()
