"""A non-editable install ships every subpackage (pyproject lists them one by one)."""

from __future__ import annotations

import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_every_package_is_listed_in_pyproject():
    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(p.parent.relative_to(REPO).parts) for p in (REPO / "postproc").rglob("__init__.py")}
    assert found <= listed, f"packages missing from pyproject.toml: {sorted(found - listed)}"


def test_every_folder_of_code_is_a_package():
    folders = {p.parent for p in (REPO / "postproc").rglob("*.py") if "__pycache__" not in p.parts}
    missing = [str(f.relative_to(REPO)) for f in folders if not (f / "__init__.py").exists()]
    assert not missing, f"folders of code without __init__.py (a wheel would leave them out): {missing}"
